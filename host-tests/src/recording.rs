//! Recorded runs on the host: what the pod's recorder hands out ([`ballpod::app::Recorder`]) as
//! data, written in the pod's own CSV text (with the core's formatting,
//! `ballpod::protocol::csv`) and read back from it — from a recorded USB stream, a `DATA:LOG?`
//! download or the simulator's files — for replay.
//!
//! Reading is strict: any fault (a missing or unknown column, a bad number, a sample number
//! that goes backwards, a `records=` count that disagrees with the rows, a run with dropped
//! stream lines) rejects the whole file with its name, line and field.

use std::fmt;
use std::path::{Path, PathBuf};

use ballpod::acquisition::{MAX_AXES, Sample, SampleFlags};
use ballpod::app::log::{LogRecord, LoggedRecord};
use ballpod::app::{
    AbortReason, Direction, Pattern, Recorder, RunCounters, RunEnd, RunMeta, Touch,
};
use ballpod::config::{AxisName, CanBitrate, Config, LvdtInput};
use ballpod::protocol::csv;

/// One thing a run recorded, in order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event {
    /// A sample the run saw.
    Sample(Sample),
    /// A touch point.
    Touch(Touch),
}

/// A recorded run.
#[derive(Clone, Debug, PartialEq)]
pub struct RecordedRun {
    /// Its header (number, pattern, direction, configuration).
    pub meta: RunMeta,
    /// Its samples and touch points, in order.
    pub events: Vec<Event>,
    /// How it ended (`None`: the recording stops before the end).
    pub end: Option<RunEnd>,
    /// One sample in this many was kept (a decimated log; 1 for the stream).
    pub decimation: u32,
    /// `# partial=1`: the stream's reader joined the run after samples of it went (replay
    /// refuses it: its results are not the pod's).
    pub partial: bool,
    /// The firmware that made the text (`# firmware=`; `None`: not named).
    pub firmware: Option<String>,
}

impl RecordedRun {
    /// A run with this header and nothing recorded yet.
    pub fn new(meta: RunMeta) -> Self {
        Self {
            meta,
            events: Vec::new(),
            end: None,
            decimation: 1,
            partial: false,
            firmware: None,
        }
    }

    /// The samples, in order.
    pub fn samples(&self) -> impl Iterator<Item = &Sample> {
        self.events.iter().filter_map(|e| match e {
            Event::Sample(s) => Some(s),
            Event::Touch(_) => None,
        })
    }

    /// The run as the pod's stream text (`# source=stream`).
    pub fn to_csv(&self) -> String {
        let mut out = String::new();
        let mut line = csv::Line::new();
        let mut put = |line: &csv::Line| out.push_str(&String::from_utf8_lossy(line));
        for i in 0..csv::meta_lines() {
            if csv::meta_line(i, &self.meta, &mut line) {
                put(&line);
            }
        }
        let mut extra = csv::Line::new();
        let _ = extra.extend_from_slice(b"# source=stream\n");
        put(&extra);
        if csv::flags_line(&mut line) {
            put(&line);
        }
        if let Some(v) = &self.firmware
            && csv::firmware_line(v, &mut line)
        {
            put(&line);
        }
        if csv::columns_line(&self.meta, &mut line) {
            put(&line);
        }
        let mut last_seq = 0u32;
        for e in &self.events {
            let r = match e {
                Event::Sample(s) => {
                    last_seq = s.seq;
                    LoggedRecord {
                        t_us: s.t_us,
                        record: LogRecord::from_sample(s),
                    }
                }
                Event::Touch(t) => LoggedRecord {
                    t_us: t.t_us,
                    record: LogRecord::from_touch(t, last_seq.wrapping_add(1)),
                },
            };
            if csv::record_line(&r, &self.meta, &mut line) {
                put(&line);
            }
        }
        if let Some(end) = &self.end {
            for i in 0..csv::END_LINES {
                if csv::end_line(i, end, &mut line) {
                    put(&line);
                }
            }
            out.push_str("# stream_dropped=0\n");
        }
        out
    }
}

/// A host recorder: keeps every run whole.
#[derive(Clone, Debug, Default)]
pub struct Recording {
    /// The runs, in order.
    pub runs: Vec<RecordedRun>,
}

