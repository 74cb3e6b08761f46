//! Sample logs (CSV, the format the pod streams over USB) and session files (JSON or TOML).
//!
//! A log: `#` metadata lines (free `key: value` text), then a header, then one line per
//! sample. Columns (comma-separated, any order):
//! - `t_s` (required): time, seconds, strictly increasing (written with 6 decimals = 1 µs);
//! - `dl_um` (required): ΔL, µm;
//! - one per configured axis: `x_mm`, `y_mm`, `z_mm` (linear), `a_deg`, `b_deg`, `c_deg`
//!   (rotary; at most two): the linear axes go to sample axes 0–2, the rotary ones to 3–4 in
//!   column order. The axes of the run's pattern plane are required;
//! - `temp_c` (optional): bar temperature, °C; `flags` (optional): the sample's validity
//!   flags as a decimal integer (`ballpod::acquisition::SampleFlags`).
//!
//! Numbers are written in the shortest form that reads back to the same `f32`, so a replay
//! sees exactly the samples the simulator's pod produced. Any fault — missing column, unknown
//! column or unit, bad number, non-monotonic time, wrong field count — rejects the whole file
//! with its name, line and field.

use std::fmt::{self, Write as _};
use std::path::{Path, PathBuf};

use ballpod::acquisition::{MAX_AXES, Sample, SampleFlags};
use ballpod::metrology::pattern::Plane;
use ballpod::session::seed002::Step;

use crate::analysis::SessionDesc;

/// A rejected log or session file.
#[derive(Clone, Debug, PartialEq)]
pub struct LogError {
    /// File.
    pub file: PathBuf,
    /// Line (1-based; 0 when the file as a whole is at fault).
    pub line: usize,
    /// Field (column name) at fault, if any.
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

/// A known column.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Col {
    T,
    Dl,
    Axis(usize),
    Temp,
    Flags,
}

/// Quantity name → (unit, column) for every known column.
const KNOWN: [(&str, &str); 10] = [
    ("t", "s"),
    ("dl", "um"),
    ("x", "mm"),
    ("y", "mm"),
    ("z", "mm"),
    ("a", "deg"),
    ("b", "deg"),
    ("c", "deg"),
    ("temp", "c"),
    ("flags", ""),
];

/// The axis columns a method's fit needs.
fn required_axes(method: &str) -> &'static [&'static str] {
    let plane = match Step::from_name(method) {
        Some(s) => {
            ballpod::session::seed002::Setup::thesis_table_4_3()
                .fit_geometry(s)
                .plane
        }
        None => Plane::XY,
    };
    match plane {
        Plane::XY => &["x_mm", "y_mm"],
        Plane::XZ => &["x_mm", "z_mm"],
        Plane::YZ => &["y_mm", "z_mm"],
    }
}

/// Writes one log.
pub fn write_log(meta: &[(&str, String)], axes: &[&str], samples: &[Sample]) -> String {
    let mut s = String::new();
    s.push_str("# ballpod sample log\n");
    for (k, v) in meta {
        let _ = writeln!(s, "# {k}: {v}");
    }
    s.push_str("t_s,dl_um");
    for a in axes {
        let _ = write!(s, ",{a}");
    }
    s.push_str(",temp_c,flags\n");
    for x in samples {
        let _ = write!(
            s,
            "{}.{:06},{}",
            x.t_us / 1_000_000,
            x.t_us % 1_000_000,
            x.delta_l_um
        );
        for v in x.axes.iter().take(axes.len()) {
            let _ = write!(s, ",{v}");
        }
        let _ = writeln!(s, ",{},{}", x.temp_c, x.flags.0);
    }
    s
}

fn parse_t_us(v: &str) -> Option<u64> {
    let (int, frac) = v.split_once('.').unwrap_or((v, ""));
    if int.is_empty() || !int.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    if frac.len() > 6 || !frac.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    let us: u64 = format!("{frac:0<6}").parse().ok()?;
    int.parse::<u64>()
        .ok()?
        .checked_mul(1_000_000)?
        .checked_add(us)
}

