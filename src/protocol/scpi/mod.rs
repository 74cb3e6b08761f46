//! The technician's USB command interface: SCPI-style commands (IEEE 488.2 common commands,
//! SCPI-99 command tree) over a byte stream, transport-agnostic.
//!
//! # Use
//!
//! ```text
//! let mut scpi = ScpiServer::new();
//! // for every chunk received from USB CDC-ACM (or the simulator's TCP socket):
//! scpi.feed(chunk, &mut app, &log, &mut |bytes| usb_write(bytes));
//! // async transports: scpi.set_pull_download(true) once, then after each feed
//! while scpi.download_pending() { let n = scpi.pull_download(&log, &mut buf); usb_write(&buf[..n]).await }
//! ```
//!
//! Bytes go in as they arrive (any chunking); each line ending in `\n` (a `\r` is ignored) is one
//! program message, executed when its `\n` arrives. Responses go out through `out` at once, in
//! pieces (one call per response unit, one per CSV line of a log download); a line that produced
//! responses ends with `\n`, their units separated by `;` (IEEE 488.2 §8.4). Execution is
//! synchronous and bounded: no call blocks or waits for time.
//!
//! The server hands every setting and session command to the application ([`App`]), which
//! accepts or refuses it (the same rules as over CANopen: a command that does not fit the
//! session state, a pattern whose geometry is not set, a change while a run is armed or
//! running → -221 with the reason), and reads its live values, results and session state.
//! Commands take effect at once, so `SESS:ARM;STAR` works.
//!
//! # Bad input
//!
//! Every rejected command queues an SCPI error (SCPI-99 Vol 2 §21.8, read by `SYSTem:ERRor?`)
//! and changes nothing. A command error (-1xx: syntax, header, parameter type) also discards the
//! rest of its line (the following units could be mis-parsed); execution errors (-2xx) do not. A
//! line longer than [`LINE_CAPACITY`] is rejected whole with -363 "Input buffer overrun" and the
//! next line is parsed normally.
//!
//! # Why not the `scpi` crate
//!
//! `scpi` 1.0.1 (Atmelfan/scpi-rs) was evaluated: it is `no_std` and can run without `alloc`,
//! but (1) it depends on `lexical-core` 0.8, which has the soundness advisory RUSTSEC-2023-0086
//! (fixed only in lexical-core 1.0, which scpi 1.0.1 does not take), plus the `scpi_derive`
//! proc-macro (syn) and `document-features`; (2) a response is built whole in one `Formatter`
//! buffer before it is sent, so a log download (tens of KiB) would need a buffer of that size —
//! here it is streamed line by line; (3) its float responses are lexical's shortest round-trip
//! digits, not fixed resolution, and pull lexical's float writer into flash; (4) it is not
//! maintained (last release 1.0.1 and last commit May 2024). The command tree here is small and
//! fixed, so a focused parser (~1 700 lines with docs, status model and number formatting:
//! short/long forms, numeric suffixes, compound headers, quoted strings, NRf numbers,
//! MIN/MAX/DEF) costs less than adapting it.
//!
//! # Command set
//!
//! The command table is the book's generated reference (`docs/src/reference/scpi-commands.md`,
//! from [`self::reference`]); the host tests execute the examples of `docs/src/technician.md`.
//! Names of patterns, directions, abort reasons, results and live values are the application's
//! ([`crate::app`]); configuration fields are [`FIELDS`] by name.
//!
//! Configuration writes (`CONFigure:<field>`, `CONFigure:AXIS<n>:NAME`) and `*SAV` are
//! protected: they need `CONFigure:UNLock` first on this port, else -203 "Command protected" and
//! nothing changes. The port locks again at power-on, on `*RST`, on `CONFigure:LOCK` and when the
//! transport reports a disconnect ([`ScpiServer::connection_closed`]). Queries are never locked.

pub mod number;
pub mod parse;
pub mod reference;
pub mod status;

use crate::acquisition::MAX_AXES;
use crate::app::device::NOT_MEASURED;
use crate::app::log::SampleLog;
use crate::app::{
    App, Command as AppCommand, CommandError, Direction, LIVE, Pattern, RESULT_COUNT, ResultId,
    ResultInfo, RunMeta, StatusWord,
};
use crate::config::{AxisName, Config, ConfigError, FIELDS, Field, FieldInfo};
use crate::protocol::download::{CsvCursor, csv_len, write_csv};
use number::{SCPI_NAN, Text, push_bytes, push_fixed, push_i64, push_significant, push_u64};
use parse::{Header, MAX_DEPTH, Mnemonic, character, keyword};
use status::{ScpiError, StatusModel, code, esr};

/// Input line buffer, bytes (the longest program message accepted, without its `\n`).
pub const LINE_CAPACITY: usize = 256;

/// `*IDN?` response (IEEE 488.2 §10.14): manufacturer and model, then the serial number (eight
/// hex digits, [`ScpiServer::set_serial`]; 0 while not set), then the firmware version.
pub const IDN_MAKER_MODEL: &str = "BALLPOD,BP-1,";
/// The firmware version of `*IDN?` ([`crate::FIRMWARE_VERSION`]).
pub const IDN_VERSION: &str = crate::FIRMWARE_VERSION;

/// Decimals of values in µm (and µrad, °C…) in responses: 0.1 nm.
const RESPONSE_DECIMALS: u32 = 4;
/// A response unit under construction.
type Response = Text<256>;

/// Counters of input the server had to drop.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ScpiCounters {
    /// Lines rejected because they exceeded [`LINE_CAPACITY`].
    pub lines_overrun: u32,
    /// Pulled log downloads cut short by a disconnect ([`ScpiServer::connection_closed`]) or
    /// ended unread ([`ScpiServer::watch_download`]).
    pub downloads_cut: u32,
}

/// A log download in pull mode: where it stands, and the metadata it started with.
#[derive(Clone, Debug)]
struct Download {
    cursor: CsvCursor,
    meta: RunMeta,
    /// While the block's length is counted (pull mode: a few lines per pull, so the
    /// application task never formats the whole log at once): the counting pass's cursor and
    /// the bytes so far. The header `#<n><len>` goes out when it is done (after a `;` if the
    /// line had responses before it).
    counting: Option<(CsvCursor, usize, bool)>,
    /// The header once counted, and how much of it has gone out.
    header: Text<32>,
    header_sent: usize,
}