impl Recorder for Recording {
    fn begin_run(&mut self, meta: &RunMeta) {
        self.runs.push(RecordedRun::new(*meta));
    }
    fn sample(&mut self, s: &Sample) {
        if let Some(r) = self.runs.last_mut() {
            r.events.push(Event::Sample(*s));
        }
    }
    fn touch(&mut self, t: &Touch) {
        if let Some(r) = self.runs.last_mut() {
            r.events.push(Event::Touch(*t));
        }
    }
    fn end_run(&mut self, end: &RunEnd) {
        if let Some(r) = self.runs.last_mut() {
            r.end = Some(*end);
        }
    }
}

/// A rejected file.
#[derive(Clone, Debug, PartialEq)]
pub struct LogError {
    /// File.
    pub file: PathBuf,
    /// Line (1-based; 0 when the file as a whole is at fault).
    pub line: usize,
    /// Field (column or key) at fault, if any.
    pub field: Option<String>,
    /// What is wrong.
    pub what: String,
}

impl fmt::Display for LogError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.file.display(), self.line)?;
        if let Some(field) = &self.field {
            write!(f, ": field `{field}`")?;
        }
        write!(f, ": {}", self.what)
    }
}

/// The text of a value in an error message: at most 40 characters.
pub fn excerpt(v: &str) -> String {
    let mut s: String = v.chars().take(40).collect();
    if v.chars().count() > 40 {
        s.push('…');
    }
    format!("{s:?}")
}

/// A column of the pod's CSV.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Col {
    Seq,
    T,
    Dl,
    /// Encoder input, and the column's name (`x_mm` …).
    Axis(usize, &'static str),
    Temp,
    Flags,
}

impl Col {
    /// The column's name in the header line.
    const fn name(self) -> &'static str {
        match self {
            Col::Seq => "seq",
            Col::T => "t_s",
            Col::Dl => "dl_um",
            Col::Axis(_, name) => name,
            Col::Temp => "temp_c",
            Col::Flags => "flags",
        }
    }
}

/// Parses a time `s.micro` (at most 6 decimals) to µs.
fn parse_t_us(v: &str) -> Option<u64> {
    let (int, frac) = v.split_once('.').unwrap_or((v, ""));
    if int.is_empty()
        || frac.len() > 6
        || !int.bytes().chain(frac.bytes()).all(|b| b.is_ascii_digit())
    {
        return None;
    }
    let mut f: u64 = frac.parse().unwrap_or(0);
    for _ in frac.len()..6 {
        f *= 10;
    }
    int.parse::<u64>()
        .ok()?
        .checked_mul(1_000_000)?
        .checked_add(f)
}

/// A number of the CSV as `f32` (`nan` allowed where `nan_ok`).
fn parse_f32(v: &str, nan_ok: bool) -> Option<f32> {
    let x: f32 = v.parse().ok()?;
    (x.is_finite() || (nan_ok && x.is_nan())).then_some(x)
}

/// The header being read: the run's metadata so far.
struct Header {
    meta: RunMeta,
    decimation: u32,
    records: Option<usize>,
    /// `firmware=`: the firmware that made the text.
    firmware: Option<String>,
    /// `source=stream`: every sample of the run is a row, and the end block is complete.
    stream: bool,
    /// `partial=1` (the stream's reader joined mid-run).
    partial: bool,
}

/// What of a run's end block has been read.
#[derive(Default)]
struct EndBlock {
    /// Line of the `seen` counter (0: not read).
    seen_line: usize,
    /// The `stream_dropped` line was read.
    stream_dropped: bool,
}

