//! SVG polar plots written by hand, in the style ball-bar users know: the nominal circle, ΔL
//! magnified about it (outward = longer), the CW and CCW traces, the fitted circle(s), and a
//! legend with the figures (G, F, H, diagnoses or eccentricities).
//!
//! Each trace point is a 1° bin mean of the run's samples, placed along the sample's
//! sensitive direction n (`ballpod::metrology::pattern::ArcGeometry::direction`, the
//! core's own) at radius `R_px + k·ΔL`. The fitted curve is r0 + e·n for n around the arc.
//! The root `<svg>` carries the plot's scale as data attributes (`data-cx`, `data-cy`,
//! `data-nominal-px`, `data-px-per-um`) so a reader can turn points back into µm; traces are
//! `<polyline id="trace-ccw|trace-cw">`, fits `<polyline id="fit-ccw|fit-cw">`, the nominal
//! circle `<circle id="nominal">`, legend lines `<text class="legend">`.

use std::fmt::Write;

use ballpod::acquisition::Sample;
use ballpod::app::bc_ballbar::Setup;
use ballpod::app::circle::CircleGeometry;
use ballpod::app::{Direction, Pattern};
use ballpod::metrology::pattern::ArcGeometry;

use crate::recording::RecordedRun;
use crate::replay::{Report, RunReport};
use crate::vmt::machine::CircleMachine;

const SIZE: f64 = 640.0;
const CX: f64 = 320.0;
const CY: f64 = 300.0;
const NOMINAL_PX: f64 = 170.0;

/// One trace: bin means (n_u, n_v, ΔL µm).
struct Trace {
    id: &'static str,
    colour: &'static str,
    points: Vec<(f64, f64, f64)>,
}

/// A fitted curve ΔL = r0 + e·n.
struct Fit {
    id: &'static str,
    colour: &'static str,
    r0_um: f64,
    e_um: [f64; 2],
}

/// 1° bin means of the run's (n, ΔL), bins by the angle of n.
fn bin_means(g: &ArcGeometry, samples: &[Sample]) -> Vec<(f64, f64, f64)> {
    let mut bins = vec![(0.0f64, 0.0f64, 0.0f64, 0usize); 360];
    for s in samples {
        if !s.flags.is_valid_for_metrology() {
            continue;
        }
        let Some([nu, nv]) = g.direction(&s.axes) else {
            continue;
        };
        let a = f64::from(nv)
            .atan2(f64::from(nu))
            .to_degrees()
            .rem_euclid(360.0);
        let b = &mut bins[(a as usize).min(359)];
        b.0 += f64::from(nu);
        b.1 += f64::from(nv);
        b.2 += f64::from(s.delta_l_um);
        b.3 += 1;
    }
    bins.into_iter()
        .filter(|b| b.3 > 0)
        .map(|(u, v, d, n)| {
            let k = n as f64;
            let norm = (u * u + v * v).sqrt().max(1e-12);
            (u / norm, v / norm, d / k)
        })
        .collect()
}

fn px(nu: f64, nv: f64, dl_um: f64, k: f64) -> (f64, f64) {
    let r = NOMINAL_PX + k * dl_um;
    // SVG y grows downwards: +v is up
    (CX + r * nu, CY - r * nv)
}

