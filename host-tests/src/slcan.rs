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
    /// Unknown command letter.
    UnknownCommand(char),
    /// Malformed identifier, length or data.
    Malformed(String),
}

/// The Lawicel `Sn` bit-rate table.
pub const BITRATES: [u32; 9] = [
    10_000, 20_000, 50_000, 100_000, 125_000, 250_000, 500_000, 800_000, 1_000_000,
];

fn hex(s: &str, what: &str) -> Result<u32, SlcanError> {
    if s.is_empty() || !s.bytes().all(|b| b.is_ascii_hexdigit()) {
        return Err(SlcanError::Malformed(format!("{what}: {s:?}")));
    }
    u32::from_str_radix(s, 16).map_err(|_| SlcanError::Malformed(format!("{what}: {s:?}")))
}

/// Parses one command line (without its CR).
pub fn parse_line(line: &str) -> Result<SlcanCommand, SlcanError> {
    let mut chars = line.chars();
    let c = chars.next().ok_or(SlcanError::Empty)?;
    let rest = chars.as_str();
    match c {
        'O' => Ok(SlcanCommand::Open),
        'L' => Ok(SlcanCommand::ListenOnly),
        'C' => Ok(SlcanCommand::Close),
        'V' | 'v' => Ok(SlcanCommand::Version),
        'N' => Ok(SlcanCommand::SerialNumber),
        'F' => Ok(SlcanCommand::Status),
        'Z' => Ok(SlcanCommand::Timestamps(rest == "1")),
        'S' => {
            let n = hex(rest, "bit rate code")? as usize;
            BITRATES
                .get(n)
                .map(|b| SlcanCommand::Bitrate(*b))
                .ok_or(SlcanError::Malformed(format!("bit rate code {n}")))
        }
        't' | 'T' | 'r' | 'R' => {
            let extended = c.is_ascii_uppercase();
            let remote = c == 'r' || c == 'R';
            let id_len = if extended { 8 } else { 3 };
            let id = hex(rest.get(..id_len).unwrap_or(""), "identifier")?;
            if (!extended && id > 0x7FF) || id > 0x1FFF_FFFF {
                return Err(SlcanError::Malformed(format!("identifier {id:#x}")));
            }
            let dlc = hex(rest.get(id_len..id_len + 1).unwrap_or(""), "length")?;
            if dlc > 8 {
                return Err(SlcanError::Malformed(format!("length {dlc}")));
            }
            let body = rest.get(id_len + 1..).unwrap_or("");
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
                for (k, d) in data.iter_mut().take(dlc as usize).enumerate() {
                    *d = hex(&body[2 * k..2 * k + 2], "data")? as u8;
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

/// Splits a byte stream into CR-terminated command lines (LF ignored).
#[derive(Default)]
pub struct LineSplitter {
    buf: String,
}

impl LineSplitter {
    /// Feeds bytes; returns the complete lines (without CR).
    pub fn push(&mut self, bytes: &[u8]) -> Vec<String> {
        let mut out = Vec::new();
        for &b in bytes {
            match b {
                b'\r' => out.push(std::mem::take(&mut self.buf)),
                b'\n' => {}
                _ if self.buf.len() < 64 => self.buf.push(b as char),
                _ => {} // over-long garbage: dropped, the line will be answered with BEL
            }
        }
        out
    }
}
