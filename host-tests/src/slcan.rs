//! SLCAN (Lawicel ASCII) framing, the CAN side of the simulator's `--serve` mode: the simulated
//! pod's CAN bus is offered as an SLCAN device on a loopback TCP port, so that `python-can`'s
//! `slcan` interface (`channel='socket://127.0.0.1:PORT'`) and the `canopen` package can act as
//! the CNC.
//!
//! Lawicel commands are ASCII lines ended by CR: `O` open, `L` listen-only, `C` close,
//! `Sn` bit rate (S0 = 10 k … S8 = 1 M), `tIIILDD…` / `TIIIIIIIILDD…` data frames,
//! `rIIIL` / `RIIIIIIIIL` remote frames, `V` / `N` version / serial, `Z0/Z1` time stamps.
//! The adapter answers CR for OK and BEL for an error; a frame sent to the host is the same
//! `t…`/`T…` line.

/// A classic CAN frame as SLCAN carries it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SlcanFrame {
    /// Identifier (11 or 29 bits).
    pub id: u32,
    /// 29-bit identifier.
    pub extended: bool,
    /// Remote transmission request.
    pub remote: bool,
    /// Data length code (0…8).
    pub dlc: u8,
    /// Data bytes (first `dlc` valid; empty for remote frames).
    pub data: [u8; 8],
}

/// One SLCAN command from the host.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SlcanCommand {
    /// `O`: open the channel.
    Open,
    /// `L`: open listen-only.
    ListenOnly,
    /// `C`: close the channel.
    Close,
    /// `Sn`: bit rate, bit/s.
    Bitrate(u32),
    /// `t`/`T`/`r`/`R`: transmit a frame.
    Transmit(SlcanFrame),
    /// `V`: hardware/software version.
    Version,
    /// `N`: serial number.
    SerialNumber,
    /// `Zn`: time stamps on/off (accepted, not used).
    Timestamps(bool),
    /// `F`: status flags.
    Status,
}

/// Why a line is not a valid SLCAN command (the adapter answers BEL).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SlcanError {
    /// Empty line.
    Empty,
    /// Unknown command byte.
    UnknownCommand(u8),
    /// Malformed identifier, length or data (what, in words).
    Malformed(String),
}

/// The Lawicel `Sn` bit-rate table.
pub const BITRATES: [u32; 9] = [
    10_000, 20_000, 50_000, 100_000, 125_000, 250_000, 500_000, 800_000, 1_000_000,
];

/// Longest command line kept: `T` + 8 identifier digits + length + 16 data digits (+ slack);
/// longer lines are dropped and answered with BEL.
pub const MAX_LINE: usize = 32;

/// The value of hexadecimal digits (the line is bytes: a non-ASCII byte is simply not a digit).
fn hex(digits: &[u8], what: &str) -> Result<u32, SlcanError> {
    if digits.is_empty() || digits.len() > 8 {
        return Err(SlcanError::Malformed(format!(
            "{what}: {} digits",
            digits.len()
        )));
    }
    digits.iter().try_fold(0u32, |acc, &b| {
        let d = char::from(b)
            .to_digit(16)
            .ok_or_else(|| SlcanError::Malformed(format!("{what}: byte {b:#04x} is not hex")))?;
        Ok((acc << 4) | d)
    })
}

