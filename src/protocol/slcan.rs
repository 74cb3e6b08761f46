//! SLCAN (Lawicel ASCII) framing: the CAN bus as CR-terminated text lines over a byte stream —
//! how the simulated pod (`sim --serve`) and the emulated board (`host-tests/emu-board`) offer
//! their CAN bus on a loopback TCP port, so that `python-can`'s `slcan` interface
//! (`channel='socket://127.0.0.1:PORT'`) and the `canopen` package act as the CNC.
//!
//! Lawicel commands are ASCII lines ended by CR: `O` open, `L` listen-only, `C` close,
//! `Sn` bit rate (S0 = 10 k … S8 = 1 M), `tIIILDD…` / `TIIIIIIIILDD…` data frames,
//! `rIIIL` / `RIIIIIIIIL` remote frames, `V` / `N` version / serial, `Z0/Z1` time stamps.
//! The adapter answers CR for OK and BEL for an error; a frame sent to the host is the same
//! `t…`/`T…` line. Written here rather than taken from a crate: the SLCAN crates on crates.io
//! drive a serial adapter from the host side, where this is the adapter.

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
    Malformed(&'static str),
}

/// The Lawicel `Sn` bit-rate table.
pub const BITRATES: [u32; 9] = [
    10_000, 20_000, 50_000, 100_000, 125_000, 250_000, 500_000, 800_000, 1_000_000,
];

/// Longest command line kept: `T` + 8 identifier digits + length + 16 data digits (+ slack);
/// longer lines are dropped and answered with BEL.
pub const MAX_LINE: usize = 32;

/// Bytes of the longest frame line: `T`, 8 identifier digits, the length, 16 data digits, CR.
pub const FRAME_LINE: usize = 27;

