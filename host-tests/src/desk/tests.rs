//! The test templates: what each writes to the pod, how it runs it, and what it keeps: the
//! ISO 230-4 circular test as a pair of runs (CCW, then CW) in one plane, the seed 002
//! ball-bar procedure (ten runs), a single-socket-method run and the seed 002 chapter 5
//! touch-probe procedure (eight spheres, two styli).

use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

use ballpod::protocol::scpi::RESPONSE_DECIMALS;
use ballpod::protocol::scpi::number::{SCPI_NAN, Text, push_fixed};
use ballpod::protocol::stream::{DecodeError, decode};

use std::collections::BTreeMap;

use ballpod::app::{Direction, Pattern};
use ballpod::config::{CirclePlane, Config, ConfigError, RunTrigger};

use super::pod::Pod;
use super::store::RunRow;
use super::{Desk, lock};
use crate::ncgen::{CircleOptions, CircleRun, Dialect, PatternTest};
use crate::replay::{Figure, Report, replay};
use crate::session_file::SetupValue;

/// The pod's status word bit: the last run's results are all there (`STAT:POD?`).
const RESULTS_READY: u32 = 1 << 10;
/// Longest a run may take before the desk gives up on it (a 150 mm circle at F100 is 9.4 min).
const RUN_TIMEOUT: Duration = Duration::from_secs(900);

/// How a run's live trace is drawn: its angle from two axis columns about a centre (a circle
/// in a plane) or from a rotary axis's column (the seed 002 steps' B arcs and C circles).
#[derive(Clone, Debug, PartialEq)]
pub enum TraceAxes {
    /// The angle of (u, v) about the centre.
    Plane {
        /// Column of the plane's first axis (`x_mm`).
        u: &'static str,
        /// Column of the second (`y_mm`).
        v: &'static str,
        /// The centre in those columns, mm.
        centre_mm: [f64; 2],
    },
    /// The angle is this column's value, degrees (`b_deg`, `c_deg`).
    Rotary(&'static str),
    /// A touch-probe run: no trace, the touches counted.
    Touches,
}

/// A test template: its runs (pattern, direction, in order) and the set-up it writes, its
/// defaults overridden by the request's.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Template {
    /// ISO 230-4 circular test: CCW, then CW, in one plane (circle_plane), radius
    /// circle_radius (bar_length set to it), feed circle_feed; started by the desk, or with
    /// run_trigger FEED_IN by the part program's feed-in (circle_arc 360° by default).
    Circle,
    /// The seed 002 ball-bar procedure (B/C axes): BX, BY, CR, CA, CR2, each CW then CCW, with
    /// the thesis Table 4.3 set-up fields `s002_*` (no defaults: the pod names the first it
    /// lacks; bar_length set to s002_l_b).
    Seed002,
    /// A single-socket-method run (seed 000): the spindle's ball dwells at stations on the
    /// bar's sphere about the socket (`ssm_socket_*`, no defaults: the pod names the first it
    /// lacks); E, the tool point's position error.
    Ssm,
    /// The seed 002 chapter 5 touch-probe procedure: eight PROBE runs — the sphere on the C
    /// table at C = 0/90/180/270° (B = 0), then on the C centreline at B = 0°, 90° with the
    /// first stylus (the set-up's `probe_length`) and again with the second
    /// ([`TestRequest::second_probe_length`], written as `probe_length` before run 7); the C
    /// axis's and the B axis's deviations. The identification's fields (`s002_origin_*`,
    /// `s002_z_c`) have no defaults: the pod names the first it lacks in its note.
    Probe,
}

impl Template {
    /// Every template.
    pub const ALL: [Self; 4] = [Self::Circle, Self::Seed002, Self::Ssm, Self::Probe];

