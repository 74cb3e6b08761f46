//! Replay's input: recorded runs in the pod's CSV text ([`crate::recording`]) given directly,
//! or a session file (TOML or JSON) that lists logs — the pod's own files or plain logs of one
//! run from elsewhere — with the set-up they need, and the inputs of the host-only methods
//! (seed 003 R-test readings, seed 004 dial-gauge readings and vertex touch-offs).
//!
//! ```toml
//! [setup]                  # configuration fields by name (config::FIELDS); they override
//! circle_radius = 150.0    # what each run recorded (a pod file records its whole set-up)
//! circle_centre_x = 0.0
//! circle_centre_y = 0.0
//!
//! [[runs]]
//! log = "ccw.csv"          # a pod file: all its runs, pattern and direction from its header
//!
//! [[runs]]
//! log = "cw_plain.csv"     # a plain log (t_s, dl_um, axes…): pattern and direction needed
//! pattern = "circle"       # any letter case
//! direction = "cw"
//!
//! [rtest]                  # seed 003 R-test (host only): rows a_deg,c_deg,dx_um,dy_um,dz_um
//! readings = "rtest.csv"
//! zero = "absolute"        # or "first_pose"
//!
//! [dial]                   # seed 004 dial gauge (host only): rows b_deg,u_mm,v_mm,reading_um
//! readings = "dial.csv"
//!
//! [vertex]                 # seed 004 axis centre (host only): rows angle_deg,u_mm,v_mm
//! readings = "vertex.csv"
//! axis = [0.0, 0.0, 1.0]
//!
//! [vector]                 # seed 001 vector diagonal method (host only, crate::diagonals)
//! readings = "vector.csv"  # rows diagonal,axis,deviation_um: each diagonal's stops in order
//! step_mm = [40.0, 30.0, 20.0]
//! tables = ["siemens_840d", "grid"]
//!
//! [body_diagonals]         # seed 001 body diagonals (host only): rows diagonal,position_mm,deviation_um
//! readings = "body.csv"
//! ```
//!
//! Only the keys a method needs are required. A fault names the file, line and field.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use ballpod::app::{Direction, Pattern, RunMeta};
use ballpod::config::Config;

use crate::recording::{LogError, RecordedRun, excerpt, parse_plain, parse_runs, pattern_names};
use crate::replay::{Figure, Share};

/// A value of the `[setup]` table: a number or a code's name.
#[derive(Clone, Debug, PartialEq, Deserialize, serde::Serialize)]
#[serde(untagged)]
pub enum SetupValue {
    /// A number in the field's unit.
    Number(f64),
    /// A code's name (`circle_plane = "ZX"`).
    Text(String),
}

/// One `[[runs]]` entry.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunEntry {
    /// The file, relative to the session file.
    pub log: String,
    /// Pattern (required for a plain log).
    #[serde(default)]
    pub pattern: Option<String>,
    /// Direction (required for a plain log of a circular pattern).
    #[serde(default)]
    pub direction: Option<String>,
}

/// `[rtest]`: the seed 003 R-test (host only).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RtestEntry {
    /// Readings file: `a_deg,c_deg,dx_um,dy_um,dz_um` (ball-centre displacement, probe − ball).
    pub readings: String,
    /// Ball centre in the c frame X, Y, Z and the c-frame origin X, Y, Z from the A axis, mm
    /// (default: seed 003 Table 3).
    #[serde(default)]
    pub geometry_mm: Option<[f64; 6]>,
    /// `absolute` (default) or `first_pose`.
    #[serde(default)]
    pub zero: Option<String>,
    /// The head's calibration: relative standard uncertainty of each axis's reading scale, ppm
    /// (default `crate::methods::rtest::U_READING_SCALE`, 5000 ppm).
    #[serde(default)]
    pub u_reading_scale_ppm: Option<f64>,
}