/// Lines the counting pass of a pulled download formats per pull: a record line is ≈ 10 k
/// instructions on the M4 (`cargo bench-m4`), so a pull holds the application task ≈ 0.5 ms,
/// well within the block queue ahead of it (64 blocks: 6.4 ms at the highest sample rate).
pub const COUNT_LINES_PER_PULL: usize = 8;

/// One SCPI session (one USB CDC-ACM port or TCP connection): line buffer, status model and
/// error queue. RAM: [`LINE_CAPACITY`] + the error queue (16 × 24 B on the host, 16 × 12 B on
/// the target) + a pending download (~40 B) + a few words.
#[derive(Clone, Debug)]
pub struct ScpiServer {
    line: heapless::Vec<u8, LINE_CAPACITY>,
    overrun: bool,
    status: StatusModel,
    counters: ScpiCounters,
    pull_mode: bool,
    download: Option<Download>,
    /// Pulls of downloads so far (wrapping).
    pulls: u32,
    /// The pulls when [`watch_download`] last saw them change, and when (µs; 0: not yet).
    ///
    /// [`watch_download`]: ScpiServer::watch_download
    download_pulls: (u32, u64),
    config_unlocked: bool,
    serial: u32,
}

/// A pulled download whose host has not taken a packet for this long ends
/// ([`ScpiServer::watch_download`]): 10 s, far beyond a host's pause between reads, well
/// within the log's use (logging is paused while a download is pending).
pub const DOWNLOAD_STALL_US: u64 = 10_000_000;

impl Default for ScpiServer {
    fn default() -> Self {
        Self::new()
    }
}

/// The mutable context of one `feed` call.
struct Exec<'a, F: FnMut(&[u8]), const N: usize> {
    status: &'a mut StatusModel,
    counters: &'a mut ScpiCounters,
    app: &'a mut App,
    log: &'a SampleLog<N>,
    out: &'a mut F,
    pull_mode: bool,
    download: &'a mut Option<Download>,
    config_unlocked: &'a mut bool,
    serial: u32,
    /// A response unit was sent on the current line.
    responded: bool,
}

impl ScpiServer {
    /// A session in its power-on state (ESR = PON, empty queue, empty line buffer).
    pub const fn new() -> Self {
        Self {
            line: heapless::Vec::new(),
            overrun: false,
            status: StatusModel::new(),
            counters: ScpiCounters {
                lines_overrun: 0,
                downloads_cut: 0,
            },
            pull_mode: false,
            download: None,
            pulls: 0,
            download_pulls: (0, 0),
            config_unlocked: false,
            serial: 0,
        }
    }

    /// The pod's serial number for `*IDN?` (the firmware: CRC-32 of the MCU's unique ID, as
    /// CANopen 0x1018:4).
    pub fn set_serial(&mut self, serial: u32) {
        self.serial = serial;
    }

    /// True after `CONFigure:UNLock` until the port locks again (module doc).
    pub const fn config_unlocked(&self) -> bool {
        self.config_unlocked
    }

    /// The transport lost its connection (USB disconnect, TCP close): configuration writes lock
    /// again and a partial input line is dropped. The status model and error queue stay. A
    /// pulled log download still pending is dropped (the log itself is untouched: download it
    /// again), counted in [`ScpiCounters::downloads_cut`] and reported on the next connection
    /// as -410 "Query INTERRUPTED" in `SYSTem:ERRor?`.
    pub fn connection_closed(&mut self) {
        self.config_unlocked = false;
        self.line.clear();
        self.overrun = false;
        if self.download.take().is_some() {
            self.counters.downloads_cut = self.counters.downloads_cut.saturating_add(1);
            self.status.push(ScpiError::with(
                code::QUERY_INTERRUPTED,
                "DATA:LOG? cut by disconnect",
            ));
        }
    }

    /// Ends a pulled download whose host has not taken any of it for [`DOWNLOAD_STALL_US`] at
    /// `now_us` (it stopped reading: the terminal hung, the program died with the port open),
    /// so that logging resumes: counted in [`ScpiCounters::downloads_cut`] and reported as -410
    /// "Query INTERRUPTED" in `SYSTem:ERRor?`. Call it with the protocols' clock, at least every
    /// second.
    pub fn watch_download(&mut self, now_us: u64) {
        if self.download.is_none() {
            return;
        }
        let (pulls, since) = self.download_pulls;
        let counted = self.pulls;
        if counted != pulls || since == 0 {
            self.download_pulls = (counted, now_us.max(1));
        } else if now_us.saturating_sub(since) >= DOWNLOAD_STALL_US {
            self.download = None;
            self.download_pulls = (counted, 0);
            self.counters.downloads_cut = self.counters.downloads_cut.saturating_add(1);
            self.status.push(ScpiError::with(
                code::QUERY_INTERRUPTED,
                "DATA:LOG? ended: not read for 10 s",
            ));
        }
    }

    /// Queues a device-specific error (-300) with a detail, e.g. the reason of a reset the
    /// application found at boot; `SYSTem:ERRor?` reports it like any other error.
    pub fn push_device_error(&mut self, detail: &'static str) {
        self.status
            .push(ScpiError::with(code::DEVICE_SPECIFIC_ERROR, detail));
    }

    /// Queues -315 "Configuration memory lost" for a stored configuration rejected at boot
    /// (`detail`, `suffix`: what was wrong, e.g. `bar_length`, ` out of range`).
    pub fn push_settings_rejected(&mut self, detail: &'static str, suffix: &'static str) {
        self.status.push(ScpiError::with_suffix(
            code::CONFIGURATION_MEMORY_LOST,
            detail,
            suffix,
        ));
    }

    /// Pull mode for the log download, for transports that cannot take a whole file inside
    /// `feed` (async USB): `DATA:LOG?` then sends only its block header through `out`, and the
    /// CSV and the final `\n` are taken with [`pull_download`](Self::pull_download) until it
    /// returns 0. `DATA:LOG?` must then be the last unit of its line (later units: -440). Input
    /// fed before the download is pulled completes it through `out` first (the order of the
    /// byte stream is kept). Off by default: `feed` streams the whole download through `out`.
    pub fn set_pull_download(&mut self, on: bool) {
        self.pull_mode = on;
    }