    /// The runs, in order.
    pub fn runs(self) -> &'static [(&'static str, &'static str)] {
        match self {
            Self::Circle => &[("CIRCLE", "CCW"), ("CIRCLE", "CW")],
            Self::Seed002 => &[
                ("BX", "CW"),
                ("BX", "CCW"),
                ("BY", "CW"),
                ("BY", "CCW"),
                ("CR", "CW"),
                ("CR", "CCW"),
                ("CA", "CW"),
                ("CA", "CCW"),
                ("CR2", "CW"),
                ("CR2", "CCW"),
            ],
            Self::Ssm => &[("SSM", "CCW")],
            Self::Probe => &[("PROBE", "CCW"); 8],
        }
    }

    /// The set-up written when the request does not give a field.
    fn defaults(self) -> Vec<(&'static str, SetupValue)> {
        match self {
            Self::Circle => vec![
                ("circle_plane", SetupValue::Text("XY".into())),
                ("circle_centre_x", SetupValue::Number(0.0)),
                ("circle_centre_y", SetupValue::Number(0.0)),
                ("circle_centre_z", SetupValue::Number(0.0)),
                ("circle_radius", SetupValue::Number(150.0)),
                ("circle_feed", SetupValue::Number(1000.0)),
                // a FEED_IN run's data arc: one turn, the part program's overshoot left out (an
                // arc "until the feed-out" weighs the overshoot's 45° twice in the fit)
                ("circle_arc", SetupValue::Number(360.0)),
            ],
            Self::Seed002 | Self::Ssm | Self::Probe => Vec::new(),
        }
    }

    /// The field `bar_length` follows unless the request sets it (an SSM run's bar keeps its
    /// own).
    fn bar_length_from(self) -> Option<&'static str> {
        match self {
            Self::Circle => Some("circle_radius"),
            Self::Seed002 => Some("s002_l_b"),
            Self::Ssm | Self::Probe => None,
        }
    }

    /// How a run of `pattern` is drawn, with this configuration.
    pub fn trace(self, pattern: &str, c: &Config) -> TraceAxes {
        match (self, pattern) {
            (Self::Seed002, "BX" | "BY") => TraceAxes::Rotary("b_deg"),
            (Self::Seed002, _) => TraceAxes::Rotary("c_deg"),
            (Self::Probe, _) => TraceAxes::Touches,
            // the stations' directions about the socket, seen from above
            (Self::Ssm, _) => TraceAxes::Plane {
                u: "x_mm",
                v: "y_mm",
                centre_mm: [
                    f64::from(c.setup.ssm_socket_mm[0]),
                    f64::from(c.setup.ssm_socket_mm[1]),
                ],
            },
            (Self::Circle, _) => {
                let t = &c.setup;
                let [x, y, z] = t.circle_centre_mm.map(f64::from);
                match t.circle_plane {
                    CirclePlane::XY => TraceAxes::Plane {
                        u: "x_mm",
                        v: "y_mm",
                        centre_mm: [x, y],
                    },
                    CirclePlane::YZ => TraceAxes::Plane {
                        u: "y_mm",
                        v: "z_mm",
                        centre_mm: [y, z],
                    },
                    CirclePlane::ZX => TraceAxes::Plane {
                        u: "z_mm",
                        v: "x_mm",
                        centre_mm: [z, x],
                    },
                }
            }
        }
    }
}

/// A request for a test.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TestRequest {
    /// The machine (its id).
    pub machine_id: i64,
    /// Who runs it.
    pub operator: String,
    /// The template.
    pub test: Template,
    /// Configuration fields by the pod's names (numbers in the field's unit, codes by name):
    /// the template's defaults overridden.
    #[serde(default)]
    pub setup: BTreeMap<String, SetupValue>,
    /// The probe template's second stylus: its tool length R′_B, mm, written as
    /// `probe_length` before run 7 (the first stylus's is the set-up's `probe_length`).
    #[serde(default)]
    pub second_probe_length: Option<f64>,
}

/// The run (0-based) before which the probe template changes to the second stylus.
const SECOND_STYLUS_RUN: usize = 6;

/// Why the core's configuration refuses a value, in words.
fn refusal(name: &str, e: ConfigError) -> String {
    match e {
        ConfigError::OutOfRange {
            value, min, max, ..
        } => {
            format!("set-up {name} = {value} is outside {min} … {max}")
        }
        ConfigError::Duplicate { .. } => format!("set-up {name} names an axis another input has"),
        e => format!("set-up {name}: {e:?}"),
    }
}

