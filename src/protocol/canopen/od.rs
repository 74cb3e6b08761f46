//! The object dictionary (CiA 301 §7.4): the single table that the SDO server, the TPDO
//! packer and the EDS generator ([`super::eds`]) all read.
//!
//! The table is written as two lookup functions over plain data rather than a static array of
//! values: [`object`] describes an index, [`entry`] describes an index:sub-index with its
//! data type, access, PDO mappability, limits and the [`Var`] that says where its value lives.
//! Values are never copied into a dictionary: [`read()`] and [`write()`] go straight to the
//! application ([`App`]: live values, configuration, session, results) and to the node's
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
//! - 0x3000–0x300B: session control and state, the run's counters, the last refusal, the touch
//!   points of the last PROBE run;
//! - 0x4000–0x4002: the results table (value, standard uncertainty, validity).

use super::abort::SdoAbort;
use super::nmt::NmtState;
use super::pdo::{self, COB_ID_EXTENDED, COB_ID_INVALID, MAX_MAPPED, TPDO_COUNT, TpdoParams};
use crate::acquisition::MAX_AXES;
use crate::app::probe::MAX_TOUCHES;
use crate::app::{
    App, Command, CommandError, DEVICE_COUNTER_COUNT, DEVICE_COUNTERS, Direction, LIVE, LIVE_COUNT,
    Pattern, RESULT_COUNT, ResultId, RunCounters,
};
use crate::config::{
    AxisName, CanBitrate, ConfigError, FIELDS, Field, FieldType, LvdtInput, POS_MM,
};

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

/// CiA 301 basic data types (§7.1.6, table 44; the EDS `DataType`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u16)]
pub enum DataType {
    /// BOOLEAN (1 byte on the bus).
    Boolean = 0x0001,
    /// UNSIGNED8.
    Unsigned8 = 0x0005,
    /// UNSIGNED16.
    Unsigned16 = 0x0006,
    /// UNSIGNED32.
    Unsigned32 = 0x0007,
    /// REAL32 (IEEE 754 single).
    Real32 = 0x0008,
    /// VISIBLE_STRING (no terminator; length = transfer length).
    VisibleString = 0x0009,
}

impl DataType {
    /// Size on the bus, bytes (`None` for strings, whose length is their content's).
    pub const fn size(self) -> Option<usize> {
        match self {
            Self::Boolean | Self::Unsigned8 => Some(1),
            Self::Unsigned16 => Some(2),
            Self::Unsigned32 | Self::Real32 => Some(4),
            Self::VisibleString => None,
        }
    }
}

/// Access type of an entry (EDS `AccessType`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    /// Read-only, never changes.
    Const,
    /// Read-only.
    Ro,
    /// Write-only.
    Wo,
    /// Read-write.
    Rw,
}

impl Access {
    /// True if an SDO upload may read it.
    pub const fn readable(self) -> bool {
        !matches!(self, Self::Wo)
    }
    /// True if an SDO download may write it.
    pub const fn writable(self) -> bool {
        matches!(self, Self::Wo | Self::Rw)
    }
    /// The EDS spelling.
    pub const fn eds(self) -> &'static str {
        match self {
            Self::Const => "const",
            Self::Ro => "ro",
            Self::Wo => "wo",
            Self::Rw => "rw",
        }
    }
}

/// Object code (CiA 301 §7.4.3, EDS `ObjectType`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum ObjectKind {
    /// A single value at sub-index 0.
    Var = 0x7,
    /// Sub-index 0 = number of entries, sub-indices 1… of one type.
    Array = 0x8,
    /// Sub-index 0 = highest sub-index, sub-indices of varying types.
    Record = 0x9,
}

/// A text of the dictionary that only the EDS and the book show (a parameter name or a unit).
/// CANopen never sends names over the bus, so the firmware keeps none: with the `firmware`
/// feature the text is dropped where the dictionary is built (1 KB of flash) and
/// [`as_str`](Self::as_str) is empty.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EdsText(#[cfg(not(feature = "firmware"))] &'static str);

impl EdsText {
    /// The text (empty on the firmware).
    pub const fn as_str(self) -> &'static str {
        #[cfg(not(feature = "firmware"))]
        return self.0;
        #[cfg(feature = "firmware")]
        ""
    }

    const fn new(text: &'static str) -> Self {
        #[cfg(not(feature = "firmware"))]
        return Self(text);
        #[cfg(feature = "firmware")]
        {
            let _ = text;
            Self()
        }
    }
}

/// One object (index) of the dictionary.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Object {
    /// Index.
    pub index: u16,
    /// Parameter name.
    pub name: EdsText,
    /// VAR, ARRAY or RECORD.
    pub kind: ObjectKind,
    /// Highest sub-index (0 for a VAR).
    pub max_sub: u8,
}

