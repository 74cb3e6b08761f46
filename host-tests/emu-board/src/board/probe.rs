//! The touch-trigger probe: a block record's edge pends this interrupt (priority 0, the STM32's
//! EXTI4), which latches the record's counters at the edge and the time and queues them; the
//! stylus level is the latest record's.

use core::sync::atomic::{AtomicU32, Ordering};

use super::probe_queue::ProbeEdge;
use super::shared;

/// The record whose edge the interrupt latches.
pub static EDGE_RECORD: AtomicU32 = AtomicU32::new(0);

/// The probe's contact: the latest record's level.
pub struct ProbeInput;

/// The stylus is seated (at rest).
pub fn seated(_input: &ProbeInput) -> bool {
    let k = EDGE_LEVEL_RECORD.load(Ordering::Relaxed);
    shared::record(k).seated != 0
}

/// The record the level is read from (the latest the sample clock took).
static EDGE_LEVEL_RECORD: AtomicU32 = AtomicU32::new(0);

/// Notes the latest record (the sample clock, per tick).
pub fn level_from(record: u32) {
    EDGE_LEVEL_RECORD.store(record, Ordering::Relaxed);
}

/// The probe interrupt.
pub extern "C" fn probe_edge() {
    let t_us = embassy_time::Instant::now().as_micros();
    let rec = shared::record(EDGE_RECORD.load(Ordering::Relaxed));
    let raw = rec.edge_raw.map(|c| c & 0xFFFF);
    super::probe_queue::queue(ProbeEdge { t_us, raw });
}
