//! The compute task: one pod sample per LVDT block, through the core's acquisition pipeline.

use core::cell::Cell;

use embassy_stm32::exti::ExtiInput;
use embassy_stm32::mode::Blocking;
use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;

use ballpod::acquisition::probe::{ProbeLatch, TriggerOutcome};
use ballpod::acquisition::{Acquisition, Sample};

use super::{encoders, lvdt, probe, thermistor};

/// The latest sample, for the CAN and USB tasks (live values; the sample log comes later).
pub static LATEST: Mutex<CriticalSectionRawMutex, Cell<Option<Sample>>> =
    Mutex::new(Cell::new(None));
/// The latest accepted touch point.
pub static LAST_TOUCH: Mutex<CriticalSectionRawMutex, Cell<Option<ProbeLatch>>> =
    Mutex::new(Cell::new(None));

/// Turns each LVDT block, the encoder counters, the probe edges and the temperature into a
/// calibrated sample with the core.
#[embassy_executor::task]
pub async fn compute_task(
    mut acq: Acquisition,
    _encoders: encoders::Encoders,
    probe_in: ExtiInput<'static, Blocking>,
) {
    loop {
        let block = lvdt::BLOCKS.receive().await;
        while let Ok(code) = thermistor::CODES.try_receive() {
            if let Err(e) = acq.update_temperature(code) {
                defmt::warn!("thermistor fault {}", defmt::Debug2Format(&e));
            }
        }
        let mut probe_event = false;
        while let Ok(edge) = probe::EDGES.try_receive() {
            if let TriggerOutcome::Accepted(latch) = acq.probe_trigger(edge.t_us, edge.raw) {
                probe_event = true;
                LAST_TOUCH.lock(|c| c.set(Some(latch)));
            }
        }
        // NC contact to ground with pull-up: seated reads low.
        acq.probe.poll(block.t_us, probe_in.is_low());
        let s = acq.sample(
            block.t_us,
            block.reading,
            encoders::raw_counts(),
            super::lost_upstream(),
            probe_event,
        );
        LATEST.lock(|c| c.set(Some(s)));
        if s.seq.is_multiple_of(1000) {
            defmt::info!(
                "sample {} dl={} um flags={=u16:#x}",
                s.seq,
                s.delta_l_um,
                s.flags.0
            );
        }
    }
}