/// Applies one `key=value` line of a run header.
fn header_line(h: &mut Header, key: &str, value: &str) -> Result<(), String> {
    let c = &mut h.meta.config;
    match key {
        "run" => h.meta.run = value.parse().map_err(|_| "not a run number".to_string())?,
        "pattern" => {
            h.meta.pattern = Pattern::from_name(value.as_bytes())
                .ok_or(format!("unknown pattern (known: {})", pattern_names()))?
        }
        "direction" => {
            h.meta.direction =
                Direction::from_name(value.as_bytes()).ok_or("CW or CCW".to_string())?
        }
        "lvdt_input" => {
            c.lvdt_input = match value {
                "AC" => LvdtInput::AcRatiometric,
                "DC" => LvdtInput::DcConditioner,
                _ => return Err("AC or DC".into()),
            }
        }
        "can_bitrate" => {
            let b: u32 = value.parse().map_err(|_| "a bit rate".to_string())?;
            c.can_bitrate = (0..4)
                .filter_map(CanBitrate::from_u8)
                .find(|r| r.bits_per_s() == b)
                .ok_or("125000, 250000, 500000 or 1000000".to_string())?;
        }
        "decimation" => h.decimation = value.parse().map_err(|_| "not a count".to_string())?,
        "records" => h.records = Some(value.parse().map_err(|_| "not a count".to_string())?),
        "source" => h.stream = value == "stream",
        "partial" => h.partial = value == "1",
        "firmware" => h.firmware = Some(value.to_string()),
        "overwritten" | "flags" => {}
        k if k.starts_with("axis_name") || k.starts_with("axis_reversed") => {
            let (name, rest) = if let Some(r) = k.strip_prefix("axis_name") {
                (true, r)
            } else {
                (false, k.trim_start_matches("axis_reversed"))
            };
            let i: usize = rest.parse().map_err(|_| "unknown key".to_string())?;
            let a = c
                .axes
                .get_mut(i)
                .ok_or("no such encoder input".to_string())?;
            if name {
                a.name = [
                    AxisName::Unused,
                    AxisName::X,
                    AxisName::Y,
                    AxisName::Z,
                    AxisName::A,
                    AxisName::B,
                    AxisName::C,
                ]
                .into_iter()
                .find(|n| n.letter().to_string() == value)
                .ok_or("X, Y, Z, A, B, C or -".to_string())?;
            } else {
                a.reversed = match value {
                    "0" => false,
                    "1" => true,
                    _ => return Err("0 or 1".into()),
                };
            }
        }
        k => {
            let f = Config::field_by_name(k).ok_or("unknown key".to_string())?;
            let info = Config::field_info(f).ok_or("unknown key".to_string())?;
            let v = match info.choice(value.as_bytes()) {
                Some(code) => f64::from(code),
                None => value
                    .parse::<f64>()
                    .map_err(|_| format!("bad number {}", excerpt(value)))?,
            };
            c.set_field(f, v);
        }
    }
    Ok(())
}

/// The pattern names, for error messages.
pub fn pattern_names() -> String {
    Pattern::ALL
        .iter()
        .map(|p| p.name())
        .collect::<Vec<_>>()
        .join(", ")
}

/// The CSV of a `DATA:LOG?` answer saved as it came: its IEEE 488.2 block header
/// `#<n><length>` (definite length; `#0` indefinite) is taken off and its length checked against
/// the bytes that follow (a trailing response terminator `\n` may follow the block). A text that
/// does not start with a block header is returned as it is.
pub fn strip_block_header<'a>(file: &Path, text: &'a str) -> Result<&'a str, LogError> {
    let err = |what: String| LogError {
        file: file.to_path_buf(),
        line: 1,
        field: None,
        what,
    };
    let b = text.as_bytes();
    let (Some(b'#'), Some(&d)) = (b.first(), b.get(1)) else {
        return Ok(text);
    };
    if !d.is_ascii_digit() {
        return Ok(text);
    }
    if d == b'0' {
        return Ok(text.get(2..).unwrap_or(""));
    }
    let n = usize::from(d - b'0');
    let digits = text.get(2..2 + n).unwrap_or("");
    let len: usize = match digits.parse() {
        Ok(v) if digits.len() == n && digits.bytes().all(|c| c.is_ascii_digit()) => v,
        _ => {
            return Err(err(format!(
                "block header `#{}{}`: {n} length digits expected",
                char::from(d),
                excerpt(digits)
            )));
        }
    };
    let body = text.get(2 + n..).unwrap_or("");
    if body.len() < len {
        return Err(err(format!(
            "the block header says {len} bytes, the file holds {}: the download was cut",
            body.len()
        )));
    }
    let (block, rest) = body.split_at_checked(len).ok_or_else(|| {
        err(format!(
            "the block header's length {len} ends inside a character"
        ))
    })?;
    if !matches!(rest, "" | "\n" | "\r\n") {
        return Err(err(format!(
            "{} bytes after the {len}-byte block: not one download",
            rest.len()
        )));
    }
    Ok(block)
}

