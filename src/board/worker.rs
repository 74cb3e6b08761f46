//! The worker: the long work of the pod in thread mode, below every interrupt — the jobs of the
//! application (`ballpod::app::job`: the ISO 230-4 figures of a run that ended, 0.1–0.3 s; the
//! seed 002 identification, 2.6 s) and the settings saves (≈ 26 ms of flash erase and
//! program). The application task hands work over through [`WORK`] and takes it back through
//! [`DONE`]; meanwhile samples, frames and bytes go on at their priorities
//! (`board::set_priorities`), and the application answers commands from its own state (a job
//! runs on its own copy of its inputs, in [`JobSlot`]).
//!
//! **Watchdog.** The worker checks in every [`super::safety::CHECK_IN_MS`] while it waits; a
//! job is one long computation with no place to report from, so while one runs its deadline
//! stands for its check-in: the watchdog takes the worker as alive until
//! [`JOB_DEADLINE_MS`] after the job began ([`job_alive`]), and a job that overruns it is
//! taken as hung (the pod resets and reports it).

use core::sync::atomic::{AtomicU32, Ordering};

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;
use embassy_time::{Duration, Instant, with_timeout};

use ballpod::app::JobSlot;
use ballpod::config::Config;
use ballpod::settings;

use super::safety::{self, Task};
use super::settings::SettingsPages;

/// The longest a job may run before the watchdog takes it as hung, ms: three times the
/// longest one measured (the seed 002 identification, 2.58 s under QEMU at 170 MHz: book
/// "Performance and memory").
pub const JOB_DEADLINE_MS: u32 = 8_000;

/// Work for the worker.
// (a configuration by value: the queue holds two, and a save copies it once)
#[allow(clippy::large_enum_variant)]
pub enum Work {
    /// Run the job in the slot (`App::start_job` filled it).
    Job(&'static mut JobSlot),
    /// Store this configuration in the next settings slot.
    Store(Config),
}

/// What the worker hands back.
pub enum Done {
    /// The slot, its job run (for `App::finish_job`).
    Job(&'static mut JobSlot),
    /// A settings save ended: whether it worked.
    Stored(bool),
}

/// Application task → worker (one job and one save can wait at once).
pub static WORK: Channel<CriticalSectionRawMutex, Work, 2> = Channel::new();
/// Worker → application task.
pub static DONE: Channel<CriticalSectionRawMutex, Done, 2> = Channel::new();

/// When the running job began, ms since boot, plus one (0: no job runs).
static JOB_BEGAN_MS: AtomicU32 = AtomicU32::new(0);
/// How long the longest job took, ms (device counters).
pub static LONGEST_JOB_MS: AtomicU32 = AtomicU32::new(0);
/// Work items (jobs and saves) begun since boot: the emulated board's CPU-load figure leaves
/// out the time they take (they use what the interrupts leave, by design).
pub static WORK_BEGUN: AtomicU32 = AtomicU32::new(0);

fn now_ms() -> u32 {
    Instant::now().as_millis() as u32
}

/// True while a job runs within its deadline (the watchdog's stand-in for the worker's
/// check-in).
pub fn job_alive() -> bool {
    match JOB_BEGAN_MS.load(Ordering::Relaxed) {
        0 => false,
        began => now_ms().wrapping_sub(began - 1) < JOB_DEADLINE_MS,
    }
}

/// Runs the work handed over, in thread mode. `flash` is `None` when the option bytes leave
/// the settings pages unusable (`ballpod::boot::OptionBytes::fault`): every save then fails.
#[embassy_executor::task]
pub async fn worker_task(mut flash: Option<SettingsPages>) {
    loop {
        safety::check_in(Task::Worker);
        let Ok(work) =
            with_timeout(Duration::from_millis(safety::CHECK_IN_MS), WORK.receive()).await
        else {
            continue;
        };
        WORK_BEGUN.fetch_add(1, Ordering::Relaxed);
        let done = match work {
            Work::Job(slot) => {
                let began = now_ms();
                JOB_BEGAN_MS.store(began.wrapping_add(1).max(1), Ordering::Relaxed);
                slot.run();
                JOB_BEGAN_MS.store(0, Ordering::Relaxed);
                let took = now_ms().wrapping_sub(began);
                LONGEST_JOB_MS.fetch_max(took, Ordering::Relaxed);
                defmt::info!("job took {} ms", took);
                Done::Job(slot)
            }
            Work::Store(cfg) => Done::Stored(flash.as_mut().is_some_and(|f| save(f, &cfg))),
        };
        safety::check_in(Task::Worker);
        DONE.send(done).await;
    }
}

/// Stores a configuration in the next settings slot (logged; on failure the previous
/// settings are still the ones loaded at boot). Returns whether it worked.
fn save(flash: &mut SettingsPages, cfg: &Config) -> bool {
    match settings::store(flash, cfg) {
        Ok(s) => {
            defmt::info!(
                "settings stored in slot {}, sequence {}",
                s.slot.index(),
                s.sequence
            );
            true
        }
        Err(e) => {
            defmt::error!("settings not stored: {}", super::settings::store_reason(&e));
            false
        }
    }
}