/// Reads one log; `method` names the run's pattern (for the required axis columns).
pub fn read_log(file: &Path, text: &str, method: &str) -> Result<Vec<Sample>, LogError> {
    let err = |line: usize, field: Option<&str>, what: String| LogError {
        file: file.to_path_buf(),
        line,
        field: field.map(str::to_string),
        what,
    };
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim_end_matches('\r')))
        .filter(|(_, l)| !l.starts_with('#') && !l.trim().is_empty());
    let (hline, header) = lines
        .next()
        .ok_or_else(|| err(0, None, "no header line".into()))?;
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let mut cols = Vec::new();
    let mut rotary = 3usize;
    for &n in &names {
        let (q, u) = n.split_once('_').unwrap_or((n, ""));
        let Some(&(_, unit)) = KNOWN.iter().find(|(kq, _)| *kq == q) else {
            return Err(err(hline, Some(n), "unknown column".into()));
        };
        if unit != u {
            return Err(err(
                hline,
                Some(n),
                format!("unknown unit {u:?} (expected {q}_{unit})"),
            ));
        }
        if names.iter().filter(|m| **m == n).count() > 1 {
            return Err(err(hline, Some(n), "column given twice".into()));
        }
        cols.push(match q {
            "t" => Col::T,
            "dl" => Col::Dl,
            "x" => Col::Axis(0),
            "y" => Col::Axis(1),
            "z" => Col::Axis(2),
            "a" | "b" | "c" => {
                if rotary >= MAX_AXES {
                    return Err(err(hline, Some(n), "more than two rotary axes".into()));
                }
                rotary += 1;
                Col::Axis(rotary - 1)
            }
            "temp" => Col::Temp,
            _ => Col::Flags,
        });
    }
    for req in ["t_s", "dl_um"].iter().chain(required_axes(method)) {
        if !names.contains(req) {
            return Err(err(hline, Some(req), "missing column".into()));
        }
    }
    let mut out = Vec::new();
    let mut last_t: Option<u64> = None;
    for (ln, l) in lines {
        let fields: Vec<&str> = l.split(',').map(str::trim).collect();
        if fields.len() != cols.len() {
            return Err(err(
                ln,
                None,
                format!("{} fields, header has {}", fields.len(), cols.len()),
            ));
        }
        let mut s = Sample {
            seq: out.len() as u32,
            temp_c: 20.0,
            ..Sample::default()
        };
        for ((c, v), name) in cols.iter().zip(&fields).zip(&names) {
            let bad = || err(ln, Some(name), format!("bad number {v:?}"));
            let f32v = || -> Result<f32, LogError> {
                v.parse::<f32>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .ok_or_else(bad)
            };
            match *c {
                Col::T => {
                    let t = parse_t_us(v).ok_or_else(bad)?;
                    if last_t.is_some_and(|p| t <= p) {
                        return Err(err(ln, Some(name), "time not increasing".into()));
                    }
                    last_t = Some(t);
                    s.t_us = t;
                }
                Col::Dl => s.delta_l_um = f32v()?,
                Col::Axis(i) => s.axes[i] = f32v()?,
                Col::Temp => s.temp_c = f32v()?,
                Col::Flags => s.flags = SampleFlags(v.parse::<u16>().map_err(|_| bad())?),
            }
        }
        out.push(s);
    }
    if out.is_empty() {
        return Err(err(hline, None, "no samples".into()));
    }
    Ok(out)
}

/// Column names of the default configuration's axes (X, Y, Z, B, C).
pub const AXIS_COLUMNS: [&str; 5] = ["x_mm", "y_mm", "z_mm", "b_deg", "c_deg"];

/// Writes every run's log and `session.json` into `dir`.
pub fn write_session(dir: &Path, desc: &SessionDesc, runs: &[Vec<Sample>]) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    for (r, samples) in desc.runs.iter().zip(runs) {
        let meta = [
            ("method", r.method.clone()),
            ("direction", r.direction.clone()),
            ("samples", samples.len().to_string()),
        ];
        let p = dir.join(&r.log);
        std::fs::write(&p, write_log(&meta, &AXIS_COLUMNS, samples))
            .map_err(|e| format!("{}: {e}", p.display()))?;
    }
    let p = dir.join("session.json");
    let text = serde_json::to_string_pretty(desc).map_err(|e| e.to_string())?;
    std::fs::write(&p, text).map_err(|e| format!("{}: {e}", p.display()))
}

/// Parses and checks a session description: TOML when `path` ends in `.toml`, JSON otherwise
/// (`path` only names the file in errors and picks the format; nothing is read). Every run must
/// have a known method and direction, and the geometry its method needs.
pub fn parse_session(path: &Path, text: &str) -> Result<SessionDesc, LogError> {
    let whole = |what: String| LogError {
        file: path.to_path_buf(),
        line: 0,
        field: None,
        what,
    };
    let desc: SessionDesc = if path.extension().is_some_and(|e| e == "toml") {
        toml::from_str(text).map_err(|e| LogError {
            line: e
                .span()
                .and_then(|s| text.get(..s.start))
                .map(|t| t.lines().count().max(1))
                .unwrap_or(0),
            ..whole(e.message().to_string())
        })?
    } else {
        serde_json::from_str(text).map_err(|e| LogError {
            line: e.line(),
            ..whole(e.to_string())
        })?
    };
    if desc.runs.is_empty() {
        return Err(whole("no runs".into()));
    }
    for (i, r) in desc.runs.iter().enumerate() {
        let bad = |what: String| LogError {
            field: Some(format!("runs[{i}]")),
            ..whole(what)
        };
        if crate::analysis::parse_direction(&r.direction).is_none() {
            return Err(bad(format!("direction {:?} (CW or CCW)", r.direction)));
        }
        if r.method != "ISO230-4" && Step::from_name(&r.method).is_none() {
            return Err(bad(format!("unknown method {:?}", r.method)));
        }
        if r.method == "ISO230-4" && desc.circle.is_none() {
            return Err(bad("ISO230-4 run without circle geometry".into()));
        }
        if r.method != "ISO230-4" && desc.seed002.is_none() {
            return Err(bad("seed 002 run without seed002 geometry".into()));
        }
    }
    Ok(desc)
}

/// Reads a session file (`.toml` or JSON) and all its logs (paths relative to it).
pub fn read_session(path: &Path) -> Result<(SessionDesc, Vec<Vec<Sample>>), LogError> {
    let text = std::fs::read_to_string(path).map_err(|e| LogError {
        file: path.to_path_buf(),
        line: 0,
        field: None,
        what: e.to_string(),
    })?;
    let desc = parse_session(path, &text)?;
    let base = path.parent().unwrap_or(Path::new("."));
    let mut runs = Vec::new();
    for r in &desc.runs {
        let p = base.join(&r.log);
        let text = std::fs::read_to_string(&p).map_err(|e| LogError {
            file: p.clone(),
            line: 0,
            field: None,
            what: e.to_string(),
        })?;
        runs.push(read_log(&p, &text, &r.method)?);
    }
    Ok((desc, runs))
}
