//! `DATA:LOG?`: the pod's log of the last run ([`crate::app::log::SampleLog`]) as the CSV text of
//! [`super::csv`], line by line, for a transport that cannot take the whole file at once (async
//! USB pulls it buffer by buffer).
//!
//! Lines: the run header, the log's own lines (`source=log`, `decimation`, `records`,
//! `overwritten`), the flags legend, the column header, one row per record, and — once the run
//! has ended — its end lines.

use super::csv::{self, Line};
use crate::app::RunMeta;
use crate::app::log::SampleLog;
use crate::protocol::scpi::number::{push_bytes, push_u64};

/// Lines between the run header and the column header: source, decimation, records,
/// overwritten, flags legend.
const LOG_LINES: usize = 6;

/// Position in the CSV text of a log: which line comes next. The log and the metadata must not
/// change while a cursor is in use (the file would not be one snapshot).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CsvCursor {
    /// Next line.
    line: usize,
    /// Bytes of the next line already handed out by [`fill`](Self::fill).
    offset: usize,
}

/// Lines of the whole file.
fn line_count<const N: usize>(log: &SampleLog<N>) -> usize {
    csv::meta_lines()
        + LOG_LINES
        + 1
        + log.len()
        + if log.end().is_some() {
            csv::END_LINES
        } else {
            0
        }
}

/// Formats line `index` of the file into `line`; false past the end.
fn format_line<const N: usize>(
    index: usize,
    log: &SampleLog<N>,
    meta: &RunMeta,
    line: &mut Line,
) -> bool {
    let m = csv::meta_lines();
    if index < m {
        return csv::meta_line(index, meta, line);
    }
    let k = index - m;
    if k < LOG_LINES {
        line.clear();
        let (key, v): (&[u8], u64) = match k {
            0 => {
                return push_bytes(line, b"# source=log\n");
            }
            1 => (b"# decimation=", u64::from(log.decimation())),
            2 => (b"# records=", log.len() as u64),
            3 => (b"# overwritten=", u64::from(log.overwritten())),
            4 => return csv::flags_line(line),
            _ => return csv::firmware_line(crate::FIRMWARE_VERSION, line),
        };
        return push_bytes(line, key) && push_u64(line, v) && push_bytes(line, b"\n");
    }
    let k = k - LOG_LINES;
    if k == 0 {
        return csv::columns_line(meta, line);
    }
    let k = k - 1;
    if let Some(r) = log.get(k) {
        return csv::record_line(&r, meta, line);
    }
    let k = k - log.len();
    match log.end() {
        Some(end) if k < csv::END_LINES => csv::end_line(k, &end, line),
        _ => false,
    }
}

impl CsvCursor {
    /// At the start of the file.
    pub const fn new() -> Self {
        Self { line: 0, offset: 0 }
    }

    /// True once every line was written.
    pub fn is_done<const N: usize>(&self, log: &SampleLog<N>) -> bool {
        self.line >= line_count(log)
    }

    /// Writes the next whole line through `out` (one call); false when the file is complete.
    pub fn next_line<const N: usize>(
        &mut self,
        log: &SampleLog<N>,
        meta: &RunMeta,
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
        meta: &RunMeta,
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

/// Writes the log as CSV, one call of `out` per line. Returns the bytes written.
pub fn write_csv<const N: usize>(
    log: &SampleLog<N>,
    meta: &RunMeta,
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
pub fn csv_len<const N: usize>(log: &SampleLog<N>, meta: &RunMeta) -> usize {
    write_csv(log, meta, &mut |_| {})
}
