//! The technician's desk (`cargo desk`): a local web page that keeps machines and their
//! tolerances, runs a test on a pod (writes its set-up over SCPI, arms and starts it, records
//! the stream port), draws the trace while the machine moves, reads the pod's results back and
//! checks them against a replay of the recorded stream, decides each figure against its
//! tolerance with the pod's U (ISO 14253-1) and keeps every run in a history file, with a
//! self-contained report per run.
//!
//! Layout: [`decision`] (the rule), [`store`] (the history, SQLite or PostgreSQL), [`spool`]
//! (runs waiting for it), [`pod`] (the link), [`tests`] (the templates: what a test writes and
//! runs), [`report`] (HTML), [`web`] (the HTTP server, thin).

pub mod decision;
pub mod exchange;
pub mod pod;
pub mod report;
pub mod spool;
pub mod store;
pub mod tests;
pub mod web;

use std::sync::{Arc, Mutex};

use pod::{Pod, StreamBuffer};
use spool::Spool;
use store::StoreHandle;

/// What the live view shows: the test under way, or the last.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct Live {
    /// The desk's number for the test (from 1 since the desk started; 0: none yet).
    pub test: u64,
    /// The run's id in the history once stored (None while it runs, or while it waits in the
    /// spool for the database).
    pub run_id: Option<i64>,
    /// What the desk is doing or waiting for (e.g. "CCW run: the machine moves").
    pub step: String,
    /// The test is over (done or failed).
    pub finished: bool,
    /// The operator asked to stop the test (`POST /api/tests/stop`): the run under way is
    /// aborted (`SESS:ABOR`) and the test ends `failed`, kept with what was recorded.
    #[serde(skip)]
    pub stop: bool,
    /// The run's key in the spool and the history.
    #[serde(skip)]
    pub spool_key: String,
    /// Where the current pod run's bytes start in the stream buffer.
    #[serde(skip)]
    pub stream_from: usize,
    /// The plane's two axis columns for the trace (e.g. `x_mm`, `y_mm`) and the centre.
    #[serde(skip)]
    pub trace: Option<tests::TraceAxes>,
}

/// The desk's state, shared by the server's handlers and the test thread.
pub struct Desk {
    /// The history.
    pub store: StoreHandle,
    /// Runs waiting for the history.
    pub spool: Spool,
    /// The pod (None: the desk serves the history without one); a test's thread holds it
    /// for the whole test.
    pub pod: Mutex<Option<Pod>>,
    /// The pod's `*IDN?`, read when the desk connected (readable while a test holds the pod).
    pub identity: Option<String>,
    /// The stream buffer of the pod (for the live view without holding the pod).
    pub stream: Option<Arc<Mutex<StreamBuffer>>>,
    /// The run under way, or the last.
    pub live: Mutex<Live>,
}

/// Locks a mutex whatever a panicked holder left (the desk's state stays readable).
pub fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

impl Desk {
    /// A desk on this history, spool and (optionally) pod; a thread stores what waits in the
    /// spool every 5 s.
    pub fn new(store: StoreHandle, spool: Spool, pod: Option<Pod>) -> Arc<Self> {
        let stream = pod.as_ref().map(|p| p.stream.clone());
        let identity = pod.as_ref().map(|p| p.identity.clone());
        let d = Arc::new(Self {
            identity,
            store,
            spool,
            pod: Mutex::new(pod),
            stream,
            live: Mutex::new(Live::default()),
        });
        let w = Arc::downgrade(&d);
        std::thread::spawn(move || {
            while let Some(d) = w.upgrade() {
                d.flush_spool();
                drop(d);
                std::thread::sleep(std::time::Duration::from_secs(5));
            }
        });
        d
    }

    /// Stores what waits in the spool; the live view learns a stored run's id.
    pub fn flush_spool(&self) {
        if let Ok(stored) = self.spool.flush(&self.store) {
            let mut live = lock(&self.live);
            for (key, id) in stored {
                if live.spool_key == key {
                    live.run_id = Some(id);
                    live.step = "done; stored from the spool".into();
                }
            }
        }
    }
}
