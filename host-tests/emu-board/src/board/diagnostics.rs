//! What the emulated board measures of itself, for the application's device counters.

use ballpod::app::{DeviceCounter, DeviceCounters};

use super::{state, uart};

/// Every device counter the board keeps (the pod adds its own: `Pod::set_device_counters`):
/// the queues' (`overruns::queue_counters`) with the UARTs' receive overruns in CAN's and
/// USB's; the stack's high-water mark (the STM32 board's measure: `stack.rs`); the
/// masked-section time and the DAC are not measured here.
pub fn device_counters() -> DeviceCounters {
    let mut c = super::overruns::queue_counters();
    c.set(
        DeviceCounter::CanRxOverruns,
        state::CAN_RX_OVERRUNS.get() + uart::UART0.rx_overruns.get(),
    );
    c.set(
        DeviceCounter::UsbRxOverruns,
        state::USB_RX_OVERRUNS.get() + uart::UART1.rx_overruns.get(),
    );
    c.set(
        DeviceCounter::StackHighWaterBytes,
        stack::stack_high_water_bytes(),
    );
    // (the harness keeps them beside its figures: no client port needed to read them)
    use super::shared::{Figure, set_figure};
    for (f, d) in [
        (Figure::AdcBlocksLost, DeviceCounter::AdcBlocksLost),
        (
            Figure::BlockQueueOverruns,
            DeviceCounter::BlockQueueOverruns,
        ),
        (Figure::WatchdogMisses, DeviceCounter::WatchdogMisses),
        (
            Figure::StackHighWaterBytes,
            DeviceCounter::StackHighWaterBytes,
        ),
    ] {
        set_figure(f, c.get(d));
    }
    use core::sync::atomic::Ordering::Relaxed;
    set_figure(
        Figure::LongestTurnUs,
        super::compute::LONGEST_TURN_US.load(Relaxed),
    );
    set_figure(
        Figure::LongestTurnKind,
        super::compute::LONGEST_TURN_KIND.load(Relaxed),
    );
    c
}

#[path = "../../../../src/board/stack.rs"]
mod stack;