fn render(title: &str, traces: &[Trace], fits: &[Fit], legend: &[String]) -> String {
    // scale: the largest |ΔL| reaches 60 % of the nominal radius, in a 1-2-5 µm/division step
    let max_dl = traces
        .iter()
        .flat_map(|t| t.points.iter().map(|p| p.2.abs()))
        .fold(0.5f64, f64::max);
    let raw = max_dl / 3.0; // µm per division, 5 divisions ≈ 0.6 R
    let mag = 10f64.powf(raw.log10().floor());
    let div_um = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|d| *d >= raw)
        .unwrap_or(10.0 * mag);
    let k = NOMINAL_PX * 0.6 / max_dl; // px per µm
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{SIZE}" height="{h}" viewBox="0 0 {SIZE} {h}" data-cx="{CX}" data-cy="{CY}" data-nominal-px="{NOMINAL_PX}" data-px-per-um="{k}" font-family="sans-serif" font-size="12">"#,
        h = SIZE + 16.0 * legend.len() as f64
    );
    let _ = writeln!(s, r#"<title>{}</title>"#, esc(title));
    let _ = writeln!(
        s,
        r#"<rect x="0" y="0" width="100%" height="100%" fill="white"/>"#
    );
    let _ = writeln!(
        s,
        r#"<text x="10" y="18" font-size="14" font-weight="bold">{}</text>"#,
        esc(title)
    );
    // grid: nominal circle and ±divisions
    for i in -2i32..=2 {
        let r = NOMINAL_PX + k * div_um * f64::from(i);
        if r <= 0.0 {
            continue;
        }
        if i == 0 {
            let _ = writeln!(
                s,
                r##"<circle id="nominal" cx="{CX}" cy="{CY}" r="{NOMINAL_PX}" fill="none" stroke="#444" stroke-width="1"/>"##
            );
        } else {
            let _ = writeln!(
                s,
                r##"<circle cx="{CX}" cy="{CY}" r="{r:.3}" fill="none" stroke="#ccc" stroke-dasharray="3 3"/>"##
            );
        }
    }
    let _ = writeln!(
        s,
        r##"<line x1="{}" y1="{CY}" x2="{}" y2="{CY}" stroke="#ccc"/><line x1="{CX}" y1="{}" x2="{CX}" y2="{}" stroke="#ccc"/>"##,
        CX - NOMINAL_PX * 1.7,
        CX + NOMINAL_PX * 1.7,
        CY - NOMINAL_PX * 1.7,
        CY + NOMINAL_PX * 1.7
    );
    for f in fits {
        let pts: Vec<String> = (0..=360)
            .map(|d| {
                let a = f64::from(d).to_radians();
                let (nu, nv) = (a.cos(), a.sin());
                let dl = f.r0_um + f.e_um[0] * nu + f.e_um[1] * nv;
                let (x, y) = px(nu, nv, dl, k);
                format!("{x:.3},{y:.3}")
            })
            .collect();
        let _ = writeln!(
            s,
            r#"<polyline id="{}" fill="none" stroke="{}" stroke-width="1" stroke-dasharray="6 3" points="{}" data-r0-um="{}" data-e-um="{} {}"/>"#,
            f.id,
            f.colour,
            pts.join(" "),
            f.r0_um,
            f.e_um[0],
            f.e_um[1]
        );
    }
    for t in traces {
        let pts: Vec<String> = t
            .points
            .iter()
            .map(|&(nu, nv, dl)| {
                let (x, y) = px(nu, nv, dl, k);
                format!("{x:.3},{y:.3}")
            })
            .collect();
        let _ = writeln!(
            s,
            r#"<polyline id="{}" fill="none" stroke="{}" stroke-width="1.5" points="{}"/>"#,
            t.id,
            t.colour,
            pts.join(" ")
        );
    }
    let _ = writeln!(
        s,
        r#"<text x="10" y="{}" class="scale">{} µm/div (magnified about the nominal circle)</text>"#,
        SIZE - 12.0,
        fmt_num(div_um)
    );
    for (i, l) in legend.iter().enumerate() {
        let _ = writeln!(
            s,
            r#"<text x="10" y="{:.0}" class="legend">{}</text>"#,
            SIZE + 4.0 + 16.0 * i as f64,
            esc(l)
        );
    }
    s.push_str("</svg>\n");
    s
}

