//! The USB sample stream: every sample of every run, as the CSV text of [`super::csv`], for a PC
//! that records whole runs (the pod's own log keeps only what fits). It is a [`Recorder`]: the
//! application hands it each run's header, samples, touch points and end; it formats them into
//! a byte ring that the transport drains (firmware: the second CDC-ACM interface; simulator:
//! its stream port).
//!
//! Nothing is lost silently: a line that does not fit the ring is dropped whole and counted;
//! the count of the run is written in its end lines (`# stream_dropped=`), and in total by
//! [`SampleStream::dropped_lines`]. A run header written while the ring is full is dropped too,
//! so a PC that connects mid-run sees the next run complete. Replay refuses a recorded run
//! with dropped lines.

use super::csv::{self, Line};
use crate::acquisition::Sample;
use crate::app::log::{LogRecord, LoggedRecord};
use crate::app::{Recorder, RunEnd, RunMeta, Touch};
use crate::protocol::scpi::number::{push_bytes, push_u64};

/// A byte ring of `N` bytes holding whole lines of the stream.
#[derive(Clone, Debug)]
pub struct SampleStream<const N: usize> {
    buf: [u8; N],
    head: usize,
    len: usize,
    meta: RunMeta,
    last_seq: u32,
    run_dropped: u32,
    dropped: u32,
    enabled: bool,
}

impl<const N: usize> Default for SampleStream<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> SampleStream<N> {
    /// An empty, disabled stream (nothing is written until a reader is there).
    pub const fn new() -> Self {
        Self {
            buf: [0; N],
            head: 0,
            len: 0,
            meta: RunMeta::ZERO,
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

    /// Lines dropped since boot because the ring was full.
    pub const fn dropped_lines(&self) -> u32 {
        self.dropped
    }

    /// Bytes waiting.
    pub const fn pending(&self) -> usize {
        self.len
    }

    fn push_line(&mut self, line: &[u8]) {
        if !self.enabled {
            return;
        }
        if N - self.len < line.len() {
            self.dropped = self.dropped.saturating_add(1);
            self.run_dropped = self.run_dropped.saturating_add(1);
            return;
        }
        for &b in line {
            let at = (self.head + self.len) % N;
            if let Some(slot) = self.buf.get_mut(at) {
                *slot = b;
            }
            self.len += 1;
        }
    }

    /// Takes up to `out.len()` bytes; returns how many.
    pub fn pull(&mut self, out: &mut [u8]) -> usize {
        let n = self.len.min(out.len());
        for o in out.iter_mut().take(n) {
            *o = self.buf.get(self.head).copied().unwrap_or(0);
            self.head = (self.head + 1) % N;
        }
        self.len -= n;
        n
    }

    fn record(&mut self, r: &LogRecord, t_us: u64) {
        let mut line = Line::new();
        let meta = self.meta;
        if csv::record_line(&LoggedRecord { t_us, record: *r }, &meta, &mut line) {
            self.push_line(&line);
        }
    }
}

impl<const N: usize> Recorder for SampleStream<N> {
    fn begin_run(&mut self, meta: &RunMeta) {
        self.meta = *meta;
        self.run_dropped = 0;
        let mut line = Line::new();
        for i in 0..csv::meta_lines() {
            if csv::meta_line(i, meta, &mut line) {
                self.push_line(&line);
            }
        }
        line.clear();
        push_bytes(&mut line, b"# source=stream\n");
        self.push_line(&line);
        if csv::flags_line(&mut line) {
            self.push_line(&line);
        }
        if csv::columns_line(meta, &mut line) {
            self.push_line(&line);
        }
    }

    fn sample(&mut self, s: &Sample) {
        self.last_seq = s.seq;
        self.record(&LogRecord::from_sample(s), s.t_us);
    }

    fn touch(&mut self, t: &Touch) {
        let next = self.last_seq.wrapping_add(1);
        self.record(&LogRecord::from_touch(t, next), t.t_us);
    }

    fn end_run(&mut self, end: &RunEnd) {
        let mut line = Line::new();
        for i in 0..csv::END_LINES {
            if csv::end_line(i, end, &mut line) {
                self.push_line(&line);
            }
        }
        line.clear();
        // counted before this line is written: a dropped end line still counts itself
        let _ = push_bytes(&mut line, b"# stream_dropped=")
            && push_u64(&mut line, u64::from(self.run_dropped))
            && push_bytes(&mut line, b"\n");
        self.push_line(&line);
    }
}
