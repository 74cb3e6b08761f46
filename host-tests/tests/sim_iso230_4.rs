//! ISO 230-4 circle on the virtual machine tool: the CCW and CW runs armed, started and stopped
//! on the simulated pod; the injected linear-axis faults come back from the pod's results table
//! (its diagnoses) with their injected sizes (±10 %), and the polar plot (parsed with
//! roxmltree, a third-party XML parser) shows what its legend says.

use ballpod_host::replay::Report;
use ballpod_host::report;
use ballpod_host::simulate::{SimOptions, SimSession, simulate};
use ballpod_host::vmt::machine::MachineFile;

fn session() -> (MachineFile, SimSession) {
    let m = MachineFile::default();
    let o = SimOptions {
        seed: 11,
        repeats: 1,
        feed_mm_per_min: 1000.0,
        seed002: false,
        circle: true,
        three_planes: false,
        feed_sweep: Vec::new(),
        nc_dir: None,
    };
    let s = simulate(&m, &o, &mut |_, _, _| {}).expect("simulated session");
    (m, s)
}

/// The CCW and CW circle of machine `m` on the simulated pod (noise seed `seed`): its report.
fn circle_pair(m: &MachineFile, seed: u64) -> Report {
    let o = SimOptions {
        seed,
        repeats: 1,
        seed002: false,
        circle: true,
        three_planes: false,
        ..SimOptions::default()
    };
    simulate(m, &o, &mut |_, _, _| {})
        .expect("simulated session")
        .report
}

/// The value of result `name` of the pod's table (it must be valid).
fn value(r: &Report, name: &str) -> f64 {
    f64::from(
        r.result(name)
            .unwrap_or_else(|| panic!("{name} not valid"))
            .value,
    )
}

fn within_10_percent(name: &str, injected: f64, diagnosed: f64) {
    assert!(
        (diagnosed / injected - 1.0).abs() <= 0.10,
        "{name}: injected {injected}, diagnosed {diagnosed}"
    );
}

#[test]
fn injected_faults_are_diagnosed_with_their_sizes() {
    let (m, s) = session();
    let r = &s.report;
    assert_eq!(
        r.runs
            .iter()
            .map(|x| (x.pattern.as_str(), x.direction.as_str(), x.outcome.as_str()))
            .collect::<Vec<_>>(),
        [("CIRCLE", "CCW", "DONE"), ("CIRCLE", "CW", "DONE")]
    );
    let c = &m.circle;
    within_10_percent("squareness", c.squareness_urad, value(r, "squareness"));
    within_10_percent(
        "scale mismatch",
        c.scale_x_um_per_m - c.scale_y_um_per_m,
        value(r, "scale_mismatch"),
    );
    // the XY plane: u = X, v = Y
    within_10_percent("reversal X", c.backlash_x_um, value(r, "reversal_u"));
    within_10_percent("reversal Y", c.backlash_y_um, value(r, "reversal_v"));
    within_10_percent(
        "cyclic",
        c.cyclic_amplitude_um,
        value(r, "cyclic_amplitude"),
    );
    assert_eq!(value(r, "cyclic_order"), f64::from(c.cyclic_order));
    within_10_percent(
        "servo mismatch",
        c.servo_mismatch_ms(),
        value(r, "servo_mismatch"),
    );
    // units as the table states them
    for (name, unit) in [
        ("squareness", "urad"),
        ("scale_mismatch", "um/m"),
        ("reversal_u", "um"),
        ("servo_mismatch", "ms"),
        ("G_bidir", "um"),
    ] {
        assert_eq!(r.result(name).expect(name).unit, unit, "{name}");
    }
}

/// Radial deviation (µm) of an SVG point from the plot's data attributes.
fn dl_of(x: f64, y: f64, cx: f64, cy: f64, nominal: f64, k: f64) -> (f64, f64) {
    let (dx, dy) = (x - cx, cy - y);
    let r = (dx * dx + dy * dy).sqrt();
    (dy.atan2(dx), (r - nominal) / k)
}

fn points(node: roxmltree::Node) -> Vec<(f64, f64)> {
    node.attribute("points")
        .expect("points")
        .split_whitespace()
        .map(|p| {
            let (x, y) = p.split_once(',').expect("x,y");
            (x.parse().expect("x"), y.parse().expect("y"))
        })
        .collect()
}

