//! Reading and writing the dictionary: an SDO upload or download of one entry, against the
//! [`App`] and the node's communication parameters ([`CommParams`]); a refusal becomes its SDO
//! abort code.

use super::super::abort::SdoAbort;
use super::super::nmt::NmtState;
use super::super::pdo::{self, COB_ID_EXTENDED, COB_ID_INVALID, TPDO_COUNT, TpdoParams};
use crate::app::{App, Command, CommandError, Direction, Pattern};
use crate::config::{AxisName, CanBitrate, ConfigError, Field, FieldType, LvdtInput};

use super::*;

/// The node's communication parameters and error state: the values behind the 0x1xxx objects
/// that are not constants. Reset to [`CommParams::new`] by NMT reset communication.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CommParams {
    /// Node-ID (1…127) the COB-IDs are derived from.
    pub node_id: u8,
    /// Serial number 0x1018:4.
    pub serial: u32,
    /// Error register 0x1001 (CiA 301 §7.5.2.2: bit 0 generic, bit 7 manufacturer specific).
    pub error_register: u8,
    /// Pre-defined error field 0x1003 (newest first).
    pub errors: [u32; ERROR_HISTORY_LEN],
    /// Number of valid entries in `errors`.
    pub error_count: u8,
    /// COB-ID SYNC 0x1005.
    pub cob_id_sync: u32,
    /// Inhibit time EMCY 0x1015, 100 µs.
    pub emcy_inhibit_100us: u16,
    /// Producer heartbeat time 0x1017, ms (0 = off).
    pub heartbeat_ms: u16,
    /// TPDO parameters 0x1800–0x1803 / 0x1A00–0x1A03.
    pub tpdo: [TpdoParams; TPDO_COUNT],
}

impl CommParams {
    /// The power-on / reset-communication values for `node_id`.
    pub fn new(node_id: u8, serial: u32) -> Self {
        Self {
            node_id,
            serial,
            error_register: 0,
            errors: [0; ERROR_HISTORY_LEN],
            error_count: 0,
            cob_id_sync: 0x80,
            emcy_inhibit_100us: DEFAULT_EMCY_INHIBIT_100US,
            heartbeat_ms: DEFAULT_HEARTBEAT_MS,
            tpdo: [0, 1, 2, 3].map(|n| pdo::default_tpdo(n, node_id)),
        }
    }

    /// Records `code` as the newest entry of the pre-defined error field (oldest drops off).
    pub fn push_error(&mut self, code: u32) {
        // newest first: shift the history down one entry (by hand: `copy_within` would link
        // the 1.5 KiB memmove into the firmware for these 28 bytes)
        let mut carry = code;
        for e in self.errors.iter_mut() {
            carry = core::mem::replace(e, carry);
        }
        self.error_count = (self.error_count + 1).min(ERROR_HISTORY_LEN as u8);
    }
}

/// Maps a refused command to its abort code: a configuration value out of the written field's
/// range → 0x0609 0031 / 0x0609 0032, NaN or a value with no meaning → 0x0609 0030 (CiA 301
/// table 22), a cross-field rule (periods per sample, duplicate axis name) → 0x0604 0043; a command the
/// session state does not allow, a pattern without its geometry, a change while a run is armed
/// or running → 0x0800 0022 (the reason in words: 0x3006).
pub(super) fn refusal_abort(err: CommandError, written: Option<Field>) -> SdoAbort {
    match err {
        CommandError::Config(ConfigError::OutOfRange {
            field,
            value,
            min,
            max,
        }) if Some(field) == written => {
            if value > max {
                SdoAbort::ValueTooHigh
            } else if value < min {
                SdoAbort::ValueTooLow
            } else {
                // NaN, or inside the range but not a whole number / not a code
                SdoAbort::InvalidValue
            }
        }
        CommandError::Config(_) => SdoAbort::ParameterIncompatible,
        CommandError::WrongState(_) | CommandError::Busy | CommandError::Missing(_) => {
            SdoAbort::WrongState
        }
    }
}

pub(super) fn put(buf: &mut [u8; MAX_VALUE_LEN], bytes: &[u8]) -> Result<usize, SdoAbort> {
    let dst = buf.get_mut(..bytes.len()).ok_or(SdoAbort::LengthMismatch)?;
    dst.copy_from_slice(bytes);
    Ok(bytes.len())
}

