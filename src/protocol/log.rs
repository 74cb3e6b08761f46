//! The sample log: a fixed-capacity ring of compact sample records that counts the samples it
//! overwrote, and its CSV form (the format the replay tool reads, `DATA:LOG?` over USB).
//!
//! # Record layout and RAM
//!
//! One [`LogRecord`] is 32 bytes: time stamp low word (u32, µs), ΔL (f32, µm), five axis
//! positions (f32, mm or degrees, exactly the sample's values), temperature (i16, 0.01 °C) and
//! the flags (u16). The f32 fields keep what the pod had bit for bit; the time stamp keeps 32
//! bits and is rebuilt from the newest sample's full 64-bit time (valid while the ring spans less
//! than 2³² µs ≈ 71.6 min, which it does at any logging rate ≥ 1 sample per 4 s).
//!
//! [`LOG_CAPACITY`] = 1024 records = 32 768 bytes, + 48 bytes of indices, counters and run
//! metadata = 32 816 bytes: half of the 64 KiB static-RAM budget, the largest single user of it.
//! At the full 1 kHz sample rate that is one second; the application sets a decimation
//! ([`SampleLog::set_decimation`]) to log a whole run (e.g. 1 in 20 → 50 Hz, 20 s).
//!
//! # CSV format (version 1)
//!
//! ```text
//! # ballpod log v1
//! # bar_length_mm=150
//! # pattern=CIRCLE
//! # direction=CCW
//! # sample_rate_hz=1000
//! # decimation=1
//! # samples=3
//! # overwritten=0
//! # flags=bit0 lvdt_over_range|bit1 lvdt_open|bit2 quadrature_error|bit3 probe_event|bit4 overrun|bit5 temperature_fault
//! t_s,dl_um,x_mm,y_mm,z_mm,b_deg,c_deg,temp_c,flags
//! 12.345678,0.1234,150.0000,0.0000,-20.0000,0.0000000,90.0000000,20.12,0
//! ```
//!
//! `#` lines are metadata (`key=value`); then the header; then one row per sample, oldest
//! first. Columns: `t_s` (s since boot, 6 decimals = 1 µs), `dl_um` (4 decimals = 0.1 nm), one
//! column per configured axis in the order X, Y, Z, A, B, C (`x_mm`… 4 decimals = 0.1 µm,
//! `a_deg`… 7 decimals = 10⁻⁷ °), `temp_c` (2 decimals), `flags` (decimal bit set of
//! [`SampleFlags`](crate::acquisition::SampleFlags)). A non-finite value is written `nan`. `sample_rate_hz` is the logging rate
//! (the pod's sample rate divided by the decimation); `overwritten` counts samples lost to the
//! ring since it was last cleared. Lines end with `\n`.
//!
//! Numbers are printed by hand in fixed point ([`crate::protocol::scpi::number`]), not with
//! `core::fmt` floats (flash, and fixed resolution is what the replay needs).

use crate::acquisition::{MAX_AXES, Sample};
use crate::config::AxisName;
use crate::protocol::pod::{Direction, Pattern, PodModel};
use crate::protocol::scpi::number::{Text, push_bytes, push_fixed, push_u64};

/// Records the firmware's log holds (32 bytes each: 32 KiB; see the module doc).
pub const LOG_CAPACITY: usize = 1024;

/// Temperature stored when the sample's temperature is not finite or beyond ±327 °C.
const TEMP_INVALID: i16 = i16::MIN;

/// One logged sample (32 bytes).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LogRecord {
    /// Low 32 bits of the time stamp, µs since boot.
    pub t_lo_us: u32,
    /// ΔL, µm.
    pub delta_l_um: f32,
    /// Axis positions in input order, mm or degrees.
    pub axes: [f32; MAX_AXES],
    /// Bar temperature, 0.01 °C ([`i16::MIN`] if not valid).
    pub temp_centi_c: i16,
    /// [`SampleFlags`](crate::acquisition::SampleFlags) bits.
    pub flags: u16,
}

const _: () = assert!(core::mem::size_of::<LogRecord>() == 32);

impl LogRecord {
    const ZERO: Self = Self {
        t_lo_us: 0,
        delta_l_um: 0.0,
        axes: [0.0; MAX_AXES],
        temp_centi_c: 0,
        flags: 0,
    };

    /// The record of a sample (temperature rounded to 0.01 °C).
    pub fn from_sample(s: &Sample) -> Self {
        let centi = f64::from(s.temp_c) * 100.0;
        let temp_centi_c = if centi.is_finite() && centi.abs() < 32_767.0 {
            (if centi < 0.0 {
                centi - 0.5
            } else {
                centi + 0.5
            }) as i16
        } else {
            TEMP_INVALID
        };
        Self {
            t_lo_us: s.t_us as u32,
            delta_l_um: s.delta_l_um,
            axes: s.axes,
            temp_centi_c,
            flags: s.flags.0,
        }
    }
}

