//! The IEEE 488.2 status model and the SCPI error/event queue.
//!
//! - Error/event queue (SCPI-99 Vol 2 §21.8, `SYSTem:ERRor[:NEXT]?`): first in, first out, of
//!   [`ERROR_QUEUE_DEPTH`] entries. When it is full, the newest entry is replaced by -350
//!   "Queue overflow" and further errors are discarded (and counted) until it is read.
//! - Standard Event Status Register (IEEE 488.2 §11.5.1): every queued error sets its class bit
//!   (-1xx CME, -2xx EXE, -3xx DDE, -4xx QYE); `*OPC` sets OPC; PON is set at power-on.
//!   `*ESR?` reads and clears it; `*ESE` masks it into the summary bit ESB.
//! - Status Byte (IEEE 488.2 §11.2): bit 2 error/event queue not empty (SCPI-99 Vol 1 §9),
//!   bit 4 MAV, bit 5 ESB, bit 6 MSS (the summary of the bits enabled by `*SRE`).

/// Depth of the error/event queue (entries).
pub const ERROR_QUEUE_DEPTH: usize = 16;

/// An SCPI error/event number (SCPI-99 Vol 2 §21.8) with a short static detail (the field or
/// parameter concerned; empty if none).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ScpiError {
    /// The error/event number (negative: standard; 0: no error).
    pub code: i16,
    /// What it concerns (a field or command name), appended to the message after `;`.
    pub detail: &'static str,
    /// Appended to the detail (e.g. `" not set"`).
    pub suffix: &'static str,
}

impl ScpiError {
    /// An error without detail.
    pub const fn new(code: i16) -> Self {
        Self {
            code,
            detail: "",
            suffix: "",
        }
    }
    /// An error with a detail.
    pub const fn with(code: i16, detail: &'static str) -> Self {
        Self {
            code,
            detail,
            suffix: "",
        }
    }
    /// An error with a detail and a suffix (`circle_radius` + ` not set`).
    pub const fn with_suffix(code: i16, detail: &'static str, suffix: &'static str) -> Self {
        Self {
            code,
            detail,
            suffix,
        }
    }
    /// The standard message of the number (SCPI-99 Vol 2 §21.8).
    pub const fn message(self) -> &'static str {
        message(self.code)
    }
}

/// Error numbers used by the pod (SCPI-99 Vol 2 §21.8).
pub mod code {
    /// 0: no error.
    pub const NO_ERROR: i16 = 0;
    /// -101: a character not allowed in that syntactic element.
    pub const INVALID_CHARACTER: i16 = -101;
    /// -102: the message does not follow the syntax.
    pub const SYNTAX_ERROR: i16 = -102;
    /// -104: a parameter of the wrong type (e.g. text where a number is expected).
    pub const DATA_TYPE_ERROR: i16 = -104;
    /// -108: more parameters than the command takes.
    pub const PARAMETER_NOT_ALLOWED: i16 = -108;
    /// -109: fewer parameters than the command needs.
    pub const MISSING_PARAMETER: i16 = -109;
    /// -113: no such command.
    pub const UNDEFINED_HEADER: i16 = -113;
    /// -114: a numeric suffix the node does not have (e.g. `AXIS9`).
    pub const HEADER_SUFFIX_OUT_OF_RANGE: i16 = -114;
    /// -121: a character not allowed in a number.
    pub const INVALID_CHARACTER_IN_NUMBER: i16 = -121;
    /// -123: exponent beyond ±32000.
    pub const EXPONENT_TOO_LARGE: i16 = -123;
    /// -124: more than 255 mantissa digits.
    pub const TOO_MANY_DIGITS: i16 = -124;
    /// -131: a unit suffix (not accepted: every value is in the unit of its field).
    pub const INVALID_SUFFIX: i16 = -131;
    /// -141: a character parameter that is not one of the choices.
    pub const INVALID_CHARACTER_DATA: i16 = -141;
    /// -158: a string where none is accepted.
    pub const STRING_DATA_NOT_ALLOWED: i16 = -158;
    /// -168: block data where none is accepted.
    pub const BLOCK_DATA_NOT_ALLOWED: i16 = -168;
    /// -203: a protected command (configuration write before `CONFigure:UNLock`).
    pub const COMMAND_PROTECTED: i16 = -203;
    /// -221: valid on its own, but conflicts with the device state or other settings.
    pub const SETTINGS_CONFLICT: i16 = -221;
    /// -222: a value outside the field's range.
    pub const DATA_OUT_OF_RANGE: i16 = -222;
    /// -224: a value that is not one of the allowed ones.
    pub const ILLEGAL_PARAMETER_VALUE: i16 = -224;
    /// -230: the requested data is not (yet) valid.
    pub const DATA_CORRUPT_OR_STALE: i16 = -230;
    /// -300: a device-specific error (e.g. the reason of the last reset, reported at boot).
    pub const DEVICE_SPECIFIC_ERROR: i16 = -300;
    /// Configuration memory lost (a stored configuration rejected at boot).
    pub const CONFIGURATION_MEMORY_LOST: i16 = -315;
    /// -350: the error queue overflowed (errors were lost).
    pub const QUEUE_OVERFLOW: i16 = -350;
    /// -410: a query whose response was interrupted (here: a log download cut by a disconnect).
    pub const QUERY_INTERRUPTED: i16 = -410;
    /// -440: a query after an indefinite (here: pulled) response in the same message.
    pub const QUERY_AFTER_BLOCK: i16 = -440;
    /// -363: an input line longer than the line buffer (the whole line was rejected).
    pub const INPUT_BUFFER_OVERRUN: i16 = -363;
}

