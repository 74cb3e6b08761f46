//! A block ready, onward: every board's LVDT path from the two secondaries' codes of one
//! sample period and the latch of its centre (time, encoder counters) to the application
//! task's queue — the loss count from the latched times, the demodulation (AC) or the mean
//! (DC) as the configuration's input mode says now, and the queue with its overrun counter.
//! The STM32 board's `lvdt` task calls it with its DMA rings' halves, the emulated board's
//! with its shared-memory ring; what comes before is each board's own.

use core::sync::atomic::{AtomicU8, Ordering};

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;

use ballpod::acquisition::MAX_AXES;
use ballpod::acquisition::lvdt::{
    BlockReading, DcFrontEnd, ExcitationTable, block_mean, demodulate_watched,
};
use ballpod::acquisition::periods_lost;
use ballpod::config::{Config, LvdtInput};

use super::Overruns;

/// ADC samples per excitation period (the DAC table length; the configuration's
/// `samples_per_period` can only be this).
pub const P: usize = ballpod::config::EXCITATION_POINTS as usize;
/// ADC samples per channel in the longest block (the DMA rings' storage):
/// [`MAX_PERIODS_PER_SAMPLE`](ballpod::config::MAX_PERIODS_PER_SAMPLE) periods.
pub const BLOCK_MAX: usize = P * ballpod::config::MAX_PERIODS_PER_SAMPLE as usize;
/// DC-input front end: ±10 V conditioner output divided to 0…3.3 V around 1.65 V.
pub const DC_FRONT_END: DcFrontEnd = DcFrontEnd {
    volts_per_count: 20.0 / 4095.0,
    offset_v: -10.0,
};

/// One demodulated block: the pod's LVDT reading for one sample period.
#[derive(Clone, Copy)]
pub struct LvdtBlock {
    /// Time at the block's centre, µs since boot.
    pub t_us: u64,
    /// The hardware encoder counters at the block's centre.
    pub raw: [u32; MAX_AXES],
    /// The block's reading in the mode it was acquired in.
    pub reading: BlockReading,
}

/// Blocks the queue holds: 64 ms of the application task's turns at 1 kHz, 6.4 ms at the
/// highest sample rate (10 kHz) — three times its longest turn in a run (a run's header, an
/// SDO answer, the live values' refresh: ≈ 2 ms; book "The emulated board"), so that a burst of
/// blocks arriving together on top of that turn is not dropped (at 32, 3.2 ms, the emulated
/// board dropped 11 blocks of a 10 kHz run when its late timer ticks met a 1.9 ms turn).
/// 48 bytes a block.
pub const BLOCK_QUEUE: usize = 64;
/// LVDT task → application task.
pub static BLOCKS: Channel<CriticalSectionRawMutex, LvdtBlock, BLOCK_QUEUE> = Channel::new();
/// Blocks dropped because the application task was behind.
pub static BLOCK_QUEUE_OVERRUNS: Overruns = Overruns::new();
/// Sample periods lost before demodulation (the LVDT task was behind the ADC DMA), from the
/// gaps between the blocks' latched times.
pub static ADC_BLOCKS_LOST: Overruns = Overruns::new();

/// The LVDT input mode the application's configuration names (`LvdtInput as u8`), set by the
/// application task; the LVDT task reads it per block, so a change takes effect at once.
pub static MODE: AtomicU8 = AtomicU8::new(0);

/// ADC samples per channel in one block of the running configuration: the excitation table
/// times the periods in a sample (validated 1…5, so at most [`BLOCK_MAX`]).
pub fn block_len(cfg: &Config) -> usize {
    // a whole number in a valid configuration
    let periods = cfg.periods_per_sample() as usize;
    (P * periods).clamp(P, BLOCK_MAX)
}

/// The block period, µs: one sample period (1000 µs at 1 kHz).
pub fn block_period_us(cfg: &Config) -> u32 {
    (1.0e6 / cfg.sample_rate_hz) as u32
}

/// The path from a block ready onward (module doc), with what it keeps between blocks.
pub struct BlockPath {
    table: ExcitationTable<P>,
    period_us: u32,
    prev_t_us: Option<u64>,
}

impl BlockPath {
    /// The path for blocks `period_us` apart.
    pub fn new(period_us: u32) -> Self {
        Self {
            table: ExcitationTable::<P>::new(),
            period_us,
            prev_t_us: None,
        }
    }

    /// One block: the codes `a`, `b` of the two secondaries (word-aligned: the core's DSP
    /// projection reads two codes per load), its centre's time `t_us` and encoder counters
    /// `raw`, and whether an ADC's analog watchdog tripped (the per-code rail test is then run).
    pub fn on_block(
        &mut self,
        a: &[u16],
        b: &[u16],
        t_us: u64,
        raw: [u32; MAX_AXES],
        tripped: bool,
    ) {
        if let Some(p) = self.prev_t_us {
            ADC_BLOCKS_LOST.add(periods_lost(p, t_us, self.period_us));
        }
        self.prev_t_us = Some(t_us);
        let dc = MODE.load(Ordering::Relaxed) == LvdtInput::DcConditioner as u8;
        let reading = if dc {
            BlockReading::DcVolts(DC_FRONT_END.volts(block_mean(a)))
        } else {
            BlockReading::Ac(demodulate_watched(a, b, &self.table, tripped))
        };
        if BLOCKS.try_send(LvdtBlock { t_us, raw, reading }).is_err() {
            BLOCK_QUEUE_OVERRUNS.count();
        }
    }
}