/// `[dial]`: the seed 004 dial-gauge centreline (host only).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DialEntry {
    /// Readings file: `b_deg,u_mm,v_mm,reading_um`.
    pub readings: String,
    /// Nominal axis direction (default +Y).
    #[serde(default)]
    pub axis: Option<[f64; 3]>,
    /// Gauge reading direction at angle 0 (default +Z; turned with the axis for the others).
    #[serde(default)]
    pub reading_dir: Option<[f64; 3]>,
    /// `primed` (default, seed 004's table axis) or `right_handed`.
    #[serde(default)]
    pub sense: Option<String>,
    /// The gauge's calibration: its scale's relative standard uncertainty, ppm (default
    /// `crate::methods::centreline::U_GAUGE_SCALE`, 10 000 ppm).
    #[serde(default)]
    pub u_gauge_scale_ppm: Option<f64>,
}

/// `[vertex]`: the seed 004 axis centre from one block vertex (host only).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VertexEntry {
    /// Readings file: `angle_deg,u_mm,v_mm`, the vertex's in-plane machine coordinates at
    /// each commanded angle ((Y, Z) about X, (X, Z) about Y, (X, Y) about Z).
    pub readings: String,
    /// Nominal axis direction, a machine axis: `[1, 0, 0]`, `[0, 1, 0]` (default) or
    /// `[0, 0, 1]` (as `[dial]`'s).
    #[serde(default)]
    pub axis: Option<[f64; 3]>,
    /// `primed` (default, seed 004's table axes) or `right_handed`.
    #[serde(default)]
    pub sense: Option<String>,
    /// One touched coordinate's repeatability, µm (default
    /// `crate::methods::centreline::U_TOUCH_UM`).
    #[serde(default)]
    pub u_touch_um: Option<f64>,
    /// The touch-off's offset (reference tool and block), µm (default
    /// `crate::methods::centreline::U_TOUCH_OFFSET_UM`).
    #[serde(default)]
    pub u_touch_offset_um: Option<f64>,
}

/// A session file.
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SessionFile {
    /// Configuration overrides by field name.
    #[serde(default)]
    pub setup: BTreeMap<String, SetupValue>,
    /// The logs.
    #[serde(default)]
    pub runs: Vec<RunEntry>,
    /// The seed 003 R-test.
    #[serde(default)]
    pub rtest: Option<RtestEntry>,
    /// The seed 004 dial gauge.
    #[serde(default)]
    pub dial: Option<DialEntry>,
    /// The seed 004 axis centre from a vertex.
    #[serde(default)]
    pub vertex: Option<VertexEntry>,
    /// The seed 001 vector (sequential-step) diagonal method.
    #[serde(default)]
    pub vector: Option<crate::diagonals::VectorEntry>,
    /// The seed 001 body-diagonal measurement.
    #[serde(default)]
    pub body_diagonals: Option<crate::diagonals::BodyDiagonalsEntry>,
    /// The machine's travel (read by `ncgen`, which refuses a program beyond it).
    #[serde(default)]
    pub travel: Option<crate::ncgen::Travel>,
}

impl SessionFile {
    /// True when the file names nothing to replay.
    fn is_empty(&self) -> bool {
        self.runs.is_empty()
            && self.rtest.is_none()
            && self.dial.is_none()
            && self.vertex.is_none()
            && self.vector.is_none()
            && self.body_diagonals.is_none()
    }
}

fn whole(file: &Path, what: String) -> LogError {
    LogError {
        file: file.to_path_buf(),
        line: 0,
        field: None,
        what,
    }
}

/// Reads a text file; bytes that are not UTF-8 are an error with line and column.
pub fn read_text(file: &Path) -> Result<String, LogError> {
    let bytes = std::fs::read(file).map_err(|e| whole(file, e.to_string()))?;
    utf8(file, bytes)
}

/// `bytes` of `file` as text; bytes that are not UTF-8 are an error with line and column.
fn utf8(file: &Path, bytes: Vec<u8>) -> Result<String, LogError> {
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let before = &e.as_bytes()[..at];
        let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
        let col = at
            - before
                .iter()
                .rposition(|&b| b == b'\n')
                .map_or(0, |p| p + 1)
            + 1;
        LogError {
            line,
            what: format!("column {col}: not UTF-8 text"),
            ..whole(file, String::new())
        }
    })
}

