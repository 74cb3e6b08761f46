//! Emergency producer (CiA 301 §7.2.7): one EMCY per newly raised fault, "error reset" once
//! every fault has cleared, at most one frame per inhibit time (0x1015).

use crate::acquisition::SampleFlags;

/// Error code 0x0000: error reset or no error (CiA 301 table 21).
pub const ERROR_RESET: u16 = 0x0000;
/// Error code 0x6000: software, generic (CiA 301 table 21) — the previous run ended in a panic,
/// a watchdog reset or a HardFault ([`super::CanOpenNode::report_boot_error`]; byte 3 says
/// which: [`REASON_PANIC`], [`REASON_WATCHDOG`], [`REASON_HARD_FAULT`]).
pub const SOFTWARE_ERROR: u16 = 0x6000;
/// Manufacturer byte 3 of a 0x6000 EMCY: the firmware panicked.
pub const REASON_PANIC: u8 = 1;
/// Manufacturer byte 3 of a 0x6000 EMCY: the independent watchdog reset the MCU.
pub const REASON_WATCHDOG: u8 = 2;
/// Manufacturer byte 3 of a 0x6000 EMCY: the core took a HardFault (its PC in `SYSTem:ERRor?`).
pub const REASON_HARD_FAULT: u8 = 6;
/// Error code 0x5000: device hardware, generic (CiA 301 table 21) — the previous run ended in
/// a low-power reset, or the option bytes are not as the firmware needs them (byte 3:
/// [`REASON_LOW_POWER_RESET`], [`REASON_OPTION_BYTES`]).
pub const DEVICE_HARDWARE: u16 = 0x5000;
/// Manufacturer byte 3 of a 0x5000 EMCY: a low-power reset ended the previous run.
pub const REASON_LOW_POWER_RESET: u8 = 4;
/// Manufacturer byte 3 of a 0x5000 EMCY: the option bytes are wrong for this firmware
/// (`SYSTem:ERRor?` says which and how to set them).
pub const REASON_OPTION_BYTES: u8 = 5;
/// Error code 0x6300: data set (CiA 301 table 21) — a stored configuration was rejected at
/// boot (byte 3: [`REASON_SETTINGS_REJECTED`], [`REASON_SETTINGS_UNREADABLE`]).
pub const DATA_SET: u16 = 0x6300;
/// Manufacturer byte 3 of a 0x6300 EMCY: the stored settings were rejected, another slot's or
/// the defaults are in use.
pub const REASON_SETTINGS_REJECTED: u8 = 3;
/// Manufacturer byte 3 of a 0x6300 EMCY: a settings slot could not be read (a double ECC error
/// in flash, a save cut by a power loss); the other slot's settings or the defaults are in use.
pub const REASON_SETTINGS_UNREADABLE: u8 = 7;
/// Error code 0x8110: CAN overrun, objects lost (CiA 301 table 21) — received frames the
/// controller could not keep.
pub const CAN_OVERRUN: u16 = 0x8110;
/// Error code 0x8120: CAN in error passive mode (CiA 301 table 21).
pub const ERROR_PASSIVE: u16 = 0x8120;
/// Error code 0x8140: recovered from bus off (CiA 301 table 21).
pub const BUS_OFF_RECOVERED: u16 = 0x8140;
/// Error register bit 0: generic error (set whenever any error is present, CiA 301 §7.5.2.2).
pub const ER_GENERIC: u8 = 1 << 0;
/// Error register bit 4: communication error (overrun, error state; CiA 301 §7.5.2.2).
pub const ER_COMMUNICATION: u8 = 1 << 4;
/// Error register bit 7: manufacturer-specific error.
pub const ER_MANUFACTURER: u8 = 1 << 7;

/// The faults that raise an EMCY, in priority order, with their CiA 301 error codes
/// (table 21: 0x50xx device hardware, 0x61xx internal software). The manufacturer-specific
/// byte 3 of the EMCY frame carries the fault's [`SampleFlags`] bit number.
pub const FAULTS: [(SampleFlags, u16); 5] = [
    (SampleFlags::LVDT_OPEN, 0x5001),
    (SampleFlags::LVDT_OVER_RANGE, 0x5002),
    (SampleFlags::QUADRATURE_ERROR, 0x5003),
    (SampleFlags::TEMPERATURE_FAULT, 0x5004),
    (SampleFlags::OVERRUN, 0x6101),
];

/// The flag bits of [`FAULTS`] (each fault is one bit: [`error_code`] maps a bit).
const FAULT_MASK: u16 = {
    let [(a, _), (b, _), (c, _), (d, _), (e, _)] = FAULTS;
    a.0 | b.0 | c.0 | d.0 | e.0
};

/// The fault bits of a sample's flags (the flags of [`FAULTS`]).
pub const fn fault_bits(flags: SampleFlags) -> u16 {
    flags.0 & FAULT_MASK
}

/// The EMCY error code of a single fault bit (`None` if it is not a fault).
pub fn error_code(bit: u16) -> Option<u16> {
    FAULTS.iter().find(|(f, _)| f.0 == bit).map(|(_, c)| *c)
}

/// EMCY frame payload (CiA 301 §7.2.7.3.1, figure 60): error code (LE), error register,
/// 5 manufacturer-specific bytes (byte 3 = flag bit number, bytes 4–7 = fault bit mask
/// currently active, LE u16, then 0).
pub fn payload(code: u16, error_register: u8, bit: u16, active: u16) -> [u8; 8] {
    let c = code.to_le_bytes();
    let a = active.to_le_bytes();
    let bit_no = if bit == 0 {
        0xFF
    } else {
        bit.trailing_zeros() as u8
    };
    [c[0], c[1], error_register, bit_no, a[0], a[1], 0, 0]
}