/// A logged sample as read back (full time stamp).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoggedSample {
    /// Time stamp, µs since boot.
    pub t_us: u64,
    /// The stored record.
    pub record: LogRecord,
}

/// Fixed-capacity ring of the last `N` logged samples (oldest overwritten and counted).
#[derive(Clone, Debug)]
pub struct SampleLog<const N: usize> {
    records: [LogRecord; N],
    /// Index of the next write.
    head: usize,
    /// Records held (≤ N).
    len: usize,
    /// Full time stamp of the newest record, µs.
    newest_t_us: u64,
    /// Samples overwritten since the last clear.
    overwritten: u32,
    /// Log one sample in `decimation_less_one + 1` (stored less one, like `meta` below, so that
    /// an empty log is all-zero bytes and a `static` log lands in `.bss`, not in 32 KiB of
    /// flash-initialised `.data`).
    decimation_less_one: u16,
    /// Samples offered since the last logged one.
    phase: u16,
    /// The run the records belong to (set by [`begin_run`](Self::begin_run)); valid when
    /// `has_meta` (an `Option` would encode `None` in a non-zero niche byte).
    meta: LogMeta,
    /// `meta` is set.
    has_meta: bool,
}

impl<const N: usize> Default for SampleLog<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> SampleLog<N> {
    /// An empty log that keeps every sample.
    pub const fn new() -> Self {
        Self {
            records: [LogRecord::ZERO; N],
            head: 0,
            len: 0,
            newest_t_us: 0,
            overwritten: 0,
            decimation_less_one: 0,
            phase: 0,
            meta: LogMeta::ZERO,
            has_meta: false,
        }
    }

    /// Capacity, records.
    pub const fn capacity(&self) -> usize {
        N
    }

    /// Records held.
    pub const fn len(&self) -> usize {
        self.len
    }

    /// True if no record is held.
    pub const fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Samples overwritten (lost before download) since the last [`clear`](Self::clear).
    pub const fn overwritten(&self) -> u32 {
        self.overwritten
    }

    /// Logs one sample in `k` (k ≥ 1; 0 is taken as 1).
    pub fn set_decimation(&mut self, k: u16) {
        self.decimation_less_one = k.max(1) - 1;
        self.phase = 0;
    }

    /// The decimation (one sample in this many is logged).
    pub const fn decimation(&self) -> u16 {
        self.decimation_less_one + 1
    }

    /// Empties the log and zeroes the overwritten counter; forgets the run's metadata.
    pub fn clear(&mut self) {
        self.head = 0;
        self.len = 0;
        self.overwritten = 0;
        self.phase = 0;
        self.has_meta = false;
    }

    /// Empties the log for a new run (at arm) and keeps the run's metadata, so that the CSV
    /// describes the run even if the pattern or configuration changes before the download.
    pub fn begin_run(&mut self, meta: LogMeta) {
        self.clear();
        self.meta = meta;
        self.has_meta = true;
    }

    /// The metadata given to [`begin_run`](Self::begin_run), if any.
    pub const fn meta(&self) -> Option<LogMeta> {
        if self.has_meta { Some(self.meta) } else { None }
    }

    /// Offers a sample: every `decimation`-th one is logged ([`push`](Self::push)).
    pub fn record(&mut self, s: &Sample) {
        if self.phase == 0 {
            self.push(s);
        }
        self.phase += 1;
        if self.phase > self.decimation_less_one {
            self.phase = 0;
        }
    }

    /// Appends a sample, overwriting (and counting) the oldest when full.
    pub fn push(&mut self, s: &Sample) {
        if N == 0 {
            self.overwritten = self.overwritten.saturating_add(1);
            return;
        }
        if let Some(slot) = self.records.get_mut(self.head) {
            *slot = LogRecord::from_sample(s);
        }
        self.head = (self.head + 1) % N;
        if self.len == N {
            self.overwritten = self.overwritten.saturating_add(1);
        } else {
            self.len += 1;
        }
        self.newest_t_us = s.t_us;
    }

    /// The `k`-th held sample, oldest first (k < [`len`](Self::len)), with its full time stamp.
    pub fn get(&self, k: usize) -> Option<LoggedSample> {
        if k >= self.len {
            return None;
        }
        let start = (self.head + N - self.len) % N.max(1);
        let r = self.records.get((start + k) % N.max(1))?;
        let newest_lo = self.newest_t_us as u32;
        let age = u64::from(newest_lo.wrapping_sub(r.t_lo_us));
        Some(LoggedSample {
            t_us: self.newest_t_us.saturating_sub(age),
            record: *r,
        })
    }

