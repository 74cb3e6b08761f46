//! The probe edges from the probe's interrupt to the application task: the time and the
//! encoder counters latched at each edge, queued (the application applies the core's debounce
//! and re-seat lock-out). Every board's; the interrupt is each board's own.

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;

use ballpod::acquisition::MAX_AXES;

use super::Overruns;

/// A probe edge as latched in the interrupt.
#[derive(Clone, Copy)]
pub struct ProbeEdge {
    /// Time of the edge, µs since boot.
    pub t_us: u64,
    /// The hardware encoder counters at the edge.
    pub raw: [u32; MAX_AXES],
}

/// Probe interrupt → application task.
pub static EDGES: Channel<CriticalSectionRawMutex, ProbeEdge, 8> = Channel::new();
/// Edges dropped because the queue was full.
pub static PROBE_QUEUE_OVERRUNS: Overruns = Overruns::new();

/// Queues an edge (from the probe's interrupt); a full queue drops it, counted.
pub fn queue(edge: ProbeEdge) {
    if EDGES.try_send(edge).is_err() {
        PROBE_QUEUE_OVERRUNS.count();
    }
}
