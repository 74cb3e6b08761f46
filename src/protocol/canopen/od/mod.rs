//! The object dictionary (CiA 301 §7.4): the single table that the SDO server, the TPDO
//! packer and the EDS generator ([`super::eds`]) all read.
//!
//! The table is written as two lookup functions over plain data rather than a static array of
//! values: [`object`] describes an index, [`entry`] describes an index:sub-index with its
//! data type, access, PDO mappability, limits and the [`Var`] that says where its value lives.
//! Values are never copied into a dictionary: [`read()`] and [`write()`] go straight to the
//! application ([`App`](crate::app::App): live values, configuration, session, results) and to the node's
//! [`CommParams`]; a write is a request the application accepts or refuses (the same rules as
//! over SCPI). Configuration objects are generated from [`crate::config::FIELDS`], the live
//! values from [`crate::app::LIVE`], the results from [`crate::app::ResultInfo::all`], so a new field,
//! live value or result appears here, in the SDO server and in `ballpod.eds` at once.
//!
//! **The wire contract.** An object's index and sub-index, name, type, access and PDO mapping
//! never change once released: the tables the dictionary is generated from ([`FIELDS`],
//! [`LIVE`], the results catalogue, the device and run counters) are append-only — a new row
//! goes at the end, a retired one stays where it is (a retired result never becomes valid: it
//! reads "no data", 0x0800 0024). [`REVISION`] says which layout a pod speaks;
//! `host-tests/tests/canopen_eds.rs` compares `ballpod.eds` with every released EDS in
//! `releases/` and fails on a moved, renamed or retyped object.
//!
//! Index map (see the module doc of [`super`] for the full table):
//! - 0x1000–0x1A03: communication profile area (CiA 301 §7.5.2);
//! - 0x2000 + i: configuration field `FIELDS[i]` in the field's unit and type (REAL32, or
//!   UNSIGNED8/16/32 for integers and codes; rw, range checked, written only in
//!   pre-operational) for the first 64 rows; 0x2040–0x2043: the enumerated configuration
//!   fields; 0x2044 + (i − 64): the rows after the first 64 ([`config_index`]);
//! - 0x2100–0x2103: live process values (REAL32 µm / °C, NaN while invalid), sample counter,
//!   status word, live-value validity mask; PDO mappable; 0x2110: the device counters
//!   (`app::device`);
//! - 0x3000–0x300C: session control and state, the run's counters, the last refusal, the touch
//!   points of the last PROBE run, the axes' positions;
//! - 0x4000–0x4002: the results table (value, standard uncertainty, validity).

mod access;
mod types;

pub use access::{CommParams, read, write};
pub use types::*;

use super::abort::SdoAbort;
use super::pdo::{MAX_MAPPED, TPDO_COUNT};
use crate::acquisition::MAX_AXES;
use crate::app::probe::MAX_TOUCHES;
use crate::app::{
    DEVICE_COUNTER_COUNT, DEVICE_COUNTERS, LIVE, LIVE_COUNT, Pattern, RESULT_COUNT, ResultId,
    RunCounters,
};
use crate::config::{FIELDS, FieldType, POS_MM};

/// Largest value of any object, bytes (the longest VISIBLE_STRING).
pub const MAX_VALUE_LEN: usize = 64;
/// Entries of the pre-defined error field 0x1003.
pub const ERROR_HISTORY_LEN: usize = 8;

