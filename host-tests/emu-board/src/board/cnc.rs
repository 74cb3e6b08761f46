//! The virtual CNC's test port: what the harness's virtual CNC does between two samples — home
//! the axes at its program's start, end the run with its program's last block — reaches the
//! application task in order with the blocks. The simulated pod's virtual CNC calls the same
//! two functions of the core (`App::reference_axes`, the STOP command) between the same two
//! samples; on the STM32 board there is no such port (a CNC references the axes and stops a
//! run over CAN).

use core::cell::Cell;

use critical_section::Mutex;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;

use ballpod::acquisition::MAX_AXES;
use ballpod::app::Command;
use ballpod::pod::Pod;

use super::shared::{CNC_PROGRAM_END, CNC_REFERENCE, Record};

/// One thing the virtual CNC did, before the block latched at `t_us`.
#[derive(Clone, Copy)]
pub struct CncEvent {
    /// The block it comes before.
    t_us: u64,
    /// The axes were homed: counters, positions (mm / degrees).
    reference: Option<([u32; MAX_AXES], [f64; MAX_AXES])>,
    /// The program ended: the run stops.
    program_end: bool,
}

/// LVDT task → application task (the harness writes one a run at the most, two runs apart).
static EVENTS: Channel<CriticalSectionRawMutex, CncEvent, 4> = Channel::new();
/// An event taken for a later block than the application's.
static HELD: Mutex<Cell<Option<CncEvent>>> = Mutex::new(Cell::new(None));

/// The record's event, if it has one, for the block latched at `t_us` (the LVDT task, before it
/// hands the block on).
pub fn from_record(rec: &Record, t_us: u64) {
    // SAFETY: the record is the harness's until the firmware marks it taken (the LVDT task's
    // caller marks it after this).
    let (cnc, raw, pos) = unsafe {
        (
            core::ptr::read_volatile(&rec.cnc),
            core::ptr::read_volatile(&rec.reference_raw),
            core::ptr::read_volatile(&rec.reference_pos),
        )
    };
    if cnc == 0 {
        return;
    }
    let positions: [f64; MAX_AXES] = core::array::from_fn(|i| {
        let word = |k: usize| u64::from(pos.get(k).copied().unwrap_or(0));
        f64::from_bits(word(2 * i) | word(2 * i + 1) << 32)
    });
    let event = CncEvent {
        t_us,
        reference: (cnc & CNC_REFERENCE != 0).then_some((raw.map(|c| c & 0xFFFF), positions)),
        program_end: cnc & CNC_PROGRAM_END != 0,
    };
    if EVENTS.try_send(event).is_err() {
        defmt::error!("virtual CNC events lost");
    }
}

/// The events before the block latched at `t_us`, given to the application (its task, before
/// the block).
pub fn apply<const L: usize, const S: usize>(pod: &mut Pod<'_, L, S>, t_us: u64) {
    loop {
        let next = critical_section::with(|cs| HELD.borrow(cs).take())
            .or_else(|| EVENTS.try_receive().ok());
        let Some(e) = next else { return };
        if e.t_us > t_us {
            critical_section::with(|cs| HELD.borrow(cs).set(Some(e)));
            return;
        }
        if let Some((raw, positions)) = e.reference {
            pod.app.reference_axes(raw, positions);
        }
        if e.program_end {
            // (refused unless a run is running: the client may have stopped it already)
            let _ = pod.app.execute(Command::Stop);
        }
    }
}
