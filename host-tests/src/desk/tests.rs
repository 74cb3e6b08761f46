//! The test templates: what each writes to the pod, how it runs it, and what it keeps. One
//! template so far: the ISO 230-4 circular test as a pair of runs (CCW, then CW) in one plane.

use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

use ballpod::protocol::scpi::RESPONSE_DECIMALS;
use ballpod::protocol::scpi::number::{SCPI_NAN, Text, push_fixed};
use ballpod::protocol::stream::{DecodeError, decode};

use super::pod::Pod;
use super::{Desk, lock};
use crate::replay::{Figure, Report, replay};

/// The pod's status word bit: the last run's results are all there (`STAT:POD?`).
const RESULTS_READY: u32 = 1 << 10;
/// Longest a run may take before the desk gives up on it (a 150 mm circle at F100 is 9.4 min).
const RUN_TIMEOUT: Duration = Duration::from_secs(900);

/// An ISO 230-4 circular test's set-up (ISO 230-4:2022 §5: radius, feed, plane, centre).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct CircleSetup {
    /// `XY`, `YZ` or `ZX`.
    pub plane: String,
    /// The circle's centre, the plane's first and second axis (mm, machine coordinates).
    pub centre_mm: [f64; 2],
    /// Nominal radius, mm (the bar's calibrated length).
    pub radius_mm: f64,
    /// Feed, mm/min.
    pub feed_mm_per_min: f64,
}

impl Default for CircleSetup {
    fn default() -> Self {
        Self {
            plane: "XY".into(),
            centre_mm: [0.0; 2],
            radius_mm: 150.0,
            feed_mm_per_min: 1000.0,
        }
    }
}

/// The two axis columns of a plane's trace in the run text, and the circle's centre.
#[derive(Clone, Debug, PartialEq)]
pub struct TraceAxes {
    /// Column of the plane's first axis (`x_mm`).
    pub u: &'static str,
    /// Column of the second (`y_mm`).
    pub v: &'static str,
    /// The centre in those columns, mm.
    pub centre_mm: [f64; 2],
}

impl CircleSetup {
    /// The plane's axes, or the field that is wrong, named.
    pub fn check(&self) -> Result<[&'static str; 2], String> {
        let axes = match self.plane.as_str() {
            "XY" => ["x", "y"],
            "YZ" => ["y", "z"],
            "ZX" => ["z", "x"],
            p => return Err(format!("circle plane {p:?} is not one of XY, YZ, ZX")),
        };
        if !(self.radius_mm.is_finite() && (10.0..=1000.0).contains(&self.radius_mm)) {
            return Err(format!(
                "circle radius {} mm is outside 10 … 1000 mm",
                self.radius_mm
            ));
        }
        if !(self.feed_mm_per_min.is_finite() && (1.0..=20_000.0).contains(&self.feed_mm_per_min)) {
            return Err(format!(
                "circle feed {} mm/min is outside 1 … 20000 mm/min",
                self.feed_mm_per_min
            ));
        }
        if !self.centre_mm.iter().all(|c| c.is_finite()) {
            return Err("circle centre is not a number".into());
        }
        Ok(axes)
    }

    /// The SCPI line that writes this set-up (bar length = radius: ΔL is read against it).
    pub fn scpi(&self) -> Result<String, String> {
        let [a, b] = self.check()?;
        let r = self.radius_mm;
        Ok(format!(
            "CONF:BAR_LENGTH {r};CIRCLE_PLANE {};CIRCLE_CENTRE_{} {};CIRCLE_CENTRE_{} {};CIRCLE_RADIUS {r};CIRCLE_FEED {}",
            self.plane,
            a.to_uppercase(),
            self.centre_mm[0],
            b.to_uppercase(),
            self.centre_mm[1],
            self.feed_mm_per_min
        ))
    }

    /// The columns the live trace reads.
    pub fn trace(&self) -> Result<TraceAxes, String> {
        let col = |a: &str| match a {
            "x" => "x_mm",
            "y" => "y_mm",
            _ => "z_mm",
        };
        let [a, b] = self.check()?;
        Ok(TraceAxes {
            u: col(a),
            v: col(b),
            centre_mm: self.centre_mm,
        })
    }
}

/// A request for a test.
#[derive(Clone, Debug, Deserialize)]
pub struct TestRequest {
    /// The machine (its id).
    pub machine_id: i64,
    /// Who runs it.
    pub operator: String,
    /// The template: `circle`.
    pub test: String,
    /// The circle's set-up.
    #[serde(default)]
    pub circle: CircleSetup,
}

