//! SDO abort codes (CiA 301 §7.2.4.3.17, table 22).

/// An SDO abort code: why the SDO server refused a transfer. The `u32` is the code sent in
/// bytes 4–7 of the abort frame (little-endian).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum SdoAbort {
    /// 0x0503 0000: toggle bit not alternated.
    ToggleBit = 0x0503_0000,
    /// 0x0504 0000: SDO protocol timed out.
    Timeout = 0x0504_0000,
    /// 0x0504 0001: client/server command specifier not valid or unknown.
    CommandSpecifier = 0x0504_0001,
    /// 0x0601 0000: unsupported access to an object (e.g. PDO mapping changed while valid).
    UnsupportedAccess = 0x0601_0000,
    /// 0x0601 0001: attempt to read a write-only object.
    WriteOnly = 0x0601_0001,
    /// 0x0601 0002: attempt to write a read-only object.
    ReadOnly = 0x0601_0002,
    /// 0x0602 0000: object does not exist in the object dictionary.
    NoObject = 0x0602_0000,
    /// 0x0604 0041: object cannot be mapped to the PDO.
    NotMappable = 0x0604_0041,
    /// 0x0604 0042: the number and length of the objects to be mapped exceed the PDO length.
    PdoLength = 0x0604_0042,
    /// 0x0604 0043: general parameter incompatibility (a cross-field rule of the configuration).
    ParameterIncompatible = 0x0604_0043,
    /// 0x0607 0010: data type does not match, length of service parameter does not match.
    LengthMismatch = 0x0607_0010,
    /// 0x0609 0011: sub-index does not exist.
    NoSubIndex = 0x0609_0011,
    /// 0x0609 0030: invalid value for parameter (download only).
    InvalidValue = 0x0609_0030,
    /// 0x0609 0031: value of parameter written too high.
    ValueTooHigh = 0x0609_0031,
    /// 0x0609 0032: value of parameter written too low.
    ValueTooLow = 0x0609_0032,
    /// 0x0800 0020: data cannot be transferred or stored to the application (e.g. wrong
    /// "save"/"load" signature, CiA 301 §7.5.2.13/14).
    CannotStore = 0x0800_0020,
    /// 0x0800 0022: data cannot be transferred or stored because of the present device state
    /// (configuration written outside pre-operational, session command in the wrong session
    /// state).
    WrongState = 0x0800_0022,
    /// 0x0800 0024: no data available (a result that is not computed yet).
    NoData = 0x0800_0024,
}

impl SdoAbort {
    /// The abort code as sent on the bus.
    pub const fn code(self) -> u32 {
        self as u32
    }
}
