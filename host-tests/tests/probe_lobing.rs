//! The touch probe's lobing in the chapter 5 budget (issue 14; `identify::mill_turn::lobing`):
//! Monte Carlo of the whole procedure at sensor level. Each procedure draws a machine (the
//! literal HTM model's deviations) and a probe whose pre-travel varies with the direction of
//! approach as a kinematic probe's does (`Instrument::probe_pretravel_at`: 1/cos lobes, all their
//! harmonics phase-locked, where the pod's budget takes harmonics 3…18 as independent, and a
//! different pre-travel along the stylus), with its three-lobe harmonic and its axial difference
//! drawn from the stated distribution (each component N(0, u²), u = `probe_u_lobing`). The pod probes the C-axis
//! spheres (C = 0/90/180/270°) and the B-axis spheres (B = 0/90° with two styli), nine touches
//! each through its probe latch, and reports each deviation with u; the truth is the machine's.

use std::collections::BTreeMap;

use ballpod::app::Contributor;
use ballpod::config::U_LOBING_UM;
use ballpod_host::rng::Rng;
use ballpod_host::scenario::{self, Scenario};

/// Procedures per test (each: eight spheres of nine touches).
const PROCEDURES: usize = 240;
/// Probe repeatability σ per touch, µm.
const REPEATABILITY_UM: f64 = 0.3;

/// The scenario of `method` for procedure `k`: a random machine and a random lobing of
/// standard uncertainty `u_um` per component (the pod keeps its default `probe_u_lobing`).
fn procedure(method: &str, k: usize, u_um: f64) -> Scenario {
    let file = format!(
        "{}/scenarios/seed002_probe.toml",
        env!("CARGO_MANIFEST_DIR")
    );
    let mut s = scenario::read(std::path::Path::new(&file)).unwrap();
    let mut rng = Rng::new(0x10b1_0000 + k as u64);
    let m = &mut s.machine.seed002;
    let mut um = |a: f64| a * (2.0 * rng.uniform() - 1.0);
    m.dx_bt_um = um(20.0);
    m.dz_bt_um = um(20.0);
    m.dx_cz_um = um(50.0);
    m.dy_cz_um = um(50.0);
    m.alpha_bt_arcsec = um(30.0);
    m.alpha_xb_arcsec = um(30.0);
    m.beta_xb_arcsec = um(30.0);
    m.gamma_xb_arcsec = um(30.0);
    m.alpha_cz_arcsec = um(30.0);
    m.beta_cz_arcsec = um(30.0);
    let i = &mut s.machine.instrument;
    // the three-lobe harmonic (c₃, s₃) ~ N(0, u²) each: amplitude and orientation
    let (c3, s3) = (u_um * rng.normal(), u_um * rng.normal());
    i.probe_lobing_um = c3.hypot(s3);
    i.probe_lobing_deg = s3.atan2(c3).to_degrees() / 3.0;
    i.probe_axial_um = u_um * rng.normal();
    i.probe_pretravel_um = 5.0 + 5.0 * rng.uniform();
    i.probe_bounces = 0;
    // the bar is off the machine while probing: its LVDT channel noiseless (the ADC noise's
    // draws are most of the simulator's time)
    i.adc_noise_counts = 0.0;
    // the pod is told the u the lobing is drawn with (its default)
    s.probe_u_lobing_um = Some(U_LOBING_UM);
    s.method = method.to_string();
    s.seed = 1000 + k as u64;
    s.noise_um = REPEATABILITY_UM;
    s
}

/// Per result: (reported − truth, u, u without the lobing's share) over the procedures.
fn monte_carlo() -> BTreeMap<String, Vec<(f64, f64, f64)>> {
    let lobing = Contributor::ProbeLobing as usize;
    let mut out: BTreeMap<String, Vec<(f64, f64, f64)>> = BTreeMap::new();
    for k in 0..PROCEDURES {
        for method in ["seed002_probe", "seed002_probe_b_axis"] {
            let s = procedure(method, k, U_LOBING_UM);
            for c in scenario::run(&s).unwrap() {
                if c.name == "sphere_radius_deviation" {
                    continue;
                }
                let share = f64::from(c.shares.unwrap()[lobing]);
                let without = (c.u * c.u - share * share).max(0.0).sqrt();
                out.entry(c.name)
                    .or_default()
                    .push((c.got - c.truth, c.u, without));
            }
        }
    }
    out
}

