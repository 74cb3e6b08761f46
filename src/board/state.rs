//! State shared between the tasks: the pod model the protocols read and write, the sample log,
//! and the queue of session commands the protocols hand to the compute task.

use core::cell::RefCell;
use core::sync::atomic::{AtomicBool, Ordering};

use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;

use ballpod::protocol::log::{LOG_CAPACITY, SampleLog};
use ballpod::protocol::pod::{PodModel, SessionCommand};

use super::Overruns;

/// The pod as CAN and USB see it (live values, configuration, session, results).
pub static POD: Mutex<CriticalSectionRawMutex, RefCell<Option<PodModel>>> =
    Mutex::new(RefCell::new(None));

/// The sample log downloaded over USB (32 KiB: `LOG_CAPACITY` records of 32 bytes).
pub static LOG: Mutex<CriticalSectionRawMutex, RefCell<SampleLog<LOG_CAPACITY>>> =
    Mutex::new(RefCell::new(SampleLog::new()));

/// Session commands from the protocol tasks to the compute task.
pub static COMMANDS: Channel<CriticalSectionRawMutex, SessionCommand, 8> = Channel::new();
/// Commands dropped because the compute task had not taken the previous ones.
pub static COMMAND_QUEUE_OVERRUNS: Overruns = Overruns::new();

/// Runs `f` on the pod model (inside a short critical section); `None` before the compute
/// task has published the first model.
pub fn with_pod<R>(f: impl FnOnce(&mut PodModel) -> R) -> Option<R> {
    POD.lock(|p| p.borrow_mut().as_mut().map(f))
}

/// Queues a command for the compute task (counted if the queue is full).
pub fn submit(cmd: SessionCommand) {
    if COMMANDS.try_send(cmd).is_err() {
        COMMAND_QUEUE_OVERRUNS.count();
    }
}

/// True while a USB log download is in progress: the compute task does not log meanwhile (the
/// download announced its length), and counts the samples it could not log.
static DOWNLOAD_ACTIVE: AtomicBool = AtomicBool::new(false);
/// Samples not logged because a download was in progress.
pub static LOG_PAUSED_SAMPLES: Overruns = Overruns::new();

/// Marks a log download as running or finished.
pub fn set_download_active(on: bool) {
    DOWNLOAD_ACTIVE.store(on, Ordering::Release);
}

/// True while a log download is in progress.
pub fn download_active() -> bool {
    DOWNLOAD_ACTIVE.load(Ordering::Acquire)
}
