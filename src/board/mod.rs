//! The NUCLEO-G474RE board layer: which peripheral does what, the queues between interrupt /
//! DMA side and the compute task, and their overrun counters. Tasks here only configure, read,
//! hand over and send; every computation is in the `ballpod` core.
//!
//! The pin table (pins, Nucleo headers, peripherals, wiring notes) is in the book:
//! `docs/src/hardware.md`.

pub mod block;
pub mod can;
pub mod compute;
pub mod diagnostics;
pub mod encoders;
pub mod lvdt;
pub mod overruns;
pub mod probe;
pub mod probe_queue;
pub mod rom_bootloader;
pub mod safety;
pub mod settings;
pub mod spawn;
pub mod state;
pub mod system_memory;
pub mod thermistor;
pub mod usb;
pub mod watchdog;
pub mod worker;

use embassy_stm32::{bind_interrupts, can as stm_can, dma, peripherals, usb as stm_usb};

pub use overruns::{Overruns, lost_upstream};

bind_interrupts!(pub struct Irqs {
    DMA1_CHANNEL1 => dma::InterruptHandler<peripherals::DMA1_CH1>;
    // the block latch first: embassy's handler clears the event flag it reads
    DMA1_CHANNEL2 => lvdt::BlockLatchIsr, dma::InterruptHandler<peripherals::DMA1_CH2>;
    DMA1_CHANNEL3 => dma::InterruptHandler<peripherals::DMA1_CH3>;
    EXTI4 => probe::ProbeEdgeIsr;
    // the event counts first: embassy's handler clears the bus-off flag it reads
    FDCAN1_IT0 => can::CanEventIsr, stm_can::IT0InterruptHandler<peripherals::FDCAN1>;
    FDCAN1_IT1 => stm_can::IT1InterruptHandler<peripherals::FDCAN1>;
    USB_LP => stm_usb::InterruptHandler<peripherals::USB>;
});

/// The I/O executor's interrupt priority (`main`: LVDT, DAC, thermistor, CAN, USB, watchdog):
/// below every peripheral interrupt, above the pod.
pub const IO_EXECUTOR_PRIORITY: embassy_stm32::interrupt::Priority =
    embassy_stm32::interrupt::Priority::P3;
/// The pod executor's interrupt priority (`main`: the application task): below the I/O, above
/// the worker in thread mode.
pub const POD_EXECUTOR_PRIORITY: embassy_stm32::interrupt::Priority =
    embassy_stm32::interrupt::Priority::P4;

/// Interrupt priorities (NVIC; 0 most urgent, 16 levels on the G474): the probe's EXTI4 at 0 so
/// a touch is latched within the interrupt entry whatever else runs; ADC1's DMA (the block
/// latch) at 1; everything else — the other DMA channels, the time driver (TIM15), FDCAN, USB
/// — at 2; then the two executors ([`IO_EXECUTOR_PRIORITY`], [`POD_EXECUTOR_PRIORITY`]) and
/// the worker in thread mode. Only a masked section (`diagnostics`: its longest is measured)
/// delays the two latches beyond their entry.
pub fn set_priorities() {
    use embassy_stm32::interrupt::{self, InterruptExt, Priority};
    interrupt::EXTI4.set_priority(Priority::P0);
    interrupt::DMA1_CHANNEL2.set_priority(Priority::P1);
    for irq in [
        interrupt::DMA1_CHANNEL1,
        interrupt::DMA1_CHANNEL3,
        interrupt::TIM1_BRK_TIM15,
        interrupt::FDCAN1_IT0,
        interrupt::FDCAN1_IT1,
        interrupt::USB_LP,
    ] {
        irq.set_priority(Priority::P2);
    }
}

/// The end of the application task's turn: nothing to show on this board (the emulated board
/// shows its virtual CNC the session here).
#[inline(always)]
pub fn after_turn<const L: usize, const S: usize>(_pod: &ballpod::pod::Pod<'_, L, S>) {}

/// Before the application takes the block latched at `t_us`: nothing on this board (the
/// emulated board's virtual CNC homes the axes or ends its program here, as the simulated
/// pod's does between two samples).
#[inline(always)]
pub fn before_block<const L: usize, const S: usize>(
    _pod: &mut ballpod::pod::Pod<'_, L, S>,
    _t_us: u64,
) {
}
