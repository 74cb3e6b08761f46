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
//! ([`crate::app`]); configuration fields are [`FIELDS`](crate::config::FIELDS) by name.
//!
//! Configuration writes (`CONFigure:<field>`, `CONFigure:AXIS<n>:NAME`) and `*SAV` are
//! protected: they need `CONFigure:UNLock` first on this port, else -203 "Command protected" and
//! nothing changes. The port locks again at power-on, on `*RST`, on `CONFigure:LOCK` and when the
//! transport reports a disconnect ([`ScpiServer::connection_closed`]). Queries are never locked.

mod commands;
mod exec;
pub mod number;
pub mod parse;
pub mod reference;
pub mod status;

use crate::app::log::SampleLog;
use crate::app::{App, RunMeta};
use crate::protocol::download::CsvCursor;
use number::{Text, push_bytes};
use status::{ScpiError, StatusModel, code};

use commands::Command;
use exec::push_block_header;
/// Input line buffer, bytes (the longest program message accepted, without its `\n`).
pub const LINE_CAPACITY: usize = 256;

/// `*IDN?` response (IEEE 488.2 §10.14): manufacturer and model, then the serial number (eight
/// hex digits, [`ScpiServer::set_serial`]; 0 while not set), then the firmware version.
pub const IDN_MAKER_MODEL: &str = "BALLPOD,BP-1,";
/// The firmware version of `*IDN?` ([`crate::FIRMWARE_VERSION`]).
pub const IDN_VERSION: &str = crate::FIRMWARE_VERSION;

/// Decimals of values in µm (and µrad, °C…) in responses: 0.1 nm.
pub const RESPONSE_DECIMALS: u32 = 4;
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