fn fmt_num(v: f64) -> String {
    format!("{v}")
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// The run's fit r0 + e·n from its report.
fn fit_of(id: &'static str, colour: &'static str, r: &RunReport) -> Option<Fit> {
    let v = |n: &str| {
        r.results
            .iter()
            .find(|f| f.name == n)
            .map(|f| f64::from(f.value))
    };
    Some(Fit {
        id,
        colour,
        r0_um: v("r0")?,
        e_um: [v("ecc_u")?, v("ecc_v")?],
    })
}

/// The value of a result of the report, `NaN` if not valid.
fn figure(r: &Report, name: &str) -> f64 {
    r.result(name).map_or(f64::NAN, |f| f64::from(f.value))
}

/// All plots of a session: `iso230_4.svg` (the last CCW and CW circles) and one
/// `seed002_<STEP>.svg` per step (its first CW/CCW pair).
pub fn plots(runs: &[(String, RecordedRun)], report: &Report) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let done = |p: Pattern, d: Direction| {
        runs.iter()
            .zip(&report.runs)
            .filter(move |((_, rr), rep)| {
                rr.meta.pattern == p && rr.meta.direction == d && rep.outcome == "DONE"
            })
            .map(|((_, rr), rep)| (rr, rep))
    };
    let samples = |rr: &RecordedRun| rr.samples().copied().collect::<Vec<Sample>>();
    if let (Some((ccw, rccw)), Some((cw, rcw))) = (
        done(Pattern::Circle, Direction::Ccw).next_back(),
        done(Pattern::Circle, Direction::Cw).next_back(),
    ) && let Ok(g) = CircleGeometry::from_config(&ccw.meta.config.setup)
    {
        let f = |n| figure(report, n);
        let legend = vec![
            format!(
                "ISO 230-4 circle R = {} mm, F{} mm/min. CCW (blue) and CW (red) traces, dashed: fitted circles",
                g.radius_mm, g.feed_mm_per_min
            ),
            format!(
                "G(CCW) = {:.2} µm  G(CW) = {:.2} µm  G(b) = {:.2} µm  H = {:.2} µm",
                f("G_ccw"),
                f("G_cw"),
                f("G_bidir"),
                f("H")
            ),
            format!(
                "F(CCW) = {:+.2}/{:+.2} µm  F(CW) = {:+.2}/{:+.2} µm",
                f("F_max_ccw"),
                f("F_min_ccw"),
                f("F_max_cw"),
                f("F_min_cw")
            ),
            format!(
                "Squareness {:.1} µrad  Scale mismatch {:.1} µm/m  Reversal u {:.2} µm  v {:.2} µm",
                f("squareness"),
                f("scale_mismatch"),
                f("reversal_u"),
                f("reversal_v")
            ),
            format!(
                "Cyclic error {:.2} µm (order {})  Servo mismatch {:.2} ms",
                f("cyclic_amplitude"),
                f("cyclic_order"),
                f("servo_mismatch")
            ),
        ];
        let svg = render(
            "ISO 230-4 circular test",
            &[
                Trace {
                    id: "trace-ccw",
                    colour: "#1f4fd1",
                    points: bin_means(&g.fit.geometry, &samples(ccw)),
                },
                Trace {
                    id: "trace-cw",
                    colour: "#d12a1f",
                    points: bin_means(&g.fit.geometry, &samples(cw)),
                },
            ],
            &[
                fit_of("fit-ccw", "#1f4fd1", rccw),
                fit_of("fit-cw", "#d12a1f", rcw),
            ]
            .into_iter()
            .flatten()
            .collect::<Vec<_>>(),
            &legend,
        );
        out.push(("iso230_4.svg".to_string(), svg));
    }
    for step in Pattern::SEED002 {
        let (Some((ccw, rccw)), Some((cw, rcw))) = (
            done(step, Direction::Ccw).next(),
            done(step, Direction::Cw).next(),
        ) else {
            continue;
        };
        let Ok(setup) = Setup::from_config(&ccw.meta.config.setup) else {
            continue;
        };
        let g = setup.fit_geometry(step);
        let (c1, c2) = if matches!(step, Pattern::Bx | Pattern::By) {
            ("ex", "ez")
        } else {
            ("ex", "ey")
        };
        let e = |r: &RunReport, n: &str| {
            r.results
                .iter()
                .find(|f| f.name == n)
                .map_or(f64::NAN, |f| f64::from(f.value))
        };
        let name = step.name();
        let mean = |k: &str| {
            report
                .result(&format!("e_{name}_{k}"))
                .map_or((f64::NAN, f64::NAN), |f| {
                    (f64::from(f.value), f.u.map_or(f64::NAN, f64::from))
                })
        };
        let ((m1, u1), (m2, u2)) = if matches!(step, Pattern::Bx | Pattern::By) {
            (mean("x"), mean("z"))
        } else {
            (mean("x"), mean("y"))
        };
        let legend = vec![
            format!(
                "Seed 002 step {name} (first repeat): CCW (blue) and CW (red), dashed: fitted limaçon r0 + e·n"
            ),
            format!(
                "CCW: {c1} = {:.3} µm, {c2} = {:.3} µm;  CW: {c1} = {:.3} µm, {c2} = {:.3} µm",
                e(rccw, "ecc_u"),
                e(rccw, "ecc_v"),
                e(rcw, "ecc_u"),
                e(rcw, "ecc_v")
            ),
            format!("Step mean: {c1} = {m1:.3} ± {u1:.3} µm, {c2} = {m2:.3} ± {u2:.3} µm"),
        ];
        let svg = render(
            &format!("Seed 002 {name}"),
            &[
                Trace {
                    id: "trace-ccw",
                    colour: "#1f4fd1",
                    points: bin_means(&g, &samples(ccw)),
                },
                Trace {
                    id: "trace-cw",
                    colour: "#d12a1f",
                    points: bin_means(&g, &samples(cw)),
                },
            ],
            &[
                fit_of("fit-ccw", "#1f4fd1", rccw),
                fit_of("fit-cw", "#d12a1f", rcw),
            ]
            .into_iter()
            .flatten()
            .collect::<Vec<_>>(),
            &legend,
        );
        out.push((format!("seed002_{name}.svg"), svg));
    }
    out
}