/// Reads a pod recording — a `DATA:LOG?` download or a recorded stream port, whose sample
/// records ([`ballpod::protocol::stream`]) become the log's text rows — as text.
pub fn read_recording(file: &Path) -> Result<String, LogError> {
    let bytes = std::fs::read(file).map_err(|e| whole(file, e.to_string()))?;
    if !bytes.contains(&ballpod::protocol::stream::RECORD_TAG) {
        return utf8(file, bytes);
    }
    let mut text = Vec::with_capacity(bytes.len() * 2);
    let decoded = ballpod::protocol::stream::decode(&bytes, |l| text.extend_from_slice(l));
    if let Err(e) = decoded {
        use ballpod::protocol::stream::DecodeError;
        let (offset, what) = match e {
            DecodeError::BadRecord { offset } => (offset, "not a sample record (more than 5 axes)"),
            DecodeError::Cut { offset } => (offset, "the recording ends inside a sample record"),
        };
        return Err(LogError {
            // the line the record's row would have been in the text
            line: text.iter().filter(|&&b| b == b'\n').count() + 1,
            what: format!("byte {offset}: {what}"),
            ..whole(file, String::new())
        });
    }
    utf8(file, text)
}

/// Parses a session file: TOML when `path` ends in `.toml`, JSON otherwise (`path` only names
/// the file in errors and picks the format; nothing is read).
pub fn parse_session(path: &Path, text: &str) -> Result<SessionFile, LogError> {
    let s = deserialize(path, text)?;
    if s.is_empty() {
        return Err(whole(
            path,
            "nothing to replay: no runs, no [rtest], [dial], [vertex], [vector] or [body_diagonals]".into(),
        ));
    }
    check_runs(path, text, &s)?;
    // every `[setup]` value against the pod's configuration, with its line (applied to each
    // run later, where the text is no longer at hand)
    apply_setup(path, &s.setup, &mut Config::default()).map_err(|mut e| {
        if let Some(key) = e.field.as_deref().and_then(|f| f.strip_prefix("setup.")) {
            e.line = line_of_key(text, key);
        }
        e
    })?;
    Ok(s)
}

/// The line (1-based) where `key` is given a value in a session file's text (TOML `key =`,
/// JSON `"key":`), 0 if none is found.
fn line_of_key(text: &str, key: &str) -> usize {
    let json = format!("\"{key}\"");
    text.lines()
        .position(|l| {
            let l = l.trim_start();
            l.strip_prefix(key)
                .or_else(|| l.strip_prefix(json.as_str()))
                .is_some_and(|rest| {
                    let rest = rest.trim_start();
                    rest.starts_with('=') || rest.starts_with(':')
                })
        })
        .map_or(0, |k| k + 1)
}

/// The configuration a set-up file gives (`ncgen`): the defaults with its `[setup]` applied. A
/// session file serves as it is; its runs and host-only tables are not read.
pub fn setup_config(path: &Path, text: &str) -> Result<Config, LogError> {
    let s = deserialize(path, text)?;
    let mut c = Config::default();
    apply_setup(path, &s.setup, &mut c)?;
    Ok(c)
}

/// The machine's travel a set-up file gives (`[travel]`, for `ncgen`), if any.
pub fn setup_travel(path: &Path, text: &str) -> Result<Option<crate::ncgen::Travel>, LogError> {
    Ok(deserialize(path, text)?.travel)
}

/// A session file's structure, TOML or JSON by the file's extension.
fn deserialize(path: &Path, text: &str) -> Result<SessionFile, LogError> {
    Ok(if path.extension().is_some_and(|e| e == "toml") {
        toml::from_str(text).map_err(|e| LogError {
            line: e
                .span()
                .and_then(|s| text.get(..s.start))
                .map(|t| t.matches('\n').count() + 1)
                .unwrap_or(0),
            ..whole(path, e.message().to_string())
        })?
    } else {
        serde_json::from_str(text).map_err(|e| LogError {
            line: e.line(),
            ..whole(path, e.to_string())
        })?
    })
}