/// The standard message of an error number (SCPI-99 Vol 2 §21.8).
pub const fn message(c: i16) -> &'static str {
    match c {
        code::NO_ERROR => "No error",
        code::INVALID_CHARACTER => "Invalid character",
        code::SYNTAX_ERROR => "Syntax error",
        code::DATA_TYPE_ERROR => "Data type error",
        code::PARAMETER_NOT_ALLOWED => "Parameter not allowed",
        code::MISSING_PARAMETER => "Missing parameter",
        code::UNDEFINED_HEADER => "Undefined header",
        code::HEADER_SUFFIX_OUT_OF_RANGE => "Header suffix out of range",
        code::INVALID_CHARACTER_IN_NUMBER => "Invalid character in number",
        code::EXPONENT_TOO_LARGE => "Exponent too large",
        code::TOO_MANY_DIGITS => "Too many digits",
        code::INVALID_SUFFIX => "Invalid suffix",
        code::INVALID_CHARACTER_DATA => "Invalid character data",
        code::STRING_DATA_NOT_ALLOWED => "String data not allowed",
        code::BLOCK_DATA_NOT_ALLOWED => "Block data not allowed",
        code::COMMAND_PROTECTED => "Command protected",
        code::SETTINGS_CONFLICT => "Settings conflict",
        code::DATA_OUT_OF_RANGE => "Data out of range",
        code::ILLEGAL_PARAMETER_VALUE => "Illegal parameter value",
        code::DATA_CORRUPT_OR_STALE => "Data corrupt or stale",
        code::DEVICE_SPECIFIC_ERROR => "Device-specific error",
        code::CONFIGURATION_MEMORY_LOST => "Configuration memory lost",
        code::QUEUE_OVERFLOW => "Queue overflow",
        code::INPUT_BUFFER_OVERRUN => "Input buffer overrun",
        code::QUERY_INTERRUPTED => "Query INTERRUPTED",
        code::QUERY_AFTER_BLOCK => "Query UNTERMINATED after indefinite response",
        -199..=-100 => "Command error",
        -299..=-200 => "Execution error",
        -399..=-300 => "Device-specific error",
        -499..=-400 => "Query error",
        _ => "Error",
    }
}