/// Puts the two parts of a refusal's text.
pub(super) fn put_text(
    buf: &mut [u8; MAX_VALUE_LEN],
    text: (&str, &str),
) -> Result<usize, SdoAbort> {
    let (a, b) = text;
    let n = a.len().min(MAX_VALUE_LEN);
    put(buf, a.as_bytes().get(..n).unwrap_or_default())?;
    let m = b.len().min(MAX_VALUE_LEN - n);
    if let (Some(dst), Some(src)) = (buf.get_mut(n..n + m), b.as_bytes().get(..m)) {
        dst.copy_from_slice(src);
    }
    Ok(n + m)
}

/// Reads the value of `var` into `buf` (little-endian, CiA 301 §7.1.7); returns its length.
/// Errors: [`SdoAbort::WriteOnly`] for the command object, [`SdoAbort::NoData`] for a result or
/// touch point that is not valid.
pub fn read(
    comm: &CommParams,
    app: &App,
    var: Var,
    buf: &mut [u8; MAX_VALUE_LEN],
) -> Result<usize, SdoAbort> {
    let u8v = |v: u8| [v];
    let tpdo = |n: u8| comm.tpdo.get(usize::from(n)).ok_or(SdoAbort::NoObject);
    let result = |k: u8| {
        crate::app::ResultId::from_index(usize::from(k))
            .map(|id| app.result(id))
            .filter(|r| r.valid)
            .ok_or(SdoAbort::NoData)
    };
    let c = app.config();
    match var {
        Var::ConstU8(v) => put(buf, &u8v(v)),
        Var::ConstU32(v) => put(buf, &v.to_le_bytes()),
        Var::ConstStr(s) => put(buf, s.as_bytes()),
        Var::ErrorRegister => put(buf, &u8v(comm.error_register)),
        Var::ErrorCount => put(buf, &u8v(comm.error_count)),
        Var::ErrorHistory(k) => {
            let v = if k >= 1 && k <= comm.error_count {
                comm.errors.get(usize::from(k - 1)).copied().unwrap_or(0)
            } else {
                0
            };
            put(buf, &v.to_le_bytes())
        }
        Var::CobIdSync => put(buf, &comm.cob_id_sync.to_le_bytes()),
        // Bit 0: the device saves parameters on command (CiA 301 §7.5.2.13, table 56).
        Var::Store | Var::Restore => put(buf, &1u32.to_le_bytes()),
        Var::EmcyInhibit => put(buf, &comm.emcy_inhibit_100us.to_le_bytes()),
        Var::Heartbeat => put(buf, &comm.heartbeat_ms.to_le_bytes()),
        Var::Serial => put(buf, &comm.serial.to_le_bytes()),
        Var::SdoCobId(d) => {
            let base = if d == 0 { 0x600u32 } else { 0x580 };
            put(buf, &(base + u32::from(comm.node_id)).to_le_bytes())
        }
        Var::TpdoCobId(n) => put(buf, &tpdo(n)?.cob_id.to_le_bytes()),
        Var::TpdoType(n) => put(buf, &u8v(tpdo(n)?.transmission_type)),
        Var::TpdoInhibit(n) => put(buf, &tpdo(n)?.inhibit_100us.to_le_bytes()),
        Var::TpdoEventTimer(n) => put(buf, &tpdo(n)?.event_timer_ms.to_le_bytes()),
        Var::TpdoMapCount(n) => put(buf, &u8v(tpdo(n)?.map_count)),
        Var::TpdoMap(n, k) => {
            let m = tpdo(n)?.map.get(usize::from(k).wrapping_sub(1)).copied();
            put(buf, &m.ok_or(SdoAbort::NoSubIndex)?.to_le_bytes())
        }
        Var::Config(f) => {
            let v = c.field_value(f).ok_or(SdoAbort::NoObject)?;
            let ty = crate::config::Config::field_info(f).map_or(FieldType::F32, |i| i.ty);
            match ty {
                // a set-up field that is not set reads NaN
                FieldType::F32 | FieldType::F64 => put(buf, &(v as f32).to_le_bytes()),
                FieldType::U8 => put(buf, &u8v(v as u8)),
                FieldType::U16 => put(buf, &(v as u16).to_le_bytes()),
                FieldType::U32 => put(buf, &(v as u32).to_le_bytes()),
            }
        }
        Var::LvdtInput => put(buf, &u8v(c.lvdt_input as u8)),
        Var::CanBitrate => put(buf, &u8v(c.can_bitrate as u8)),
        Var::AxisName(i) => {
            let a = c.axes.get(usize::from(i)).ok_or(SdoAbort::NoSubIndex)?;
            put(buf, &u8v(a.name as u8))
        }
        Var::AxisReversed(i) => {
            let a = c.axes.get(usize::from(i)).ok_or(SdoAbort::NoSubIndex)?;
            put(buf, &u8v(u8::from(a.reversed)))
        }
        Var::Live(k) => {
            // NaN while invalid (bit k−1 of 0x2103 clear): never a plausible 0.0
            let v = app
                .live()
                .values
                .get(usize::from(k).wrapping_sub(1))
                .copied()
                .ok_or(SdoAbort::NoSubIndex)?;
            put(buf, &v.to_le_bytes())
        }
        Var::SampleCounter => put(buf, &app.live().sample_counter.to_le_bytes()),
        Var::StatusWord => put(buf, &app.live().status.0.to_le_bytes()),
        Var::LiveValid => put(buf, &app.live().valid.to_le_bytes()),
        Var::Pattern => put(buf, &u8v(app.pattern() as u8)),
        Var::Direction => put(buf, &u8v(app.direction() as u8)),
        Var::Command => Err(SdoAbort::WriteOnly),
        Var::SessionState => put(buf, &u8v(app.session() as u8)),
        Var::AbortReason => put(buf, &u8v(app.abort_reason().map_or(0, |r| r as u8))),
        Var::RunCounter(k) => {
            let v = app.run_counters().as_array();
            put(buf, &counter(&v, k)?.to_le_bytes())
        }
        Var::DeviceCounter(k) => {
            let v = app.device_counters().0;
            put(buf, &counter(&v, k)?.to_le_bytes())
        }
        Var::Refusal => put_text(buf, app.last_refusal().map_or(("", ""), |r| r.text())),
        Var::ProcedureNote => put_text(buf, app.procedure_note().map_or(("", ""), |r| r.text())),
        Var::TouchCount => put(buf, &u8v(app.touch_points().len() as u8)),
        Var::Touch(axis, k) => {
            let p = app
                .touch_points()
                .get(usize::from(k))
                .ok_or(SdoAbort::NoData)?;
            let v = p
                .get(usize::from(axis))
                .copied()
                .ok_or(SdoAbort::NoSubIndex)?;
            put(buf, &(v as f32).to_le_bytes())
        }
        Var::AxisPosition(k) => {
            let p = app.axis_position(usize::from(k)).unwrap_or(f32::NAN);
            put(buf, &p.to_le_bytes())
        }
        Var::ResultValue(k) => put(buf, &result(k)?.value.to_le_bytes()),
        Var::ResultUncertainty(k) => put(buf, &result(k)?.std_uncertainty.to_le_bytes()),
        Var::ResultValid(k) => {
            let valid = crate::app::ResultId::from_index(usize::from(k))
                .is_some_and(|id| app.result(id).valid);
            put(buf, &u8v(u8::from(valid)))
        }
    }
}