    /// The held samples, oldest first, with their full time stamps.
    pub fn iter(&self) -> impl Iterator<Item = LoggedSample> + '_ {
        (0..self.len).filter_map(|k| self.get(k))
    }
}

/// What the CSV metadata says about the run (taken from the pod at download time).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LogMeta {
    /// Calibrated bar length, mm.
    pub bar_length_mm: f32,
    /// Pattern of the run.
    pub pattern: Pattern,
    /// Direction of the run.
    pub direction: Direction,
    /// The pod's sample rate, Hz (divided by the decimation in the file).
    pub sample_rate_hz: f32,
    /// Axis assignment of the encoder inputs (index = input, as in [`Sample::axes`]).
    pub axes: [AxisName; MAX_AXES],
}

impl LogMeta {
    /// All-zero metadata (placeholder of an empty log).
    pub const ZERO: Self = Self {
        bar_length_mm: 0.0,
        pattern: Pattern::Circle,
        direction: Direction::Ccw,
        sample_rate_hz: 0.0,
        axes: [AxisName::Unused; MAX_AXES],
    };

    /// The metadata of the pod's current configuration and run.
    pub fn from_pod(pod: &PodModel) -> Self {
        let mut axes = [AxisName::Unused; MAX_AXES];
        for (a, c) in axes.iter_mut().zip(pod.config.axes.iter()) {
            *a = c.name;
        }
        Self {
            bar_length_mm: pod.config.bar_length_mm,
            pattern: pod.pattern,
            direction: pod.direction,
            sample_rate_hz: pod.config.sample_rate_hz,
            axes,
        }
    }
}

/// The metadata name of a pattern (upper case long form).
pub const fn pattern_name(p: Pattern) -> &'static str {
    match p {
        Pattern::Circle => "CIRCLE",
        Pattern::Bx => "BX",
        Pattern::By => "BY",
        Pattern::Cr => "CR",
        Pattern::Ca => "CA",
        Pattern::CrPrime => "CRPRIME",
        Pattern::Ssm => "SSM",
        Pattern::Probe => "PROBE",
    }
}

/// The metadata name of a direction.
pub const fn direction_name(d: Direction) -> &'static str {
    match d {
        Direction::Ccw => "CCW",
        Direction::Cw => "CW",
    }
}

/// The CSV columns of the configured axes: (input index, column name, decimals), in the order
/// X, Y, Z, A, B, C.
fn axis_columns(axes: &[AxisName; MAX_AXES]) -> impl Iterator<Item = (usize, &'static str, u32)> {
    const ORDER: [(AxisName, &str, u32); 6] = [
        (AxisName::X, "x_mm", 4),
        (AxisName::Y, "y_mm", 4),
        (AxisName::Z, "z_mm", 4),
        (AxisName::A, "a_deg", 7),
        (AxisName::B, "b_deg", 7),
        (AxisName::C, "c_deg", 7),
    ];
    ORDER.into_iter().filter_map(move |(name, col, dec)| {
        axes.iter()
            .position(|&a| a == name)
            .map(|input| (input, col, dec))
    })
}

/// Longest CSV line, bytes (a data row with five axes is at most ~150).
pub const CSV_LINE_MAX: usize = 192;

/// One CSV line under construction.
type Line = Text<CSV_LINE_MAX>;

/// Metadata lines before the header (module doc).
const META_LINES: usize = 9;

/// Position in the CSV text of a log: which line comes next. Lets a transport that cannot take
/// the whole file at once (async USB) pull it line by line or buffer by buffer. The log and the
/// metadata must not change while a cursor is in use (the file would not be one snapshot).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CsvCursor {
    /// Next line: metadata lines, the header, then one per record.
    line: usize,
    /// Bytes of the next line already handed out by [`fill`](Self::fill).
    offset: usize,
}

impl CsvCursor {
    /// At the start of the file.
    pub const fn new() -> Self {
        Self { line: 0, offset: 0 }
    }

    /// True once every line was written.
    pub const fn is_done<const N: usize>(&self, log: &SampleLog<N>) -> bool {
        self.line >= META_LINES + 1 + log.len()
    }

    /// Writes the next whole line through `out` (one call); false when the file is complete.
    pub fn next_line<const N: usize>(
        &mut self,
        log: &SampleLog<N>,
        meta: &LogMeta,
        out: &mut impl FnMut(&[u8]),
    ) -> bool {
        let mut line = Line::new();
        if !format_line(self.line, log, meta, &mut line) {
            return false;
        }
        out(line.get(self.offset..).unwrap_or_default());
        self.line += 1;
        self.offset = 0;
        true
    }

