//! The technician's desk (`cargo desk`): a local web page that keeps machines and their
//! tolerances, runs a test on a pod (writes its set-up over SCPI, arms and starts it, records
//! the stream port), draws the trace while the machine moves, reads the pod's results back and
//! checks them against a replay of the recorded stream, decides each figure against its
//! tolerance with the pod's U (ISO 14253-1) and keeps every run in a history file, with a
//! self-contained report per run.
//!
//! Layout: [`decision`] (the rule), [`store`] (the history), [`pod`] (the link), [`tests`] (the
//! templates: what a test writes and runs), [`report`] (HTML), [`web`] (the HTTP server, thin).

pub mod decision;
pub mod pod;
pub mod report;
pub mod store;
pub mod tests;
pub mod web;

use std::sync::{Arc, Mutex};

use pod::{Pod, StreamBuffer};
use store::Store;

/// What the live view shows: the run under way.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct Live {
    /// The desk's run row (None: nothing run yet).
    pub run_id: Option<i64>,
    /// What the desk is doing or waiting for (e.g. "CCW run: the machine moves").
    pub step: String,
    /// The test is over (done or failed).
    pub finished: bool,
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
    pub store: Mutex<Store>,
    /// The pod (None: the desk serves the history without one).
    pub pod: Mutex<Option<Pod>>,
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
    /// A desk on this history and (optionally) pod.
    pub fn new(store: Store, pod: Option<Pod>) -> Arc<Self> {
        let stream = pod.as_ref().map(|p| p.stream.clone());
        Arc::new(Self {
            store: Mutex::new(store),
            pod: Mutex::new(pod),
            stream,
            live: Mutex::new(Live::default()),
        })
    }
}
