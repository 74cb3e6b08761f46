//! The emulated board: QEMU's mps2-an386 (Cortex-M4F) standing in for the NUCLEO-G474RE. The
//! application task, the worker, the queues, the watchdog's check-ins and the path from a
//! block ready onward are the STM32 board's own files (`src/board/`, included below by path);
//! the modules of this folder put the emulator's peripherals behind the same names:
//!
//! | STM32 board | emulated board |
//! |---|---|
//! | ADC1/ADC2 DMA rings, TIM6, the block latch (DMA1 CH2, priority 1) | the harness's block ring in shared memory, the dual timer at the sample rate (priority 1) |
//! | five timers in encoder mode | the counters in each block record, latched by the same interrupt |
//! | EXTI4 probe edge (priority 0) | a software-pended interrupt for a block record's edge (priority 0) |
//! | ADC3 thermistor every 100 ms | the code in the block records, every 100 ms |
//! | FDCAN1 | SLCAN over UART0 (QEMU serial 0 on a TCP port) |
//! | USB command and stream ports | UART1 and UART2 (serial 1 and 2) |
//! | IWDG | the CMSDK watchdog |
//! | the settings pages in flash | two RAM pages with the G4's erase and double-word rules |
//! | embassy-stm32's time driver (TIM15) | CMSDK timers 0 (time base) and 1 (alarm) |
//! | ST's ROM bootloader (system memory) | an entry counted, the boot goes on |
//!
//! Priorities as on the STM32 board: probe 0, block latch 1, UARTs and timers 2, the I/O
//! executor 3, the pod executor 4, the worker in thread mode.

#[path = "../../../../src/board/block.rs"]
pub mod block;
#[path = "../../../../src/board/compute.rs"]
pub mod compute;
#[path = "../../../../src/board/overruns.rs"]
pub mod overruns;
#[path = "../../../../src/board/probe_queue.rs"]
pub mod probe_queue;
#[path = "../../../../src/board/rom_bootloader.rs"]
pub mod rom_bootloader;
#[path = "../../../../src/board/safety.rs"]
pub mod safety;
#[path = "../../../../src/board/spawn.rs"]
pub mod spawn;
// (the USB disconnect events: QEMU's UARTs have no modem lines to see one)
#[allow(dead_code)]
#[path = "../../../../src/board/state.rs"]
pub mod state;
#[path = "../../../../src/board/worker.rs"]
pub mod worker;

pub mod can;
pub mod cnc;
pub mod diagnostics;
pub mod encoders;
pub mod hw;
pub mod load;
pub mod lvdt;
pub mod probe;
pub mod settings;
pub mod shared;
pub mod system_memory;
pub mod thermistor;
pub mod time;
pub mod uart;
pub mod usb;
pub mod watchdog;

pub use overruns::{Overruns, lost_upstream};

/// The end of the application task's turn: the session goes to the shared region, where the
/// harness's virtual CNC reads it (what a CNC would see over the protocols).
pub fn after_turn<const L: usize, const S: usize>(pod: &ballpod::pod::Pod<'_, L, S>) {
    shared::publish_session(pod.app);
}

/// Before the application takes the block latched at `t_us`: what the virtual CNC did between
/// the two samples ([`cnc`]).
pub fn before_block<const L: usize, const S: usize>(
    pod: &mut ballpod::pod::Pod<'_, L, S>,
    t_us: u64,
) {
    cnc::apply(pod, t_us);
}