/// The set-up a request writes, in order, checked by the core's own configuration rules
/// (`ballpod::config`, as the pod checks it): each field's name and value as the pod takes
/// them (`CONF:<NAME> <value>`), and the configuration they make.
pub fn setup_lines(req: &TestRequest) -> Result<(Vec<(String, String)>, Config), String> {
    let mut fields: BTreeMap<String, SetupValue> = req
        .test
        .defaults()
        .into_iter()
        .map(|(k, v)| (k.to_string(), v))
        .collect();
    fields.extend(req.setup.clone());
    // bar_length follows the template's field, written last (its own refusal names the field
    // it follows first)
    let derived = (!fields.contains_key("bar_length"))
        .then(|| {
            req.test
                .bar_length_from()
                .and_then(|f| fields.get(f))
                .cloned()
        })
        .flatten()
        .map(|v| ("bar_length".to_string(), v));
    let mut c = Config::default();
    let mut lines = Vec::new();
    for (name, v) in fields
        .iter()
        .map(|(k, v)| (k.clone(), v.clone()))
        .chain(derived)
    {
        let name = name.as_str();
        let v = &v;
        let f = Config::field_by_name(name).ok_or(format!(
            "set-up {name:?} is not a configuration field of the pod"
        ))?;
        let info = Config::field_info(f).ok_or(format!(
            "set-up {name:?} is not a configuration field of the pod"
        ))?;
        let (x, text) = match v {
            SetupValue::Number(x) if info.choices().is_empty() => (*x, format!("{x}")),
            SetupValue::Number(x) => {
                return Err(format!(
                    "set-up {name} = {x}: the field takes one of {}",
                    info.choices().join(", ")
                ));
            }
            SetupValue::Text(t) if info.choices().is_empty() => {
                return Err(format!(
                    "set-up {name} = {t:?}: the field takes a number ({})",
                    info.unit.as_str()
                ));
            }
            SetupValue::Text(t) => {
                let code = info.choice(t.as_bytes()).ok_or(format!(
                    "set-up {name} = {t:?} is not one of {}",
                    info.choices().join(", ")
                ))?;
                (f64::from(code), t.clone())
            }
        };
        c.set(f, x).map_err(|e| refusal(name, e))?;
        lines.push((name.to_uppercase(), text));
    }
    Ok((lines, c))
}

/// The set-up a template changes between its runs: (run, field, value) — the probe
/// template's second stylus before run 7, checked by the core's rules as the first is.
pub fn changes(req: &TestRequest) -> Result<Vec<(usize, String, String)>, String> {
    match (req.test, req.second_probe_length) {
        (Template::Probe, Some(r)) => {
            let first = req.setup.get("probe_length");
            if !matches!(first, Some(SetupValue::Number(_))) {
                return Err(
                    "the probe test needs probe_length, the first stylus's tool length \
                            (mm, runs 1–6)"
                        .into(),
                );
            }
            let f =
                Config::field_by_name("probe_length").ok_or("the pod has no probe_length field")?;
            Config::default()
                .set(f, r)
                .map_err(|e| refusal("second_probe_length", e))?;
            Ok(vec![(
                SECOND_STYLUS_RUN,
                "PROBE_LENGTH".to_string(),
                format!("{r}"),
            )])
        }
        (Template::Probe, None) => Err(
            "the probe test needs second_probe_length, the second stylus's tool length \
             (mm, runs 7–8)"
                .into(),
        ),
        (_, Some(_)) => Err("second_probe_length is the probe test's alone".into()),
        (_, None) => Ok(Vec::new()),
    }
}

/// The part program of a test, for the control to run (`ncgen`'s, from the same set-up): the
/// circle's CCW and CW runs, or the seed 002 procedure's five steps, each CW then CCW, at
/// 1000 mm/min, one after the other.
pub fn part_program(req: &TestRequest, dialect: Dialect) -> Result<String, String> {
    let (_, config) = setup_lines(req)?;
    match req.test {
        Template::Circle => CircleRun::from_config(&config, CircleOptions::default())
            .map(|t| t.program(dialect))
            .map_err(|e| format!("part program: {e}")),
        Template::Seed002 => {
            let mut out = String::new();
            for step in [
                Pattern::Bx,
                Pattern::By,
                Pattern::Cr,
                Pattern::Ca,
                Pattern::Cr2,
            ] {
                let feed = 1000.0;
                let steps = PatternTest::default_steps(&config, step, feed)
                    .map_err(|e| format!("part program {}: {e}", step.name()))?;
                let t = PatternTest::from_config(
                    &config,
                    step,
                    steps,
                    feed,
                    vec![Direction::Cw, Direction::Ccw],
                )
                .map_err(|e| format!("part program {}: {e}", step.name()))?;
                out.push_str(&t.program(dialect));
            }
            Ok(out)
        }
        // its stations follow a target point the desk does not ask for
        Template::Ssm => Err(
            "part program: an SSM run's program needs its target point: \
                              `cargo ncgen -- ssm SETUP --target X Y Z`"
                .into(),
        ),
        // where the sphere stands on the C table is the technician's choice
        Template::Probe => Err(
            "part program: each sphere's program needs where the sphere stands: \
             `cargo ncgen -- sphere --centre X Y Z --b-deg B --c-deg C`, one per run"
                .into(),
        ),
    }
}