/// The value of hexadecimal digits (the line is bytes: a non-ASCII byte is simply not a digit);
/// `what` names the field in the error.
fn hex(digits: &[u8], what: &'static str) -> Result<u32, SlcanError> {
    if digits.is_empty() || digits.len() > 8 {
        return Err(SlcanError::Malformed(what));
    }
    digits.iter().try_fold(0u32, |acc, &b| {
        let d = char::from(b)
            .to_digit(16)
            .ok_or(SlcanError::Malformed(what))?;
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
                .ok_or(SlcanError::Malformed("bit rate code beyond S8"))
        }
        b't' | b'T' | b'r' | b'R' => {
            let extended = c.is_ascii_uppercase();
            let remote = c == b'r' || c == b'R';
            let id_len = if extended { 8 } else { 3 };
            let id = hex(rest.get(..id_len).unwrap_or(&[]), "identifier")?;
            if (!extended && id > 0x7FF) || id > 0x1FFF_FFFF {
                return Err(SlcanError::Malformed("identifier out of range"));
            }
            let dlc = hex(rest.get(id_len..id_len + 1).unwrap_or(&[]), "length")?;
            if dlc > 8 {
                return Err(SlcanError::Malformed("length over 8"));
            }
            let body = rest.get(id_len + 1..).unwrap_or(&[]);
            let mut data = [0u8; 8];
            if remote {
                if !body.is_empty() {
                    return Err(SlcanError::Malformed("data in a remote frame"));
                }
            } else {
                if body.len() != 2 * dlc as usize {
                    return Err(SlcanError::Malformed("data digits not twice the length"));
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
pub fn format_frame(f: &SlcanFrame) -> heapless::Vec<u8, FRAME_LINE> {
    const HEX: &[u8; 16] = b"0123456789ABCDEF";
    let mut out = heapless::Vec::new();
    let mut push = |b: u8| {
        // FRAME_LINE is the longest line: never full
        let _ = out.push(b);
    };
    push(match (f.extended, f.remote) {
        (false, false) => b't',
        (true, false) => b'T',
        (false, true) => b'r',
        (true, true) => b'R',
    });
    let digits = if f.extended { 8 } else { 3 };
    for k in (0..digits).rev() {
        push(
            HEX.get(((f.id >> (4 * k)) & 0xF) as usize)
                .copied()
                .unwrap_or(b'0'),
        );
    }
    let dlc = f.dlc.min(8);
    push(b'0' + dlc);
    if !f.remote {
        for &b in f.data.iter().take(usize::from(dlc)) {
            push(HEX.get(usize::from(b >> 4)).copied().unwrap_or(b'0'));
            push(HEX.get(usize::from(b & 0xF)).copied().unwrap_or(b'0'));
        }
    }
    push(b'\r');
    out
}

/// A line of the stream: its bytes, or the marker of a line that was too long.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Line<'a> {
    /// A complete line (without CR).
    Bytes(&'a [u8]),
    /// A line longer than [`MAX_LINE`] (dropped).
    TooLong,
}

impl Line<'_> {
    /// The command of the line, or why it is none.
    pub fn parse(&self) -> Result<SlcanCommand, SlcanError> {
        match self {
            Line::Bytes(b) => parse_line(b),
            Line::TooLong => Err(SlcanError::Malformed("line too long")),
        }
    }
}

/// Splits a byte stream into CR-terminated command lines (LF ignored). A line longer than
/// [`MAX_LINE`] bytes comes out as [`Line::TooLong`]: its bytes are dropped and it parses as an
/// error (BEL), so garbage never grows the buffer.
#[derive(Clone, Debug, Default)]
pub struct LineSplitter {
    buf: heapless::Vec<u8, MAX_LINE>,
    overlong: bool,
}

impl LineSplitter {
    /// Feeds bytes; hands each complete line to `line`.
    pub fn push(&mut self, bytes: &[u8], line: &mut impl FnMut(Line<'_>)) {
        for &b in bytes {
            match b {
                b'\r' => {
                    if core::mem::take(&mut self.overlong) {
                        line(Line::TooLong);
                    } else {
                        line(Line::Bytes(&self.buf));
                    }
                    self.buf.clear();
                }
                b'\n' => {}
                _ => {
                    if self.buf.push(b).is_err() {
                        self.overlong = true;
                    }
                }
            }
        }
    }
}

/// The adapter's side of an SLCAN port: the channel's open state, the answers to the host's
/// commands, and the CAN frames the host transmits (the pod's node uses standard data frames
/// only: extended and remote frames are acknowledged and dropped). `sim --serve` and the
/// emulated board both speak through it.
///
/// The bus has a bit rate: the host's adapter sets its own (`Sn`), the pod's controller runs at
/// [`set_node_bit_rate`](Self::set_node_bit_rate)'s. Frames pass only while the two agree, as
/// on a real bus, where a node at another bit rate sees error frames only (an adapter that was
/// never given `Sn` is taken to be at the pod's rate).
#[derive(Clone, Copy, Debug, Default)]
pub struct SlcanPort {
    open: bool,
    /// The host adapter's bit rate, bit/s (`None` until an `Sn`).
    host_bit_rate: Option<u32>,
    /// The pod controller's bit rate, bit/s (0 until set: any).
    node_bit_rate: u32,
}

impl SlcanPort {
    /// True while the host has the channel open (`O` or `L`).
    pub const fn is_open(&self) -> bool {
        self.open
    }

    /// True while frames pass between the host and the pod: the channel is open and both
    /// sides run at the same bit rate.
    pub fn passes(&self) -> bool {
        let same = match self.host_bit_rate {
            Some(h) => self.node_bit_rate == 0 || h == self.node_bit_rate,
            None => true,
        };
        self.open && same
    }

    /// The pod's controller runs at `bits_per_s` (at boot, and after an LSS bit-rate switch).
    pub fn set_node_bit_rate(&mut self, bits_per_s: u32) {
        self.node_bit_rate = bits_per_s;
    }

    /// The host (re)connected: the channel is closed until it opens it, at the bit rate it
    /// sets then.
    pub fn reset(&mut self) {
        self.open = false;
        self.host_bit_rate = None;
    }

    /// One line from the host: its answer through `reply` (CR, `z`/`Z` CR for a frame, BEL
    /// for an error) and the frame it transmits, if a standard data frame.
    pub fn on_line(
        &mut self,
        line: Line<'_>,
        reply: &mut impl FnMut(&[u8]),
    ) -> Option<crate::protocol::canopen::CanFrame> {
        match line.parse() {
            Ok(SlcanCommand::Open) | Ok(SlcanCommand::ListenOnly) => {
                self.open = true;
                reply(b"\r");
            }
            Ok(SlcanCommand::Close) => {
                self.open = false;
                reply(b"\r");
            }
            Ok(SlcanCommand::Bitrate(b)) => {
                self.host_bit_rate = Some(b);
                reply(b"\r");
            }
            Ok(SlcanCommand::Transmit(f)) => {
                reply(if f.extended { b"Z\r" } else { b"z\r" });
                if f.extended || f.remote || !self.passes() {
                    return None;
                }
                let len = usize::from(f.dlc.min(8));
                return crate::protocol::canopen::CanFrame::new(
                    u16::try_from(f.id).ok()?,
                    f.data.get(..len).unwrap_or(&[]),
                );
            }
            Ok(SlcanCommand::Version) => reply(b"V0101\r"),
            Ok(SlcanCommand::SerialNumber) => reply(b"NBP01\r"),
            Ok(SlcanCommand::Status) => reply(b"F00\r"),
            Ok(_) => reply(b"\r"),
            Err(_) => reply(b"\x07"),
        }
        None
    }

    /// The line that reports a frame of the pod's node to the host.
    pub fn frame_line(f: &crate::protocol::canopen::CanFrame) -> heapless::Vec<u8, FRAME_LINE> {
        let p = f.payload();
        let mut data = [0u8; 8];
        if let Some(d) = data.get_mut(..p.len()) {
            d.copy_from_slice(p);
        }
        format_frame(&SlcanFrame {
            id: u32::from(f.id),
            extended: false,
            remote: false,
            dlc: p.len() as u8,
            data,
        })
    }
}
