//! The USB sample stream: every sample of every run, for a PC that records whole runs (the
//! pod's own log keeps only what fits). It is a [`Recorder`]: the application hands it each
//! run's header, samples, touch points and end; it writes them into a byte ring that the
//! transport drains (firmware: the second CDC-ACM interface; simulator: its stream port).
//!
//! # Format: the run text of [`super::csv`], each row as a binary record
//!
//! A run's header and end are the text lines of [`super::csv`] (with `# source=stream`), and
//! each sample or touch point is one **record** of `24 + 4·n` bytes, little-endian, `n` the
//! number of axis columns of the run's column line (0…5):
//!
//! | offset | type | what |
//! |---|---|---|
//! | 0 | u8 | [`RECORD_TAG`] `0xB5` (not ASCII: never the first byte of a text line) |
//! | 1 | u8 | `n` |
//! | 2 | u16 | flags (`SampleFlags` bits; bit 15 a touch point) |
//! | 4 | u32 | `seq`, sample number (a touch point: the next sample's) |
//! | 8 | u64 | time stamp, µs since boot |
//! | 16 | f32 | ΔL, µm (NaN: not valid; a touch point) |
//! | 20 | n × f32 | positions of the axis columns in the column line's order, mm or ° |
//! | 20 + 4n | f32 | bar temperature, °C, as sampled (NaN: not valid) |
//!
//! Every record starts at a multiple of 4 bytes of the stream: 0–3 NUL bytes (`0x00`) before
//! a record pad it there (after a run's column line), which a reader skips. So the pod writes
//! a record as `6 + n` aligned word stores, and the stream's bytes go out with word copies.
//!
//! A record is the row the log's text would have ([`decode`] turns a recorded stream into that
//! text, exactly; `cargo replay` reads either): a binary record costs the sample path a copy
//! where formatting the row took ~10 000 Cortex-M4F instructions a sample, and it is half the
//! bytes (the book's "The sample stream and the log" has the figures).
//!
//! Nothing is lost silently: a line or record that does not fit the ring is dropped whole and
//! counted; the count of the run is written in its end lines (`# stream_dropped=`), and in
//! total by [`SampleStream::dropped_lines`]. A reader that connects while a run is recorded
//! gets its header at once ([`SampleStream::join_run`]), with `# partial=1` if samples of it
//! went before. Replay refuses a recorded run with dropped lines or marked partial. With no
//! reader attached the stream does nothing.

use super::csv::{self, Line, Row};
use crate::acquisition::{MAX_AXES, Sample};
use crate::app::log::LogRecord;
use crate::app::{Recorder, RunEnd, RunMeta, Touch};
use crate::protocol::scpi::number::{push_bytes, push_u64};

/// First byte of a sample record.
pub const RECORD_TAG: u8 = 0xB5;

/// Bytes of a record with `n` axis columns.
pub const fn record_len(n: usize) -> usize {
    24 + 4 * n
}

/// Bytes of the longest record (five axis columns).
pub const RECORD_MAX: usize = record_len(MAX_AXES);

/// Bytes of the firmware's ring: a run's header (up to 2 473 bytes of text with every
/// real-valued set-up field set to a nine-digit value, any pattern — written at once when the
/// run starts, between runs, when the ring has drained), then at least 46 records (46 ms at
/// 1 kHz) before the USB host must have read; about 600 bytes to spare for new fields. `host-tests/tests/stream_records.rs` holds the longest
/// header against it; a configuration field adds a line to every header, so a field that makes
/// that test fail grows this ring (the stack pays for it: `.ci/stack-report`).
pub const FIRMWARE_RING_BYTES: usize = 5120;

/// A byte ring of `N` bytes holding whole lines and records of the stream (`N` a multiple of
/// 4; the bytes past the last multiple are not used).
#[derive(Clone, Debug)]
pub struct SampleStream<const N: usize> {
    buf: Ring<N>,
    head: usize,
    len: usize,
    /// Input index of each axis column of the current run (`csv::axis_columns`).
    columns: [u8; MAX_AXES],
    /// Axis columns of the current run.
    n_columns: u8,
    last_seq: u32,
    run_dropped: u32,
    dropped: u32,
    enabled: bool,
}

/// The ring's bytes, word-aligned: items start on words ([`SampleStream`]).
#[derive(Clone, Debug)]
#[repr(C, align(4))]
struct Ring<const N: usize>([u8; N]);

impl<const N: usize> Default for SampleStream<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> SampleStream<N> {
    /// An empty, disabled stream (nothing is written until a reader is there).
    pub const fn new() -> Self {
        Self {
            buf: Ring([0; N]),
            head: 0,
            len: 0,
            columns: [0; MAX_AXES],
            n_columns: 0,
            last_seq: 0,
            run_dropped: 0,
            dropped: 0,
            enabled: false,
        }
    }

