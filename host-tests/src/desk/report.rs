//! A run's figures with their decisions, and the self-contained HTML report (test conditions,
//! polar plots in the ball-bar convention, figures ± U with the decision, the largest
//! contributors, this machine's trend per toleranced figure, traceability).

use std::collections::BTreeMap;
use std::fmt::Write;
use std::path::Path;

use serde::Serialize;

use super::decision::{Decision, Tolerance, decide};
use super::store::{Machine, RunRow, Store};
use super::tests::stream_text;
use crate::gum::coverage_factor;
use crate::recording::RecordedRun;
use crate::replay::{Figure, Report};

/// One figure of a run with its expanded uncertainty and decision.
#[derive(Clone, Debug, Serialize)]
pub struct FigureView {
    /// Result name.
    pub name: String,
    /// Value, `unit`.
    pub value: f64,
    /// Standard uncertainty (None: not evaluated).
    pub u: Option<f64>,
    /// Coverage factor for 95 % (2, or Student's t at the figure's degrees of freedom).
    pub k: Option<f64>,
    /// Expanded uncertainty U = k·u.
    pub expanded_u: Option<f64>,
    /// Unit.
    pub unit: String,
    /// The machine's tolerance for it, if set.
    pub tolerance: Option<Tolerance>,
    /// The ISO 14253-1 decision (only where a tolerance is set).
    pub decision: Option<Decision>,
    /// The largest contributors to u: (name, standard uncertainty in `unit`).
    pub contributors: Vec<(String, f64)>,
}

/// A run as the desk shows it.
#[derive(Clone, Debug, Serialize)]
pub struct RunView {
    /// The stored row.
    pub run: RunRow,
    /// The machine.
    pub machine: Machine,
    /// Figures (the replay's, which equal the pod's printed results when `replay_check` is
    /// empty; the pod's where the replay failed).
    pub figures: Vec<FigureView>,
}

/// The figures of a stored run (replay first, else the pod's).
pub fn figures_of(run: &RunRow) -> Vec<Figure> {
    serde_json::from_value::<Report>(run.replay.clone())
        .map(|r| r.results)
        .or_else(|_| serde_json::from_value(run.pod_results.clone()))
        .unwrap_or_default()
}

/// A run's figures with their decisions against the machine's tolerances.
pub fn view(store: &mut Store, id: i64) -> Result<RunView, String> {
    let run = store.run(id)?;
    let machine = store.machine(run.machine_id)?;
    let tol = store.tolerances(run.machine_id)?;
    let figures = figures_of(&run)
        .into_iter()
        .map(|f| figure_view(&f, &tol))
        .collect();
    Ok(RunView {
        run,
        machine,
        figures,
    })
}

fn figure_view(f: &Figure, tol: &BTreeMap<String, Tolerance>) -> FigureView {
    let u = f.u.map(f64::from);
    let k = u.and(coverage_factor(f.dof.map(f64::from)));
    let expanded_u = u.zip(k).map(|(u, k)| u * k);
    let tolerance = tol.get(&f.name).copied();
    FigureView {
        name: f.name.clone(),
        value: f64::from(f.value),
        u,
        k,
        expanded_u,
        unit: f.unit.clone(),
        tolerance,
        decision: tolerance.map(|t| decide(f64::from(f.value), expanded_u, t)),
        contributors: f
            .contributors
            .iter()
            .map(|c| (c.name.clone(), f64::from(c.u)))
            .collect(),
    }
}

/// One run's point of a trend.
#[derive(Clone, Debug, Serialize)]
pub struct TrendPoint {
    /// The run.
    pub run_id: i64,
    /// When it started (RFC 3339).
    pub started: String,
    /// The figure's value.
    pub value: f64,
    /// Its expanded uncertainty.
    pub expanded_u: Option<f64>,
}