    /// Fills `buf` with the following bytes of the file (lines split across calls where they
    /// do not fit); returns the bytes written, 0 once the file is complete.
    pub fn fill<const N: usize>(
        &mut self,
        log: &SampleLog<N>,
        meta: &LogMeta,
        buf: &mut [u8],
    ) -> usize {
        let mut n = 0;
        let mut line = Line::new();
        while n < buf.len() && format_line(self.line, log, meta, &mut line) {
            let rest = line.get(self.offset..).unwrap_or_default();
            let dst = buf.get_mut(n..).unwrap_or_default();
            let k = rest.len().min(dst.len());
            if let (Some(d), Some(s)) = (dst.get_mut(..k), rest.get(..k)) {
                d.copy_from_slice(s);
            }
            n += k;
            if k == rest.len() {
                self.line += 1;
                self.offset = 0;
            } else {
                self.offset += k;
            }
        }
        n
    }
}

/// Formats line `index` of the CSV file into `line` (cleared first); false past the end.
fn format_line<const N: usize>(
    index: usize,
    log: &SampleLog<N>,
    meta: &LogMeta,
    line: &mut Line,
) -> bool {
    line.clear();
    let kv = |line: &mut Line, key: &str| {
        push_bytes(line, b"# ") && push_bytes(line, key.as_bytes()) && push_bytes(line, b"=")
    };
    match index {
        0 => {
            push_bytes(line, b"# ballpod log v1");
        }
        1 => {
            kv(line, "bar_length_mm");
            push_fixed(line, f64::from(meta.bar_length_mm), 4, true, b"nan");
        }
        2 => {
            kv(line, "pattern");
            push_bytes(line, pattern_name(meta.pattern).as_bytes());
        }
        3 => {
            kv(line, "direction");
            push_bytes(line, direction_name(meta.direction).as_bytes());
        }
        4 => {
            kv(line, "sample_rate_hz");
            let rate = f64::from(meta.sample_rate_hz) / f64::from(log.decimation());
            push_fixed(line, rate, 4, true, b"nan");
        }
        5 => {
            kv(line, "decimation");
            push_u64(line, u64::from(log.decimation()));
        }
        6 => {
            kv(line, "samples");
            push_u64(line, log.len() as u64);
        }
        7 => {
            kv(line, "overwritten");
            push_u64(line, u64::from(log.overwritten()));
        }
        8 => {
            push_bytes(
                line,
                b"# flags=bit0 lvdt_over_range|bit1 lvdt_open|bit2 quadrature_error|bit3 probe_event|bit4 overrun|bit5 temperature_fault",
            );
        }
        META_LINES => {
            push_bytes(line, b"t_s,dl_um");
            for (_, col, _) in axis_columns(&meta.axes) {
                push_bytes(line, b",");
                push_bytes(line, col.as_bytes());
            }
            push_bytes(line, b",temp_c,flags");
        }
        k => {
            let Some(s) = log.get(k - META_LINES - 1) else {
                return false;
            };
            let r = &s.record;
            push_u64(line, s.t_us / 1_000_000);
            push_bytes(line, b".");
            let mut digits = [b'0'; 6];
            let mut f = s.t_us % 1_000_000;
            for d in digits.iter_mut().rev() {
                *d = b'0' + (f % 10) as u8;
                f /= 10;
            }
            push_bytes(line, &digits);
            push_bytes(line, b",");
            push_fixed(line, f64::from(r.delta_l_um), 4, false, b"nan");
            for (input, _, dec) in axis_columns(&meta.axes) {
                push_bytes(line, b",");
                let v = r.axes.get(input).copied().unwrap_or(f32::NAN);
                push_fixed(line, f64::from(v), dec, false, b"nan");
            }
            push_bytes(line, b",");
            if r.temp_centi_c == TEMP_INVALID {
                push_bytes(line, b"nan");
            } else {
                push_fixed(line, f64::from(r.temp_centi_c) / 100.0, 2, false, b"nan");
            }
            push_bytes(line, b",");
            push_u64(line, u64::from(r.flags));
        }
    }
    push_bytes(line, b"\n")
}

/// Writes the log as CSV (module doc), one call of `out` per line. Returns the bytes written.
pub fn write_csv<const N: usize>(
    log: &SampleLog<N>,
    meta: &LogMeta,
    out: &mut impl FnMut(&[u8]),
) -> usize {
    let mut total = 0usize;
    let mut cursor = CsvCursor::new();
    while cursor.next_line(log, meta, &mut |line: &[u8]| {
        total += line.len();
        out(line);
    }) {}
    total
}

/// Bytes [`write_csv`] would write (for a definite-length block header).
pub fn csv_len<const N: usize>(log: &SampleLog<N>, meta: &LogMeta) -> usize {
    write_csv(log, meta, &mut |_| {})
}