    /// True while a pulled log download has bytes left.
    pub const fn download_pending(&self) -> bool {
        self.download.is_some()
    }

    /// True while a pulled download has not yet sent its whole block header: its length is
    /// being counted ([`pull_download`](Self::pull_download) returns 0 meanwhile) or the header
    /// is going out.
    pub fn download_header_pending(&self) -> bool {
        self.download
            .as_ref()
            .is_some_and(|d| d.counting.is_some() || d.header_sent < d.header.len())
    }

    /// The next bytes of a pending log download (pull mode), at most `buf.len()` (give at least
    /// 1 byte): first its block header, once a few pulls have counted the block's length
    /// (0 bytes meanwhile: [`download_header_pending`](Self::download_header_pending)), then the
    /// CSV and the final `\n`; 0 when nothing is pending. The log must not change until it returns 0 (the
    /// block length was announced): pause logging while [`download_pending`](Self::download_pending).
    pub fn pull_download<const N: usize>(&mut self, log: &SampleLog<N>, buf: &mut [u8]) -> usize {
        let Some(d) = self.download.as_mut() else {
            return 0;
        };
        self.pulls = self.pulls.wrapping_add(1);
        if let Some((cursor, bytes, separate)) = d.counting.as_mut() {
            // the block's length first, [`COUNT_LINES_PER_PULL`] lines at a time
            let mut done = false;
            for _ in 0..COUNT_LINES_PER_PULL {
                if !cursor.next_line(log, &d.meta, &mut |l| *bytes += l.len()) {
                    done = true;
                    break;
                }
            }
            if !done {
                return 0;
            }
            d.header.clear();
            if *separate {
                push_bytes(&mut d.header, b";");
            }
            push_block_header(&mut d.header, *bytes);
            d.counting = None;
        }
        if let Some(rest) = d.header.get(d.header_sent..).filter(|r| !r.is_empty()) {
            // the header alone (a pull that ends it sends nothing else)
            let n = rest.len().min(buf.len());
            if let (Some(dst), Some(src)) = (buf.get_mut(..n), rest.get(..n)) {
                dst.copy_from_slice(src);
            }
            d.header_sent += n;
            return n;
        }
        let mut n = d.cursor.fill(log, &d.meta, buf);
        if d.cursor.is_done(log)
            && let Some(b) = buf.get_mut(n)
        {
            // The response message terminator (IEEE 488.2 §8.5).
            *b = b'\n';
            n += 1;
            self.download = None;
        }
        n
    }

    /// The status model and error queue (read-only; for the application's status word).
    pub const fn status(&self) -> &StatusModel {
        &self.status
    }

    /// Counters of dropped input.
    pub const fn counters(&self) -> ScpiCounters {
        self.counters
    }

    /// Takes received bytes; executes every complete line (settings and commands go to `app`
    /// at once); sends responses through `out` (module doc).
    pub fn feed<const N: usize>(
        &mut self,
        bytes: &[u8],
        app: &mut App,
        log: &SampleLog<N>,
        out: &mut impl FnMut(&[u8]),
    ) {
        let mut x = Exec {
            status: &mut self.status,
            counters: &mut self.counters,
            app,
            log,
            out,
            pull_mode: self.pull_mode,
            download: &mut self.download,
            config_unlocked: &mut self.config_unlocked,
            serial: self.serial,
            responded: false,
        };
        for &b in bytes {
            match b {
                b'\n' => {
                    if self.overrun {
                        // The whole line is rejected; the next one starts clean.
                        x.status
                            .push(ScpiError::with(code::INPUT_BUFFER_OVERRUN, "line too long"));
                        x.counters.lines_overrun = x.counters.lines_overrun.saturating_add(1);
                        self.overrun = false;
                    } else {
                        x.finish_download();
                        x.line(&self.line);
                    }
                    self.line.clear();
                }
                b'\r' => {}
                _ => {
                    if !self.overrun && self.line.push(b).is_err() {
                        self.overrun = true;
                    }
                }
            }
        }
    }
}

/// Axis names with their SCPI forms.
const AXIS_NAMES: [(AxisName, &str); 7] = [
    (AxisName::X, "X"),
    (AxisName::Y, "Y"),
    (AxisName::Z, "Z"),
    (AxisName::A, "A"),
    (AxisName::B, "B"),
    (AxisName::C, "C"),
    (AxisName::Unused, "NONE"),
];

/// A resolved command.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Command {
    Idn,
    Rst,
    Cls,
    Opc,
    Wai,
    Esr,
    Ese,
    Sre,
    Stb,
    Sav,
    SystErr,
    SystVersion,
    SystCount,
    SystBootloader,
    ConfUnlock,
    ConfLock,
    ConfField(Field, &'static FieldInfo),
    ConfAxisName(usize),
    AxisPosition(usize),
    SessPattern,
    SessDirection,
    SessArm,
    SessStart,
    SessStop,
    SessAbort,
    SessClear,
    SessState,
    SessReason,
    SessCount,
    SessNote,
    StatPod,
    MeasDl,
    MeasAll,
    MeasValid,
    FetchResult,
    FetchBudget,
    FetchCatalog,
    FetchTouch,
    FetchTouchCount,
    DataLogCount,
    DataLog,
}

/// What a command accepts: query form, set form.
const fn forms(c: Command) -> (bool, bool) {
    use Command::*;
    match c {
        Idn | Esr | Stb | SystErr | SystVersion | SystCount | SessState | SessReason
        | SessCount | SessNote | StatPod | MeasDl | MeasAll | MeasValid | FetchResult
        | FetchBudget | FetchCatalog | FetchTouch | FetchTouchCount | DataLogCount | DataLog => {
            (true, false)
        }
        Rst | Cls | Wai | Sav | SystBootloader | ConfUnlock | SessArm | SessStart | SessStop
        | SessAbort | SessClear => (false, true),
        Opc | Ese | Sre | ConfLock | ConfField(..) | ConfAxisName(_) | AxisPosition(_)
        | SessPattern | SessDirection => (true, true),
    }
}