/// Each run's pattern and direction name one the pod knows.
fn check_runs(path: &Path, text: &str, s: &SessionFile) -> Result<(), LogError> {
    for (i, r) in s.runs.iter().enumerate() {
        let bad = |key: &str, value: &str, what: String| LogError {
            field: Some(format!("runs[{i}].{key}")),
            line: line_of(text, key, value),
            ..whole(path, what)
        };
        if let Some(p) = &r.pattern
            && Pattern::from_name(p.as_bytes()).is_none()
        {
            let what = format!(
                "unknown pattern {} (known: {})",
                excerpt(p),
                pattern_names()
            );
            return Err(bad("pattern", p, what));
        }
        if let Some(d) = &r.direction
            && Direction::from_name(d.as_bytes()).is_none()
        {
            return Err(bad(
                "direction",
                d,
                format!("direction {} (CW or CCW)", excerpt(d)),
            ));
        }
    }
    Ok(())
}

/// The line (1-based) of the first `key` … `"value"` pair in a session file's text, 0 if none
/// is found (the parsers give positions of syntax errors only, not of values they accepted).
fn line_of(text: &str, key: &str, value: &str) -> usize {
    let quoted = format!("\"{value}\"");
    text.lines()
        .position(|l| l.contains(key) && l.contains(&quoted))
        .map_or(0, |k| k + 1)
}

/// Applies the `[setup]` overrides to a configuration.
fn apply_setup(
    path: &Path,
    setup: &BTreeMap<String, SetupValue>,
    c: &mut Config,
) -> Result<(), LogError> {
    for (k, v) in setup {
        let bad = |what: String| LogError {
            field: Some(format!("setup.{k}")),
            ..whole(path, what)
        };
        let f = Config::field_by_name(k).ok_or(bad("unknown configuration field".into()))?;
        let info = Config::field_info(f).ok_or(bad("unknown configuration field".into()))?;
        let x = match v {
            SetupValue::Number(x) => *x,
            SetupValue::Text(t) if info.choices().is_empty() => {
                return Err(bad(format!(
                    "{} is not a number: the field takes a number ({})",
                    excerpt(t),
                    info.unit.as_str()
                )));
            }
            SetupValue::Text(t) => f64::from(info.choice(t.as_bytes()).ok_or(bad(format!(
                "{} is not one of {}",
                excerpt(t),
                info.choices().join(", ")
            )))?),
        };
        c.set(f, x).map_err(|e| bad(format!("refused: {e:?}")))?;
    }
    Ok(())
}

/// The runs a session file lists (paths relative to it), in order, each with its file name.
pub fn read_runs(path: &Path, s: &SessionFile) -> Result<Vec<(String, RecordedRun)>, LogError> {
    let base = path.parent().unwrap_or(Path::new("."));
    let mut out = Vec::new();
    for (i, entry) in s.runs.iter().enumerate() {
        let file = base.join(&entry.log);
        let text = read_recording(&file)?;
        let pattern = entry
            .pattern
            .as_ref()
            .and_then(|p| Pattern::from_name(p.as_bytes()));
        let direction = entry
            .direction
            .as_ref()
            .and_then(|d| Direction::from_name(d.as_bytes()));
        // a saved `DATA:LOG?` download keeps its block header (`#<n><length>`) before the run
        let body = crate::recording::strip_block_header(&file, &text)?;
        let runs = if body.trim_start().starts_with("# ballpod run v") {
            let mut runs = parse_runs(&file, &text)?;
            for r in &mut runs {
                let disagree = |what: &str, rec: &str| LogError {
                    field: Some(format!("runs[{i}].{what}")),
                    ..whole(path, format!("the log recorded {rec}"))
                };
                if pattern.is_some_and(|p| p != r.meta.pattern) {
                    return Err(disagree("pattern", r.meta.pattern.name()));
                }
                if direction.is_some_and(|d| d != r.meta.direction) {
                    return Err(disagree("direction", r.meta.direction.name()));
                }
                apply_setup(path, &s.setup, &mut r.meta.config)?;
            }
            runs
        } else {
            let missing = |what: &str| LogError {
                field: Some(format!("runs[{i}].{what}")),
                ..whole(path, format!("a plain log needs its {what}"))
            };
            let pattern = pattern.ok_or(missing("pattern"))?;
            let direction = match direction {
                Some(d) => d,
                None if pattern.has_direction() => return Err(missing("direction")),
                None => Direction::Ccw,
            };
            let mut config = Config::default();
            apply_setup(path, &s.setup, &mut config)?;
            let meta = RunMeta {
                run: i as u32 + 1,
                pattern,
                direction,
                config,
            };
            vec![parse_plain(&file, &text, meta)?]
        };
        let n = runs.len();
        for (k, r) in runs.into_iter().enumerate() {
            let name = if n == 1 {
                entry.log.clone()
            } else {
                format!("{}#{}", entry.log, k + 1)
            };
            out.push((name, r));
        }
    }
    Ok(out)
}