/// One figure over a machine's completed runs, oldest first.
pub fn trend(store: &mut Store, machine: i64, figure: &str) -> Result<Vec<TrendPoint>, String> {
    let tol = BTreeMap::new();
    Ok(store
        .runs(Some(machine))?
        .iter()
        .filter(|r| r.state == "done")
        .filter_map(|r| {
            let f = figures_of(r).into_iter().find(|f| f.name == figure)?;
            let v = figure_view(&f, &tol);
            Some(TrendPoint {
                run_id: r.id,
                started: r.started.clone(),
                value: v.value,
                expanded_u: v.expanded_u,
            })
        })
        .collect())
}

/// A unit as a reader writes it (the protocols' ASCII `um`, `urad` → µm, µrad).
pub fn unit_text(unit: &str) -> String {
    match unit.strip_prefix('u') {
        Some(rest) if rest.starts_with('m') || rest.starts_with("rad") => format!("µ{rest}"),
        _ => unit.to_string(),
    }
}

/// Text for HTML.
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// A trend chart: the values with their U bars, the tolerance's limits as lines (SVG).
pub fn trend_svg(points: &[TrendPoint], tol: Option<Tolerance>, title: &str, unit: &str) -> String {
    let (w, h, m) = (640.0, 260.0, 50.0);
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for p in points {
        let (v, u) = (p.value, p.expanded_u.unwrap_or(0.0));
        lo = lo.min(v - u);
        hi = hi.max(v + u);
    }
    for l in tol.iter().flat_map(|t| [t.lower, t.upper]).flatten() {
        lo = lo.min(l);
        hi = hi.max(l);
    }
    if !(lo.is_finite() && hi.is_finite()) {
        lo = 0.0;
        hi = 1.0;
    }
    if hi - lo < 1e-9 {
        hi += 0.5;
        lo -= 0.5;
    }
    let pad = 0.08 * (hi - lo);
    let (lo, hi) = (lo - pad, hi + pad);
    let n = points.len().max(1) as f64;
    let x = |i: usize| m + (w - 2.0 * m) * (i as f64 + 0.5) / n;
    let y = |v: f64| h - m - (h - 2.0 * m) * (v - lo) / (hi - lo);
    let mut s = String::new();
    let _ = write!(
        s,
        r##"<svg xmlns="http://www.w3.org/2000/svg" class="trend" width="{w}" height="{h}" viewBox="0 0 {w} {h}"><rect width="{w}" height="{h}" fill="white"/><text x="{m}" y="20" font-size="14">{} ({})</text><line x1="{m}" y1="{}" x2="{}" y2="{}" stroke="#888"/>"##,
        esc(title),
        esc(&unit_text(unit)),
        h - m,
        w - m,
        h - m
    );
    for (l, name) in tol
        .iter()
        .flat_map(|t| [(t.lower, "lower limit"), (t.upper, "upper limit")])
    {
        if let Some(l) = l {
            let _ = write!(
                s,
                r##"<line class="limit" x1="{m}" y1="{0:.1}" x2="{1}" y2="{0:.1}" stroke="#d12a1f" stroke-dasharray="6 4"/><text x="{1}" y="{2:.1}" font-size="11" text-anchor="end" fill="#d12a1f">{name} {l}</text>"##,
                y(l),
                w - m,
                y(l) - 4.0
            );
        }
    }
    for (i, p) in points.iter().enumerate() {
        let (id, started, v) = (p.run_id, &p.started, p.value);
        if let Some(u) = p.expanded_u {
            let _ = write!(
                s,
                r##"<line x1="{0:.1}" y1="{1:.1}" x2="{0:.1}" y2="{2:.1}" stroke="#1f4fd1"/>"##,
                x(i),
                y(v + u),
                y(v - u)
            );
        }
        let _ = write!(
            s,
            r##"<circle class="point" cx="{:.1}" cy="{:.1}" r="4" fill="#1f4fd1"><title>run {id}, {}: {v:.4}</title></circle><text x="{:.1}" y="{}" font-size="10" text-anchor="middle">{}</text>"##,
            x(i),
            y(v),
            esc(started),
            x(i),
            h - m + 16.0,
            esc(started.get(..10).unwrap_or(started))
        );
    }
    let _ = write!(
        s,
        r##"<text x="8" y="{:.1}" font-size="10">{hi:.3}</text><text x="8" y="{:.1}" font-size="10">{lo:.3}</text></svg>"##,
        y(hi) + 10.0,
        y(lo)
    );
    s
}