/// Starts a test in a thread of its own; the run's id. Refused (named) when a field is wrong,
/// the desk has no pod, or a test runs already.
pub fn start(desk: &Arc<Desk>, req: TestRequest) -> Result<i64, String> {
    if req.test != "circle" {
        return Err(format!("test {:?} is not one of: circle", req.test));
    }
    if req.operator.trim().is_empty() {
        return Err("operator is missing".into());
    }
    let trace = req.circle.trace()?;
    let identity = {
        let pod = lock(&desk.pod);
        pod.as_ref()
            .ok_or("the desk has no pod (start it with --pod-usb and --pod-stream)")?
            .identity
            .clone()
    };
    let mut live = lock(&desk.live);
    if live.run_id.is_some() && !live.finished {
        return Err("a test is running: wait for its end".into());
    }
    let setup = serde_json::to_value(&req.circle).map_err(|e| e.to_string())?;
    let id = lock(&desk.store).begin_run(
        req.machine_id,
        &req.test,
        req.operator.trim(),
        &identity,
        &setup,
    )?;
    *live = super::Live {
        run_id: Some(id),
        step: "writing the set-up".into(),
        finished: false,
        stream_from: 0,
        trace: Some(trace),
    };
    drop(live);
    let d = desk.clone();
    std::thread::spawn(move || {
        let mut guard = lock(&d.pod);
        let outcome = match guard.as_mut() {
            Some(pod) => circle_pair(&d, pod, &req.circle),
            None => Err(Outcome::failed("the pod went away".into())),
        };
        drop(guard);
        finish(&d, id, outcome);
    });
    Ok(id)
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

/// The circular test's two runs.
fn circle_pair(desk: &Desk, pod: &mut Pod, setup: &CircleSetup) -> Result<Recorded, Outcome> {
    let start = pod.stream_len();
    let with_stream = |pod: &Pod, note: String| {
        let (stream, closed) = pod.stream_since(start);
        Outcome {
            state: if closed { "cut" } else { "failed" },
            note,
            stream,
        }
    };
    let line = setup.scpi().map_err(Outcome::failed)?;
    pod.command("CONF:UNL").map_err(Outcome::failed)?;
    pod.command(&line).map_err(Outcome::failed)?;
    for dir in ["CCW", "CW"] {
        {
            let mut live = lock(&desk.live);
            live.stream_from = pod.stream_len();
            live.step = format!("{dir} run: armed, starting");
        }
        pod.command(&format!("SESS:PATT CIRCLE;DIR {dir};:SESS:ARM"))
            .map_err(|e| with_stream(pod, e))?;
        pod.command("SESS:STAR").map_err(|e| with_stream(pod, e))?;
        step(desk, format!("{dir} run: the machine moves"));
        let t0 = Instant::now();
        let state = loop {
            let s = pod.query("SESS:STAT?").map_err(|e| with_stream(pod, e))?;
            if s != "RUNNING" && s != "ARMED" {
                break s;
            }
            if t0.elapsed() > RUN_TIMEOUT {
                return Err(with_stream(
                    pod,
                    format!("the {dir} run did not end in {RUN_TIMEOUT:?}"),
                ));
            }
            std::thread::sleep(Duration::from_millis(100));
        };
        if state != "DONE" {
            return Err(with_stream(pod, format!("the {dir} run ended {state}")));
        }
        step(desk, format!("{dir} run: the pod computes its results"));
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
    // the stream's end lines follow the run's end: wait for both runs' last line
    let t0 = Instant::now();
    loop {
        let (bytes, closed) = pod.stream_since(start);
        let text = stream_text(&bytes);
        if text.matches("# stream_dropped=").count() >= 2 {
            return Ok(Recorded {
                pod_results,
                stream: bytes,
            });
        }
        if closed || t0.elapsed() > Duration::from_secs(10) {
            return Err(with_stream(
                pod,
                "the stream did not carry both runs' ends".into(),
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
fn finish(desk: &Desk, id: i64, outcome: Result<Recorded, Outcome>) {
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
    let pod_json = serde_json::to_value(&pod_results).unwrap_or_default();
    let stored =
        lock(&desk.store).finish_run(id, state, &note, &pod_json, &replay_json, &check, &stream);
    let mut live = lock(&desk.live);
    live.finished = true;
    live.step = match stored {
        Ok(()) if state == "done" => "done".into(),
        Ok(()) => format!("{state}: {note}"),
        Err(e) => format!("{state}; not stored: {e}"),
    };
}

/// The live trace of the run under way: its samples, samples lost (gaps in `seq`), and up to
/// `max` points (angle °, ΔL µm) spread over it.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Trace {
    /// Samples recorded so far.
    pub samples: usize,
    /// Samples lost (gaps in the pod's sample counter).
    pub lost: u64,
    /// (angle in the plane, degrees; ΔL, µm).
    pub points: Vec<[f32; 2]>,
}

/// The trace of the last run in `bytes` (a run's text from its header on).
pub fn trace(bytes: &[u8], axes: &TraceAxes, max: usize) -> Trace {
    let text = stream_text(bytes);
    let Some(start) = text.rfind("# ballpod run") else {
        return Trace::default();
    };
    let mut cols: Option<(usize, usize, usize, usize)> = None;
    let mut rows = Vec::new();
    let mut lost = 0;
    let mut last_seq: Option<u64> = None;
    for line in text[start..].lines() {
        if line.starts_with('#') {
            continue;
        }
        let f: Vec<&str> = line.split(',').collect();
        match cols {
            None if line.starts_with("seq,") => {
                let at = |n: &str| f.iter().position(|c| *c == n);
                if let (Some(s), Some(d), Some(u), Some(v)) =
                    (at("seq"), at("dl_um"), at(axes.u), at(axes.v))
                {
                    cols = Some((s, d, u, v));
                }
            }
            None => {}
            Some((s, d, u, v)) => {
                let num = |k: usize| f.get(k).and_then(|x| x.parse::<f64>().ok());
                if let Some(seq) = num(s).map(|x| x as u64) {
                    if let Some(l) = last_seq {
                        lost += seq.saturating_sub(l + 1);
                    }
                    last_seq = Some(seq);
                }
                if let (Some(dl), Some(pu), Some(pv)) = (num(d), num(u), num(v))
                    && dl.is_finite()
                {
                    let a = (pv - axes.centre_mm[1])
                        .atan2(pu - axes.centre_mm[0])
                        .to_degrees();
                    rows.push([a as f32, dl as f32]);
                }
            }
        }
    }
    let step = rows.len().div_ceil(max.max(1)).max(1);
    Trace {
        samples: rows.len(),
        lost,
        points: rows.iter().step_by(step).copied().collect(),
    }
}