/// A readings file of the host-only methods: comma-separated numbers under a header with the
/// columns `names` (any order, more columns allowed, `#` comments), read with the `csv` crate.
fn read_table(file: &Path, names: &[&str]) -> Result<Vec<Vec<f64>>, LogError> {
    let text = read_text(file)?;
    let err = |line: u64, field: Option<String>, what: String| LogError {
        file: file.to_path_buf(),
        line: line as usize,
        field,
        what,
    };
    let crate::recording::CsvTable {
        mut reader,
        header,
        header_line,
    } = crate::recording::CsvTable::read(file, &text)?;
    let cols = names
        .iter()
        .map(|n| {
            header.iter().position(|f| f == *n).ok_or_else(|| {
                err(
                    header_line,
                    Some((*n).into()),
                    "required column missing".into(),
                )
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let mut rows = Vec::new();
    for record in reader.records() {
        let record = record.map_err(|e| crate::recording::CsvTable::error(file, &e))?;
        let line = record.position().map_or(0, |p| p.line());
        let row = cols
            .iter()
            .zip(names)
            .map(|(&i, n)| {
                let v = record.get(i).unwrap_or("");
                v.parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| {
                        err(
                            line,
                            Some((*n).into()),
                            format!("bad number {}", excerpt(v)),
                        )
                    })
            })
            .collect::<Result<Vec<_>, _>>()?;
        rows.push(row);
    }
    if rows.is_empty() {
        return Err(whole(file, "no readings".into()));
    }
    Ok(rows)
}

/// A relative standard uncertainty given in ppm as `field` (µ = 1e-6; `default` when absent),
/// refused with the field named when negative or not finite.
fn relative_u(path: &Path, field: &str, ppm: Option<f64>, default: f64) -> Result<f64, LogError> {
    match ppm {
        None => Ok(default),
        Some(v) if v.is_finite() && v >= 0.0 => Ok(v * 1e-6),
        Some(v) => Err(LogError {
            field: Some(field.into()),
            ..whole(path, format!("{v} (a standard uncertainty: finite, ≥ 0)"))
        }),
    }
}

/// A host figure's shares (name, standard uncertainty in the figure's unit), largest first.
fn shares(parts: &[(&str, f64)]) -> Vec<Share> {
    let mut s: Vec<Share> = parts
        .iter()
        .map(|&(name, u)| Share {
            name: name.into(),
            u: u as f32,
        })
        .collect();
    s.sort_by(|a, b| b.u.total_cmp(&a.u));
    s
}

/// The seed 003 R-test of `[rtest]`: the 11 location and ball errors, and the covariance of
/// the ones reported.
pub fn rtest(
    path: &Path,
    e: &RtestEntry,
) -> Result<(Vec<Figure>, crate::replay::DeviationCovariance), LogError> {
    use crate::methods::rtest::{
        ReadingZero, RtestConfig, RtestGeometry, RtestParam, RtestSample, U_READING_SCALE, identify,
    };
    let file = path.parent().unwrap_or(Path::new(".")).join(&e.readings);
    let rows = read_table(&file, &["a_deg", "c_deg", "dx_um", "dy_um", "dz_um"])?;
    let samples: Vec<RtestSample> = rows
        .iter()
        .map(|r| RtestSample {
            a_deg: r[0],
            c_deg: r[1],
            reading_um: [r[2], r[3], r[4]],
        })
        .collect();
    let geometry = e
        .geometry_mm
        .map_or(RtestGeometry::SEED003_TABLE3, RtestGeometry::from_array);
    let zero = match e.zero.as_deref() {
        None | Some("absolute") => ReadingZero::Absolute,
        Some("first_pose") => ReadingZero::FirstPose,
        Some(z) => {
            return Err(LogError {
                field: Some("rtest.zero".into()),
                ..whole(path, format!("{} (absolute or first_pose)", excerpt(z)))
            });
        }
    };
    let u_reading_scale = relative_u(
        path,
        "rtest.u_reading_scale_ppm",
        e.u_reading_scale_ppm,
        U_READING_SCALE,
    )?;
    let cfg = RtestConfig {
        zero,
        u_reading_scale,
        ..RtestConfig::default()
    };
    let r = identify(&geometry, &samples, &cfg)
        .map_err(|x| whole(&file, format!("R-test identification: {x:?}")))?;
    let (v, u) = (r.errors.to_array(), r.std_uncertainty.to_array());
    let (type_a, scale) = (r.u_type_a.to_array(), r.u_reading_scale.to_array());
    // a parameter the path does not determine (fixed, or only in a combination with fixed
    // ones) is NaN: not reported, like an invalid result
    let reported: Vec<RtestParam> = RtestParam::ALL
        .into_iter()
        .filter(|p| v[p.index()].is_finite())
        .collect();
    let unit = |p: &RtestParam| if p.is_angular() { "arcsec" } else { "um" };
    let figures = reported
        .iter()
        .map(|p| {
            let j = p.index();
            Figure {
                name: format!("rtest_{}", p.name()),
                value: v[j] as f32,
                u: Some(u[j] as f32),
                dof: None,
                unit: unit(p).into(),
                contributors: shares(&[("type_a", type_a[j]), ("head_scale", scale[j])]),
            }
        })
        .collect();
    let covariance = crate::replay::DeviationCovariance {
        names: reported
            .iter()
            .map(|p| format!("rtest_{}", p.name()))
            .collect(),
        units: reported.iter().map(|p| unit(p).to_string()).collect(),
        matrix: reported
            .iter()
            .map(|p| {
                reported
                    .iter()
                    .map(|q| r.covariance[p.index()][q.index()])
                    .collect()
            })
            .collect(),
    };
    Ok((figures, covariance))
}

/// A seed 004 table's `sense`: `primed` (default, seed 004's table axes) or `right_handed`.
fn rotation_sense(
    path: &Path,
    field: &str,
    sense: Option<&str>,
) -> Result<crate::methods::centreline::RotationSense, LogError> {
    use crate::methods::centreline::RotationSense;
    match sense {
        None | Some("primed") => Ok(RotationSense::Primed),
        Some("right_handed") => Ok(RotationSense::RightHanded),
        Some(s) => Err(LogError {
            field: Some(field.into()),
            ..whole(path, format!("{} (primed or right_handed)", excerpt(s)))
        }),
    }
}

/// The seed 004 dial-gauge axis direction of `[dial]`: the tilts of the axis.
pub fn dial(path: &Path, e: &DialEntry) -> Result<Vec<Figure>, LogError> {
    use crate::methods::centreline::{
        DialPoint, GaugeFrame, NormalAtAngle, RotationSense, U_GAUGE_SCALE, axis_direction_lsq,
        plane_normal,
    };
    let file = path.parent().unwrap_or(Path::new(".")).join(&e.readings);
    let rows = read_table(&file, &["b_deg", "u_mm", "v_mm", "reading_um"])?;
    let axis = e.axis.unwrap_or([0.0, 1.0, 0.0]);
    let w0 = e.reading_dir.unwrap_or([0.0, 0.0, 1.0]);
    let sense = rotation_sense(path, "dial.sense", e.sense.as_deref())?;
    use crate::forward_seed004 as fw;
    let mut angles: Vec<f64> = rows.iter().map(|r| r[0]).collect();
    angles.dedup();
    let mut positions = Vec::new();
    for b in angles {
        let pts: Vec<DialPoint> = rows
            .iter()
            .filter(|r| r[0] == b)
            .map(|r| DialPoint {
                u_mm: r[1],
                v_mm: r[2],
                reading_um: r[3],
            })
            .collect();
        // the gauge reads the face as the table turned it: by −b for a commanded +b on a
        // primed axis (seed 004), by +b on a right-handed one
        let turn = match sense {
            RotationSense::Primed => -b,
            RotationSense::RightHanded => b,
        };
        let w = fw::normalize(fw::mul(fw::rodrigues(axis, turn.to_radians()), w0));
        let u = fw::normalize(fw::sub(axis, fw::scale(fw::dot(axis, w), w)));
        let g = GaugeFrame {
            lateral_u: u,
            lateral_v: fw::cross(w, u),
            reading_dir: w,
        };
        let pn =
            plane_normal(&pts, &g).map_err(|x| whole(&file, format!("face at {b}°: {x:?}")))?;
        positions.push(NormalAtAngle {
            commanded_deg: b,
            normal: pn.normal,
        });
    }
    let u_scale = relative_u(
        path,
        "dial.u_gauge_scale_ppm",
        e.u_gauge_scale_ppm,
        U_GAUGE_SCALE,
    )?;
    let est = axis_direction_lsq(&positions, sense, axis)
        .map_err(|x| whole(&file, format!("axis direction: {x:?}")))?;
    let gauge = est
        .gauge_scale_share_urad(axis, u_scale)
        .map_err(|x| whole(&file, format!("axis direction: {x:?}")))?;
    // the tilt components (p, q) of the nominal axis: X and −Z for the default +Y
    let figure = |name: &str, value: f64, k: usize| {
        let type_a = est.tilt_uncertainty_urad[k];
        Figure {
            name: name.into(),
            value: (value * 1e6) as f32,
            u: Some(type_a.hypot(gauge[k]) as f32),
            dof: crate::gum::effective_dof(&[
                (type_a * type_a, est.tilt_degrees_of_freedom),
                (gauge[k] * gauge[k], None),
            ])
            .map(|nu| nu as u32),
            unit: "urad".into(),
            contributors: shares(&[("type_a", type_a), ("gauge_scale", gauge[k])]),
        }
    };
    Ok(vec![
        figure("dial_tilt_x", est.direction[0], 0),
        figure("dial_tilt_z", est.direction[2], 1),
    ])
}

/// The seed 004 axis centre of `[vertex]`: one block vertex touched off at each axis
/// position (`crate::methods::centreline::axis_centre_budget`).
pub fn vertex(path: &Path, e: &VertexEntry) -> Result<Vec<Figure>, LogError> {
    use crate::methods::centreline::{
        NominalAxis, PointAtAngle, TouchUncertainty, U_TOUCH_OFFSET_UM, U_TOUCH_UM,
        axis_centre_budget,
    };
    let file = path.parent().unwrap_or(Path::new(".")).join(&e.readings);
    let rows = read_table(&file, &["angle_deg", "u_mm", "v_mm"])?;
    let bad = |field: &str, what: String| LogError {
        field: Some(field.into()),
        ..whole(path, what)
    };
    // the in-plane coordinates' letters in the order of `NominalAxis`
    let (axis, letters) = match e.axis {
        Some([1.0, 0.0, 0.0]) => (NominalAxis::X, ["y", "z"]),
        None | Some([0.0, 1.0, 0.0]) => (NominalAxis::Y, ["x", "z"]),
        Some([0.0, 0.0, 1.0]) => (NominalAxis::Z, ["x", "y"]),
        Some(v) => {
            return Err(bad(
                "vertex.axis",
                format!("{v:?} (a machine axis: [1, 0, 0], [0, 1, 0] or [0, 0, 1])"),
            ));
        }
    };
    let sense = rotation_sense(path, "vertex.sense", e.sense.as_deref())?;
    let mut touch = TouchUncertainty::default();
    for (slot, value, field, default) in [
        (
            &mut touch.repeatability_um,
            e.u_touch_um,
            "vertex.u_touch_um",
            U_TOUCH_UM,
        ),
        (
            &mut touch.offset_um,
            e.u_touch_offset_um,
            "vertex.u_touch_offset_um",
            U_TOUCH_OFFSET_UM,
        ),
    ] {
        *slot = match value {
            None => default,
            Some(v) if v.is_finite() && v >= 0.0 => v,
            Some(v) => {
                return Err(bad(
                    field,
                    format!("{v} (a standard uncertainty: finite, ≥ 0)"),
                ));
            }
        };
    }
    let positions: Vec<PointAtAngle> = rows
        .iter()
        .map(|r| PointAtAngle {
            commanded_deg: r[0],
            point_mm: [r[1], r[2]],
        })
        .collect();
    let b = axis_centre_budget(&positions, axis, sense, touch)
        .map_err(|x| whole(&file, format!("axis centre: {x:?}")))?;
    let random = if b.random_is_type_a {
        "type_a"
    } else {
        "touch"
    };
    Ok((0..2)
        .map(|k| Figure {
            name: format!("vertex_centre_{}", letters[k]),
            value: (b.centre.centre_mm[k] * 1e3) as f32,
            // not evaluated (positions not quarter turns apart): null, not a number
            u: b.u_um[k].is_finite().then_some(b.u_um[k] as f32),
            dof: b.degrees_of_freedom[k],
            unit: "um".into(),
            contributors: shares(&[(random, b.random_um[k]), ("touch_offset", b.offset_um[k])]),
        })
        .collect())
}

/// What replay reads.
#[derive(Clone, Debug, Default)]
pub struct Inputs {
    /// The runs, each with the name of its source.
    pub runs: Vec<(String, RecordedRun)>,
    /// The host-only methods' figures.
    pub host: Vec<Figure>,
    /// The covariance of the R-test's figures, when `[rtest]` was replayed.
    pub rtest_covariance: Option<crate::replay::DeviationCovariance>,
    /// Files the host-only methods write (name, text): seed 001 curves and tables.
    pub files: Vec<(String, String)>,
}

/// What replay reads: the files it was given (pod files, or one session file).
pub fn read_inputs(files: &[PathBuf]) -> Result<Inputs, LogError> {
    let mut inputs = Inputs::default();
    let Inputs {
        runs,
        host,
        rtest_covariance,
        files: out,
    } = &mut inputs;
    for f in files {
        let is_session = f.extension().is_some_and(|e| e == "toml" || e == "json");
        if is_session {
            let s = parse_session(f, &read_text(f)?)?;
            runs.extend(read_runs(f, &s)?);
            if let Some(r) = &s.rtest {
                let (figures, covariance) = rtest(f, r)?;
                host.extend(figures);
                *rtest_covariance = Some(covariance);
            }
            if let Some(d) = &s.dial {
                host.extend(dial(f, d)?);
            }
            if let Some(v) = &s.vertex {
                host.extend(vertex(f, v)?);
            }
            for o in [
                s.vector.as_ref().map(|v| crate::diagonals::vector(f, v)),
                s.body_diagonals
                    .as_ref()
                    .map(|b| crate::diagonals::body_diagonals(f, b)),
            ]
            .into_iter()
            .flatten()
            {
                let o = o?;
                host.extend(o.figures);
                out.extend(o.files);
            }
        } else {
            let text = read_recording(f)?;
            let name = f
                .file_name()
                .map_or(String::new(), |n| n.to_string_lossy().into_owned());
            let rs = parse_runs(f, &text)?;
            let n = rs.len();
            for (k, r) in rs.into_iter().enumerate() {
                runs.push((
                    if n == 1 {
                        name.clone()
                    } else {
                        format!("{name}#{}", k + 1)
                    },
                    r,
                ));
            }
        }
    }
    Ok(inputs)
}