/// The runs a stored run's stream holds, each named by the stream.
fn recorded(store: &mut Store, id: i64) -> Vec<(String, RecordedRun)> {
    let Ok(bytes) = store.stream(id) else {
        return Vec::new();
    };
    crate::recording::parse_runs(Path::new("stream"), &stream_text(&bytes))
        .map(|runs| {
            runs.into_iter()
                .map(|r| ("stream".to_string(), r))
                .collect()
        })
        .unwrap_or_default()
}

/// The polar plots of a run's stream with the replay the desk stored for it (the replay's own
/// SVGs; none where the run was not replayed).
fn plots(runs: &[(String, RecordedRun)], replay: &serde_json::Value) -> Vec<(String, String)> {
    match serde_json::from_value::<Report>(replay.clone()) {
        Ok(report) => crate::report::plots(runs, &report),
        Err(_) => Vec::new(),
    }
}

/// The bar's temperature over each run: (pattern and direction, mean, least, most, °C); a
/// run whose thermistor gave no valid reading is left out.
fn temperatures(runs: &[(String, RecordedRun)]) -> Vec<(String, f64, f64, f64)> {
    runs.iter()
        .filter_map(|(_, r)| {
            let t: Vec<f64> = r
                .samples()
                .map(|s| f64::from(s.temp_c))
                .filter(|t| t.is_finite())
                .collect();
            let n = t.len() as f64;
            (!t.is_empty()).then(|| {
                (
                    format!("{} {}", r.meta.pattern.name(), r.meta.direction.name()),
                    t.iter().sum::<f64>() / n,
                    t.iter().copied().fold(f64::INFINITY, f64::min),
                    t.iter().copied().fold(f64::NEG_INFINITY, f64::max),
                )
            })
        })
        .collect()
}

/// Colours of the overlaid runs, in order.
const OVERLAY_COLOURS: [&str; 4] = ["#1f4fd1", "#d12a1f", "#1f9d3a", "#8a3fd1"];

/// Stored runs drawn over each other: each recorded run's ΔL about its angle (a circle's
/// angle in its plane, a seed 002 step's rotary axis), ΔL 0 on the grey circle, 5 px per µm
/// (SVG).
pub fn overlay_svg(store: &mut Store, ids: &[i64]) -> Result<String, String> {
    let (size, r0, gain) = (520.0, 180.0, 5.0);
    let c = size / 2.0;
    let mut s = format!(
        r##"<svg xmlns="http://www.w3.org/2000/svg" class="overlay" width="{size}" height="{}" viewBox="0 0 {size} {}"><rect width="100%" height="100%" fill="white"/><circle cx="{c}" cy="{c}" r="{r0}" fill="none" stroke="#bbb"/>"##,
        size + 20.0 * ids.len() as f64,
        size + 20.0 * ids.len() as f64
    );
    for (k, &id) in ids.iter().enumerate() {
        let row = store.run(id)?;
        let template = serde_json::from_value::<super::tests::Template>(serde_json::Value::String(
            row.test.clone(),
        ))
        .map_err(|_| format!("run {id}: test {:?} has no trace", row.test))?;
        let colour = OVERLAY_COLOURS[k % OVERLAY_COLOURS.len()];
        for (_, r) in recorded(store, id) {
            let axes = template.trace(r.meta.pattern.name(), &r.meta.config);
            let t = super::tests::trace_of_text(&r.to_csv(), &axes, 1440);
            let dash = if r.meta.direction.name() == "CW" {
                r#" stroke-dasharray="4 2""#
            } else {
                ""
            };
            let points: Vec<String> = t
                .points
                .iter()
                .map(|&[a, dl]| {
                    let (rr, th) = (r0 + gain * f64::from(dl), f64::from(a).to_radians());
                    format!("{:.1},{:.1}", c + rr * th.cos(), c - rr * th.sin())
                })
                .collect();
            let _ = write!(
                s,
                r#"<polyline class="run-{id}" fill="none" stroke="{colour}" stroke-width="1.2"{dash} points="{}"/>"#,
                points.join(" ")
            );
        }
        let _ = write!(
            s,
            r#"<text x="10" y="{:.0}" font-size="13" fill="{colour}">run {id}, {} — {} (CW dashed)</text>"#,
            size + 14.0 + 20.0 * k as f64,
            esc(&row.started),
            esc(&row.test)
        );
    }
    s.push_str("</svg>");
    Ok(s)
}