/// Device type 0x1000 (CiA 301 §7.5.2.1): 0 = no standardised device profile. The live values
/// are REAL32 process values in the CiA 404 spirit but the pod does not implement the CiA 404
/// objects, so it does not claim the profile (0x0000_0194) a master would then expect.
pub const DEVICE_TYPE: u32 = 0x0000_0000;
/// Vendor-ID 0x1018:1 (0 until a CiA vendor ID is assigned).
pub const VENDOR_ID: u32 = 0;
/// Product code 0x1018:2.
pub const PRODUCT_CODE: u32 = 0xBA11_0001;
/// Revision number 0x1018:3 (CiA 301 §7.5.2.26): the wire layout's major revision (upper 16
/// bits) . minor revision (lower 16 bits). The minor grows with each release that appends
/// objects; the major only with a deliberate break of the layout, which `CHANGELOG.md` names.
/// `host-tests/tests/canopen_eds.rs` compares the EDS with every released one in `releases/`.
pub const REVISION: u32 = 0x0001_0001;
/// Manufacturer device name 0x1008.
pub const DEVICE_NAME: &str = "ballpod measurement pod";
/// Manufacturer hardware version 0x1009.
pub const HW_VERSION: &str = "NUCLEO-G474RE rev A";
/// Manufacturer software version 0x100A: `ballpod ` and [`crate::FIRMWARE_VERSION`].
pub const SW_VERSION: &str = concat!(
    "ballpod ",
    env!("CARGO_PKG_VERSION"),
    "+",
    env!("BALLPOD_COMMIT")
);
/// 0x100A as the EDS gives it: the release, without the commit a pod was built from (the EDS
/// describes the device's release, and stays the committed one across commits).
pub const SW_RELEASE: &str = concat!("ballpod ", env!("CARGO_PKG_VERSION"));
/// The "save" signature of 0x1010 (ASCII `s a v e`, CiA 301 §7.5.2.13).
pub const SAVE_SIGNATURE: u32 = 0x6576_6173;
/// The "load" signature of 0x1011 (ASCII `l o a d`, CiA 301 §7.5.2.14).
pub const LOAD_SIGNATURE: u32 = 0x6461_6F6C;
/// Default EMCY inhibit time 0x1015, 100 µs units (100 ms: a flapping sensor cannot flood the
/// bus with EMCY frames).
pub const DEFAULT_EMCY_INHIBIT_100US: u16 = 1000;
/// Default heartbeat producer time 0x1017, ms.
pub const DEFAULT_HEARTBEAT_MS: u16 = 1000;

/// Index of the first configuration object (`FIELDS[i]` is at [`config_index`]`(i)`).
pub const CONFIG_BASE: u16 = 0x2000;
/// Index of the first enumerated configuration object (0x2040 lvdt_input … 0x2043
/// axis_reversed).
pub const CONFIG_ENUMS: u16 = 0x2040;
/// Index of the configuration field after the first 64 (the block below the enumerated
/// objects is full; the rows after it follow the enumerated objects).
pub const CONFIG_AFTER_ENUMS: u16 = CONFIG_ENUMS + 4;

/// The object index of configuration field `FIELDS[row]`: 0x2000 + row below the enumerated
/// objects, [`CONFIG_AFTER_ENUMS`] + (row − 64) after them (up to 0x20FF; 0x2100 is the live
/// values).
pub const fn config_index(row: usize) -> u16 {
    let first = (CONFIG_ENUMS - CONFIG_BASE) as usize;
    if row < first {
        CONFIG_BASE + row as u16
    } else {
        CONFIG_AFTER_ENUMS + (row - first) as u16
    }
}

/// The [`FIELDS`] row of configuration object `index`, if it is one ([`config_index`]'s
/// inverse).
pub fn config_row(index: u16) -> Option<usize> {
    let row = match index {
        CONFIG_BASE..CONFIG_ENUMS => index - CONFIG_BASE,
        CONFIG_AFTER_ENUMS..LIVE_VALUES => {
            index - CONFIG_AFTER_ENUMS + (CONFIG_ENUMS - CONFIG_BASE)
        }
        _ => return None,
    };
    let row = usize::from(row);
    (row < FIELDS.len()).then_some(row)
}
/// Index of the live REAL32 values (0x2100:1 ΔL … 0x2100:8 temperature).
pub const LIVE_VALUES: u16 = 0x2100;
/// Index of the results' values (sub-index k+1 = the k-th of `ResultId::ALL`).
pub const RESULT_VALUES: u16 = 0x4000;

