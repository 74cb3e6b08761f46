//! LVDT acquisition: DAC1 plays the excitation sine from a DMA table on every TIM6 update;
//! ADC1 and ADC2 sample the two secondaries on the same TIM6 trigger into DMA ring buffers of
//! one block (one pod sample period) each; the LVDT task reads a block as two half-rings,
//! demodulates it with the core and queues it with the encoder counts and time latched at its
//! centre.
//!
//! DAC update and ADC conversions start on the same edge, so the secondaries are seen a fixed
//! settling delay after each DAC step: a constant phase, which the core's magnitude
//! demodulation ignores by construction.
//!
//! **Sample timing.** A block's reading is the mean over its conversions, so its
//! instant is the block's centre. ADC1's DMA raises its half- and full-transfer interrupts at
//! the two half-ring boundaries, and [`BlockLatchIsr`] (priority 1, under only the probe's
//! EXTI4) latches the five encoder counters and the time there; the event between a block's two
//! halves is its centre. At the default 1 kHz (100 conversions 10 µs apart, centre at 49.5)
//! the latch follows conversion 49: it is 5 µs less the conversion time (≈ 0.9 µs) and the interrupt's entry (≈ 0.2 µs)
//! before the centre, ≈ 3.9 µs, 0.07 µm of travel at 16.7 mm/s (docs: sample timing).
//!
//! **Rail test.** The ADCs' analog watchdogs 1 (window 1…4094 codes) watch every conversion;
//! [`BlockLatchIsr`] reads and clears their flags at each half-ring event and the core's
//! [`demodulate_watched`] tests a block's codes in software only if a watchdog tripped at one
//! of the block's two events or at the event before (whose interrupt may have run after the
//! block's first conversions), or if one of those latches is no longer held.
//!
//! **Loss** is counted from the gaps between the blocks' latched times
//! ([`ballpod::acquisition::periods_lost`]), however the blocks were lost. After an overrun of
//! either ring both are cleared at one DMA position ([`realign`]), so A's and B's halves stay
//! the same conversions.

use core::cell::Cell;
use core::sync::atomic::{AtomicU32, Ordering};

use embassy_stm32::adc::{Adc, AdcChannel, AdcConfig, Exten, RingBufferedAdc, SampleTime};
use embassy_stm32::dac::{DacChannel, ValueArray};
use embassy_stm32::mode::Async;
use embassy_stm32::time::hz;
use embassy_stm32::timer::low_level::{RoundTo, Timer as LlTimer};
use embassy_stm32::{Peri, pac, peripherals, triggers};
use static_cell::StaticCell;

use super::block::{BLOCK_MAX, BlockPath, P};
use ballpod::acquisition::MAX_AXES;
use ballpod::acquisition::lvdt::{ADC12_FULL_SCALE, ExcitationTable};
use ballpod::acquisition::rings::{DmaRing, realign};
use ballpod::config::Config;
use embassy_stm32::interrupt::typelevel::{DMA1_CHANNEL2, Handler};

use super::Irqs;

/// DAC excitation amplitude, counts (±1000 about mid-scale: 1.6 V peak-to-peak at 3.3 V).
pub const EXCITATION_AMPLITUDE: u16 = 1000;
/// What [`BlockLatchIsr`] latches at a half-ring boundary.
#[derive(Clone, Copy)]
struct Latch {
    /// Event number since boot (from 1; 0: never written).
    seq: u32,
    t_us: u64,
    raw: [u32; MAX_AXES],
    /// An ADC's analog watchdog had tripped since the event before.
    watchdog: bool,
}

/// The last four latches, slot `seq % 4` (the task is at most two events behind without the
/// ring overrunning); each access copies one slot under the lock.
static LATCHES: critical_section::Mutex<[Cell<Latch>; 4]> = critical_section::Mutex::new(
    [const {
        Cell::new(Latch {
            seq: 0,
            t_us: 0,
            raw: [0; MAX_AXES],
            watchdog: true,
        })
    }; 4],
);
/// The newest event's number (written by the interrupt only).
static LATCH_SEQ: AtomicU32 = AtomicU32::new(0);