/// Where the value of an entry lives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Var {
    /// A constant UNSIGNED8 (sub-index 0 of arrays / records).
    ConstU8(u8),
    /// A constant UNSIGNED32.
    ConstU32(u32),
    /// A constant string.
    ConstStr(&'static str),
    /// 0x1001 error register.
    ErrorRegister,
    /// 0x1003:0 number of errors in the history (write 0 to clear).
    ErrorCount,
    /// 0x1003:k error k (1 = newest).
    ErrorHistory(u8),
    /// 0x1005 COB-ID SYNC.
    CobIdSync,
    /// 0x1010:1 store all parameters.
    Store,
    /// 0x1011:1 restore all default parameters.
    Restore,
    /// 0x1015 inhibit time EMCY, 100 µs.
    EmcyInhibit,
    /// 0x1017 producer heartbeat time, ms.
    Heartbeat,
    /// 0x1018:4 serial number.
    Serial,
    /// 0x1200:1 / 0x1200:2 SDO COB-ID (0 = client→server 0x600+n, 1 = server→client 0x580+n).
    SdoCobId(u8),
    /// 0x180n:1 TPDO COB-ID.
    TpdoCobId(u8),
    /// 0x180n:2 TPDO transmission type.
    TpdoType(u8),
    /// 0x180n:3 TPDO inhibit time.
    TpdoInhibit(u8),
    /// 0x180n:5 TPDO event timer.
    TpdoEventTimer(u8),
    /// 0x1A0n:0 number of mapped objects.
    TpdoMapCount(u8),
    /// 0x1A0n:k mapping entry k (1…8).
    TpdoMap(u8, u8),
    /// A configuration field (the field, with the element number for indexed fields), in the
    /// entry's data type.
    Config(Field),
    /// 0x2040 LVDT input mode.
    LvdtInput,
    /// 0x2041 CAN bit rate code.
    CanBitrate,
    /// 0x2042:k axis name of input k.
    AxisName(u8),
    /// 0x2043:k counting direction of input k.
    AxisReversed(u8),
    /// 0x2100:k live REAL32 value k (1…8).
    Live(u8),
    /// 0x2101 sample counter.
    SampleCounter,
    /// 0x2102 status word.
    StatusWord,
    /// 0x2103 validity mask of the live values (bit k−1 = 0x2100:k).
    LiveValid,
    /// 0x2110:k device counter k (1…[`DEVICE_COUNTER_COUNT`], [`DEVICE_COUNTERS`] order;
    /// 0xFFFF_FFFF: not measured).
    DeviceCounter(u8),
    /// 0x3000 pattern of the next run.
    Pattern,
    /// 0x3001 direction of the next run.
    Direction,
    /// 0x3002 session command (write-only).
    Command,
    /// 0x3003 session state.
    SessionState,
    /// 0x3004 abort reason.
    AbortReason,
    /// 0x3005:k run counter k (1…[`RunCounters::LEN`], [`RunCounters::NAMES`] order).
    RunCounter(u8),
    /// 0x3006 why the last command was refused (text).
    Refusal,
    /// 0x3007 what the last procedure step could not do (text).
    ProcedureNote,
    /// 0x3008 number of touch points of the last PROBE run.
    TouchCount,
    /// 0x3009–0x300B:k coordinate (0 X, 1 Y, 2 Z) of touch point k.
    Touch(u8, u8),
    /// 0x300C:k+1 position of encoder input k (read), or its reference (write), mm / degrees.
    AxisPosition(u8),
    /// 0x4000:k+1 result k value.
    ResultValue(u8),
    /// 0x4001:k+1 result k standard uncertainty.
    ResultUncertainty(u8),
    /// 0x4002:k+1 result k valid.
    ResultValid(u8),
}

/// One entry (index:sub-index) of the dictionary.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Entry {
    /// Index.
    pub index: u16,
    /// Sub-index.
    pub sub: u8,
    /// Parameter name (for ARRAY elements of generated objects the EDS appends the element).
    pub name: EdsText,
    /// Element number appended to `name` in the EDS (`name_k`), if any.
    pub element: Option<u8>,
    /// Data type.
    pub ty: DataType,
    /// Access type.
    pub access: Access,
    /// True if the entry may be mapped into a TPDO.
    pub pdo_mappable: bool,
    /// Where the value lives.
    pub var: Var,
    /// Inclusive value limits (EDS `LowLimit`/`HighLimit`), in the entry's unit.
    pub limits: Option<(f64, f64)>,
    /// Unit of the value (documentation; empty if none).
    pub unit: EdsText,
    /// True if the default value is "$NODEID + x" in the EDS.
    pub node_id_relative: bool,
}

const fn e(
    index: u16,
    sub: u8,
    name: &'static str,
    ty: DataType,
    access: Access,
    var: Var,
) -> Entry {
    Entry {
        index,
        sub,
        name: EdsText::new(name),
        element: None,
        ty,
        access,
        pdo_mappable: false,
        var,
        limits: None,
        unit: EdsText::new(""),
        node_id_relative: false,
    }
}

impl Entry {
    const fn mappable(mut self) -> Self {
        self.pdo_mappable = true;
        self
    }
    const fn limits(mut self, lo: f64, hi: f64) -> Self {
        self.limits = Some((lo, hi));
        self
    }
    const fn unit(mut self, unit: &'static str) -> Self {
        self.unit = EdsText::new(unit);
        self
    }
    const fn node_rel(mut self) -> Self {
        self.node_id_relative = true;
        self
    }
    const fn element(mut self, k: u8) -> Self {
        self.element = Some(k);
        self
    }
}

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
        0x3000 => var(Unsigned8, Rw, Var::Pattern).map(|e| e.limits(0.0, 7.0)),
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
fn refusal_abort(err: CommandError, written: Option<Field>) -> SdoAbort {
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

fn put(buf: &mut [u8; MAX_VALUE_LEN], bytes: &[u8]) -> Result<usize, SdoAbort> {
    let dst = buf.get_mut(..bytes.len()).ok_or(SdoAbort::LengthMismatch)?;
    dst.copy_from_slice(bytes);
    Ok(bytes.len())
}

/// Puts the two parts of a refusal's text.
fn put_text(buf: &mut [u8; MAX_VALUE_LEN], text: (&str, &str)) -> Result<usize, SdoAbort> {
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

fn le_u32(data: &[u8]) -> u32 {
    let mut b = [0u8; 4];
    for (d, s) in b.iter_mut().zip(data) {
        *d = *s;
    }
    u32::from_le_bytes(b)
}

/// Checks an unsigned write against the entry's limits.
fn check_limits(e: &Entry, v: f64) -> Result<(), SdoAbort> {
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
