//! The overrun counters of the board's bounded queues, and the samples they lost: a producer
//! that finds its queue full drops the item and counts it, never silently. Every board's.

use core::sync::atomic::{AtomicU32, Ordering};

use ballpod::app::{DeviceCounter, DeviceCounters};

/// An overrun counter of a bounded queue: incremented when a producer finds the queue full
/// (the item is dropped and counted, never silently).
pub struct Overruns(AtomicU32);

impl Overruns {
    /// A counter at zero.
    pub const fn new() -> Self {
        Self(AtomicU32::new(0))
    }
    /// Counts one lost item.
    pub fn count(&self) {
        self.0.fetch_add(1, Ordering::Relaxed);
    }
    /// Counts `n` lost items.
    pub fn add(&self, n: u32) {
        if n != 0 {
            self.0.fetch_add(n, Ordering::Relaxed);
        }
    }
    /// Items lost so far.
    pub fn get(&self) -> u32 {
        self.0.load(Ordering::Relaxed)
    }
}

/// Samples lost by the queues feeding them (ADC DMA ring, LVDT block queue): the application
/// task hands this total to the core, which flags the next sample `OVERRUN` and numbers it past
/// the lost ones. (A dropped probe edge is no lost sample: `probe_queue::PROBE_QUEUE_OVERRUNS`.)
pub fn lost_upstream() -> u32 {
    super::block::ADC_BLOCKS_LOST
        .get()
        .wrapping_add(super::block::BLOCK_QUEUE_OVERRUNS.get())
}

/// The device counters of the queues every board has (the LVDT blocks, the probe edges, the
/// thermistor codes, CAN and USB in and out) and of the watchdog's looks; the rest of the table
/// at its start (each board adds what it measures).
pub fn queue_counters() -> DeviceCounters {
    use DeviceCounter as C;
    let mut c = DeviceCounters::START;
    for (k, v) in [
        (C::AdcBlocksLost, super::block::ADC_BLOCKS_LOST.get()),
        (
            C::BlockQueueOverruns,
            super::block::BLOCK_QUEUE_OVERRUNS.get(),
        ),
        (
            C::ProbeQueueOverruns,
            super::probe_queue::PROBE_QUEUE_OVERRUNS.get(),
        ),
        (
            C::ThermistorQueueOverruns,
            super::thermistor::CODE_QUEUE_OVERRUNS.get(),
        ),
        (C::CanRxOverruns, super::state::CAN_RX_OVERRUNS.get()),
        (C::CanTxOverruns, super::state::CAN_TX_OVERRUNS.get()),
        (C::CanTxDropped, super::state::CAN_TX_DROPPED.get()),
        (C::CanRxLost, super::state::CAN_RX_LOST.get()),
        (C::UsbRxOverruns, super::state::USB_RX_OVERRUNS.get()),
        (C::UsbTxOverruns, super::state::USB_TX_OVERRUNS.get()),
        (C::WatchdogMisses, super::safety::WATCHDOG_MISSES.get()),
    ] {
        c.set(k, v);
    }
    c
}
