//! The dictionary's vocabulary: CiA 301 data types and access, object kinds, the EDS texts,
//! an object's description and one entry's type, access and range.

use crate::config::Field;

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

    pub(super) const fn new(text: &'static str) -> Self {
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
    /// 0x2110:k device counter k (1…[`DEVICE_COUNTER_COUNT`](crate::app::DEVICE_COUNTER_COUNT), [`DEVICE_COUNTERS`](crate::app::DEVICE_COUNTERS) order;
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
    /// 0x3005:k run counter k (1…[`RunCounters::LEN`](crate::app::RunCounters::LEN), [`RunCounters::NAMES`](crate::app::RunCounters::NAMES) order).
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

pub(super) const fn e(
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
    pub(super) const fn mappable(mut self) -> Self {
        self.pdo_mappable = true;
        self
    }
    pub(super) const fn limits(mut self, lo: f64, hi: f64) -> Self {
        self.limits = Some((lo, hi));
        self
    }
    pub(super) const fn unit(mut self, unit: &'static str) -> Self {
        self.unit = EdsText::new(unit);
        self
    }
    pub(super) const fn node_rel(mut self) -> Self {
        self.node_id_relative = true;
        self
    }
    pub(super) const fn element(mut self, k: u8) -> Self {
        self.element = Some(k);
        self
    }
}