fn common(name: &[u8]) -> Option<Command> {
    const TABLE: [(&str, Command); 10] = [
        ("IDN", Command::Idn),
        ("RST", Command::Rst),
        ("CLS", Command::Cls),
        ("OPC", Command::Opc),
        ("WAI", Command::Wai),
        ("ESR", Command::Esr),
        ("ESE", Command::Ese),
        ("SRE", Command::Sre),
        ("STB", Command::Stb),
        ("SAV", Command::Sav),
    ];
    TABLE
        .iter()
        .find(|(n, _)| name.eq_ignore_ascii_case(n.as_bytes()))
        .map(|&(_, c)| c)
}

/// True for the fields that take a numeric suffix (an index).
const fn indexed(f: Field) -> bool {
    matches!(
        f,
        Field::LvdtPolyUm(_) | Field::AxisCountsPerUnit(_) | Field::AxisMaxSpeed(_)
    )
}

/// `CONFigure:<field>[<k>]`: a [`FIELDS`] entry by name (case-insensitive).
fn config_field(m: &Mnemonic<'_>) -> Result<Command, ScpiError> {
    if let Some(info) = FIELDS
        .iter()
        .find(|i| !indexed(i.field) && m.text.eq_ignore_ascii_case(i.name.as_bytes()))
    {
        return Ok(Command::ConfField(info.field, info));
    }
    let info = FIELDS
        .iter()
        .find(|i| indexed(i.field) && m.name.eq_ignore_ascii_case(i.name.as_bytes()))
        .ok_or(ScpiError::new(code::UNDEFINED_HEADER))?;
    let k = m.suffix.unwrap_or(1);
    let out_of_range = ScpiError::with(code::HEADER_SUFFIX_OUT_OF_RANGE, info.name);
    let field = match info.field {
        Field::LvdtPolyUm(_) if k <= 3 => Field::LvdtPolyUm(k as u8),
        Field::AxisCountsPerUnit(_) if (1..=MAX_AXES as u32).contains(&k) => {
            Field::AxisCountsPerUnit((k - 1) as u8)
        }
        Field::AxisMaxSpeed(_) if (1..=MAX_AXES as u32).contains(&k) => {
            Field::AxisMaxSpeed((k - 1) as u8)
        }
        _ => return Err(out_of_range),
    };
    Ok(Command::ConfField(field, info))
}

/// The encoder input (0-based) of an `AXIS<n>` node, n = 1 … [`MAX_AXES`].
fn axis_input(a: &Mnemonic<'_>) -> Result<usize, ScpiError> {
    let k = a.suffix.unwrap_or(1);
    if !(1..=MAX_AXES as u32).contains(&k) {
        return Err(ScpiError::with(code::HEADER_SUFFIX_OUT_OF_RANGE, "AXIS"));
    }
    Ok((k - 1) as usize)
}