/// Standard Event Status Register bits (IEEE 488.2 §11.5.1.1).
pub mod esr {
    /// Bit 0: operation complete (`*OPC`).
    pub const OPC: u8 = 1 << 0;
    /// Bit 2: query error (-4xx).
    pub const QYE: u8 = 1 << 2;
    /// Bit 3: device-dependent error (-3xx and positive numbers).
    pub const DDE: u8 = 1 << 3;
    /// Bit 4: execution error (-2xx).
    pub const EXE: u8 = 1 << 4;
    /// Bit 5: command error (-1xx).
    pub const CME: u8 = 1 << 5;
    /// Bit 7: power on.
    pub const PON: u8 = 1 << 7;
}

/// Status Byte bits (IEEE 488.2 §11.2.1; bit 2 from SCPI-99 Vol 1 §9).
pub mod stb {
    /// Bit 2: the error/event queue is not empty.
    pub const EAV: u8 = 1 << 2;
    /// Bit 4: message available (always 0 here: responses are sent as they are made).
    pub const MAV: u8 = 1 << 4;
    /// Bit 5: event status bit (`*ESR` & `*ESE` ≠ 0).
    pub const ESB: u8 = 1 << 5;
    /// Bit 6: master summary status (`STB & SRE` over the other bits ≠ 0).
    pub const MSS: u8 = 1 << 6;
}

/// The error/event queue and the status registers of one SCPI session.
#[derive(Clone, Debug)]
pub struct StatusModel {
    queue: heapless::Deque<ScpiError, ERROR_QUEUE_DEPTH>,
    /// Errors lost to a full queue since power-on.
    pub errors_discarded: u32,
    /// Standard Event Status Register.
    pub esr: u8,
    /// Standard Event Status Enable register (`*ESE`).
    pub ese: u8,
    /// Service Request Enable register (`*SRE`; bit 6 is ignored).
    pub sre: u8,
}

impl Default for StatusModel {
    fn default() -> Self {
        Self::new()
    }
}

impl StatusModel {
    /// Power-on state: empty queue, ESR = PON, enables cleared (IEEE 488.2 §11.5.1.1, §10.10).
    pub const fn new() -> Self {
        Self {
            queue: heapless::Deque::new(),
            errors_discarded: 0,
            esr: esr::PON,
            ese: 0,
            sre: 0,
        }
    }

    /// Queues an error and sets its ESR class bit.
    pub fn push(&mut self, e: ScpiError) {
        self.esr |= match e.code {
            -199..=-100 => esr::CME,
            -299..=-200 => esr::EXE,
            -499..=-400 => esr::QYE,
            _ => esr::DDE,
        };
        if self.queue.is_full() {
            // SCPI-99 Vol 2 §21.8: the newest entry becomes -350 and the error is lost.
            if let Some(last) = self.queue.back_mut() {
                *last = ScpiError::new(code::QUEUE_OVERFLOW);
            }
            self.errors_discarded = self.errors_discarded.saturating_add(1);
        } else {
            let _ = self.queue.push_back(e);
        }
    }

    /// Takes the oldest error (0 "No error" if the queue is empty).
    pub fn pop(&mut self) -> ScpiError {
        self.queue
            .pop_front()
            .unwrap_or(ScpiError::new(code::NO_ERROR))
    }

    /// Number of queued errors.
    pub fn len(&self) -> usize {
        self.queue.len()
    }

    /// True if no error is queued.
    pub fn is_empty(&self) -> bool {
        self.queue.is_empty()
    }

    /// `*CLS` (IEEE 488.2 §10.3): clears the queue and the ESR; the enable registers stay.
    pub fn clear(&mut self) {
        self.queue.clear();
        self.esr = 0;
    }

    /// The Status Byte (IEEE 488.2 §11.2): EAV, ESB and the MSS summary.
    pub fn status_byte(&self) -> u8 {
        let mut s = 0;
        if !self.queue.is_empty() {
            s |= stb::EAV;
        }
        if self.esr & self.ese != 0 {
            s |= stb::ESB;
        }
        if s & self.sre & !stb::MSS != 0 {
            s |= stb::MSS;
        }
        s
    }
}