/// ADC1 DMA (DMA1 channel 2) interrupt, bound before embassy's handler (which clears the flag):
/// at a half- or full-transfer event, latch the encoder counters and the time.
pub struct BlockLatchIsr;

impl Handler<DMA1_CHANNEL2> for BlockLatchIsr {
    unsafe fn on_interrupt() {
        let raw = super::encoders::latched_counts();
        let t_us = embassy_time::Instant::now().as_micros();
        let (isr, cr) = (pac::DMA1.isr().read(), pac::DMA1.ch(1).cr().read());
        // the same condition as embassy's handler, which acknowledges one event per call
        if (isr.htif(1) && cr.htie()) || (isr.tcif(1) && cr.tcie()) {
            let seq = LATCH_SEQ.load(Ordering::Relaxed).wrapping_add(1);
            LATCH_SEQ.store(seq, Ordering::Relaxed);
            let watchdog = watchdog_tripped();
            critical_section::with(|cs| {
                if let Some(slot) = LATCHES.borrow(cs).get(seq as usize % 4) {
                    slot.set(Latch {
                        seq,
                        t_us,
                        raw,
                        watchdog,
                    });
                }
            });
        }
    }
}

/// Reads and clears the analog watchdog 1 flags of ADC1 and ADC2 (write-1-to-clear: writing
/// only the one bit leaves the other flags alone): true if either had tripped.
fn watchdog_tripped() -> bool {
    let mut tripped = false;
    for adc in [pac::ADC1, pac::ADC2] {
        if adc.isr().read().awd1() {
            adc.isr().write(|w| w.set_awd1(true));
            tripped = true;
        }
    }
    tripped
}

/// Whether the block whose events are `centre` and `end` needs the per-code rail test: a
/// watchdog tripped at either event or at the one before, or one of the three latches is
/// not held any more.
fn block_watchdog_tripped(centre: u32, end: u32) -> bool {
    [centre.wrapping_sub(1), centre, end]
        .into_iter()
        .any(|seq| latch_of(seq).is_none_or(|l| l.watchdog))
}

/// The latch of event `seq`, if it is still held.
fn latch_of(seq: u32) -> Option<Latch> {
    let l = critical_section::with(|cs| LATCHES.borrow(cs).get(seq as usize % 4).map(Cell::get));
    l.filter(|x| x.seq == seq && seq != 0)
}

/// The latch of a block's centre, and the number of the event that ended the block: event
/// `centre` if it is given and still held; else (at start, or to resync after an overrun: that
/// block carries `OVERRUN` anyway) the one before the newest event, taking the newest as the
/// block's end.
fn latch(centre: Option<u32>) -> (Latch, u32) {
    if let Some(x) = centre.and_then(latch_of) {
        return (x, x.seq.wrapping_add(1));
    }
    let newest = LATCH_SEQ.load(Ordering::Relaxed);
    let x = latch_of(newest.wrapping_sub(1))
        .or_else(|| latch_of(newest))
        .unwrap_or(Latch {
            seq: newest,
            t_us: embassy_time::Instant::now().as_micros(),
            raw: super::encoders::latched_counts(),
            watchdog: true,
        });
    (x, newest)
}

/// An ADC's ring and the DMA1 channel that fills it (0-based: ADC1 on channel 2 → 1, ADC2 on
/// channel 3 → 2), as [`realign`] sees them.
struct Ring<'r, T: embassy_stm32::adc::Instance>(&'r mut RingBufferedAdc<'static, T>, usize);

impl<T: embassy_stm32::adc::Instance> DmaRing for Ring<'_, T> {
    fn remaining(&mut self) -> u16 {
        pac::DMA1.ch(self.1).ndtr().read().ndt()
    }

    fn clear(&mut self) {
        self.0.clear();
    }
}