/// The circle's diagnoses in words: each fault the pod named (`faults_named`, at least 3 u
/// from zero) with its share of G, largest first, and the oscillations named
/// (`oscillations_named`); `u`, `v` are the plane's axes.
fn diagnoses(figures: &[FigureView], [u, v]: [&str; 2]) -> Vec<String> {
    use ballpod::metrology::iso230_4::Fault;
    let get = |n: &str| figures.iter().find(|f| f.name == n);
    let mut out = Vec::new();
    if let Some(bits) = get("faults_named").map(|f| f.value as u32) {
        let mut named: Vec<(f64, String)> = Fault::ALL
            .iter()
            .filter(|f| bits & (1 << (**f as u8)) != 0)
            .map(|f| {
                // Debug names: Squareness, ReversalU, … → "squareness", "reversal of X"
                let (what, share) = match f {
                    Fault::Squareness => ("out-of-squareness".to_string(), "share_squareness"),
                    Fault::ScaleMismatch => ("scale mismatch".to_string(), "share_scale_mismatch"),
                    Fault::ReversalU => (format!("reversal steps of {u}"), "share_reversal_u"),
                    Fault::ReversalV => (format!("reversal steps of {v}"), "share_reversal_v"),
                    Fault::StraightnessU => {
                        (format!("straightness of {u}"), "share_straightness_u")
                    }
                    Fault::StraightnessV => {
                        (format!("straightness of {v}"), "share_straightness_v")
                    }
                    Fault::Cyclic => ("cyclic error".to_string(), "share_cyclic"),
                    Fault::LateralPlayU => (format!("lateral play of {u}"), "share_lateral_play_u"),
                    Fault::LateralPlayV => (format!("lateral play of {v}"), "share_lateral_play_v"),
                };
                let g = get(share).map_or(0.0, |f| f.value);
                let text = get(share).map_or(what.clone(), |f| {
                    format!("{what}: {:.2} µm of G (U {})", f.value, num(f.expanded_u))
                });
                (g, text)
            })
            .collect();
        named.sort_by(|a, b| b.0.total_cmp(&a.0));
        out.extend(named.into_iter().map(|(_, t)| t));
    }
    // oscillations_named's bits (the result's definition): 1, 2 vibration of u, v; 4, 8
    // stick-slip of u, v
    if let Some(bits) = get("oscillations_named").map(|f| f.value as u32) {
        for (bit, what, amp, hz) in [
            (
                1,
                format!("vibration of {u}"),
                "vibration_u",
                "vibration_frequency",
            ),
            (
                2,
                format!("vibration of {v}"),
                "vibration_v",
                "vibration_frequency",
            ),
            (
                4,
                format!("stick-slip of {u}"),
                "stick_slip_u",
                "stick_slip_frequency",
            ),
            (
                8,
                format!("stick-slip of {v}"),
                "stick_slip_v",
                "stick_slip_frequency",
            ),
        ] {
            if bits & bit != 0 {
                let a = get(amp).map_or(String::new(), |f| format!(": {:.2} µm", f.value));
                let f = get(hz).map_or(String::new(), |f| format!(" at {:.1} Hz", f.value));
                out.push(format!("{what}{a}{f}"));
            }
        }
    }
    out
}