#[test]
fn the_polar_plot_is_well_formed_and_shows_what_its_legend_says() {
    let (_, s) = session();
    let r = &s.report;
    let plots = report::plots(&s.runs, r);
    let (_, svg) = plots
        .iter()
        .find(|(n, _)| n == "iso230_4.svg")
        .expect("ISO plot");
    let doc = roxmltree::Document::parse(svg).expect("well-formed SVG");
    let root = doc.root_element();
    assert_eq!(root.tag_name().name(), "svg");
    let attr = |n: &str| -> f64 { root.attribute(n).expect(n).parse().expect(n) };
    let (cx, cy, nominal, k) = (
        attr("data-cx"),
        attr("data-cy"),
        attr("data-nominal-px"),
        attr("data-px-per-um"),
    );
    let by_id = |id: &str| {
        doc.descendants()
            .find(|n| n.attribute("id") == Some(id))
            .unwrap_or_else(|| panic!("no #{id}"))
    };
    let legend: String = doc
        .descendants()
        .filter(|n| n.attribute("class") == Some("legend"))
        .filter_map(|n| n.text())
        .collect::<Vec<_>>()
        .join("\n");
    // the legend states G per direction: recover G from the drawn trace and fitted circle
    for dir in ["ccw", "cw"] {
        let g_json = value(r, &format!("G_{dir}"));
        let label = format!("G({}) = {:.2} µm", dir.to_uppercase(), g_json);
        assert!(legend.contains(&label), "legend lacks {label}:\n{legend}");
        let fit = by_id(&format!("fit-{dir}"));
        let r0: f64 = fit
            .attribute("data-r0-um")
            .expect("r0")
            .parse()
            .expect("r0");
        let e: Vec<f64> = fit
            .attribute("data-e-um")
            .expect("e")
            .split(' ')
            .map(|v| v.parse().expect("e"))
            .collect();
        let pts = points(by_id(&format!("trace-{dir}")));
        assert!(pts.len() >= 350, "{} trace points", pts.len());
        let dev: Vec<f64> = pts
            .iter()
            .map(|&(x, y)| {
                let (a, dl) = dl_of(x, y, cx, cy, nominal, k);
                dl - (r0 + e[0] * a.cos() + e[1] * a.sin())
            })
            .collect();
        let g_plot = dev.iter().cloned().fold(f64::MIN, f64::max)
            - dev.iter().cloned().fold(f64::MAX, f64::min);
        // the plot's 1° bins and 3-decimal pixels against the core's bins
        assert!(
            (g_plot - g_json).abs() <= 0.05 * g_json + 0.05,
            "{dir}: G from the plot {g_plot} vs legend {g_json}"
        );
        // the dashed circle is the run's own fit
        let run = r
            .runs
            .iter()
            .find(|x| x.direction == dir.to_uppercase())
            .expect("run");
        let of = |n: &str| {
            f64::from(
                run.results
                    .iter()
                    .find(|f| f.name == n)
                    .expect("run result")
                    .value,
            )
        };
        assert_eq!((r0, e[0], e[1]), (of("r0"), of("ecc_u"), of("ecc_v")));
    }
    // the CW/CCW traces differ where the legend says there is hysteresis
    assert!(legend.contains(&format!("H = {:.2} µm", value(r, "H"))));
    assert!(legend.contains("Squareness") && legend.contains("Reversal"));
    assert!(by_id("nominal").attribute("r").is_some());
}

/// Reversal spikes on the virtual machine (X 4 µm, τ 8 ms; Y none) come back at each point of
/// X with their height and time constant, and none at Y's, from the pod's results table.
#[test]
fn reversal_spikes_come_back_at_each_point_with_their_height() {
    let mut m = MachineFile::default();
    m.circle.reversal_spike_x_um = 4.0;
    m.circle.reversal_spike_ms = 8.0;
    let r = &circle_pair(&m, 12);
    let get = |n: &str| {
        let v = r.result(n).unwrap_or_else(|| panic!("{n} not valid"));
        (f64::from(v.value), v.u.map(f64::from))
    };
    // X reverses at 180° in both runs (a full turn from 0°: 0°/360° is its start and end)
    let (h, u) = get("spike_u_neg");
    let u = u.expect("u");
    assert!((h - 4.0).abs() <= 3.0 * u, "spike_u_neg {h} ± {u}");
    let (tau, _) = get("spike_time_u_neg");
    assert!((tau / 8.0 - 1.0).abs() < 0.2, "τ {tau} ms");
    for n in ["spike_v_pos", "spike_v_neg"] {
        let (h, u) = get(n);
        let u = u.expect("u");
        assert!(h.abs() <= 3.0 * u, "{n} {h} ± {u}");
    }
    // 0° is the runs' start and end: no window about it
    assert!(r.result("spike_u_pos").is_none());
}