static RING_A: StaticCell<[u16; BLOCK_MAX]> = StaticCell::new();
static RING_B: StaticCell<[u16; BLOCK_MAX]> = StaticCell::new();

/// The peripherals the LVDT acquisition owns.
pub struct LvdtPeripherals {
    /// Sample clock.
    pub tim6: Peri<'static, peripherals::TIM6>,
    /// Excitation DAC, its DMA channel and output pin.
    pub dac: (
        Peri<'static, peripherals::DAC1>,
        Peri<'static, peripherals::DMA1_CH1>,
        Peri<'static, peripherals::PA4>,
    ),
    /// Secondary A: ADC1, DMA, pin.
    pub adc_a: (
        Peri<'static, peripherals::ADC1>,
        Peri<'static, peripherals::DMA1_CH2>,
        Peri<'static, peripherals::PA0>,
    ),
    /// Secondary B: ADC2, DMA, pin.
    pub adc_b: (
        Peri<'static, peripherals::ADC2>,
        Peri<'static, peripherals::DMA1_CH3>,
        Peri<'static, peripherals::PA1>,
    ),
}

/// Configures DAC, ADCs and TIM6 and starts the sample clock; returns what the two tasks own.
pub fn start(
    p: LvdtPeripherals,
    cfg: &Config,
) -> (
    DacChannel<'static, Async>,
    RingBufferedAdc<'static, peripherals::ADC1>,
    RingBufferedAdc<'static, peripherals::ADC2>,
) {
    let dac = DacChannel::new_triggered(p.dac.0, p.dac.1, triggers::TIM6_TRGO, Irqs, p.dac.2);
    // new_triggered selects TSEL but leaves TEN off: clear EN, set TEN; write() sets EN again.
    pac::DAC1.cr().modify(|w| w.set_en(0, false));
    pac::DAC1.cr().modify(|w| w.set_ten(0, true));

    let adc1 = Adc::new(p.adc_a.0, AdcConfig::default());
    let adc2 = Adc::new(p.adc_b.0, AdcConfig::default());
    // one block per ring: the ring's halves end at the block's centre and end
    let len = super::block::block_len(cfg);
    let ring = |r: &'static mut [u16; BLOCK_MAX]| r.get_mut(..len).unwrap_or(&mut []);
    let mut ring_a = adc1.into_ring_buffered(
        p.adc_a.1,
        ring(RING_A.init([0; BLOCK_MAX])),
        Irqs,
        [(p.adc_a.2.degrade_adc(), SampleTime::CYCLES24_5)].into_iter(),
        triggers::TIM6_TRGO,
        Exten::RISING_EDGE,
    );
    let mut ring_b = adc2.into_ring_buffered(
        p.adc_b.1,
        ring(RING_B.init([0; BLOCK_MAX])),
        Irqs,
        [(p.adc_b.2.degrade_adc(), SampleTime::CYCLES24_5)].into_iter(),
        triggers::TIM6_TRGO,
        Exten::RISING_EDGE,
    );
    // after an overrun the ring skips to the next half-ring boundary, so reads stay aligned
    // with the DMA events the latch sees
    ring_a.set_alignment(len / 2);
    ring_b.set_alignment(len / 2);
    // analog watchdog 1 on each ADC's one regular channel: a code outside 1…4094 (a rail)
    // sets AWD1 (RM0440, "analog window watchdog"); written while the ADCs are not converting
    for adc in [pac::ADC1, pac::ADC2] {
        adc.tr1().modify(|w| {
            w.set_lt1(1);
            w.set_ht1(ADC12_FULL_SCALE - 1);
            w.set_awdfilt(0);
        });
        adc.cfgr().modify(|w| {
            w.set_awd1sgl(pac::adc::vals::Awd1sgl::ALL);
            w.set_awd1en(true);
        });
        adc.isr().write(|w| w.set_awd1(true));
    }
    ring_a.start();
    ring_b.start();

    // TIM6: update event at excitation × P, routed to TRGO. Started by the DAC task once its
    // circular DMA runs, so DAC and ADCs begin on the same edge.
    let tim6 = LlTimer::new(p.tim6);
    let rate = (cfg.excitation_hz as u32).saturating_mul(P as u32);
    tim6.set_frequency(hz(rate), RoundTo::Faster);
    tim6.generate_update_event();
    tim6.regs_basic()
        .cr2()
        .modify(|w| w.set_mms(pac::timer::vals::Mms::UPDATE));
    // Keep TIM6 clocked for the life of the program (its Drop would gate the clock).
    core::mem::forget(tim6);
    (dac, ring_a, ring_b)
}