/// Parses one command line (without its CR).
pub fn parse_line(line: &[u8]) -> Result<SlcanCommand, SlcanError> {
    let (&c, rest) = line.split_first().ok_or(SlcanError::Empty)?;
    match c {
        b'O' => Ok(SlcanCommand::Open),
        b'L' => Ok(SlcanCommand::ListenOnly),
        b'C' => Ok(SlcanCommand::Close),
        b'V' | b'v' => Ok(SlcanCommand::Version),
        b'N' => Ok(SlcanCommand::SerialNumber),
        b'F' => Ok(SlcanCommand::Status),
        b'Z' => Ok(SlcanCommand::Timestamps(rest == b"1")),
        b'S' => {
            let n = hex(rest, "bit rate code")? as usize;
            BITRATES
                .get(n)
                .map(|b| SlcanCommand::Bitrate(*b))
                .ok_or(SlcanError::Malformed(format!("bit rate code {n}")))
        }
        b't' | b'T' | b'r' | b'R' => {
            let extended = c.is_ascii_uppercase();
            let remote = c == b'r' || c == b'R';
            let id_len = if extended { 8 } else { 3 };
            let id = hex(rest.get(..id_len).unwrap_or(&[]), "identifier")?;
            if (!extended && id > 0x7FF) || id > 0x1FFF_FFFF {
                return Err(SlcanError::Malformed(format!("identifier {id:#x}")));
            }
            let dlc = hex(rest.get(id_len..id_len + 1).unwrap_or(&[]), "length")?;
            if dlc > 8 {
                return Err(SlcanError::Malformed(format!("length {dlc}")));
            }
            let body = rest.get(id_len + 1..).unwrap_or(&[]);
            let mut data = [0u8; 8];
            if remote {
                if !body.is_empty() {
                    return Err(SlcanError::Malformed("data in a remote frame".into()));
                }
            } else {
                if body.len() != 2 * dlc as usize {
                    return Err(SlcanError::Malformed(format!(
                        "{} data digits for length {dlc}",
                        body.len()
                    )));
                }
                for (d, pair) in data.iter_mut().zip(body.chunks_exact(2)) {
                    *d = hex(pair, "data")? as u8;
                }
            }
            Ok(SlcanCommand::Transmit(SlcanFrame {
                id,
                extended,
                remote,
                dlc: dlc as u8,
                data,
            }))
        }
        other => Err(SlcanError::UnknownCommand(other)),
    }
}

/// The line (with its CR) that reports a received frame to the host.
pub fn format_frame(f: &SlcanFrame) -> String {
    let mut s = match (f.extended, f.remote) {
        (false, false) => format!("t{:03X}{}", f.id, f.dlc),
        (true, false) => format!("T{:08X}{}", f.id, f.dlc),
        (false, true) => format!("r{:03X}{}", f.id, f.dlc),
        (true, true) => format!("R{:08X}{}", f.id, f.dlc),
    };
    if !f.remote {
        for b in f.data.iter().take(usize::from(f.dlc.min(8))) {
            s.push_str(&format!("{b:02X}"));
        }
    }
    s.push('\r');
    s
}

/// Splits a byte stream into CR-terminated command lines (LF ignored). A line longer than
/// [`MAX_LINE`] bytes is returned empty-handed as an over-long marker: its bytes are dropped and
/// it parses as an error (BEL), so garbage never grows the buffer.
#[derive(Default)]
pub struct LineSplitter {
    buf: Vec<u8>,
    overlong: bool,
}

/// A line of the stream: its bytes, or the marker of a line that was too long.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Line {
    /// A complete line (without CR).
    Bytes(Vec<u8>),
    /// A line longer than [`MAX_LINE`] (dropped).
    TooLong,
}

impl Line {
    /// The command of the line, or why it is none.
    pub fn parse(&self) -> Result<SlcanCommand, SlcanError> {
        match self {
            Line::Bytes(b) => parse_line(b),
            Line::TooLong => Err(SlcanError::Malformed(format!(
                "line longer than {MAX_LINE} bytes"
            ))),
        }
    }
}

impl LineSplitter {
    /// Feeds bytes; returns the complete lines.
    pub fn push(&mut self, bytes: &[u8]) -> Vec<Line> {
        let mut out = Vec::new();
        for &b in bytes {
            match b {
                b'\r' => {
                    let line = std::mem::take(&mut self.buf);
                    out.push(if std::mem::take(&mut self.overlong) {
                        Line::TooLong
                    } else {
                        Line::Bytes(line)
                    });
                }
                b'\n' => {}
                _ if self.buf.len() < MAX_LINE => self.buf.push(b),
                _ => self.overlong = true,
            }
        }
        out
    }
}