    /// A reader connected (`true`: the ring starts empty) or left (`false`: nothing is
    /// written, nothing counted).
    pub fn set_enabled(&mut self, on: bool) {
        self.enabled = on;
        self.head = 0;
        self.len = 0;
    }

    /// True while a reader is connected.
    pub const fn enabled(&self) -> bool {
        self.enabled
    }

    /// Lines and records dropped since boot because the ring was full.
    pub const fn dropped_lines(&self) -> u32 {
        self.dropped
    }

    /// Bytes waiting.
    pub const fn pending(&self) -> usize {
        self.len
    }

    /// The ring's capacity: `N` rounded down to whole words.
    const CAP: usize = N & !3;

    /// Appends `bytes` whole, or drops and counts them.
    fn push(&mut self, bytes: &[u8]) {
        if !self.enabled {
            return;
        }
        if Self::CAP - self.len < bytes.len() {
            self.dropped = self.dropped.saturating_add(1);
            self.run_dropped = self.run_dropped.saturating_add(1);
            return;
        }
        let tail = (self.head + self.len) % Self::CAP;
        let first = bytes.len().min(Self::CAP - tail);
        let (a, b) = (
            bytes.get(..first).unwrap_or(&[]),
            bytes.get(first..).unwrap_or(&[]),
        );
        if let Some(dst) = self.buf.0.get_mut(tail..tail + first) {
            dst.copy_from_slice(a);
        }
        if let Some(dst) = self.buf.0.get_mut(..b.len()) {
            dst.copy_from_slice(b);
        }
        self.len += bytes.len();
    }

    /// Hands up to `max` bytes to `out` straight from the ring — one or two slices, oldest
    /// first, no copy of its own — ending on a word of the ring unless it empties it; returns
    /// how many.
    pub fn drain(&mut self, max: usize, out: &mut impl FnMut(&[u8])) -> usize {
        let mut n = self.len.min(max);
        if n < self.len {
            n = ((self.head + n) & !3).saturating_sub(self.head);
        }
        let first = n.min(Self::CAP - self.head);
        if let Some(a) = self.buf.0.get(self.head..self.head + first) {
            out(a);
        }
        if n > first
            && let Some(b) = self.buf.0.get(..n - first)
        {
            out(b);
        }
        self.head = (self.head + n) % Self::CAP;
        self.len -= n;
        n
    }

    /// Writes one record: the axes in input order `axes`, the temperature as sampled.
    fn record(
        &mut self,
        seq: u32,
        t_us: u64,
        delta_l_um: f32,
        axes: &[f32; MAX_AXES],
        temp_c: f32,
        flags: u16,
    ) {
        if !self.enabled {
            return;
        }
        let n = usize::from(self.n_columns);
        let head = [
            u32::from(RECORD_TAG) | u32::from(self.n_columns) << 8 | u32::from(flags) << 16,
            seq,
            t_us as u32,
            (t_us >> 32) as u32,
            delta_l_um.to_bits(),
        ];
        let columns = self.columns;
        let columns = columns.get(..n).unwrap_or(&[]);
        let tail = (self.head + self.len) % Self::CAP;
        // NULs up to the next word (after a text line), never across the ring's end
        let pad = tail.wrapping_neg() & 3;
        let len = pad + record_len(n);
        // the sample path: straight into the ring, word by word
        if Self::CAP - self.len >= len
            && let Some(dst) = self.buf.0.get_mut(tail..tail + len)
        {
            encode(dst, pad, &head, columns, axes, temp_c);
            self.len += len;
            return;
        }
        // wrapping the ring's end or not fitting: padding and record as one item (dropped
        // together)
        let mut bytes = [0u8; 3 + RECORD_MAX];
        encode(&mut bytes, pad, &head, columns, axes, temp_c);
        self.push(bytes.get(..len).unwrap_or(&[]));
    }
}

/// Writes `pad` NULs, then a record into `dst`: its first five words, the positions of the
/// axis `columns` (input indices into `axes`), the temperature.
#[inline(always)]
fn encode(
    dst: &mut [u8],
    pad: usize,
    head: &[u32; 5],
    columns: &[u8],
    axes: &[f32; MAX_AXES],
    temp_c: f32,
) {
    if let Some(zeros) = dst.get_mut(..pad) {
        zeros.fill(0);
    }
    let mut slots = dst.get_mut(pad..).unwrap_or(&mut []).chunks_exact_mut(4);
    let mut put = |w: u32| {
        if let Some(d) = slots.next() {
            d.copy_from_slice(&w.to_le_bytes());
        }
    };
    let [w0, w1, w2, w3, w4] = *head;
    put(w0);
    put(w1);
    put(w2);
    put(w3);
    put(w4);
    for &i in columns {
        put(axes.get(usize::from(i)).map_or(0, |v| v.to_bits()));
    }
    put(temp_c.to_bits());
}