/// One fault alone on the virtual machine's circle ([`CircleMachine`]) for the book's
/// signature plots: (file stem, title, the machine, whether the plot keeps the circle's radius
/// change, and the legend: model, signature, what the pod reports).
type Signature = (
    &'static str,
    &'static str,
    CircleMachine,
    bool,
    [&'static str; 3],
);

/// The faults of the book's signature plots, each alone on a 150 mm circle at F1000.
fn signatures() -> Vec<Signature> {
    let p = CircleMachine::perfect;
    vec![
        (
            "squareness",
            "Out-of-squareness 20 µrad",
            CircleMachine {
                squareness_urad: 20.0,
                ..p()
            },
            false,
            [
                "Model: E_x = S·y (Y leans towards +X)",
                "Signature: (S·R/2)·sin 2θ, a 45° ellipse, the same both directions",
                "Reported: squareness S, µrad",
            ],
        ),
        (
            "scale_mismatch",
            "Scale mismatch 20 µm/m",
            CircleMachine {
                scale_x_um_per_m: 10.0,
                scale_y_um_per_m: -10.0,
                ..p()
            },
            false,
            [
                "Model: E_x = k_x·x, E_y = k_y·y, k_x − k_y = 20 µm/m",
                "Signature: ((k_x − k_y)·R/2)·cos 2θ, an ellipse along the axes",
                "Reported: scale_mismatch k_u − k_v, µm/m (full circle only)",
            ],
        ),
        (
            "reversal",
            "Reversal steps of X, 4 µm",
            CircleMachine {
                backlash_x_um: 4.0,
                ..p()
            },
            false,
            [
                "Model: X lags B/2 behind its direction of travel",
                "Signature: a step of B where X reverses (0°, 180°), opposite in CW",
                "Reported: reversal_u_pos, reversal_u_neg (each point), reversal_u (mean), µm",
            ],
        ),
        (
            "straightness",
            "Straightness of X, 4 µm over the diameter",
            CircleMachine {
                straightness_y_along_x_um: 4.0,
                ..p()
            },
            false,
            [
                "Model: X's path bows across it, E_y = s·(x/R)²",
                "Signature: (s/4)·sin 3θ about the fitted circle, the same both directions",
                "Reported: straightness_u s, µm (full circle only)",
            ],
        ),
        (
            "cyclic",
            "Cyclic error 1 µm, 8 per revolution",
            CircleMachine {
                cyclic_amplitude_um: 1.0,
                ..p()
            },
            false,
            [
                "Model: a radial error periodic in angle, A·cos(kθ + φ)",
                "Signature: k lobes, the same both directions",
                "Reported: cyclic_amplitude A, µm; cyclic_order k (4–16, full circle only)",
            ],
        ),
        (
            "servo_mismatch",
            "Servo mismatch 1 ms",
            CircleMachine {
                servo_lag_x_ms: 1.0,
                ..p()
            },
            false,
            [
                "Model: X follows its command 1 ms later than Y",
                "Signature: a 45° ellipse whose sign flips with the direction",
                "Reported: servo_mismatch τ_u − τ_v, ms (needs circle_feed)",
            ],
        ),
        (
            "mean_scale",
            "Mean scale 20 µm/m (both axes)",
            CircleMachine {
                scale_x_um_per_m: 20.0,
                scale_y_um_per_m: 20.0,
                ..p()
            },
            true,
            [
                "Model: E_x = k·x, E_y = k·y",
                "Signature: a larger circle, r0 = R·k (about the nominal circle)",
                "Reported: scale_mean (k_u + k_v)/2, µm/m, relative to the bar's length",
            ],
        ),
        (
            "lateral_play",
            "Lateral play of X, 4 µm",
            CircleMachine {
                lateral_play_x_um: 4.0,
                ..p()
            },
            false,
            [
                "Model: X's carriage runs p/2 towards +Y while X travels +, −Y while −",
                "Signature: a cusp (p/2)·|sin θ| at X's reversal points, its sign flipping with the direction",
                "Reported: lateral_play_u p, µm (full circle only)",
            ],
        ),
        (
            "spike",
            "Reversal spike of X, 4 µm (τ 400 ms: drawn wide)",
            CircleMachine {
                reversal_spike_x_um: 4.0,
                reversal_spike_ms: 400.0,
                ..p()
            },
            false,
            [
                "Model: after X reverses it stays behind its command by h·e^(−Δt/τ)",
                "Signature: an outward spike where X reverses (180°), usually narrower than 1°",
                "Reported: spike_u_neg h, µm; spike_time_u_neg τ, ms (from the samples themselves)",
            ],
        ),
        (
            "vibration",
            "Vibration of X, 2 µm (at 0.5 Hz: drawn slow)",
            CircleMachine {
                vibration_x_um: 2.0,
                vibration_hz: 0.5,
                ..p()
            },
            false,
            [
                "Model: X oscillates in time, E_x = A·sin(2πf·t)",
                "Signature: a wave along X (full at 0°/180°, none at 90°/270°), not tied to the angle",
                "Reported: vibration_u A, µm; vibration_frequency f, Hz (31–450 Hz at 1 kHz)",
            ],
        ),
        (
            "stick_slip",
            "Stick-slip of X, 2 µm (at 0.5 Hz for 6 s: drawn slow)",
            CircleMachine {
                stick_slip_x_um: 2.0,
                stick_slip_hz: 0.5,
                stick_slip_ms: 6000.0,
                ..p()
            },
            false,
            [
                "Model: after X reverses it sticks and slips, E_x = a·sin(2πf·Δt)",
                "Signature: an oscillation from X's reversal (180°) on, none before it",
                "Reported: stick_slip_u a, µm; stick_slip_frequency f, Hz (from the samples)",
            ],
        ),
    ]
}

/// Where the book keeps the signature plots ([`signature_plots`]), from the repository's root.
pub const SIGNATURE_DIR: &str = "docs/src/images/signatures";

/// The book's polar plot of each ball-bar diagnosis's signature ([`SIGNATURE_DIR`]):
/// each fault alone on the virtual machine's circle ([`CircleMachine::pose`], the forward
/// model, noise-free), CCW and CW, one point a degree, about each direction's least-squares
/// circle (the mean scale's about the nominal one).
pub fn signature_plots() -> Vec<(String, String)> {
    signatures()
        .into_iter()
        .map(|(stem, title, m, keep_r0, legend)| {
            let trace = |id: &'static str, colour: &'static str, dir: f64| {
                let th: Vec<f64> = (0..360).map(|d| f64::from(d).to_radians()).collect();
                let dl: Vec<f64> = th.iter().map(|t| m.pose(dir * t, dir).0).collect();
                let rows: Vec<Vec<f64>> = th
                    .iter()
                    .map(|t| vec![1.0, (dir * t).cos(), (dir * t).sin()])
                    .collect();
                let (x, _) = crate::oracle::lstsq(&rows, &dl);
                let r0 = if keep_r0 { 0.0 } else { x[0] };
                let points = rows
                    .iter()
                    .zip(&dl)
                    .map(|(g, d)| (g[1], g[2], d - r0 - x[1] * g[1] - x[2] * g[2]))
                    .collect();
                Trace { id, colour, points }
            };
            let svg = render(
                title,
                &[
                    trace("trace-ccw", "#1f4fd1", 1.0),
                    trace("trace-cw", "#d12a1f", -1.0),
                ],
                &[],
                &legend
                    .iter()
                    .map(|s| s.to_string())
                    .chain(["CCW blue, CW red; R 150 mm, F1000, noise-free".to_string()])
                    .collect::<Vec<_>>(),
            );
            (format!("{stem}.svg"), svg)
        })
        .collect()
}