/// Resolves a compound header path (SCPI-99 Vol 1 §6: `[...]` nodes optional).
fn resolve(path: &[Mnemonic<'_>]) -> Result<Command, ScpiError> {
    let undefined = ScpiError::new(code::UNDEFINED_HEADER);
    Ok(match path {
        [s, e] if s.is("SYSTem") && e.is("ERRor") => Command::SystErr,
        [s, e, n] if s.is("SYSTem") && e.is("ERRor") && n.is("NEXT") => Command::SystErr,
        [s, v] if s.is("SYSTem") && v.is("VERSion") => Command::SystVersion,
        [s, c] if s.is("SYSTem") && c.is("COUNt") => Command::SystCount,
        [s, b] if s.is("SYSTem") && b.is("BOOTloader") => Command::SystBootloader,
        [c, a, n] if c.is("CONFigure") && a.is_with_suffix("AXIS") && n.is("NAME") => {
            Command::ConfAxisName(axis_input(a)?)
        }
        [a, p] if a.is_with_suffix("AXIS") && p.is("POSition") => {
            Command::AxisPosition(axis_input(a)?)
        }
        [c, u] if c.is("CONFigure") && u.is("UNLock") => Command::ConfUnlock,
        [c, l] if c.is("CONFigure") && l.is("LOCK") => Command::ConfLock,
        [c, f] if c.is("CONFigure") => config_field(f)?,
        [s, x] if s.is("SESSion") => {
            const SESSION: [(&str, Command); 11] = [
                ("PATTern", Command::SessPattern),
                ("DIRection", Command::SessDirection),
                ("ARM", Command::SessArm),
                ("STARt", Command::SessStart),
                ("STOP", Command::SessStop),
                ("ABORt", Command::SessAbort),
                ("CLEar", Command::SessClear),
                ("STATe", Command::SessState),
                ("REASon", Command::SessReason),
                ("COUNt", Command::SessCount),
                ("NOTE", Command::SessNote),
            ];
            SESSION
                .iter()
                .find(|(f, _)| x.is(f))
                .map(|&(_, c)| c)
                .ok_or(undefined)?
        }
        [s, p] if s.is("STATus") && p.is("POD") => Command::StatPod,
        [m, x] if m.is("MEASure") && x.is("DL") => Command::MeasDl,
        [m, x] if m.is("MEASure") && x.is("ALL") => Command::MeasAll,
        [m, x] if m.is("MEASure") && x.is("VALid") => Command::MeasValid,
        [f, r] if f.is("FETCh") && r.is("RESult") => Command::FetchResult,
        [f, r, c] if f.is("FETCh") && r.is("RESult") && c.is("CATalog") => Command::FetchCatalog,
        [f, r, b] if f.is("FETCh") && r.is("RESult") && b.is("BUDGet") => Command::FetchBudget,
        [f, t] if f.is("FETCh") && t.is("TOUCh") => Command::FetchTouch,
        [f, t, c] if f.is("FETCh") && t.is("TOUCh") && c.is("COUNt") => Command::FetchTouchCount,
        [d, l] if d.is("DATA") && l.is("LOG") => Command::DataLog,
        [d, l, c] if d.is("DATA") && l.is("LOG") && c.is("COUNt") => Command::DataLogCount,
        _ => return Err(undefined),
    })
}

/// A parameter as decimal numeric program data (IEEE 488.2 §7.7.2).
fn numeric(p: &[u8]) -> Result<f64, ScpiError> {
    match p.first() {
        Some(b'0'..=b'9' | b'+' | b'-' | b'.') => number::parse_decimal(p).map_err(|e| {
            ScpiError::new(match e {
                number::NumberError::InvalidCharacter => code::INVALID_CHARACTER_IN_NUMBER,
                number::NumberError::ExponentTooLarge => code::EXPONENT_TOO_LARGE,
                number::NumberError::TooManyDigits => code::TOO_MANY_DIGITS,
                number::NumberError::Suffix => code::INVALID_SUFFIX,
            })
        }),
        _ => Err(ScpiError::new(code::DATA_TYPE_ERROR)),
    }
}

/// A numeric parameter that may also be `MINimum`, `MAXimum` or `DEFault` (SCPI-99 Vol 1
/// §7.2.1.1).
/// True for the keywords a numeric parameter may take instead of a number (SCPI-99 §7.2.1).
fn is_keyword_value(k: &[u8]) -> bool {
    keyword(k, "MINimum") || keyword(k, "MAXimum") || keyword(k, "DEFault")
}

fn numeric_or_keyword(p: &[u8], min: f64, max: f64, default: f64) -> Result<f64, ScpiError> {
    if p.first().is_some_and(|c| c.is_ascii_alphabetic()) {
        let k = character(p)?;
        return if keyword(k, "MINimum") {
            Ok(min)
        } else if keyword(k, "MAXimum") {
            Ok(max)
        } else if keyword(k, "DEFault") {
            Ok(default)
        } else {
            Err(ScpiError::new(code::DATA_TYPE_ERROR))
        };
    }
    numeric(p)
}

/// Appends the header of an IEEE 488.2 §8.7.9 definite length arbitrary block of `len` bytes:
/// `#`, the number of length digits, the length.
fn push_block_header<const C: usize>(r: &mut Text<C>, len: usize) {
    let mut digits: Text<24> = Text::new();
    push_u64(&mut digits, len as u64);
    push_bytes(r, b"#");
    push_u64(r, digits.len() as u64);
    push_bytes(r, &digits);
}

/// Appends counters comma-separated; with `device`, a figure not measured ([`NOT_MEASURED`])
/// as NaN.
fn push_counters<const C: usize>(r: &mut Text<C>, values: &[u32], device: bool) {
    for (k, &v) in values.iter().enumerate() {
        if k > 0 {
            push_bytes(r, b",");
        }
        if device && v == NOT_MEASURED {
            push_bytes(r, SCPI_NAN);
        } else {
            push_u64(r, u64::from(v));
        }
    }
}

/// The SCPI error of a command the application refused: a value out of its field's range → -222
/// naming the field; anything else (state, geometry not set, a change while a run is armed or
/// running, a cross-field rule) → -221 with the application's reason.
fn refusal(e: CommandError) -> ScpiError {
    let (detail, suffix) = e.text();
    let code = match e {
        CommandError::Config(ConfigError::OutOfRange {
            field: Field::PeriodsPerSample | Field::AxisCounterReach(_),
            ..
        }) => code::SETTINGS_CONFLICT,
        CommandError::Config(ConfigError::OutOfRange { .. }) => code::DATA_OUT_OF_RANGE,
        _ => code::SETTINGS_CONFLICT,
    };
    ScpiError::with_suffix(code, detail, suffix)
}

impl<F: FnMut(&[u8]), const N: usize> Exec<'_, F, N> {
    /// Sends the rest of a pulled download through `out` (more input arrived first).
    fn finish_download(&mut self) {
        if let Some(mut d) = self.download.take() {
            if let Some((_, _, separate)) = d.counting {
                // input arrived while the length was still being counted: the whole block now
                d.header.clear();
                if separate {
                    push_bytes(&mut d.header, b";");
                }
                push_block_header(&mut d.header, csv_len(self.log, &d.meta));
            }
            (self.out)(d.header.get(d.header_sent..).unwrap_or(&[]));
            let out = &mut *self.out;
            while d.cursor.next_line(self.log, &d.meta, &mut |l| out(l)) {}
            out(b"\n");
        }
    }

    /// Executes one program message (IEEE 488.2 §7.3: units separated by `;`).
    fn line(&mut self, line: &[u8]) {
        self.responded = false;
        // The path of the previous compound command, for relative headers (SCPI-99 Vol 1 §6.2.4).
        let mut prefix: heapless::Vec<Mnemonic<'_>, MAX_DEPTH> = heapless::Vec::new();
        let _ = parse::split(line, b';', |unit| {
            if unit.is_empty() {
                return Ok(());
            }
            if self.download.is_some() {
                // Pull mode: the log block must be the last response of its message.
                self.status.push(ScpiError::with(
                    code::QUERY_AFTER_BLOCK,
                    "DATA:LOG? must end its line",
                ));
                return Err(());
            }
            match self.unit(unit, &mut prefix) {
                Ok(()) => Ok(()),
                Err(e) => {
                    self.status.push(e);
                    // A command error leaves the rest of the message unparseable: drop it.
                    if (-199..=-100).contains(&e.code) {
                        Err(())
                    } else {
                        Ok(())
                    }
                }
            }
        });
        if self.responded && self.download.is_none() {
            (self.out)(b"\n");
        }
    }

    /// Executes one message unit.
    fn unit<'l>(
        &mut self,
        unit: &'l [u8],
        prefix: &mut heapless::Vec<Mnemonic<'l>, MAX_DEPTH>,
    ) -> Result<(), ScpiError> {
        let (h, param_text) = parse::header(unit)?;
        let params = parse::params(param_text)?;
        let cmd = match h.common {
            Some(name) => common(name).ok_or(ScpiError::new(code::UNDEFINED_HEADER))?,
            None => self.resolve_path(&h, prefix)?,
        };
        let (query_ok, set_ok) = forms(cmd);
        if (h.query && !query_ok) || (!h.query && !set_ok) {
            return Err(ScpiError::new(code::UNDEFINED_HEADER));
        }
        if h.query {
            self.query(cmd, &params)
        } else {
            self.set(cmd, &params)
        }
    }

    /// Resolves a compound header, relative to `prefix` unless it starts with `:`; a relative
    /// header that does not resolve is tried from the root too (lenient, as most instruments).
    fn resolve_path<'l>(
        &self,
        h: &Header<'l>,
        prefix: &mut heapless::Vec<Mnemonic<'l>, MAX_DEPTH>,
    ) -> Result<Command, ScpiError> {
        let mut full: heapless::Vec<Mnemonic<'l>, { 2 * MAX_DEPTH }> = heapless::Vec::new();
        let mut cmd = Err(ScpiError::new(code::UNDEFINED_HEADER));
        if !h.absolute && !prefix.is_empty() {
            let _ = full.extend_from_slice(prefix);
            let _ = full.extend_from_slice(&h.path);
            cmd = resolve(&full);
        }
        if cmd.is_err() {
            full.clear();
            let _ = full.extend_from_slice(&h.path);
            cmd = resolve(&full);
        }
        let cmd = cmd?;
        prefix.clear();
        if let Some((_, parents)) = full.split_last() {
            for m in parents.iter().take(MAX_DEPTH) {
                let _ = prefix.push(*m);
            }
        }
        Ok(cmd)
    }

    /// Starts a response unit (IEEE 488.2 §8.4.1: units separated by `;`).
    fn respond(&mut self, r: &[u8]) {
        if self.responded {
            (self.out)(b";");
        }
        (self.out)(r);
        self.responded = true;
    }

    /// Hands a session command to the application.
    fn act(&mut self, c: AppCommand) -> Result<(), ScpiError> {
        self.app.execute(c).map_err(refusal)
    }

    /// Rejects configuration writes unless this port was unlocked.
    fn unlocked_for(&self, what: &'static str) -> Result<(), ScpiError> {
        if *self.config_unlocked {
            Ok(())
        } else {
            Err(ScpiError::with(code::COMMAND_PROTECTED, what))
        }
    }

    fn set(&mut self, cmd: Command, p: &[&[u8]]) -> Result<(), ScpiError> {
        let arg = |n: usize| -> Result<&[u8], ScpiError> {
            match p.len() {
                l if l < n + 1 => Err(ScpiError::new(code::MISSING_PARAMETER)),
                l if l > n + 1 => Err(ScpiError::new(code::PARAMETER_NOT_ALLOWED)),
                _ => p
                    .get(n)
                    .copied()
                    .ok_or(ScpiError::new(code::MISSING_PARAMETER)),
            }
        };
        let none = || {
            if p.is_empty() {
                Ok(())
            } else {
                Err(ScpiError::new(code::PARAMETER_NOT_ALLOWED))
            }
        };
        match cmd {
            Command::Rst => {
                // IEEE 488.2 §10.32: device reset; the status registers and the queue stay.
                none()?;
                self.act(AppCommand::Reset)?;
                *self.config_unlocked = false;
            }
            Command::Cls => {
                none()?;
                self.status.clear();
            }
            Command::Opc => {
                // Every command completes before the next is parsed (IEEE 488.2 §12.5.2).
                none()?;
                self.status.esr |= esr::OPC;
            }
            Command::Wai => none()?,
            Command::Ese | Command::Sre => {
                let v = numeric(arg(0)?)?;
                if !(-0.5..255.5).contains(&v) {
                    return Err(ScpiError::new(code::DATA_OUT_OF_RANGE));
                }
                let b = libm::round(v) as u8;
                if cmd == Command::Ese {
                    self.status.ese = b;
                } else {
                    self.status.sre = b & !status::stb::MSS;
                }
            }
            Command::Sav => {
                let v = numeric(arg(0)?)?;
                if v != 0.0 {
                    return Err(ScpiError::with(code::DATA_OUT_OF_RANGE, "one register: 0"));
                }
                self.unlocked_for("*SAV: CONF:UNL first")?;
                self.act(AppCommand::StoreSettings)?;
            }
            Command::SystBootloader => {
                none()?;
                self.unlocked_for("SYST:BOOT: CONF:UNL first")?;
                self.app.request_bootloader().map_err(refusal)?;
            }
            Command::ConfUnlock => {
                none()?;
                *self.config_unlocked = true;
            }
            Command::ConfLock => {
                none()?;
                *self.config_unlocked = false;
            }
            Command::ConfField(field, info) => {
                self.unlocked_for("CONF:UNL first")?;
                let a = arg(0)?;
                let choice = match character(a) {
                    // a code field given by name: one of its choices, else -224 (a number
                    // is taken as the code itself below)
                    Ok(name) if !info.choices().is_empty() && !is_keyword_value(name) => {
                        Some(info.choice(name).map(f64::from).ok_or(ScpiError {
                            code: code::ILLEGAL_PARAMETER_VALUE,
                            detail: crate::app::field_name(field),
                            suffix: ": unknown code name",
                        })?)
                    }
                    _ => None,
                };
                let v = match choice {
                    Some(v) => v,
                    None => {
                        let default = Config::default().field_value(field).unwrap_or(info.min);
                        numeric_or_keyword(a, info.min, info.max, default)?
                    }
                };
                if v.is_nan() {
                    // A set-up field's default is "not set": as over CANopen, only restoring
                    // the defaults clears it (src/config.rs, `FieldInfo::optional`).
                    return Err(ScpiError {
                        code: code::ILLEGAL_PARAMETER_VALUE,
                        detail: crate::app::field_name(field),
                        suffix: " has no default (restoring the defaults clears it)",
                    });
                }
                self.app.set_field(field, v).map_err(refusal)?;
            }
            Command::AxisPosition(i) => {
                let v = numeric(arg(0)?)?;
                if !(v.abs() <= crate::config::POS_MM) {
                    return Err(ScpiError::with(
                        code::DATA_OUT_OF_RANGE,
                        "axis position out of range",
                    ));
                }
                self.app.reference_axis(i, v).map_err(refusal)?;
            }
            Command::ConfAxisName(i) => {
                self.unlocked_for("CONF:UNL first")?;
                let k = character(arg(0)?)?;
                let name = AXIS_NAMES
                    .iter()
                    .find(|(_, f)| keyword(k, f))
                    .map(|&(n, _)| n)
                    .ok_or(ScpiError::with(
                        code::ILLEGAL_PARAMETER_VALUE,
                        "X|Y|Z|A|B|C|NONE",
                    ))?;
                self.app
                    .configure(|c| {
                        if let Some(a) = c.axes.get_mut(i) {
                            a.name = name;
                        }
                    })
                    .map_err(refusal)?;
            }
            Command::SessPattern => {
                let k = character(arg(0)?)?;
                let pattern = Pattern::from_name(k).ok_or(ScpiError::with(
                    code::ILLEGAL_PARAMETER_VALUE,
                    "CIRCLE|BX|BY|CR|CA|CR2|SSM|PROBE",
                ))?;
                self.app.set_pattern(pattern).map_err(refusal)?;
            }
            Command::SessDirection => {
                let k = character(arg(0)?)?;
                let direction = Direction::from_name(k)
                    .ok_or(ScpiError::with(code::ILLEGAL_PARAMETER_VALUE, "CW|CCW"))?;
                self.app.set_direction(direction).map_err(refusal)?;
            }
            Command::SessArm
            | Command::SessStart
            | Command::SessStop
            | Command::SessAbort
            | Command::SessClear => {
                none()?;
                self.act(match cmd {
                    Command::SessArm => AppCommand::Arm,
                    Command::SessStart => AppCommand::Start,
                    Command::SessStop => AppCommand::Stop,
                    Command::SessAbort => AppCommand::Abort,
                    _ => AppCommand::Clear,
                })?;
            }
            _ => return Err(ScpiError::new(code::UNDEFINED_HEADER)),
        }
        Ok(())
    }

    fn query(&mut self, cmd: Command, p: &[&[u8]]) -> Result<(), ScpiError> {
        let mut r = Response::new();
        let none = || {
            if p.is_empty() {
                Ok(())
            } else {
                Err(ScpiError::new(code::PARAMETER_NOT_ALLOWED))
            }
        };
        let fixed = |r: &mut Response, v: f32| {
            push_fixed(r, f64::from(v), RESPONSE_DECIMALS, false, SCPI_NAN)
        };
        match cmd {
            Command::Idn => {
                none()?;
                push_bytes(&mut r, IDN_MAKER_MODEL.as_bytes());
                if self.serial == 0 {
                    push_bytes(&mut r, b"0");
                } else {
                    push_bytes(&mut r, &crate::num::hex8(self.serial));
                }
                push_bytes(&mut r, b",");
                push_bytes(&mut r, IDN_VERSION.as_bytes());
            }
            Command::Opc => {
                none()?;
                push_bytes(&mut r, b"1");
            }
            Command::Esr => {
                // IEEE 488.2 §10.12: read and clear.
                none()?;
                push_u64(&mut r, u64::from(self.status.esr));
                self.status.esr = 0;
            }
            Command::Ese => {
                none()?;
                push_u64(&mut r, u64::from(self.status.ese));
            }
            Command::Sre => {
                none()?;
                push_u64(&mut r, u64::from(self.status.sre));
            }
            Command::Stb => {
                none()?;
                push_u64(&mut r, u64::from(self.status.status_byte()));
            }
            Command::SystErr => {
                none()?;
                let e = self.status.pop();
                push_i64(&mut r, i64::from(e.code));
                push_bytes(&mut r, b",\"");
                push_bytes(&mut r, e.message().as_bytes());
                if !e.detail.is_empty() {
                    push_bytes(&mut r, b";");
                    push_bytes(&mut r, e.detail.as_bytes());
                    push_bytes(&mut r, e.suffix.as_bytes());
                }
                push_bytes(&mut r, b"\"");
            }
            Command::SystVersion => {
                none()?;
                push_bytes(&mut r, b"1999.0");
            }
            Command::ConfLock => {
                none()?;
                push_bytes(&mut r, if *self.config_unlocked { b"0" } else { b"1" });
            }
            Command::ConfField(field, info) => {
                let v = match p {
                    [] => self.app.config().field_value(field),
                    [k] => {
                        let k = character(k)?;
                        if keyword(k, "MINimum") {
                            Some(info.min)
                        } else if keyword(k, "MAXimum") {
                            Some(info.max)
                        } else if keyword(k, "DEFault") {
                            Config::default().field_value(field)
                        } else {
                            return Err(ScpiError::new(code::ILLEGAL_PARAMETER_VALUE));
                        }
                    }
                    _ => return Err(ScpiError::new(code::PARAMETER_NOT_ALLOWED)),
                };
                let v = v.unwrap_or(f64::NAN);
                match info.choices().get(v as usize).filter(|_| v >= 0.0) {
                    // a code field answers its code's name
                    Some(name) => {
                        push_bytes(&mut r, name.as_bytes());
                    }
                    None => {
                        // f32 fields as typed (7 digits); the f64 encoder scale with 15; a
                        // set-up field that is not set answers 9.91E+37 (SCPI NaN)
                        let digits = if matches!(field, Field::AxisCountsPerUnit(_)) {
                            15
                        } else {
                            7
                        };
                        push_significant(&mut r, v, digits, SCPI_NAN);
                    }
                }
            }
            Command::ConfAxisName(i) => {
                none()?;
                let name = self
                    .app
                    .config()
                    .axes
                    .get(i)
                    .map_or(AxisName::Unused, |a| a.name);
                let form = AXIS_NAMES
                    .iter()
                    .find(|(n, _)| *n == name)
                    .map_or("NONE", |&(_, f)| f);
                push_bytes(&mut r, form.as_bytes());
            }
            Command::SessPattern => {
                none()?;
                push_bytes(&mut r, self.app.pattern().name().as_bytes());
            }
            Command::SessDirection => {
                none()?;
                push_bytes(&mut r, self.app.direction().name().as_bytes());
            }
            Command::SessState => {
                none()?;
                push_bytes(&mut r, self.app.session().name().as_bytes());
            }
            Command::SessReason => {
                none()?;
                let name = self.app.abort_reason().map_or("NONE", |a| a.name());
                push_bytes(&mut r, name.as_bytes());
            }
            Command::SessNote => {
                // what the last procedure step could not do, quoted (empty: nothing)
                none()?;
                let (a, b) = self.app.procedure_note().map_or(("", ""), |e| e.text());
                push_bytes(&mut r, b"\"");
                push_bytes(&mut r, a.as_bytes());
                push_bytes(&mut r, b.as_bytes());
                push_bytes(&mut r, b"\"");
            }
            Command::SessCount => {
                none()?;
                push_counters(&mut r, &self.app.run_counters().as_array(), false);
            }
            Command::SystCount => {
                none()?;
                push_counters(&mut r, &self.app.device_counters().0, true);
            }
            Command::StatPod => {
                none()?;
                let mut w = self.app.live().status.0;
                if !self.status.is_empty() {
                    w |= StatusWord::ERROR;
                }
                push_u64(&mut r, u64::from(w));
            }
            Command::AxisPosition(i) => {
                none()?;
                fixed(&mut r, self.app.axis_position(i).unwrap_or(f32::NAN));
            }
            Command::MeasDl => {
                none()?;
                fixed(
                    &mut r,
                    self.app
                        .live()
                        .get(crate::app::Live::DeltaL)
                        .unwrap_or(f32::NAN),
                );
            }
            Command::MeasAll => {
                // invalid values (bit clear in the mask) read 9.91E+37, SCPI's NaN
                none()?;
                let l = self.app.live();
                push_u64(&mut r, u64::from(l.sample_counter));
                for v in l.values {
                    push_bytes(&mut r, b",");
                    fixed(&mut r, v);
                }
                push_bytes(&mut r, b",");
                push_u64(&mut r, u64::from(l.status.0));
                push_bytes(&mut r, b",");
                push_u64(&mut r, u64::from(l.valid));
            }
            Command::MeasValid => {
                // the names of the valid live values, quoted
                none()?;
                let l = self.app.live();
                let mut first = true;
                for (k, (name, _)) in LIVE.iter().enumerate() {
                    if l.valid & (1 << k) != 0 {
                        if !first {
                            push_bytes(&mut r, b",");
                        }
                        first = false;
                        push_bytes(&mut r, b"\"");
                        push_bytes(&mut r, name.as_bytes());
                        push_bytes(&mut r, b"\"");
                    }
                }
            }
            Command::FetchResult | Command::FetchBudget => {
                let arg = match p {
                    [] => return Err(ScpiError::new(code::MISSING_PARAMETER)),
                    [a] => *a,
                    _ => return Err(ScpiError::new(code::PARAMETER_NOT_ALLOWED)),
                };
                let id = if arg.first().is_some_and(|c| c.is_ascii_alphabetic()) {
                    ResultId::from_name(character(arg)?).ok_or(ScpiError::with(
                        code::ILLEGAL_PARAMETER_VALUE,
                        "result name (FETC:RES:CAT?)",
                    ))?
                } else {
                    let v = numeric(arg)?;
                    if !(v >= 0.0 && v <= (RESULT_COUNT - 1) as f64 && v == libm::round(v)) {
                        return Err(ScpiError::with(
                            code::DATA_OUT_OF_RANGE,
                            "result index (FETC:RES:CAT?)",
                        ));
                    }
                    ResultId::from_index(v as usize)
                        .ok_or(ScpiError::new(code::DATA_OUT_OF_RANGE))?
                };
                let entry = self.app.result(id);
                let info = id.info();
                let unit = info.unit.as_str();
                if !entry.valid {
                    return Err(ScpiError::with_suffix(
                        code::DATA_CORRUPT_OR_STALE,
                        info.name,
                        " has no valid value",
                    ));
                }
                if matches!(cmd, Command::FetchBudget) {
                    // u, then the largest contributors and their shares, largest first
                    fixed(&mut r, entry.std_uncertainty);
                    for (c, share) in entry.largest_contributors().into_iter().flatten() {
                        push_bytes(&mut r, b",");
                        for b in c.name().bytes() {
                            push_bytes(&mut r, &[b.to_ascii_uppercase()]);
                        }
                        push_bytes(&mut r, b",");
                        fixed(&mut r, share);
                    }
                } else {
                    fixed(&mut r, entry.value);
                    push_bytes(&mut r, b",");
                    fixed(&mut r, entry.std_uncertainty);
                    push_bytes(&mut r, b",");
                    for c in unit.bytes() {
                        push_bytes(&mut r, &[c.to_ascii_uppercase()]);
                    }
                }
            }
            Command::FetchCatalog => {
                none()?;
                // one response unit per name: the catalogue is longer than a response buffer
                for (k, info) in ResultInfo::all().enumerate() {
                    let mut n = Response::new();
                    if k > 0 {
                        push_bytes(&mut n, b",");
                    }
                    push_bytes(&mut n, b"\"");
                    push_bytes(&mut n, info.name.as_bytes());
                    push_bytes(&mut n, b"\"");
                    if k == 0 {
                        self.respond(&n);
                    } else {
                        (self.out)(&n);
                    }
                }
                return Ok(());
            }
            Command::FetchTouchCount => {
                none()?;
                push_u64(&mut r, self.app.touch_points().len() as u64);
            }
            Command::FetchTouch => {
                // touch point k (1-based) of the last PROBE run: x,y,z in mm
                let k = match p {
                    [] => return Err(ScpiError::new(code::MISSING_PARAMETER)),
                    [a] => numeric(a)?,
                    _ => return Err(ScpiError::new(code::PARAMETER_NOT_ALLOWED)),
                };
                let points = self.app.touch_points();
                let point = (k >= 1.0 && k == libm::round(k))
                    .then(|| points.get(k as usize - 1))
                    .flatten()
                    .ok_or(ScpiError::with(
                        code::DATA_OUT_OF_RANGE,
                        "touch point 1..FETC:TOUC:COUN?",
                    ))?;
                for (i, v) in point.iter().enumerate() {
                    if i > 0 {
                        push_bytes(&mut r, b",");
                    }
                    push_fixed(&mut r, *v, RESPONSE_DECIMALS, false, SCPI_NAN);
                }
            }
            Command::DataLogCount => {
                none()?;
                push_u64(&mut r, self.log.len() as u64);
            }
            Command::DataLog => {
                none()?;
                // The run's metadata if the application recorded it at arm, else the pod's now.
                let meta = self.log.meta().copied().unwrap_or(*self.app.run_meta());
                if self.pull_mode {
                    // the length is counted by the pulls, which send the header when it is known
                    *self.download = Some(Download {
                        cursor: CsvCursor::new(),
                        meta,
                        counting: Some((CsvCursor::new(), 0, self.responded)),
                        header: Text::new(),
                        header_sent: 0,
                    });
                    self.responded = true;
                } else {
                    push_block_header(&mut r, csv_len(self.log, &meta));
                    self.respond(&r);
                    let out = &mut *self.out;
                    write_csv(self.log, &meta, &mut |chunk| out(chunk));
                }
                return Ok(());
            }
            _ => return Err(ScpiError::new(code::UNDEFINED_HEADER)),
        }
        self.respond(&r);
        Ok(())
    }
}