impl<const N: usize> SampleStream<N> {
    /// A reader joined while the run of `meta` is recorded: its header, with `# partial=1` if
    /// samples of it went before (replay refuses such a run: its results are not the pod's).
    pub fn join_run(&mut self, meta: &RunMeta, partial: bool) {
        self.header(meta, partial);
    }

    fn header(&mut self, meta: &RunMeta, partial: bool) {
        self.run_dropped = 0;
        self.n_columns = 0;
        for ((input, _), slot) in csv::axis_columns(meta).zip(self.columns.iter_mut()) {
            *slot = input as u8;
            self.n_columns += 1;
        }
        if !self.enabled {
            return;
        }
        let mut line = Line::new();
        for i in 0..csv::meta_lines() {
            if csv::meta_line(i, meta, &mut line) {
                self.push(&line);
            }
        }
        line.clear();
        push_bytes(&mut line, b"# source=stream\n");
        self.push(&line);
        if partial {
            line.clear();
            push_bytes(&mut line, b"# partial=1\n");
            self.push(&line);
        }
        if csv::flags_line(&mut line) {
            self.push(&line);
        }
        if csv::firmware_line(crate::FIRMWARE_VERSION, &mut line) {
            self.push(&line);
        }
        if csv::columns_line(meta, &mut line) {
            self.push(&line);
        }
    }
}

impl<const N: usize> Recorder for SampleStream<N> {
    fn begin_run(&mut self, meta: &RunMeta) {
        self.header(meta, false);
    }

    fn sample(&mut self, s: &Sample) {
        self.last_seq = s.seq;
        self.record(s.seq, s.t_us, s.delta_l_um, &s.axes, s.temp_c, s.flags.0);
    }

    fn touch(&mut self, t: &Touch) {
        let next = self.last_seq.wrapping_add(1);
        self.record(next, t.t_us, f32::NAN, &t.axes, f32::NAN, LogRecord::TOUCH);
    }

    fn end_run(&mut self, end: &RunEnd) {
        if !self.enabled {
            return;
        }
        let mut line = Line::new();
        for i in 0..csv::END_LINES {
            if csv::end_line(i, end, &mut line) {
                self.push(&line);
            }
        }
        line.clear();
        // counted before this line is written: a dropped end line still counts itself
        let _ = push_bytes(&mut line, b"# stream_dropped=")
            && push_u64(&mut line, u64::from(self.run_dropped))
            && push_bytes(&mut line, b"\n");
        self.push(&line);
    }
}

/// Why a recorded stream could not be turned into text ([`decode`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DecodeError {
    /// A record claims more than five axis columns: the bytes at `offset` are not a record.
    BadRecord {
        /// Byte offset of the record's tag.
        offset: usize,
    },
    /// The bytes end inside a record (the recording was cut).
    Cut {
        /// Byte offset of the record's tag.
        offset: usize,
    },
}

/// Turns a recorded stream into its text ([`super::csv`]): lines are passed through as they
/// are (their padding dropped), each record becomes the row the log writes for the same
/// sample. `out` receives each
/// line with its `\n` (a last line without one as it is). Returns the bytes read.
pub fn decode(bytes: &[u8], mut out: impl FnMut(&[u8])) -> Result<usize, DecodeError> {
    let mut at = 0;
    let mut line = Line::new();
    while let Some(&first) = bytes.get(at) {
        if first == 0 {
            // padding up to the next item
            at += 1;
            continue;
        }
        if first != RECORD_TAG {
            let rest = bytes.get(at..).unwrap_or(&[]);
            let end = rest
                .iter()
                .position(|&b| b == b'\n')
                .map_or(rest.len(), |p| p + 1);
            out(rest.get(..end).unwrap_or(&[]));
            at += end;
            continue;
        }
        let n = usize::from(bytes.get(at + 1).copied().unwrap_or(0));
        if n > MAX_AXES {
            return Err(DecodeError::BadRecord { offset: at });
        }
        let Some(rec) = bytes.get(at..at + record_len(n)) else {
            return Err(DecodeError::Cut { offset: at });
        };
        let word = |k: usize| {
            u32::from_le_bytes(
                rec.get(4 * k..4 * k + 4)
                    .and_then(|b| b.try_into().ok())
                    .unwrap_or([0; 4]),
            )
        };
        let mut axes = [f32::NAN; MAX_AXES];
        for (k, a) in axes.iter_mut().take(n).enumerate() {
            *a = f32::from_bits(word(5 + k));
        }
        let row = Row {
            seq: word(1),
            t_us: u64::from(word(2)) | u64::from(word(3)) << 32,
            delta_l_um: f32::from_bits(word(4)),
            axes: axes.get(..n).unwrap_or(&[]),
            temp_c: LogRecord::c_of_centi(LogRecord::centi_c(f32::from_bits(word(5 + n)))),
            flags: (word(0) >> 16) as u16,
        };
        if csv::row_line(&row, &mut line) {
            out(&line);
        }
        at += record_len(n);
    }
    Ok(at)
}