/// Fraction of |error| ≤ 2u, and rms u / rms error, for u = `u(e, u, without)`.
fn coverage(v: &[(f64, f64, f64)], u: fn(&(f64, f64, f64)) -> f64) -> (f64, f64) {
    let inside = v.iter().filter(|x| x.0.abs() <= 2.0 * u(x)).count();
    let rms = |f: &dyn Fn(&(f64, f64, f64)) -> f64| {
        (v.iter().map(|x| f(x).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
    };
    (inside as f64 / v.len() as f64, rms(&u) / rms(&|x| x.0))
}

#[test]
fn the_lobing_budget_covers_the_truth_in_95_percent_of_procedures() {
    let results = monte_carlo();
    assert_eq!(results.len(), 9, "four C-axis and five B-axis results");
    let mut failed = Vec::new();
    for (name, v) in &results {
        let (cov, ratio) = coverage(v, |x| x.1);
        let (without, _) = coverage(v, |x| x.2);
        println!(
            "{name}: U covers {:.1} % (without the lobing's share {:.1} %), rms u / rms error {ratio:.2}",
            100.0 * cov,
            100.0 * without
        );
        if !(0.92..=0.98).contains(&cov) || !(0.8..=1.2).contains(&ratio) {
            failed.push(name.clone());
        }
    }
    assert!(failed.is_empty(), "not covered as stated: {failed:?}");
    // the control: δx_CZ, δy_CZ and δz_BT take the lobing's common shift whole, and the fits'
    // scatter does not show it
    for name in ["dx_CZ", "dy_CZ", "dz_BT"] {
        let (without, _) = coverage(&results[name], |x| x.2);
        assert!(
            without < 0.8,
            "{name} without the lobing's share: {:.1} %",
            100.0 * without
        );
    }
}

/// ∫ cos(3kψ)/cos ψ dψ over ±60°, the k-th lobe harmonic of the kinematic 1/cos law (Simpson,
/// 20 000 intervals; the integrand is smooth there).
fn lobe_integral(k: usize) -> f64 {
    let (a, n) = (60f64.to_radians(), 20_000);
    let h = 2.0 * a / n as f64;
    let f = |x: f64| (3.0 * k as f64 * x).cos() / x.cos();
    let inner: f64 = (1..n)
        .map(|i| f(-a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 })
        .sum();
    (f(-a) + inner + f(a)) * h / 3.0
}

/// The numbers the touch-probe page quotes after `before` (a list like "0.43, 0.90 and 0.90").
fn quoted(before: &str) -> Vec<f64> {
    let page =
        std::fs::read_to_string(ballpod_host::docs::root().join("docs/src/methods/touch-probe.md"))
            .expect("touch-probe.md");
    let flat = page.split_whitespace().collect::<Vec<_>>().join(" ");
    let rest = flat
        .split_once(before)
        .unwrap_or_else(|| panic!("no {before:?}"))
        .1;
    rest.split([',', ' '])
        .take_while(|w| w.is_empty() || w.parse::<f64>().is_ok() || *w == "and")
        .filter_map(|w| w.parse().ok())
        .collect()
}

/// The numbers the page quotes after `before` are `computed`, to the two decimals it gives.
fn page_shows(before: &str, computed: &[f64]) {
    let want: Vec<String> = computed.iter().map(|c| format!("{c:.2}")).collect();
    let got: Vec<String> = quoted(before).iter().map(|s| format!("{s:.2}")).collect();
    assert_eq!(got, want, "touch-probe.md after {before:?}");
}

#[test]
fn the_lobe_harmonics_and_the_sphere_centres_response_are_the_books() {
    use ballpod::identify::mill_turn::lobing::lobing_basis;
    use ballpod::identify::mill_turn::probe::fit_sphere;
    // the harmonics' amplitudes relative to the third's, from the 1/cos law by quadrature
    let ratio: Vec<f64> = (1..=6)
        .map(|k| (lobe_integral(k) / lobe_integral(1)).abs())
        .collect();
    // the pod's basis at a touch across the stylus at φ = 0 holds them
    let basis = lobing_basis([1.0, 0.0, 0.0], 0.0, 1.0);
    for (k, r) in ratio.iter().enumerate() {
        assert!(
            (f64::from(basis[2 * k]) - r).abs() < 1e-3,
            "harmonic {}: {r}",
            3 * (k + 1)
        );
    }
    page_shows("and 18 have", &ratio);
    // the nine touches of `ncgen sphere` at B = 0: the centre's response across the stylus per
    // µm of the 3rd, 9th and 15th harmonics' amplitude, by the test's own least squares
    // (n·δc + δR = g at each touch) and by the pod's sphere fit
    let dirs = ballpod_host::vmt::motion::probing_directions();
    let rows: Vec<Vec<f64>> = dirs.iter().map(|n| vec![n[0], n[1], n[2], 1.0]).collect();
    let points: Vec<[f64; 3]> = dirs
        .iter()
        .map(|n| [100.0 + 12.5 * n[0], 20.0 + 12.5 * n[1], -40.0 + 12.5 * n[2]])
        .collect();
    let fit = fit_sphere(&points, 0.0).expect("the sphere fit");
    let mut across = Vec::new();
    for k in [1usize, 3, 5] {
        let j = 2 * (k - 1); // the cosine component of harmonic 3k
        let g: Vec<f64> = dirs
            .iter()
            .map(|n| {
                let rho2 = n[0] * n[0] + n[1] * n[1];
                rho2 * (3.0 * k as f64 * n[1].atan2(n[0])).cos()
            })
            .collect();
        let (x, _) = ballpod_host::oracle::lstsq(&rows, &g);
        let oracle = x[0].hypot(x[1]);
        let [dx, dy, _] = fit.lobing_um_per_um[j].map(f64::from);
        let pod = dx.hypot(dy) / ratio[k - 1];
        // (the pod holds the ratios to three digits)
        assert!(
            (pod - oracle).abs() < 5e-3,
            "harmonic {}: pod {pod}, oracle {oracle}",
            3 * k
        );
        across.push(oracle);
    }
    page_shows("move it across by", &across);
}