/// Plays the excitation table forever (circular DMA), then starts the sample clock.
#[embassy_executor::task]
pub async fn dac_task(mut dac: DacChannel<'static, Async>) {
    // The table lives in this task's (static) future for as long as the DMA reads it.
    let table = ExcitationTable::<P>::new().dac_codes(EXCITATION_AMPLITUDE);
    // `join` polls the write first, which arms the circular DMA, and only then starts TIM6:
    // the first trigger finds the DMA ready (no underrun at start).
    embassy_futures::join::join(dac.write(ValueArray::Bit12Right(&table), true), async {
        pac::TIM6.cr1().modify(|w| w.set_cen(true));
    })
    .await;
}

/// Reads one block per sample period from both ADC rings (two half-rings each), demodulates
/// it (AC) or averages it (DC: the application converts the volts with its zero and span) as
/// the input mode says, and queues the reading with the latch of its centre
/// ([`BlockPath`]). `len` is the block length (`block::block_len`), `period_us` the sample
/// period, for the loss count.
#[embassy_executor::task]
pub async fn lvdt_task(
    mut ring_a: RingBufferedAdc<'static, peripherals::ADC1>,
    mut ring_b: RingBufferedAdc<'static, peripherals::ADC2>,
    len: usize,
    period_us: u32,
) {
    // word-aligned: the core's DSP projection reads two codes per load (unaligned blocks take
    // its portable path, which is slower)
    #[repr(align(4))]
    struct Codes([u16; BLOCK_MAX]);
    let (mut a, mut b) = (Codes([0; BLOCK_MAX]), Codes([0; BLOCK_MAX]));
    // the latch event that ends the next block's first half (event 1 at ring position len/2;
    // None: find it from the newest event)
    let mut centre_seq = Some(1u32);
    let mut path = BlockPath::new(period_us);
    loop {
        super::safety::check_in(super::safety::Task::Lvdt);
        let (a, b) = (
            a.0.get_mut(..len).unwrap_or(&mut []),
            b.0.get_mut(..len).unwrap_or(&mut []),
        );
        let (a1, a2) = a.split_at_mut_checked(len / 2).unwrap_or_default();
        let (b1, b2) = b.split_at_mut_checked(len / 2).unwrap_or_default();
        // ADC2 runs in step with ADC1: its halves are there when ADC1's are
        let ok = ring_a.read(a1).await.is_ok()
            && ring_b.read(b1).await.is_ok()
            && ring_a.read(a2).await.is_ok()
            && ring_b.read(b2).await.is_ok();
        if !ok {
            // Either ring was lapped: both restart at one DMA position (the next half-ring
            // boundary); the lost periods show in the gap of the next block's time.
            if !realign(&mut Ring(&mut ring_a, 1), &mut Ring(&mut ring_b, 2)) {
                defmt::warn!("ADC rings: ADC1 and ADC2 DMA positions disagree");
            }
            centre_seq = None;
            continue;
        }
        let (centre, end) = latch(centre_seq);
        centre_seq = Some(end.wrapping_add(1));
        let tripped = block_watchdog_tripped(centre.seq, end);
        path.on_block(a, b, centre.t_us, centre.raw, tripped);
    }
}