pub(super) fn le_u32(data: &[u8]) -> u32 {
    let mut b = [0u8; 4];
    for (d, s) in b.iter_mut().zip(data) {
        *d = *s;
    }
    u32::from_le_bytes(b)
}

/// Checks an unsigned write against the entry's limits.
pub(super) fn check_limits(e: &Entry, v: f64) -> Result<(), SdoAbort> {
    match e.limits {
        Some((_, hi)) if v > hi => Err(SdoAbort::ValueTooHigh),
        Some((lo, _)) if v < lo => Err(SdoAbort::ValueTooLow),
        _ => Ok(()),
    }
}

/// Writes `data` (exactly the entry's size; the SDO server checked it) to entry `e`.
///
/// Every check happens before anything changes: on error the application and the parameters
/// are as before. Rules of CANopen: configuration objects (0x2000–0x20FF) only in
/// pre-operational ([`SdoAbort::WrongState`] otherwise); PDO mapping only while the PDO is
/// invalid and its sub-index 0 is 0 (the procedure of CiA 301 §7.5.2.38). Everything else —
/// whether a command fits the session state, a pattern's geometry is set, a value is
/// acceptable — the application decides ([`App::execute`], [`App::set_field`]), and a refusal
/// is aborted with the code of `refusal_abort`.
pub fn write(
    comm: &mut CommParams,
    app: &mut App,
    nmt: NmtState,
    e: &Entry,
    data: &[u8],
) -> Result<(), SdoAbort> {
    if !e.access.writable() {
        return Err(SdoAbort::ReadOnly);
    }
    let raw = le_u32(data);
    let is_config = (CONFIG_BASE..CONFIG_BASE + 0x100).contains(&e.index);
    if is_config && nmt != NmtState::PreOperational {
        return Err(SdoAbort::WrongState);
    }
    let v = if e.ty == DataType::Real32 {
        let v = f64::from(f32::from_le_bytes(raw.to_le_bytes()));
        if v.is_nan() {
            return Err(SdoAbort::InvalidValue);
        }
        v
    } else {
        f64::from(raw)
    };
    // A REAL32 configuration field's range is the configuration's own check (limits rounded
    // to REAL32, so the EDS's LowLimit/HighLimit are writable), aborted by `refusal_abort`.
    if !(matches!(e.var, Var::Config(_)) && e.ty == DataType::Real32) {
        check_limits(e, v)?;
    }
    let tpdo_index = |n: u8| usize::from(n).min(TPDO_COUNT - 1);
    let refused = |f: Option<Field>| move |err| refusal_abort(err, f);
    match e.var {
        Var::ErrorCount => {
            comm.errors = [0; ERROR_HISTORY_LEN];
            comm.error_count = 0;
        }
        Var::CobIdSync => {
            // Bit 30 = 1 would make the node a SYNC producer (not supported); 29-bit IDs are not
            // supported; CAN-ID 0 is NMT.
            if raw & (1 << 30 | COB_ID_EXTENDED) != 0 || raw & 0x1FFF_F800 != 0 || raw & 0x7FF == 0
            {
                return Err(SdoAbort::InvalidValue);
            }
            comm.cob_id_sync = raw;
        }
        Var::Store => {
            if raw != SAVE_SIGNATURE {
                return Err(SdoAbort::CannotStore);
            }
            app.execute(Command::StoreSettings).map_err(refused(None))?;
        }
        Var::Restore => {
            if raw != LOAD_SIGNATURE {
                return Err(SdoAbort::CannotStore);
            }
            app.execute(Command::RestoreDefaults)
                .map_err(refused(None))?;
        }
        Var::EmcyInhibit => comm.emcy_inhibit_100us = raw as u16,
        Var::Heartbeat => comm.heartbeat_ms = raw as u16,
        Var::TpdoCobId(n) => {
            let p = comm.tpdo.get_mut(tpdo_index(n)).ok_or(SdoAbort::NoObject)?;
            // CiA 301 §7.5.2.35: the CAN-ID may only change while the PDO is invalid.
            let id_change = (raw & 0x7FF) != (p.cob_id & 0x7FF);
            if raw & COB_ID_EXTENDED != 0
                || raw & 0x1FFF_F800 != 0
                || raw & 0x7FF == 0
                || (p.is_valid() && raw & COB_ID_INVALID == 0 && id_change)
            {
                return Err(SdoAbort::InvalidValue);
            }
            p.cob_id = raw;
        }
        Var::TpdoType(n) => {
            let t = raw as u8;
            // Supported: synchronous cyclic 1–240, event-driven 254/255 (CiA 301 table 71).
            // 0 (acyclic synchronous), 241–251 (reserved), 252/253 (RTR only) are not.
            if !(matches!(t, 1..=240) || t == 254 || t == 255) {
                return Err(SdoAbort::InvalidValue);
            }
            let p = comm.tpdo.get_mut(tpdo_index(n)).ok_or(SdoAbort::NoObject)?;
            p.transmission_type = t;
        }
        Var::TpdoInhibit(n) => {
            let p = comm.tpdo.get_mut(tpdo_index(n)).ok_or(SdoAbort::NoObject)?;
            if p.is_valid() {
                // CiA 301 §7.5.2.35: sub-index 3 cannot change while the PDO exists.
                return Err(SdoAbort::UnsupportedAccess);
            }
            p.inhibit_100us = raw as u16;
        }
        Var::TpdoEventTimer(n) => {
            let p = comm.tpdo.get_mut(tpdo_index(n)).ok_or(SdoAbort::NoObject)?;
            p.event_timer_ms = raw as u16;
        }
        Var::TpdoMapCount(n) => {
            let p = comm.tpdo.get_mut(tpdo_index(n)).ok_or(SdoAbort::NoObject)?;
            if p.is_valid() {
                return Err(SdoAbort::UnsupportedAccess);
            }
            let count = raw as u8;
            let mut next = *p;
            next.map_count = count;
            let all_set = next.map.iter().take(usize::from(count)).all(|&m| m != 0);
            if !all_set {
                return Err(SdoAbort::NotMappable);
            }
            if next.mapped_bits() > 64 {
                return Err(SdoAbort::PdoLength);
            }
            p.map_count = count;
        }
        Var::TpdoMap(n, k) => {
            let p = comm.tpdo.get_mut(tpdo_index(n)).ok_or(SdoAbort::NoObject)?;
            if p.is_valid() || p.map_count != 0 {
                return Err(SdoAbort::UnsupportedAccess);
            }
            if raw != 0 {
                let target = entry((raw >> 16) as u16, (raw >> 8) as u8)
                    .map_err(|_| SdoAbort::NotMappable)?;
                let bits = target.ty.size().map_or(0, |s| s * 8);
                if !target.pdo_mappable || bits != (raw & 0xFF) as usize {
                    return Err(SdoAbort::NotMappable);
                }
            }
            let slot = p
                .map
                .get_mut(usize::from(k).wrapping_sub(1))
                .ok_or(SdoAbort::NoSubIndex)?;
            *slot = raw;
        }
        Var::Config(f) => app.set_field(f, v).map_err(refused(Some(f)))?,
        Var::AxisPosition(k) => app
            .reference_axis(usize::from(k), v)
            .map_err(refused(None))?,
        Var::LvdtInput => {
            let m = match raw {
                0 => LvdtInput::AcRatiometric,
                _ => LvdtInput::DcConditioner,
            };
            app.configure(|c| c.lvdt_input = m).map_err(refused(None))?;
        }
        Var::CanBitrate => {
            let b = CanBitrate::from_u8(raw as u8).ok_or(SdoAbort::ValueTooHigh)?;
            app.configure(|c| c.can_bitrate = b)
                .map_err(refused(None))?;
        }
        Var::AxisName(i) => {
            let name = AxisName::from_u8(raw as u8).ok_or(SdoAbort::ValueTooHigh)?;
            app.configure(|c| {
                if let Some(a) = c.axes.get_mut(usize::from(i)) {
                    a.name = name;
                }
            })
            .map_err(refused(None))?;
        }
        Var::AxisReversed(i) => {
            let rev = match raw {
                0 => false,
                1 => true,
                _ => return Err(SdoAbort::InvalidValue),
            };
            app.configure(|c| {
                if let Some(a) = c.axes.get_mut(usize::from(i)) {
                    a.reversed = rev;
                }
            })
            .map_err(refused(None))?;
        }
        Var::Pattern => {
            let p = Pattern::from_u8(raw as u8).ok_or(SdoAbort::ValueTooHigh)?;
            app.set_pattern(p).map_err(refused(None))?;
        }
        Var::Direction => {
            let d = Direction::from_u8(raw as u8).ok_or(SdoAbort::ValueTooHigh)?;
            app.set_direction(d).map_err(refused(None))?;
        }
        Var::Command => {
            let c = Command::from_u8(raw as u8).ok_or(SdoAbort::ValueTooHigh)?;
            app.execute(c).map_err(refused(None))?;
        }
        _ => return Err(SdoAbort::ReadOnly),
    }
    Ok(())
}