/// The traceability rows of the bar and its LVDT, from the runs' headers (the pod's fields
/// `bar_serial`, `bar_certificate`, `bar_calibrated`, `lvdt_serial`); one row per distinct
/// instrument.
fn instrument_rows(runs: &[(String, RecordedRun)]) -> String {
    let entered = |v: u32| {
        if v == 0 {
            "not entered".to_string()
        } else {
            v.to_string()
        }
    };
    let date = |v: u32| {
        if v == 0 {
            "not entered".to_string()
        } else {
            format!("{:04}-{:02}-{:02}", v / 10_000, v / 100 % 100, v % 100)
        }
    };
    let mut seen = Vec::new();
    for (_, r) in runs {
        let i = crate::replay::Instrument::of(&r.meta.config);
        if !seen.contains(&i) {
            seen.push(i);
        }
    }
    seen.iter()
        .map(|i| {
            format!(
                "<tr><th>ball bar</th><td class=\"instrument\">serial {}, calibration certificate {} of {}; LVDT serial {}</td></tr>",
                entered(i.bar_serial),
                entered(i.bar_certificate),
                date(i.bar_calibrated),
                entered(i.lvdt_serial)
            )
        })
        .collect()
}

fn num(v: Option<f64>) -> String {
    v.map_or("—".into(), |v| format!("{v:.4}"))
}

