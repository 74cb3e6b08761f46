//! LVDT acquisition: DAC1 plays the excitation sine from a DMA table on every TIM6 update;
//! ADC1 and ADC2 sample the two secondaries on the same TIM6 trigger into DMA ring buffers; the
//! LVDT task demodulates each block (one pod sample period) with the core and queues it.
//!
//! DAC update and ADC conversions start on the same edge, so the secondaries are seen a fixed
//! settling delay after each DAC step: a constant phase, which the core's magnitude
//! demodulation ignores by construction.

use embassy_stm32::adc::{Adc, AdcChannel, AdcConfig, Exten, RingBufferedAdc, SampleTime};
use embassy_stm32::dac::{DacChannel, ValueArray};
use embassy_stm32::mode::Async;
use embassy_stm32::time::hz;
use embassy_stm32::timer::low_level::{RoundTo, Timer as LlTimer};
use embassy_stm32::{Peri, pac, peripherals, triggers};
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;
use static_cell::StaticCell;

use ballpod::acquisition::lvdt::{
    DcFrontEnd, ExcitationTable, LvdtReading, block_mean, dc_reading, demodulate,
};
use ballpod::config::{Config, LvdtInput};

use super::{Irqs, Overruns};

/// ADC samples per excitation period (the DAC table length); the configuration's
/// `samples_per_period` must equal it in this firmware build.
pub const P: usize = 20;
/// Excitation periods per pod sample (5 kHz excitation, 1 kHz samples).
pub const PERIODS_PER_SAMPLE: usize = 5;
/// ADC samples per channel per pod sample.
pub const BLOCK: usize = P * PERIODS_PER_SAMPLE;
/// DAC excitation amplitude, counts (±1000 about mid-scale: 1.6 V peak-to-peak at 3.3 V).
pub const EXCITATION_AMPLITUDE: u16 = 1000;
/// DC-input front end: ±10 V conditioner output divided to 0…3.3 V around 1.65 V.
pub const DC_FRONT_END: DcFrontEnd = DcFrontEnd {
    volts_per_count: 20.0 / 4095.0,
    offset_v: -10.0,
};

/// One demodulated block: the pod's LVDT reading for one sample period.
#[derive(Clone, Copy)]
pub struct LvdtBlock {
    /// Time at the end of the block, µs since boot.
    pub t_us: u64,
    /// The reading (or why the block could not be demodulated).
    pub reading: Result<LvdtReading, ballpod::acquisition::lvdt::DemodError>,
}

/// LVDT task → compute task.
pub static BLOCKS: Channel<CriticalSectionRawMutex, LvdtBlock, 4> = Channel::new();
/// Blocks dropped because the compute task was behind.
pub static BLOCK_QUEUE_OVERRUNS: Overruns = Overruns::new();
/// ADC DMA ring overruns (the LVDT task was behind the DMA).
pub static ADC_RING_OVERRUNS: Overruns = Overruns::new();

static RING_A: StaticCell<[u16; 2 * BLOCK]> = StaticCell::new();
static RING_B: StaticCell<[u16; 2 * BLOCK]> = StaticCell::new();

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
    let mut ring_a = adc1.into_ring_buffered(
        p.adc_a.1,
        RING_A.init([0; 2 * BLOCK]),
        Irqs,
        [(p.adc_a.2.degrade_adc(), SampleTime::CYCLES24_5)].into_iter(),
        triggers::TIM6_TRGO,
        Exten::RISING_EDGE,
    );
    let mut ring_b = adc2.into_ring_buffered(
        p.adc_b.1,
        RING_B.init([0; 2 * BLOCK]),
        Irqs,
        [(p.adc_b.2.degrade_adc(), SampleTime::CYCLES24_5)].into_iter(),
        triggers::TIM6_TRGO,
        Exten::RISING_EDGE,
    );
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

/// Plays the excitation table forever (circular DMA) after starting the sample clock.
#[embassy_executor::task]
pub async fn dac_task(mut dac: DacChannel<'static, Async>) {
    // The table lives in this task's (static) future for as long as the DMA reads it.
    let table = ExcitationTable::<P>::new().dac_codes(EXCITATION_AMPLITUDE);
    pac::TIM6.cr1().modify(|w| w.set_cen(true));
    dac.write(ValueArray::Bit12Right(&table), true).await;
}

/// Reads one block per sample period from both ADC rings, demodulates it (AC) or averages it
/// (DC) with the core, and queues the reading for the compute task.
#[embassy_executor::task]
pub async fn lvdt_task(
    mut ring_a: RingBufferedAdc<'static, peripherals::ADC1>,
    mut ring_b: RingBufferedAdc<'static, peripherals::ADC2>,
    mode: LvdtInput,
    dc_zero_v: f32,
    dc_span_v: f32,
) {
    let table = ExcitationTable::<P>::new();
    let mut a = [0u16; BLOCK];
    let mut b = [0u16; BLOCK];
    loop {
        super::safety::check_in(super::safety::Task::Lvdt);
        let ok_a = ring_a.read(&mut a).await;
        let ok_b = ring_b.read(&mut b).await;
        if ok_a.is_err() || ok_b.is_err() {
            // The ring restarts itself on the next read; the lost samples are counted and the
            // next pod sample carries OVERRUN.
            ADC_RING_OVERRUNS.count();
            continue;
        }
        let reading = match mode {
            LvdtInput::AcRatiometric => demodulate(&a, &b, &table),
            LvdtInput::DcConditioner => Ok(dc_reading(
                DC_FRONT_END.volts(block_mean(&a)),
                dc_zero_v,
                dc_span_v,
                -10.5,
                10.5,
            )),
        };
        let block = LvdtBlock {
            t_us: embassy_time::Instant::now().as_micros(),
            reading,
        };
        if BLOCKS.try_send(block).is_err() {
            BLOCK_QUEUE_OVERRUNS.count();
        }
    }
}
