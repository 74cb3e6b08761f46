//! The CPU load, measured in emulated time: thread mode sleeps in WFI with interrupts masked,
//! so the time from going to sleep to the wake-up is idle to the µs (the interrupt that woke
//! it runs after the second reading). The time between two sleeps is busy: the interrupt
//! executors (acquisition, CAN, USB, the application task) and the worker's polls — unless the
//! worker began a job or a save in it, which by design takes whatever the interrupts leave:
//! such a stretch is left out.
//!
//! Measured while a run runs (the session state the firmware publishes for the virtual CNC),
//! over 100 ms windows of measured time: the totals ([`Figure::RunBusyUs`],
//! [`Figure::RunMeasuredUs`]) and the busiest window ([`Figure::RunLoadPeakPermille`]) of those
//! in which no owed sample period was delivered (`lvdt::block_latch`: after QEMU stalled on the
//! host, the firmware catches up at 1.5 times the sample rate — work the pod never sees). With
//! them the blocks the application task dropped while a run ran or a job computed
//! ([`Figure::RunBlocksDropped`]: `block_queue_overruns` grown in such a stretch).
//! Another board's sleep has no such hook: this is the emulated board's figure.

use core::cell::Cell;
use core::sync::atomic::{AtomicBool, Ordering};

use ballpod::app::SessionState;
use critical_section::Mutex;
use embassy_time::Instant;

use super::block::BLOCK_QUEUE_OVERRUNS;
use super::shared::{Figure, figure, region, set_figure};
use super::worker::{WORK_BEGUN, job_alive};

/// Length of a window, µs of measured time.
const WINDOW_US: u64 = 100_000;

#[derive(Clone, Copy)]
struct State {
    /// The end of the last sleep, µs.
    woke_us: u64,
    /// [`WORK_BEGUN`] then.
    work: u32,
    /// [`BLOCK_QUEUE_OVERRUNS`] then.
    dropped: u32,
    /// [`Figure::PeriodsDeliveredLate`] when the window began.
    late: u32,
    /// The window so far: busy and measured µs.
    busy_us: u64,
    measured_us: u64,
}

static STATE: Mutex<Cell<Option<State>>> = Mutex::new(Cell::new(None));

/// True from just before thread mode's WFI to just after it: read by the NMI, which then
/// knows the core was asleep when it came (`watchdog`).
static ASLEEP: AtomicBool = AtomicBool::new(false);

/// Whether thread mode sleeps in its WFI (or is just about to, or just woke).
pub fn asleep() -> bool {
    ASLEEP.load(Ordering::Relaxed)
}

/// True while the published session is RUNNING.
fn running() -> bool {
    region().session.load(Ordering::Relaxed) & 0xFF == SessionState::Running as u32
}

/// Sleeps until an interrupt, and counts the time before it as busy and the sleep as idle.
pub fn sleep() {
    critical_section::with(|cs| {
        let went_us = Instant::now().as_micros();
        ASLEEP.store(true, Ordering::Relaxed);
        cortex_m::asm::wfi();
        ASLEEP.store(false, Ordering::Relaxed);
        let woke_us = Instant::now().as_micros();
        let work = WORK_BEGUN.load(Ordering::Relaxed);
        let dropped = BLOCK_QUEUE_OVERRUNS.get();
        let cell = STATE.borrow(cs);
        let mut s = cell.get().unwrap_or(State {
            woke_us,
            work,
            dropped,
            late: figure(Figure::PeriodsDeliveredLate),
            busy_us: 0,
            measured_us: 0,
        });
        // blocks dropped in a stretch of a run or of a job (`job_alive`: one runs now)
        if dropped != s.dropped && (running() || work != s.work || job_alive()) {
            let f = Figure::RunBlocksDropped;
            set_figure(f, figure(f).wrapping_add(dropped.wrapping_sub(s.dropped)));
        }
        // the stretch since the last wake-up: busy, then idle; left out if work began in it
        // or no run runs
        if work == s.work && running() {
            let busy = went_us.saturating_sub(s.woke_us);
            s.busy_us += busy;
            s.measured_us += woke_us.saturating_sub(s.woke_us);
            if s.measured_us >= WINDOW_US {
                let add = |f: Figure, v: u64| {
                    set_figure(f, figure(f).wrapping_add(v as u32));
                };
                add(Figure::RunBusyUs, s.busy_us);
                add(Figure::RunMeasuredUs, s.measured_us);
                let permille = (s.busy_us * 1000 / s.measured_us) as u32;
                let late = figure(Figure::PeriodsDeliveredLate);
                if late == s.late && permille > figure(Figure::RunLoadPeakPermille) {
                    set_figure(Figure::RunLoadPeakPermille, permille);
                }
                s.late = late;
                s.busy_us = 0;
                s.measured_us = 0;
            }
        }
        s.woke_us = woke_us;
        s.work = work;
        s.dropped = dropped;
        cell.set(Some(s));
    });
}