/// Vibration and stick-slip on the virtual machine (X vibrates 1.5 µm at 120 Hz, Y sticks and
/// slips 2 µm at 60 Hz after each reversal; with the default machine's other faults and the
/// full sensor chain) come back from the pod's results table: each amplitude and frequency
/// within 3u, named on its axis (`oscillations_named` 1 + 8), the other axis's not.
#[test]
fn vibration_and_stick_slip_come_back_per_axis() {
    let mut m = MachineFile::default();
    m.circle.vibration_x_um = 1.5;
    m.circle.vibration_hz = 120.0;
    m.circle.stick_slip_y_um = 2.0;
    m.circle.stick_slip_hz = 60.0;
    let r = &circle_pair(&m, 13);
    let get = |n: &str| {
        let v = r.result(n).unwrap_or_else(|| panic!("{n} not valid"));
        (f64::from(v.value), v.u.map(f64::from).expect("u"))
    };
    for (n, truth) in [
        ("vibration_u", 1.5),
        ("vibration_frequency", 120.0),
        ("stick_slip_v", 2.0),
        ("stick_slip_frequency", 60.0),
    ] {
        let (x, u) = get(n);
        println!("{n}: {x:.3} ± {u:.3} (injected {truth})");
        assert!(
            (x - truth).abs() <= 3.0 * u,
            "{n} {x} ± {u}, injected {truth}"
        );
    }
    assert_eq!(get("oscillations_named").0, 9.0);
    for n in ["vibration_v", "stick_slip_u"] {
        let (x, u) = get(n);
        assert!(x <= 3.0 * u, "{n} {x} ± {u}");
    }
}

/// Lateral play on the virtual machine (X 3 µm, Y −2 µm, with the default machine's other
/// faults and the full sensor chain) comes back for each axis within 3u (the u of the pod's
/// results table, its own and the bar's), is named, and leaves the other diagnoses where the
/// machine without it puts them (within their u).
#[test]
fn lateral_play_comes_back_per_axis_and_moves_no_other_diagnosis() {
    let o = SimOptions {
        seed: 14,
        repeats: 1,
        seed002: false,
        circle: true,
        three_planes: false,
        ..SimOptions::default()
    };
    let run = |m: &MachineFile| {
        simulate(m, &o, &mut |_, _, _| {})
            .expect("simulated session")
            .report
    };
    let mut m = MachineFile::default();
    let without = run(&m);
    m.circle.lateral_play_x_um = 3.0;
    m.circle.lateral_play_y_um = -2.0;
    let with = run(&m);
    for (n, truth) in [("lateral_play_u", 3.0), ("lateral_play_v", -2.0)] {
        let v = with.result(n).unwrap_or_else(|| panic!("{n} not valid"));
        let u = f64::from(v.u.expect("u"));
        let got = f64::from(v.value);
        assert!((got - truth).abs() <= 3.0 * u, "{n} {got} ± {u}");
    }
    let named = with.result("faults_named").expect("faults_named").value as u32;
    assert_eq!(named & (128 | 256), 128 | 256, "faults_named {named}");
    for n in [
        "squareness",
        "scale_mismatch",
        "reversal_u",
        "reversal_v",
        "cyclic_amplitude",
        "straightness_u",
        "straightness_v",
    ] {
        let (a, b) = (without.result(n).expect(n), with.result(n).expect(n));
        let u = f64::from(a.u.expect("u")).hypot(f64::from(b.u.expect("u")));
        let d = f64::from(b.value) - f64::from(a.value);
        assert!(d.abs() <= 3.0 * u, "{n} moved by {d} (u {u})");
    }
}