/// Starts a test in a thread of its own; the run's id. Refused (named) when a field is wrong,
/// the desk has no pod, or a test runs already.
pub fn start(desk: &Arc<Desk>, req: TestRequest) -> Result<u64, String> {
    if req.operator.trim().is_empty() {
        return Err("operator is missing".into());
    }
    let (lines, config) = setup_lines(&req)?;
    let changes = changes(&req)?;
    let machine_id = req.machine_id;
    desk.store.call(move |s| s.machine(machine_id))?;
    // (not from the pod's lock: a running test holds it)
    let identity = desk.identity.clone().ok_or(
        "the desk has no pod (start it with --pod-serial, --pod-command-port or --pod-usb)",
    )?;
    let mut live = lock(&desk.live);
    if live.test != 0 && !live.finished {
        return Err("a test is running: wait for its end".into());
    }
    let test = live.test + 1;
    let started = super::store::now();
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    let run = RunRow {
        spool_key: format!("{started}-{:x}-{test}-{nanos:09}", std::process::id()),
        machine_id,
        test: serde_json::to_value(req.test)
            .ok()
            .and_then(|v| v.as_str().map(String::from))
            .unwrap_or_default(),
        operator: req.operator.trim().to_string(),
        started,
        pod_identity: identity,
        setup: serde_json::to_value(
            lines
                .iter()
                .cloned()
                .chain(
                    changes
                        .iter()
                        .map(|(k, n, v)| (format!("{n} from run {}", k + 1), v.clone())),
                )
                .collect::<BTreeMap<_, _>>(),
        )
        .map_err(|e| e.to_string())?,
        ..RunRow::default()
    };
    *live = super::Live {
        test,
        run_id: None,
        step: "writing the set-up".into(),
        finished: false,
        stop: false,
        spool_key: run.spool_key.clone(),
        stream_from: 0,
        trace: None,
    };
    drop(live);
    let d = desk.clone();
    std::thread::spawn(move || {
        let mut guard = lock(&d.pod);
        let outcome = match guard.as_mut() {
            Some(pod) => run_template(&d, pod, req.test, &lines, &changes, &config),
            None => Err(Outcome::failed("the pod went away".into())),
        };
        drop(guard);
        finish(&d, run, outcome);
    });
    Ok(test)
}

/// Asks the test under way to stop (its run aborted, `SESS:ABOR`); the test's number.
/// Refused when no test runs.
pub fn stop(desk: &Desk) -> Result<u64, String> {
    let mut live = lock(&desk.live);
    if live.test == 0 || live.finished {
        return Err("there is no test running to stop".into());
    }
    live.stop = true;
    Ok(live.test)
}

/// What a test left: the pod's results, the stream of its runs.
struct Recorded {
    pod_results: Vec<Figure>,
    stream: Vec<u8>,
}

/// Why a test did not complete: `failed` (refused, aborted) or `cut` (the pod went away), with
/// what was recorded up to then.
struct Outcome {
    state: &'static str,
    note: String,
    stream: Vec<u8>,
}

impl Outcome {
    fn failed(note: String) -> Self {
        Self {
            state: "failed",
            note,
            stream: Vec::new(),
        }
    }
}

fn step(desk: &Desk, s: String) {
    lock(&desk.live).step = s;
}