/// Reads the runs of a pod CSV text (`# ballpod run v2`: a log download — with or without its
/// `DATA:LOG?` block header ([`strip_block_header`]) — or a recorded stream; a stream holds
/// any number of runs one after the other). Read line by line by hand, not with the `csv`
/// crate: its `# key=value` lines interleave with the rows and carry the run's state (the
/// plain logs and the readings tables are read with `csv`).
pub fn parse_runs(file: &Path, text: &str) -> Result<Vec<RecordedRun>, LogError> {
    parse_runs_with(file, text, true)
}

/// [`parse_runs`]; `every_axis`: each configured encoder input must have its column (a pod's
/// file; a plain log's synthetic header names the default inputs, and [`parse_plain`] checks
/// the columns its pattern needs).
fn parse_runs_with(
    file: &Path,
    text: &str,
    every_axis: bool,
) -> Result<Vec<RecordedRun>, LogError> {
    let err = |line: usize, field: Option<&str>, what: String| LogError {
        file: file.to_path_buf(),
        line,
        field: field.map(str::to_string),
        what,
    };
    let text = strip_block_header(file, text)?;
    let mut runs = Vec::new();
    let mut header: Option<Header> = None;
    let mut cols: Option<Vec<Col>> = None;
    let mut current: Option<RecordedRun> = None;
    let mut counters = [0u32; RunCounters::LEN];
    let mut end: Option<(Option<AbortReason>, bool)> = None;
    let mut last_seq: Option<u32> = None;
    // Of the current run's end block: the line of `seen`, whether `stream_dropped` came.
    let mut end_block = EndBlock::default();
    let finish = |run: Option<RecordedRun>,
                  header: &Option<Header>,
                  end_block: &EndBlock,
                  runs: &mut Vec<RecordedRun>,
                  line: usize|
     -> Result<(), LogError> {
        if let Some(r) = run {
            if header.as_ref().is_some_and(|h| h.stream) {
                // The pod ends every run of its stream with `end`, the counters and
                // `stream_dropped` (lines its ring dropped, checked above). Without them the
                // reader lost the end of the run — and with it the count of what was lost.
                let complete =
                    r.end.is_some() && end_block.seen_line > 0 && end_block.stream_dropped;
                if !complete {
                    return Err(err(
                        line,
                        None,
                        format!(
                            "run {} of the stream ends without its end lines (end, seen, \
                             stream_dropped): lines were lost",
                            r.meta.run
                        ),
                    ));
                }
                let rows = r.samples().count();
                let seen = r.end.map_or(0, |e| e.counters.seen) as usize;
                // a partial run (`# partial=1`) lacks its first samples by design: replay
                // refuses it with that reason
                if rows != seen && !r.partial {
                    return Err(err(
                        end_block.seen_line,
                        Some("seen"),
                        format!(
                            "the pod saw {seen} samples, the stream holds {rows}: lines were lost"
                        ),
                    ));
                }
            }
            let rows = r.events.len();
            if let Some(n) = header.as_ref().and_then(|h| h.records)
                && n != rows
            {
                return Err(err(
                    line,
                    Some("records"),
                    format!("the header says {n} records, the file holds {rows}"),
                ));
            }
            runs.push(r);
        }
        Ok(())
    };
    for (k, raw) in text.lines().enumerate() {
        let n = k + 1;
        let l = raw.trim_end_matches('\r');
        if l.trim().is_empty() {
            continue;
        }
        if let Some(meta) = l.strip_prefix('#') {
            let meta = meta.trim();
            if let Some(v) = meta.strip_prefix("ballpod run v") {
                if v != csv::VERSION.to_string() {
                    return Err(err(
                        n,
                        None,
                        format!(
                            "format version {} (this replay reads {})",
                            excerpt(v),
                            csv::VERSION
                        ),
                    ));
                }
                finish(current.take(), &header, &end_block, &mut runs, n)?;
                end_block = EndBlock::default();
                header = Some(Header {
                    meta: RunMeta {
                        config: Config::default(),
                        ..RunMeta::ZERO
                    },
                    decimation: 1,
                    partial: false,
                    records: None,
                    firmware: None,
                    stream: false,
                });
                cols = None;
                end = None;
                counters = [0; RunCounters::LEN];
                last_seq = None;
                continue;
            }
            let Some((key, value)) = meta.split_once('=') else {
                continue; // free comment
            };
            let (key, value) = (key.trim(), value.trim());
            if let Some(run) = current.as_mut() {
                // end lines of the run
                match key {
                    "end" => {
                        end = Some((None, value == "ABORTED"));
                    }
                    "reason" => {
                        let r = if value == "NONE" {
                            None
                        } else {
                            Some(AbortReason::from_name(value.as_bytes()).ok_or(err(
                                n,
                                Some("reason"),
                                format!("unknown reason {}", excerpt(value)),
                            ))?)
                        };
                        end = end.map(|(_, a)| (r, a));
                    }
                    "stream_dropped" => {
                        end_block.stream_dropped = true;
                        let d: u32 = value
                            .parse()
                            .map_err(|_| err(n, Some(key), "not a count".into()))?;
                        if d > 0 {
                            return Err(err(
                                n,
                                Some(key),
                                format!(
                                    "run {} lost {d} lines of the stream: it cannot be replayed",
                                    run.meta.run
                                ),
                            ));
                        }
                    }
                    k => {
                        let i = RunCounters::NAMES.iter().position(|x| *x == k).ok_or(err(
                            n,
                            Some(k),
                            "unknown key after the run's rows".into(),
                        ))?;
                        if let Some(c) = counters.get_mut(i) {
                            *c = value
                                .parse()
                                .map_err(|_| err(n, Some(k), "not a count".into()))?;
                        }
                        if k == "seen" {
                            end_block.seen_line = n;
                        }
                    }
                }
                if let Some((abort, _)) = end {
                    run.end = Some(RunEnd {
                        run: run.meta.run,
                        abort,
                        counters: RunCounters::from_array(counters),
                    });
                }
                continue;
            }
            let h = header.as_mut().ok_or(err(
                n,
                None,
                "no `# ballpod run v2` line before the metadata".into(),
            ))?;
            header_line(h, key, value).map_err(|w| err(n, Some(key), w))?;
            continue;
        }
        let Some(h) = header.as_ref() else {
            return Err(err(
                n,
                None,
                "not a ballpod run file (no `# ballpod run v2` line)".into(),
            ));
        };
        let Some(c) = cols.as_ref() else {
            // the column header
            let mut v = Vec::new();
            for name in l.split(',') {
                let name = name.trim();
                let col = match name {
                    "seq" => Col::Seq,
                    "t_s" => Col::T,
                    "dl_um" => Col::Dl,
                    "temp_c" => Col::Temp,
                    "flags" => Col::Flags,
                    _ => {
                        let (column, axis) = [
                            ("x_mm", AxisName::X),
                            ("y_mm", AxisName::Y),
                            ("z_mm", AxisName::Z),
                            ("a_deg", AxisName::A),
                            ("b_deg", AxisName::B),
                            ("c_deg", AxisName::C),
                        ]
                        .into_iter()
                        .find(|(c, _)| *c == name)
                        .ok_or(err(
                            n,
                            Some(name),
                            "unknown column".into(),
                        ))?;
                        let input = h
                            .meta
                            .config
                            .axes
                            .iter()
                            .position(|a| a.name == axis)
                            .ok_or(err(
                                n,
                                Some(name),
                                "no encoder input is configured for this axis".into(),
                            ))?;
                        Col::Axis(input, column)
                    }
                };
                if v.contains(&col) {
                    return Err(err(n, Some(name), "column given twice".into()));
                }
                v.push(col);
            }
            for need in [Col::Seq, Col::T, Col::Dl, Col::Flags] {
                if !v.contains(&need) {
                    return Err(err(n, Some(need.name()), "column missing".into()));
                }
            }
            // every configured encoder input has its column (the pod writes them all; a run
            // without one would replay as an axis fault, not as recorded)
            for (i, column) in csv::axis_columns(&h.meta).filter(|_| every_axis) {
                if !v.iter().any(|c| matches!(c, Col::Axis(j, _) if *j == i)) {
                    return Err(err(
                        n,
                        Some(column),
                        "column missing (the run's configuration has this encoder input)".into(),
                    ));
                }
            }
            if let Err(e) = h.meta.config.validate() {
                let (what, why) = ballpod::app::CommandError::Config(e).text();
                return Err(err(
                    n,
                    None,
                    format!("the run's configuration is not valid: {what}{why}"),
                ));
            }
            cols = Some(v);
            current = Some(RecordedRun {
                decimation: h.decimation,
                partial: h.partial,
                firmware: h.firmware.clone(),
                ..RecordedRun::new(h.meta)
            });
            continue;
        };
        let fields: Vec<&str> = l.split(',').collect();
        if fields.len() != c.len() {
            return Err(err(
                n,
                None,
                format!("{} fields, the header has {}", fields.len(), c.len()),
            ));
        }
        let mut s = Sample {
            axes: [f32::NAN; MAX_AXES],
            ..Sample::default()
        };
        let mut flags = 0u16;
        for (col, v) in c.iter().zip(&fields) {
            let v = v.trim();
            let bad = || err(n, Some(col.name()), format!("bad number {}", excerpt(v)));
            match col {
                Col::Seq => s.seq = v.parse().map_err(|_| bad())?,
                Col::T => s.t_us = parse_t_us(v).ok_or_else(bad)?,
                Col::Dl => s.delta_l_um = parse_f32(v, true).ok_or_else(bad)?,
                Col::Axis(i, _) => {
                    if let Some(a) = s.axes.get_mut(*i) {
                        *a = parse_f32(v, true).ok_or_else(bad)?;
                    }
                }
                Col::Temp => s.temp_c = parse_f32(v, true).ok_or_else(bad)?,
                Col::Flags => flags = v.parse().map_err(|_| bad())?,
            }
        }
        let run = current
            .as_mut()
            .ok_or(err(n, None, "a row after the run's end".into()))?;
        if run.end.is_some() {
            return Err(err(n, None, "a row after the run's end".into()));
        }
        if flags & LogRecord::TOUCH != 0 {
            run.events.push(Event::Touch(Touch {
                t_us: s.t_us,
                axes: s.axes,
            }));
            continue;
        }
        if let Some(prev) = last_seq
            && s.seq <= prev
        {
            return Err(err(
                n,
                Some("seq"),
                format!("sample number {} after {prev}: not increasing", s.seq),
            ));
        }
        last_seq = Some(s.seq);
        s.flags = SampleFlags(flags);
        run.events.push(Event::Sample(s));
    }
    finish(
        current.take(),
        &header,
        &end_block,
        &mut runs,
        text.lines().count(),
    )?;
    if runs.is_empty() {
        return Err(err(0, None, "no run in the file".into()));
    }
    Ok(runs)
}