/// The self-contained HTML report of one run.
pub fn html(store: &mut Store, id: i64) -> Result<String, String> {
    let v = view(store, id)?;
    let r = &v.run;
    let m = &v.machine;
    let mut s = String::new();
    let _ = write!(
        s,
        r#"<!doctype html><html lang="en"><head><meta charset="utf-8"><title>ballpod report — {name}, run {id}</title>
<style>body{{font-family:sans-serif;max-width:60em;margin:2em auto;color:#222}}table{{border-collapse:collapse}}td,th{{border:1px solid #ccc;padding:2px 6px;text-align:left}}
.conforms{{background:#d8f5d8}}.does_not_conform{{background:#f8d0d0}}.undecided{{background:#fff3c4}}svg{{max-width:100%;height:auto}}figure{{margin:0}}
@media print{{body{{margin:0;max-width:none}}figure svg{{max-height:11cm;width:auto}}figure,svg.trend,tr{{break-inside:avoid}}}}</style></head><body>
<h1>Ball-bar test report</h1><p id="summary">Machine <b>{name}</b> · test <b>{test}</b> · run {id} · {started} · operator {op} · state <b id="state">{state}</b></p>"#,
        name = esc(&m.name),
        test = esc(&r.test),
        started = esc(&r.started),
        op = esc(&r.operator),
        state = esc(&r.state)
    );
    if !r.note.is_empty() {
        let _ = write!(s, r#"<p id="note"><b>Note:</b> {}</p>"#, esc(&r.note));
    }
    s.push_str("<h2>Test conditions</h2><table id=\"setup\">");
    if let Some(o) = r.setup.as_object() {
        for (k, val) in o {
            let _ = write!(
                s,
                "<tr><th>{}</th><td>{}</td></tr>",
                esc(k),
                esc(&val.as_str().map_or_else(|| val.to_string(), String::from))
            );
        }
    }
    if let Ok(t) =
        serde_json::from_value::<super::tests::Template>(serde_json::Value::String(r.test.clone()))
    {
        let runs: Vec<String> = t.runs().iter().map(|(p, d)| format!("{p} {d}")).collect();
        let _ = write!(s, "<tr><th>runs</th><td>{}</td></tr>", runs.join(", "));
    }
    let runs = recorded(store, id);
    for (run, mean, lo, hi) in temperatures(&runs) {
        let _ = write!(
            s,
            "<tr><th>bar temperature, {}</th><td>{mean:.2} °C ({lo:.2} … {hi:.2})</td></tr>",
            esc(&run)
        );
    }
    s.push_str("</table>");
    s.push_str("<h2>Polar plots</h2><div id=\"plots\">");
    for (name, svg) in plots(&runs, &r.replay) {
        let body = svg.find("<svg").map_or(svg.as_str(), |k| &svg[k..]);
        let _ = write!(
            s,
            "<figure><figcaption>{}</figcaption>{body}</figure>",
            esc(&name)
        );
    }
    s.push_str("</div>");
    if let Some((_, r0)) = runs.first()
        && r0.meta.pattern.name() == "CIRCLE"
    {
        let axes = match r0.meta.config.setup.circle_plane {
            ballpod::config::CirclePlane::XY => ["X", "Y"],
            ballpod::config::CirclePlane::YZ => ["Y", "Z"],
            ballpod::config::CirclePlane::ZX => ["Z", "X"],
        };
        let d = diagnoses(&v.figures, axes);
        s.push_str("<h2>Diagnoses</h2><ul id=\"diagnoses\">");
        if d.is_empty() {
            s.push_str("<li>no fault named (none at least 3 u from zero)</li>");
        }
        for line in d {
            let _ = write!(s, "<li>{}</li>", esc(&line));
        }
        s.push_str("</ul>");
    }
    s.push_str("<h2>Figures</h2><p>U = k·u for about 95 % (k = 2, or Student's t at the figure's degrees of freedom). Decisions by ISO 14253-1: conformance proven when the value is inside the tolerance by more than U, non-conformance when outside by more than U, else undecided.</p>");
    s.push_str("<table id=\"figures\"><tr><th>figure</th><th>value</th><th>U</th><th>unit</th><th>tolerance</th><th>decision</th><th>largest contributors to u</th></tr>");
    for f in &v.figures {
        let tol = f.tolerance.map_or(String::new(), |t| {
            format!(
                "{} … {}",
                t.lower.map_or("".into(), |l| l.to_string()),
                t.upper.map_or("".into(), |h| h.to_string())
            )
        });
        let (class, words) = f.decision.map_or((String::new(), ""), |d| {
            (
                serde_json::to_value(d)
                    .ok()
                    .and_then(|x| x.as_str().map(String::from))
                    .unwrap_or_default(),
                d.words(),
            )
        });
        let contributors: Vec<String> = f
            .contributors
            .iter()
            .map(|(n, u)| format!("{} {u:.4}", esc(n)))
            .collect();
        let _ = write!(
            s,
            r#"<tr data-name="{n}" class="{class}"><td>{n}</td><td class="value">{}</td><td class="U">{}</td><td>{}</td><td>{tol}</td><td class="decision">{words}</td><td>{}</td></tr>"#,
            format_args!("{:.4}", f.value),
            num(f.expanded_u),
            esc(&unit_text(&f.unit)),
            contributors.join(", "),
            n = esc(&f.name)
        );
    }
    s.push_str("</table><h2>Trend of this machine</h2>");
    let tol = store.tolerances(m.id)?;
    for (figure, t) in &tol {
        let points = trend(store, m.id, figure)?;
        let unit = v
            .figures
            .iter()
            .find(|f| &f.name == figure)
            .map_or("", |f| f.unit.as_str());
        s.push_str(&trend_svg(&points, Some(*t), figure, unit));
    }
    let _ = write!(
        s,
        r#"<h2>Traceability</h2><table id="trace"><tr><th>machine</th><td>{} {} {}, serial {} ({})</td></tr><tr><th>pod</th><td>{}</td></tr>{}<tr><th>replay of the recorded stream</th><td>{}</td></tr><tr><th>report made</th><td>{}</td></tr></table></body></html>"#,
        esc(&m.builder),
        esc(&m.model),
        esc(&m.name),
        esc(&m.serial),
        esc(&m.kinematics),
        esc(&r.pod_identity),
        instrument_rows(&runs),
        if r.state != "done" {
            "not replayed".to_string()
        } else if r.replay_check.is_empty() {
            "equal to the pod's results, digit for digit".to_string()
        } else {
            esc(&r.replay_check)
        },
        super::store::now()
    );
    Ok(s)
}