/// A template's runs, one after the other, each ended by the machine's motion.
fn run_template(
    desk: &Desk,
    pod: &mut Pod,
    template: Template,
    lines: &[(String, String)],
    changes: &[(usize, String, String)],
    config: &Config,
) -> Result<Recorded, Outcome> {
    // (nothing else arms the pod while the desk holds it: what came before is no test's)
    pod.stream_restart();
    let start = 0;
    let with_stream = |pod: &Pod, note: String| {
        let (stream, closed) = pod.stream_since(start);
        Outcome {
            state: if closed { "cut" } else { "failed" },
            note,
            stream,
        }
    };
    // a test starts from a cleared session: the pod's results are then this test's alone, as
    // the replay of its stream (which starts from a fresh application) has them; without it a
    // circle after a seed 002 procedure reads the procedure's results as the pod's
    pod.command("SESS:CLE").map_err(Outcome::failed)?;
    pod.command("CONF:UNL").map_err(Outcome::failed)?;
    for (name, value) in lines {
        pod.command(&format!("CONF:{name} {value}"))
            .map_err(Outcome::failed)?;
    }
    // a FEED_IN circle starts and ends itself with the part program's feed-in and data arc
    // (`app::trigger`): the desk arms it and waits; otherwise the desk starts each run
    let self_started =
        config.setup.run_trigger == RunTrigger::FeedIn && template == Template::Circle;
    let runs = template.runs();
    for (k, &(pattern, dir)) in runs.iter().enumerate() {
        let what = format!("run {} of {} ({pattern} {dir})", k + 1, runs.len());
        for (_, name, value) in changes.iter().filter(|(at, ..)| *at == k) {
            step(desk, format!("{what}: {name} {value}"));
            pod.command(&format!("CONF:{name} {value}"))
                .map_err(|e| with_stream(pod, e))?;
        }
        {
            let mut live = lock(&desk.live);
            live.stream_from = pod.stream_len();
            live.trace = Some(template.trace(pattern, config));
            live.step = format!("{what}: armed, starting");
        }
        pod.command(&format!("SESS:PATT {pattern};DIR {dir};:SESS:ARM"))
            .map_err(|e| with_stream(pod, e))?;
        if !self_started {
            pod.command("SESS:STAR").map_err(|e| with_stream(pod, e))?;
            step(desk, format!("{what}: the machine moves"));
        }
        let t0 = Instant::now();
        let state = loop {
            if lock(&desk.live).stop {
                pod.command("SESS:ABOR").map_err(|e| with_stream(pod, e))?;
                return Err(with_stream(pod, format!("{what}: stopped by the operator")));
            }
            let s = pod.query("SESS:STAT?").map_err(|e| with_stream(pod, e))?;
            if s == "ARMED" && self_started {
                // what the pod waits for, in its words
                let note = pod.query("SESS:NOTE?").map_err(|e| with_stream(pod, e))?;
                step(
                    desk,
                    format!("{what}: armed; the pod: {}", note.trim_matches('"')),
                );
            } else if s == "RUNNING" && self_started {
                step(desk, format!("{what}: the machine moves"));
            }
            if s != "RUNNING" && s != "ARMED" {
                break s;
            }
            if t0.elapsed() > RUN_TIMEOUT {
                return Err(with_stream(
                    pod,
                    format!("{what} did not end in {RUN_TIMEOUT:?}"),
                ));
            }
            std::thread::sleep(Duration::from_millis(100));
        };
        if state != "DONE" {
            return Err(with_stream(pod, format!("{what} ended {state}")));
        }
        step(desk, format!("{what}: the pod computes its results"));
        let t0 = Instant::now();
        loop {
            let w: u32 = pod
                .query("STAT:POD?")
                .map_err(|e| with_stream(pod, e))?
                .parse()
                .map_err(|_| with_stream(pod, "STAT:POD? is not a number".into()))?;
            if w & RESULTS_READY != 0 {
                break;
            }
            if t0.elapsed() > Duration::from_secs(60) {
                return Err(with_stream(
                    pod,
                    "the pod's results did not come in 60 s".into(),
                ));
            }
            std::thread::sleep(Duration::from_millis(100));
        }
    }
    step(desk, "reading the pod's results".into());
    let pod_results = read_results(pod).map_err(|e| with_stream(pod, e))?;
    // the stream's end lines follow each run's end: wait for every run's last line
    let t0 = Instant::now();
    loop {
        let (bytes, closed) = pod.stream_since(start);
        let text = stream_text(&bytes);
        if text.matches("# stream_dropped=").count() >= runs.len() {
            return Ok(Recorded {
                pod_results,
                stream: bytes,
            });
        }
        if closed || t0.elapsed() > Duration::from_secs(10) {
            return Err(with_stream(
                pod,
                "the stream did not carry every run's end".into(),
            ));
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Every valid result the pod reports (`FETC:RES:CAT?`, then `FETC:RES?` each), as printed.
fn read_results(pod: &mut Pod) -> Result<Vec<Figure>, String> {
    let cat = pod.query("FETC:RES:CAT?")?;
    let mut out = Vec::new();
    for name in cat.split(',').map(|n| n.trim_matches('"')) {
        let answer = pod.query(&format!("FETC:RES? {name};:SYST:ERR?"))?;
        // a valid result answers `value,u,UNIT;<error queue>`; an invalid one sends nothing
        // and queues -230 with its reason: the error queue's line alone
        // (its text may hold a ';': `-230,"Data corrupt or stale;<name> has no valid value"`)
        if answer.starts_with("-230,\"") {
            continue;
        }
        let Some((first, err)) = answer.split_once(';') else {
            return Err(format!("FETC:RES? {name}: {answer}"));
        };
        if !err.starts_with("0,") {
            return Err(format!("FETC:RES? {name}: {answer}"));
        }
        let parts: Vec<&str> = first.split(',').collect();
        let [v, u, unit] = parts[..] else {
            return Err(format!("FETC:RES? {name}: {answer:?} is not value,u,unit"));
        };
        let num = |s: &str| {
            s.parse::<f32>()
                .map_err(|_| format!("FETC:RES? {name}: {s:?}"))
        };
        out.push(Figure {
            name: name.to_string(),
            value: num(v)?,
            u: (u.as_bytes() != SCPI_NAN).then(|| num(u)).transpose()?,
            dof: None,
            unit: unit.to_lowercase(),
            contributors: Vec::new(),
        });
    }
    Ok(out)
}

/// A value as the pod prints it in `FETC:RES?` (4 decimals; NaN as SCPI's 9.91E+37).
fn printed(v: Option<f32>) -> String {
    let mut t: Text<48> = Text::new();
    push_fixed(
        &mut t,
        v.map_or(f64::NAN, f64::from),
        RESPONSE_DECIMALS,
        false,
        SCPI_NAN,
    );
    String::from_utf8_lossy(&t).into_owned()
}

/// The stream's bytes as run text (records decoded; a record cut at the end left out).
pub fn stream_text(bytes: &[u8]) -> String {
    let mut text = Vec::new();
    let upto = match decode(bytes, |_| {}) {
        Ok(n) => n,
        Err(DecodeError::Cut { offset } | DecodeError::BadRecord { offset }) => offset,
    };
    let _ = decode(bytes.get(..upto).unwrap_or(&[]), |l| {
        text.extend_from_slice(l)
    });
    String::from_utf8_lossy(&text).into_owned()
}

/// Replays the recorded stream; the report, and what differs from the pod's printed results
/// (empty: the same, digit for digit, and the same set of valid results).
pub fn replay_check(stream: &[u8], pod_results: &[Figure]) -> Result<(Report, String), String> {
    let runs = crate::recording::parse_runs(Path::new("stream"), &stream_text(stream))
        .map_err(|e| e.to_string())?;
    let named: Vec<(String, _)> = runs
        .into_iter()
        .map(|r| ("stream".to_string(), r))
        .collect();
    let report = replay(&named)?;
    let mut diffs = Vec::new();
    for f in &report.results {
        match pod_results.iter().find(|p| p.name == f.name) {
            None => diffs.push(format!("{}: valid in the replay, not on the pod", f.name)),
            Some(p) => {
                if printed(Some(f.value)) != printed(Some(p.value)) || printed(f.u) != printed(p.u)
                {
                    diffs.push(format!(
                        "{}: pod {} ± {}, replay {} ± {}",
                        f.name,
                        printed(Some(p.value)),
                        printed(p.u),
                        printed(Some(f.value)),
                        printed(f.u)
                    ));
                }
            }
        }
    }
    for p in pod_results {
        if !report.results.iter().any(|f| f.name == p.name) {
            diffs.push(format!("{}: valid on the pod, not in the replay", p.name));
        }
    }
    Ok((report, diffs.join("; ")))
}

/// Stores what a test left, checked against the replay.
fn finish(desk: &Desk, mut run: RunRow, outcome: Result<Recorded, Outcome>) {
    let (state, mut note, stream, pod_results) = match outcome {
        Ok(r) => ("done", String::new(), r.stream, r.pod_results),
        Err(o) => (o.state, o.note, o.stream, Vec::new()),
    };
    let (replay_json, check) = if state == "done" {
        match replay_check(&stream, &pod_results) {
            Ok((report, check)) => (serde_json::to_value(&report).unwrap_or_default(), check),
            Err(e) => (
                serde_json::Value::Null,
                format!("replay refused the stream: {e}"),
            ),
        }
    } else {
        (serde_json::Value::Null, String::new())
    };
    if !check.is_empty() {
        note = format!("replay differs from the pod: {check}");
    }
    run.state = state.into();
    run.note = note.clone();
    run.pod_results = serde_json::to_value(&pod_results).unwrap_or_default();
    run.replay = replay_json;
    run.replay_check = check;
    let said = if state == "done" {
        "done".to_string()
    } else {
        format!("{state}: {note}")
    };
    // into the spool first, then the history: nothing is lost if the database is not there
    let step = match desk.spool.put(&run, &stream) {
        Err(e) => format!("{said}; NOT KEPT: {e}"),
        Ok(()) => match desk.spool.flush(&desk.store) {
            Ok(stored) => {
                let id = stored
                    .iter()
                    .find(|(k, _)| *k == run.spool_key)
                    .map(|(_, id)| *id);
                lock(&desk.live).run_id = id;
                said
            }
            Err(e) => format!(
                "{said}; kept in the spool ({}) until the database takes it: {e}",
                desk.spool.dir().display()
            ),
        },
    };
    let mut live = lock(&desk.live);
    live.finished = true;
    live.step = step;
}

/// The live trace of the run under way: its samples, samples lost (gaps in `seq`), touch
/// points, and up to `max` points (angle °, ΔL µm) spread over it.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Trace {
    /// Samples recorded so far.
    pub samples: usize,
    /// Samples lost (gaps in the pod's sample counter).
    pub lost: u64,
    /// Touch points recorded so far (a PROBE run's).
    pub touches: usize,
    /// (angle in the plane, degrees; ΔL, µm).
    pub points: Vec<[f32; 2]>,
}

/// The trace of the last run in `bytes` (a run's stream from its header on).
pub fn trace(bytes: &[u8], axes: &TraceAxes, max: usize) -> Trace {
    trace_of_text(&stream_text(bytes), axes, max)
}

/// The trace of the last run in a run text.
pub fn trace_of_text(text: &str, axes: &TraceAxes, max: usize) -> Trace {
    let Some(start) = text.rfind("# ballpod run") else {
        return Trace::default();
    };
    let (cu, cv) = match axes {
        TraceAxes::Plane { u, v, .. } => (*u, *v),
        TraceAxes::Rotary(c) => (*c, *c),
        TraceAxes::Touches => ("seq", "seq"),
    };
    let mut cols: Option<[usize; 5]> = None;
    let mut rows = Vec::new();
    let (mut samples, mut touches) = (0, 0);
    let mut lost = 0;
    let mut last_seq: Option<u64> = None;
    for line in text.get(start..).unwrap_or("").lines() {
        if line.starts_with('#') {
            continue;
        }
        let f: Vec<&str> = line.split(',').collect();
        let Some([s, d, u, v, fl]) = cols else {
            if line.starts_with("seq,") {
                let at = |n: &str| f.iter().position(|c| *c == n);
                if let (Some(s), Some(d), Some(u), Some(v), Some(fl)) =
                    (at("seq"), at("dl_um"), at(cu), at(cv), at("flags"))
                {
                    cols = Some([s, d, u, v, fl]);
                }
            }
            continue;
        };
        let num = |k: usize| f.get(k).and_then(|x| x.parse::<f64>().ok());
        let flags = f.get(fl).and_then(|x| x.parse::<u16>().ok()).unwrap_or(0);
        if flags & ballpod::app::log::LogRecord::TOUCH != 0 {
            touches += 1;
            continue;
        }
        samples += 1;
        if let Some(seq) = num(s).map(|x| x as u64) {
            if let Some(l) = last_seq {
                lost += seq.saturating_sub(l + 1);
            }
            last_seq = Some(seq);
        }
        if let (Some(dl), Some(pu), Some(pv)) = (num(d), num(u), num(v))
            && dl.is_finite()
        {
            let a = match axes {
                TraceAxes::Plane { centre_mm, .. } => {
                    (pv - centre_mm[1]).atan2(pu - centre_mm[0]).to_degrees()
                }
                TraceAxes::Rotary(_) => pu,
                TraceAxes::Touches => continue,
            };
            rows.push([a as f32, dl as f32]);
        }
    }
    let step = rows.len().div_ceil(max.max(1)).max(1);
    Trace {
        samples,
        lost,
        touches,
        points: rows.iter().step_by(step).copied().collect(),
    }
}