use Access::{Const, Ro, Rw, Wo};
use DataType::{Boolean, Real32, Unsigned8, Unsigned16, Unsigned32, VisibleString};

/// The data type of a configuration field's object.
const fn field_type(ty: FieldType) -> DataType {
    match ty {
        FieldType::F32 | FieldType::F64 => DataType::Real32,
        FieldType::U8 => DataType::Unsigned8,
        FieldType::U16 => DataType::Unsigned16,
        FieldType::U32 => DataType::Unsigned32,
    }
}

/// Every index of the dictionary, ascending.
pub fn indices() -> impl Iterator<Item = u16> {
    const COMM: [u16; 12] = [
        0x1000, 0x1001, 0x1003, 0x1005, 0x1008, 0x1009, 0x100A, 0x1010, 0x1011, 0x1015, 0x1017,
        0x1018,
    ];
    COMM.into_iter()
        .chain([0x1200])
        .chain(0x1800..0x1800 + TPDO_COUNT as u16)
        .chain(0x1A00..0x1A00 + TPDO_COUNT as u16)
        .chain((CONFIG_BASE..LIVE_VALUES).filter(|&i| {
            config_row(i).is_some() || (CONFIG_ENUMS..CONFIG_AFTER_ENUMS).contains(&i)
        }))
        .chain(0x2100..=0x2103)
        .chain(core::iter::once(0x2110))
        .chain(0x3000..=0x300C)
        .chain(0x4000..=0x4002)
}

/// Describes object `index`, or `None` if it does not exist.
pub fn object(index: u16) -> Option<Object> {
    use ObjectKind::{Array, Record, Var as V};
    let o = |name, kind, max_sub| {
        Some(Object {
            index,
            name: EdsText::new(name),
            kind,
            max_sub,
        })
    };
    match index {
        0x1000 => o("Device type", V, 0),
        0x1001 => o("Error register", V, 0),
        0x1003 => o("Pre-defined error field", Array, ERROR_HISTORY_LEN as u8),
        0x1005 => o("COB-ID SYNC", V, 0),
        0x1008 => o("Manufacturer device name", V, 0),
        0x1009 => o("Manufacturer hardware version", V, 0),
        0x100A => o("Manufacturer software version", V, 0),
        0x1010 => o("Store parameters", Array, 1),
        0x1011 => o("Restore default parameters", Array, 1),
        0x1015 => o("Inhibit time EMCY", V, 0),
        0x1017 => o("Producer heartbeat time", V, 0),
        0x1018 => o("Identity object", Record, 4),
        0x1200 => o("SDO server parameter", Record, 2),
        0x1800..=0x1803 => {
            const N: [&str; TPDO_COUNT] = [
                "TPDO communication parameter 1",
                "TPDO communication parameter 2",
                "TPDO communication parameter 3",
                "TPDO communication parameter 4",
            ];
            // (not `?`: the name is dropped on the firmware, so must the lookup be)
            o(
                N.get(usize::from(index - 0x1800)).copied().unwrap_or(""),
                Record,
                5,
            )
        }
        0x1A00..=0x1A03 => {
            const N: [&str; TPDO_COUNT] = [
                "TPDO mapping parameter 1",
                "TPDO mapping parameter 2",
                "TPDO mapping parameter 3",
                "TPDO mapping parameter 4",
            ];
            o(
                N.get(usize::from(index - 0x1A00)).copied().unwrap_or(""),
                Record,
                MAX_MAPPED as u8,
            )
        }
        0x2040 => o("lvdt_input", V, 0),
        0x2041 => o("can_bitrate", V, 0),
        0x2042 => o("axis_name", Array, MAX_AXES as u8),
        0x2043 => o("axis_reversed", Array, MAX_AXES as u8),
        0x2100 => o("live_values", Array, LIVE_COUNT as u8),
        0x2101 => o("sample_counter", V, 0),
        0x2102 => o("status_word", V, 0),
        0x2103 => o("live_valid", V, 0),
        0x2110 => o("device_counters", Array, DEVICE_COUNTER_COUNT as u8),
        0x3000 => o("pattern", V, 0),
        0x3001 => o("direction", V, 0),
        0x3002 => o("session_command", V, 0),
        0x3003 => o("session_state", V, 0),
        0x3004 => o("abort_reason", V, 0),
        0x3005 => o("run_counters", Array, RunCounters::LEN as u8),
        0x3006 => o("last_refusal", V, 0),
        0x3007 => o("procedure_note", V, 0),
        0x3008 => o("touch_count", V, 0),
        0x3009 => o("touch_x", Array, MAX_TOUCHES as u8),
        0x300A => o("touch_y", Array, MAX_TOUCHES as u8),
        0x300B => o("touch_z", Array, MAX_TOUCHES as u8),
        0x300C => o("axis_position", Array, MAX_AXES as u8),
        0x4000 => o("result_value", Array, RESULT_COUNT as u8),
        0x4001 => o("result_uncertainty", Array, RESULT_COUNT as u8),
        0x4002 => o("result_valid", Array, RESULT_COUNT as u8),
        i if config_row(i).is_some() => {
            let info = FIELDS.get(config_row(i)?)?;
            match info.elements {
                0 => o(info.name, V, 0),
                n => o(info.name, Array, n),
            }
        }
        _ => None,
    }
}