/// A comma-separated table with `#` comment lines (a plain log, a readings file), read with
/// the `csv` crate: the reader past its header, the header, and the header's line.
pub struct CsvTable<'a> {
    /// The records after the header (each knows its line).
    pub reader: ::csv::Reader<&'a [u8]>,
    /// The column names.
    pub header: ::csv::StringRecord,
    /// The header's line (1-based).
    pub header_line: u64,
}

impl<'a> CsvTable<'a> {
    /// Opens `text` (of `file`, for the errors) and reads its header.
    pub fn read(file: &Path, text: &'a str) -> Result<Self, LogError> {
        let mut reader = ::csv::ReaderBuilder::new()
            .comment(Some(b'#'))
            .trim(::csv::Trim::All)
            .flexible(true)
            .from_reader(text.as_bytes());
        let header = reader.headers().map_err(|e| Self::error(file, &e))?.clone();
        // the csv crate places a header after comment lines on the first comment's line: the
        // header's line is the first that is neither a comment nor blank
        let header_line = text
            .lines()
            .position(|l| !(l.starts_with('#') || l.trim().is_empty()))
            .map_or(1, |k| k as u64 + 1);
        Ok(Self {
            reader,
            header,
            header_line,
        })
    }

    /// A `csv` error as a file error on its line.
    pub fn error(file: &Path, e: &::csv::Error) -> LogError {
        LogError {
            file: file.to_path_buf(),
            line: e.position().map_or(0, |p| p.line() as usize),
            field: None,
            what: e.to_string(),
        }
    }
}

