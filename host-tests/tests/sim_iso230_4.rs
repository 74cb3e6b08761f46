//! ISO 230-4 circle on the virtual machine tool: the injected linear-axis faults come back
//! from the core's diagnostics with their injected sizes (±10 %), and the polar plot (parsed
//! with roxmltree, a third-party XML parser) shows what its legend says.

use ballpod_host::analysis::{IsoResult, Results, analyse};
use ballpod_host::report;
use ballpod_host::simulate::{SimOptions, SimSession, simulate};
use ballpod_host::vmt::machine::MachineFile;

fn session() -> (MachineFile, SimSession, Results) {
    let m = MachineFile::default();
    let o = SimOptions {
        seed: 11,
        repeats: 1,
        feed_mm_per_min: 1000.0,
        seed002: false,
        circle: true,
    };
    let s = simulate(&m, &o, &mut |_, _, _| {});
    let r = analyse(&s.desc, &s.runs).expect("analysis");
    (m, s, r)
}

fn within_10_percent(name: &str, injected: f64, diagnosed: f64) {
    assert!(
        (diagnosed / injected - 1.0).abs() <= 0.10,
        "{name}: injected {injected}, diagnosed {diagnosed}"
    );
}

#[test]
fn injected_faults_are_diagnosed_with_their_sizes() {
    let (m, _, r) = session();
    let c = &m.circle;
    let iso: &IsoResult = r.iso230_4.as_ref().expect("both directions");
    let d = &iso.diagnostics;
    within_10_percent(
        "squareness",
        c.squareness_urad,
        f64::from(d.squareness_urad),
    );
    within_10_percent(
        "scale mismatch",
        c.scale_x_um_per_m - c.scale_y_um_per_m,
        f64::from(d.scale_mismatch_um_per_m),
    );
    within_10_percent("reversal X", c.backlash_x_um, f64::from(d.reversal_x_um));
    within_10_percent("reversal Y", c.backlash_y_um, f64::from(d.reversal_y_um));
    within_10_percent(
        "cyclic",
        c.cyclic_amplitude_um,
        f64::from(d.cyclic_amplitude_um),
    );
    assert_eq!(d.cyclic_order, c.cyclic_order);
    within_10_percent(
        "servo mismatch",
        c.servo_mismatch_ms(),
        iso.servo_mismatch_ms,
    );
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
    let (_, s, r) = session();
    let plots = report::plots(&s.desc, &s.runs, &r);
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
    let iso = r.iso230_4.as_ref().expect("iso");
    // the legend states G per direction: recover G from the drawn trace and fitted circle
    for (dir, g_json) in [("ccw", iso.ccw.g_um), ("cw", iso.cw.g_um)] {
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
            (g_plot - f64::from(g_json)).abs() <= 0.05 * f64::from(g_json) + 0.05,
            "{dir}: G from the plot {g_plot} vs legend {g_json}"
        );
    }
    // the CW/CCW traces differ where the legend says there is hysteresis
    assert!(legend.contains(&format!("H = {:.2} µm", iso.hysteresis_h_um)));
    assert!(legend.contains("Squareness") && legend.contains("Reversal"));
    assert!(by_id("nominal").attribute("r").is_some());
}