/// A read-only array of U32 counters named `names` (sub 0: their number; sub k: counter k).
fn counters(
    index: u16,
    sub: u8,
    names: &[&'static str],
    var: fn(u8) -> Var,
) -> Result<Entry, SdoAbort> {
    if sub == 0 {
        return Ok(e(
            index,
            0,
            "Highest sub-index supported",
            Unsigned8,
            Const,
            Var::ConstU8(names.len() as u8),
        ));
    }
    let name = names
        .get(usize::from(sub - 1))
        .ok_or(SdoAbort::NoSubIndex)?;
    Ok(e(index, sub, name, Unsigned32, Ro, var(sub)))
}

/// Counter `k` (from 1) of `values`.
fn counter(values: &[u32], k: u8) -> Result<u32, SdoAbort> {
    values
        .get(usize::from(k).wrapping_sub(1))
        .copied()
        .ok_or(SdoAbort::NoSubIndex)
}

/// Describes entry `index`:`sub`: [`SdoAbort::NoObject`] if the index does not exist,
/// [`SdoAbort::NoSubIndex`] if the sub-index does not (CiA 301 §7.2.4.3.17).
pub fn entry(index: u16, sub: u8) -> Result<Entry, SdoAbort> {
    let obj = object(index).ok_or(SdoAbort::NoObject)?;
    let nosub = Err(SdoAbort::NoSubIndex);
    if sub > obj.max_sub {
        return nosub;
    }
    let count = |n: u8| {
        Ok(e(
            index,
            0,
            "Highest sub-index supported",
            Unsigned8,
            Const,
            Var::ConstU8(n),
        ))
    };
    let var = |ty, access, v| {
        if sub == 0 {
            Ok(e(index, 0, obj.name.as_str(), ty, access, v))
        } else {
            Err(SdoAbort::NoSubIndex)
        }
    };
    match index {
        0x1000 => var(Unsigned32, Const, Var::ConstU32(DEVICE_TYPE)),
        0x1001 => var(Unsigned8, Ro, Var::ErrorRegister).map(Entry::mappable),
        0x1003 => Ok(match sub {
            0 => e(index, 0, "Number of errors", Unsigned8, Rw, Var::ErrorCount).limits(0.0, 0.0),
            k => e(
                index,
                k,
                "Standard error field",
                Unsigned32,
                Ro,
                Var::ErrorHistory(k),
            )
            .element(k),
        }),
        0x1005 => var(Unsigned32, Rw, Var::CobIdSync),
        0x1008 => var(VisibleString, Const, Var::ConstStr(DEVICE_NAME)),
        0x1009 => var(VisibleString, Const, Var::ConstStr(HW_VERSION)),
        0x100A => var(VisibleString, Const, Var::ConstStr(SW_VERSION)),
        0x1010 => match sub {
            0 => count(1),
            _ => Ok(e(
                index,
                1,
                "Save all parameters",
                Unsigned32,
                Rw,
                Var::Store,
            )),
        },
        0x1011 => match sub {
            0 => count(1),
            _ => Ok(e(
                index,
                1,
                "Restore all default parameters",
                Unsigned32,
                Rw,
                Var::Restore,
            )),
        },
        0x1015 => var(Unsigned16, Rw, Var::EmcyInhibit).map(|e| e.unit("100us")),
        0x1017 => var(Unsigned16, Rw, Var::Heartbeat).map(|e| e.unit("ms")),
        0x1018 => Ok(match sub {
            0 => return count(4),
            1 => e(
                index,
                1,
                "Vendor-ID",
                Unsigned32,
                Ro,
                Var::ConstU32(VENDOR_ID),
            ),
            2 => e(
                index,
                2,
                "Product code",
                Unsigned32,
                Ro,
                Var::ConstU32(PRODUCT_CODE),
            ),
            3 => e(
                index,
                3,
                "Revision number",
                Unsigned32,
                Ro,
                Var::ConstU32(REVISION),
            ),
            _ => e(index, 4, "Serial number", Unsigned32, Ro, Var::Serial),
        }),
        0x1200 => Ok(match sub {
            0 => return count(2),
            1 => e(
                index,
                1,
                "COB-ID client to server",
                Unsigned32,
                Ro,
                Var::SdoCobId(0),
            )
            .node_rel(),
            _ => e(
                index,
                2,
                "COB-ID server to client",
                Unsigned32,
                Ro,
                Var::SdoCobId(1),
            )
            .node_rel(),
        }),
        0x1800..=0x1803 => {
            let n = (index - 0x1800) as u8;
            Ok(match sub {
                0 => return count(5),
                1 => e(
                    index,
                    1,
                    "COB-ID used by TPDO",
                    Unsigned32,
                    Rw,
                    Var::TpdoCobId(n),
                )
                .node_rel(),
                2 => e(
                    index,
                    2,
                    "Transmission type",
                    Unsigned8,
                    Rw,
                    Var::TpdoType(n),
                ),
                3 => e(
                    index,
                    3,
                    "Inhibit time",
                    Unsigned16,
                    Rw,
                    Var::TpdoInhibit(n),
                )
                .unit("100us"),
                // Sub-index 4 is reserved (CiA 301 §7.5.2.35).
                4 => return nosub,
                _ => e(
                    index,
                    5,
                    "Event timer",
                    Unsigned16,
                    Rw,
                    Var::TpdoEventTimer(n),
                )
                .unit("ms"),
            })
        }
        0x1A00..=0x1A03 => {
            let n = (index - 0x1A00) as u8;
            Ok(match sub {
                0 => e(
                    index,
                    0,
                    "Number of mapped application objects",
                    Unsigned8,
                    Rw,
                    Var::TpdoMapCount(n),
                )
                .limits(0.0, MAX_MAPPED as f64),
                k => e(
                    index,
                    k,
                    "Mapping entry",
                    Unsigned32,
                    Rw,
                    Var::TpdoMap(n, k),
                )
                .element(k),
            })
        }
        0x2040 => var(Unsigned8, Rw, Var::LvdtInput).map(|e| e.limits(0.0, 1.0)),
        0x2041 => var(Unsigned8, Rw, Var::CanBitrate).map(|e| e.limits(0.0, 3.0)),
        0x2042 => match sub {
            0 => count(MAX_AXES as u8),
            k => Ok(
                e(index, k, "axis_name", Unsigned8, Rw, Var::AxisName(k - 1))
                    .limits(0.0, 6.0)
                    .element(k - 1),
            ),
        },
        0x2043 => match sub {
            0 => count(MAX_AXES as u8),
            k => Ok(e(
                index,
                k,
                "axis_reversed",
                Boolean,
                Rw,
                Var::AxisReversed(k - 1),
            )
            .element(k - 1)),
        },
        0x2100 => match sub {
            0 => count(LIVE_COUNT as u8),
            k => {
                let (name, unit) = LIVE.get(usize::from(k - 1)).copied().unwrap_or(("", ""));
                Ok(e(index, k, name, Real32, Ro, Var::Live(k))
                    .mappable()
                    .unit(unit))
            }
        },
        0x2101 => var(Unsigned32, Ro, Var::SampleCounter).map(Entry::mappable),
        0x2102 => var(Unsigned16, Ro, Var::StatusWord).map(Entry::mappable),
        0x2103 => var(Unsigned16, Ro, Var::LiveValid).map(Entry::mappable),
        0x2110 => counters(index, sub, &DEVICE_COUNTERS, Var::DeviceCounter),
        0x3000 => {
            var(Unsigned8, Rw, Var::Pattern).map(|e| e.limits(0.0, (Pattern::ALL.len() - 1) as f64))
        }
        0x3001 => var(Unsigned8, Rw, Var::Direction).map(|e| e.limits(0.0, 1.0)),
        0x3002 => var(Unsigned8, Wo, Var::Command).map(|e| e.limits(1.0, 8.0)),
        0x3003 => var(Unsigned8, Ro, Var::SessionState).map(Entry::mappable),
        0x3004 => var(Unsigned8, Ro, Var::AbortReason),
        0x3005 => counters(index, sub, &RunCounters::NAMES, Var::RunCounter),
        0x3006 => var(VisibleString, Ro, Var::Refusal),
        0x3007 => var(VisibleString, Ro, Var::ProcedureNote),
        0x3008 => var(Unsigned8, Ro, Var::TouchCount),
        0x3009..=0x300B => match sub {
            0 => count(MAX_TOUCHES as u8),
            k => Ok(e(
                index,
                k,
                obj.name.as_str(),
                Real32,
                Ro,
                Var::Touch((index - 0x3009) as u8, k - 1),
            )
            .unit("mm")
            .element(k - 1)),
        },

        0x300C => match sub {
            0 => count(MAX_AXES as u8),
            k => Ok(e(
                index,
                k,
                obj.name.as_str(),
                Real32,
                Rw,
                Var::AxisPosition(k - 1),
            )
            .limits(-POS_MM, POS_MM)
            .unit("mm or deg")
            .element(k)),
        },
        0x4000..=0x4002 => match sub {
            0 => count(RESULT_COUNT as u8),
            k => {
                let r = ResultId::from_index(usize::from(k - 1))
                    .ok_or(SdoAbort::NoSubIndex)?
                    .info();
                Ok(match index {
                    0x4000 => e(index, k, r.name, Real32, Ro, Var::ResultValue(k - 1))
                        .unit(r.unit.as_str()),
                    0x4001 => e(index, k, r.name, Real32, Ro, Var::ResultUncertainty(k - 1))
                        .unit(r.unit.as_str()),
                    _ => e(index, k, r.name, Boolean, Ro, Var::ResultValid(k - 1)),
                })
            }
        },
        _ => {
            let info = config_row(index)
                .and_then(|row| FIELDS.get(row))
                .ok_or(SdoAbort::NoObject)?;
            let base = |sub, f, name| {
                e(index, sub, name, field_type(info.ty), Rw, Var::Config(f))
                    .limits(info.min, info.max)
                    .unit(info.unit.as_str())
            };
            match (info.elements, sub) {
                (0, 0) => Ok(base(0, info.field, info.name)),
                (_, 0) => count(info.elements),
                (_, k) => Ok(base(k, info.element(k - 1), info.name).element(k - 1)),
            }
        }
    }
}