/// Reads a plain log of one run (no `# ballpod run v2` header; e.g. exported from another
/// recorder): `#` lines are comments, then a header of columns `t_s` (required), `dl_um`
/// (required), `x_mm` `y_mm` `z_mm` `a_deg` `b_deg` `c_deg` (those of `meta`'s configured axes;
/// the pattern's plane is required), `temp_c`, `flags` (optional), any order. Samples are
/// numbered by row.
pub fn parse_plain(file: &Path, text: &str, meta: RunMeta) -> Result<RecordedRun, LogError> {
    let mut body = String::from("# ballpod run v2\n");
    // reuse the strict reader: a synthetic header with the run's metadata, seq added per row
    let mut line = csv::Line::new();
    for i in 1..csv::meta_lines() {
        if csv::meta_line(i, &meta, &mut line) {
            body.push_str(&String::from_utf8_lossy(&line));
        }
    }
    let err = |line: u64, field: Option<&str>, what: String| LogError {
        file: file.to_path_buf(),
        line: line as usize,
        field: field.map(str::to_string),
        what,
    };
    let CsvTable {
        mut reader,
        header,
        header_line,
    } = CsvTable::read(file, text)?;
    let names: Vec<&str> = header.iter().collect();
    if names.iter().all(|n| n.is_empty()) {
        return Err(err(0, None, "no samples".into()));
    }
    let plane_cols: &[&str] = match meta.pattern {
        Pattern::Circle => match meta.config.setup.circle_plane {
            ballpod::config::CirclePlane::XY => &["x_mm", "y_mm"],
            ballpod::config::CirclePlane::YZ => &["y_mm", "z_mm"],
            ballpod::config::CirclePlane::ZX => &["z_mm", "x_mm"],
        },
        Pattern::Bx | Pattern::By => &["x_mm", "z_mm"],
        Pattern::Cr | Pattern::Ca | Pattern::Cr2 => &["x_mm", "y_mm"],
        Pattern::Ssm | Pattern::Probe => &["x_mm", "y_mm", "z_mm"],
    };
    for need in ["t_s", "dl_um"] {
        if !names.contains(&need) {
            return Err(err(
                header_line,
                Some(need),
                "required column missing".into(),
            ));
        }
    }
    for need in plane_cols {
        if !names.contains(need) {
            return Err(err(
                header_line,
                Some(need),
                format!("required column missing for a {} run", meta.pattern.name()),
            ));
        }
    }
    // the synthetic text keeps every row on its input line (blank lines for comments)
    let has_flags = names.contains(&"flags");
    let mut at = 1u64;
    // blank lines up to input line `line`, which the caller then writes
    let pad_to = |body: &mut String, at: &mut u64, line: u64| {
        while *at < line {
            body.push('\n');
            *at += 1;
        }
        *at += 1;
    };
    pad_to(&mut body, &mut at, header_line);
    body.push_str("seq,");
    body.push_str(&names.join(","));
    body.push_str(if has_flags { "\n" } else { ",flags\n" });
    for (seq, record) in reader.records().enumerate() {
        let record = record.map_err(|e| CsvTable::error(file, &e))?;
        let line = record.position().map_or(at, |p| p.line());
        pad_to(&mut body, &mut at, line);
        body.push_str(&format!("{seq},"));
        body.push_str(&record.iter().collect::<Vec<_>>().join(","));
        body.push_str(if has_flags { "\n" } else { ",0\n" });
    }
    // the synthetic text has one line per input line (+1 for the version line, +config lines
    // ahead): report errors on the input's own line numbers
    let offset = csv::meta_lines();
    let mut runs = parse_runs_with(file, &body, false).map_err(|mut e| {
        e.line = e.line.saturating_sub(offset);
        e
    })?;
    runs.pop().ok_or(LogError {
        file: file.to_path_buf(),
        line: 0,
        field: None,
        what: "no samples".into(),
    })
}
