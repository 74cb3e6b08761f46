//! The ballpod firmware on the emulated board: QEMU's mps2-an386 (Cortex-M4F) in place of the
//! NUCLEO-G474RE. The application task (`compute_task`), the worker, the queues, the
//! watchdog's check-ins and the path from a block ready onward are the STM32 board's own
//! sources; the executors and priorities are the same (`src/main.rs`): the I/O executor
//! (LVDT, thermistor, CAN, USB, watchdog), the pod executor (the application task), the worker
//! in thread mode. The peripherals are the emulator's (`board`). The host's `emu` starts it
//! (book "The emulated board").
#![no_std]
#![no_main]

mod board;

use core::sync::atomic::Ordering;

use embassy_executor::{InterruptExecutor, Spawner};

use board::spawn::spawn;

/// The I/O executor: acquisition, CAN, USB and the watchdog.
static EXECUTOR_IO: InterruptExecutor = InterruptExecutor::new();
/// The pod executor: the application task.
static EXECUTOR_POD: InterruptExecutor = InterruptExecutor::new();

/// The I/O executor's interrupt.
pub extern "C" fn exec_io() {
    // SAFETY: the interrupt is this executor's alone.
    unsafe { EXECUTOR_IO.on_interrupt() }
}

/// The pod executor's interrupt.
pub extern "C" fn exec_pod() {
    // SAFETY: the interrupt is this executor's alone.
    unsafe { EXECUTOR_POD.on_interrupt() }
}

/// No log transport on the emulator: defmt's output is dropped.
#[defmt::global_logger]
struct NoLog;

// SAFETY: nothing is written anywhere, so every call order is fine.
unsafe impl defmt::Logger for NoLog {
    fn acquire() {}
    unsafe fn flush() {}
    unsafe fn release() {}
    unsafe fn write(_bytes: &[u8]) {}
}

/// Thread mode: the worker's executor. Not embassy's thread executor, which sleeps with WFE:
/// QEMU takes WFE as a hint and spins on it, so emulated time would run on instructions even
/// while the firmware idles. WFI halts until an interrupt; a task woken while the executor
/// polls (from an interrupt already taken) waits for the next one (the sample clock's tick:
/// at most one sample period). The STM32 board keeps embassy's.
#[cortex_m_rt::entry]
fn main() -> ! {
    static EXECUTOR: static_cell::StaticCell<embassy_executor::raw::Executor> =
        static_cell::StaticCell::new();
    // embassy's thread-mode context (its pender answers it with SEV, which WFI ignores)
    let executor = EXECUTOR.init(embassy_executor::raw::Executor::new(usize::MAX as *mut ()));
    init(executor.spawner());
    loop {
        // SAFETY: polled from thread mode only, never reentrantly.
        unsafe { executor.poll() };
        board::load::sleep();
    }
}

/// Boots the pod: the settings, the pod's state, the executors and their tasks.
fn init(spawner: Spawner) {
    // (the STM32 board's first step: the ROM bootloader if the last run asked for it)
    board::rom_bootloader::enter_if_asked();
    board::time::start();
    let watchdog = board::watchdog::take_reset_flag();
    if watchdog {
        use board::shared::{Figure, figure, set_figure};
        set_figure(
            Figure::WatchdogResets,
            figure(Figure::WatchdogResets).wrapping_add(1),
        );
    }
    // a panic or HardFault record first, else the emulated watchdog's flag (the reset cause
    // and its report are the firmware's: `ballpod::boot`)
    let (can_report, usb_report) = match board::safety::take_reset_report() {
        Some(board::safety::ResetReport::Panic(text)) => (
            Some((
                ballpod::protocol::canopen::emcy::SOFTWARE_ERROR,
                ballpod::protocol::canopen::emcy::REASON_PANIC,
            )),
            Some(text),
        ),
        Some(board::safety::ResetReport::HardFault(text)) => (
            Some((
                ballpod::protocol::canopen::emcy::SOFTWARE_ERROR,
                ballpod::protocol::canopen::emcy::REASON_HARD_FAULT,
            )),
            Some(text),
        ),
        None => match watchdog
            .then(|| ballpod::boot::ResetCause::Watchdog.fault())
            .flatten()
        {
            Some((code, reason, text)) => (Some((code, reason)), Some(text)),
            None => (None, None),
        },
    };
    let region = board::shared::region();
    let fresh = region.boots.load(Ordering::Relaxed) == 0;
    let mut flash = board::settings::SettingsPages::take(fresh);
    if fresh && let Some(preset) = board::shared::preset_settings() {
        // (validated by the harness: a store cannot refuse them)
        let _ = ballpod::settings::store(&mut flash, &preset);
    }
    let loaded = ballpod::settings::load(&mut flash);
    let cfg = loaded.config;
    let boot = ballpod::pod::BootReport {
        can: can_report,
        usb: usb_report,
        settings_rejected: loaded.rejected(),
        settings_unreadable: loaded.unreadable(),
        // (QEMU's board has no option bytes to check)
        option_bytes: None,
    };
    let serial = 0x0E4D_0000 | region.boots.load(Ordering::Relaxed);
    let pod = board::compute::PodState::new(cfg, serial, boot);
    for u in [
        &board::uart::UART0,
        &board::uart::UART1,
        &board::uart::UART2,
    ] {
        u.start();
    }
    board::hw::set_priorities();
    let io = EXECUTOR_IO.start(board::hw::EXEC_IO);
    let pod_spawner = EXECUTOR_POD.start(board::hw::EXEC_POD);
    let period_us = board::block::block_period_us(&cfg);
    spawn(
        &pod_spawner,
        "compute",
        board::compute::compute_task(pod, board::encoders::Encoders, board::probe::ProbeInput),
    );
    spawn(&spawner, "worker", board::worker::worker_task(Some(flash)));
    spawn(
        &io,
        "lvdt",
        board::lvdt::lvdt_task(board::block::block_len(&cfg), period_us),
    );
    spawn(&io, "thermistor", board::thermistor::thermistor_task());
    spawn(&io, "can", board::can::can_task(cfg.can_bitrate));
    spawn(&io, "usb", board::usb::usb_task());
    spawn(&io, "watchdog", board::watchdog::watchdog_task());
    board::lvdt::start(period_us);
    board::shared::booted();
}
