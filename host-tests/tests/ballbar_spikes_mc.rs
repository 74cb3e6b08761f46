//! Reversal spikes (issue 45) against a forward model of the axes written here — positions,
//! then the bar's length between the balls — never the pod's fit: after each reversal the axis
//! stays behind its command at the end of its travel by h·e^(−Δt/τ) (static friction, then the
//! servo catching up), Δt from the reversal instant; with the reversal steps (lost motion) at
//! each point, a squareness, scales, and 0.2 µm of bar noise at 1 kHz.
//!
//! "Done when" of issue 45 for this diagnosis: ≥ 200 spikes alone and ≥ 200 with every other
//! fault present, at random phase (start angle), size (radius) and feed, CCW and CW: U = 2u
//! covers the injected height in 95 % ± 3 % and u is within 20 % of the scatter.

use ballpod::metrology::iso230_4::SpikeCapture;
use ballpod_host::oracle::Rng;

#[derive(Clone, Copy, Debug, Default)]
struct Machine {
    radius_mm: f64,
    feed_mm_per_min: f64,
    /// Spike heights at the reversal points 0°, 90°, 180°, 270°, µm, and their time constant, s.
    spike_um: [f64; 4],
    tau_s: f64,
    /// Reversal steps at the points, µm.
    step_um: [f64; 4],
    squareness: f64,
    k_u: f64,
    k_v: f64,
    start_deg: f64,
    /// +1 CCW, −1 CW.
    dir: f64,
    /// Vibration of u and v: amplitude (µm) and phase (rad) of E = A·sin(2πf·t + φ), t from
    /// the run's start, and its frequency f, Hz.
    vib_um: [f64; 2],
    vib_phase: [f64; 2],
    vib_hz: f64,
    /// Stick-slip of u and v: amplitude (µm) and phase of E = a·sin(2πf·Δt + φ), Δt from the
    /// axis's latest reversal, for `slip_s`; its frequency, Hz.
    slip_um: [f64; 2],
    slip_phase: [f64; 2],
    slip_hz: f64,
    slip_s: f64,
}

const RATE_HZ: f64 = 1000.0;
const NOISE_UM: f64 = 0.2;

/// One full turn of `m` through a fresh capture; the capture.
fn capture(m: &Machine, rng: &mut Rng) -> SpikeCapture {
    let r = m.radius_mm;
    let omega = m.feed_mm_per_min / 60.0 / r;
    let n = (std::f64::consts::TAU / omega * RATE_HZ) as usize;
    let start = m.start_deg.to_radians();
    let mut c = SpikeCapture::new();
    for i in 0..n {
        let t = i as f64 / RATE_HZ;
        let travelled = omega * t;
        let th = start + m.dir * travelled;
        let (s, co) = th.sin_cos();
        // the last reversal of each axis before now: u reverses at 0° and 180° (sin θ = 0),
        // v at 90° and 270°; each point's angle along the travel from the start
        let since = |point_deg: f64| {
            let a = (m.dir * (point_deg.to_radians() - start)).rem_euclid(std::f64::consts::TAU);
            if a <= travelled {
                Some((travelled - a) / omega)
            } else {
                None
            }
        };
        let spike =
            |p: usize, deg: f64| since(deg).map_or(0.0, |dt| m.spike_um[p] * (-dt / m.tau_s).exp());
        // u: the latest of its points 0° and 180° the run has passed
        let latest = |a: usize, b: usize| {
            let (da, db) = (since(90.0 * a as f64), since(90.0 * b as f64));
            match (da, db) {
                (Some(x), Some(y)) => Some(if x < y { a } else { b }),
                (Some(_), None) => Some(a),
                (None, Some(_)) => Some(b),
                _ => None,
            }
        };
        // along the axis's previous travel, i.e. towards the end it reversed at: + at 0°/90°
        let e_spike_u = latest(0, 2).map_or(0.0, |p| {
            let sgn = if p == 0 { 1.0 } else { -1.0 };
            sgn * spike(p, 90.0 * p as f64)
        });
        let e_spike_v = latest(1, 3).map_or(0.0, |p| {
            let sgn = if p == 1 { 1.0 } else { -1.0 };
            sgn * spike(p, 90.0 * p as f64)
        });
        // vibration, in time; stick-slip from the axis's latest reversal, for slip_s
        let tau = std::f64::consts::TAU;
        let vib = |i: usize| m.vib_um[i] * (tau * m.vib_hz * t + m.vib_phase[i]).sin();
        let slip = |i: usize, p: Option<usize>| {
            p.and_then(|p| since(90.0 * p as f64))
                .filter(|dt| *dt < m.slip_s)
                .map_or(0.0, |dt| {
                    m.slip_um[i] * (tau * m.slip_hz * dt + m.slip_phase[i]).sin()
                })
        };
        let e_spike_u = e_spike_u + vib(0) + slip(0, latest(0, 2));
        let e_spike_v = e_spike_v + vib(1) + slip(1, latest(1, 3));
        // lost motion: the axis lags B/2 behind its direction of travel, B of the end it is at
        let (vu, vv) = (-m.dir * s, m.dir * co);
        let b_u = if co > 0.0 { m.step_um[0] } else { m.step_um[2] };
        let b_v = if s > 0.0 { m.step_um[1] } else { m.step_um[3] };
        let u = r * co;
        let v = r * s;
        let eu = m.squareness * v + m.k_u * u + (-vu.signum() * b_u / 2.0 + e_spike_u) * 1e-3;
        let ev = m.k_v * v + (-vv.signum() * b_v / 2.0 + e_spike_v) * 1e-3;
        let len = ((u + eu).powi(2) + (v + ev).powi(2)).sqrt();
        let dl = (len - r) * 1e3 + NOISE_UM * rng.normal();
        c.update(dl as f32, [co as f32, s as f32], (t * 1e6) as u64);
    }
    c
}

fn machine(rng: &mut Rng, others: bool) -> Machine {
    let on = |b: bool, x: f64| if b { x } else { 0.0 };
    Machine {
        radius_mm: rng.range(60.0, 160.0),
        feed_mm_per_min: rng.range(500.0, 3000.0),
        spike_um: [0.0; 4].map(|_| rng.range(0.0, 8.0)),
        // 2 ms … 24 ms: within TAU_SPAN's 0.5 … 24 samples at 1 kHz
        tau_s: rng.range(2e-3, 24e-3),
        step_um: [0.0; 4].map(|_| on(others, rng.range(-2.0, 8.0))),
        squareness: on(others, rng.range(-40e-6, 40e-6)),
        k_u: on(others, rng.range(-15e-6, 15e-6)),
        k_v: on(others, rng.range(-15e-6, 15e-6)),
        start_deg: rng.range(0.0, 360.0),
        dir: if rng.range(0.0, 1.0) < 0.5 { 1.0 } else { -1.0 },
        ..Default::default()
    }
}

/// `m` with a vibration and a stick-slip (amplitudes 0–2 µm where `others`, else none) at
/// random frequencies and phases.
fn oscillating(rng: &mut Rng, m: Machine, others: bool) -> Machine {
    let on = |b: bool, x: f64| if b { x } else { 0.0 };
    let phases = |rng: &mut Rng| [0.0; 2].map(|_| rng.range(0.0, std::f64::consts::TAU));
    let vib_hz = rng.range(40.0, 400.0);
    // two oscillations closer than twice the window's resolution (1/64 of the sample rate)
    // are one to the fit: the pod's stated limit
    let slip_hz = loop {
        let f = rng.range(40.0, 250.0);
        if (f - vib_hz).abs() >= 2.0 * RATE_HZ / 64.0 {
            break f;
        }
    };
    Machine {
        vib_um: [0.0; 2].map(|_| on(others, rng.range(0.0, 2.0))),
        vib_phase: phases(rng),
        vib_hz,
        slip_um: [0.0; 2].map(|_| on(others, rng.range(0.0, 2.0))),
        slip_phase: phases(rng),
        slip_hz,
        slip_s: 0.2,
        ..m
    }
}

/// Coverage of U = 2u and rms u / rms error.
fn verdict(e: &[(f64, f64)]) -> (f64, f64) {
    let n = e.len() as f64;
    let cov = e.iter().filter(|(e, u)| e.abs() <= 2.0 * u).count() as f64 / n;
    let e2 = e.iter().map(|(e, _)| e * e).sum::<f64>() / n;
    let u2 = e.iter().map(|(_, u)| u * u).sum::<f64>() / n;
    (cov, (u2 / e2).sqrt())
}

#[test]
fn monte_carlo_spike_heights_cover_the_truth_within_their_u() {
    let mut rng = Rng::new(20_261_201);
    let mut failed = Vec::new();
    for (label, others, oscillations) in [
        ("alone", false, false),
        ("with every fault", true, false),
        ("with every fault, a vibration and a stick-slip", true, true),
    ] {
        let mut errors = Vec::new();
        let mut tau_ratio = Vec::new();
        for _ in 0..80 {
            let m = machine(&mut rng, others);
            let m = if oscillations {
                oscillating(&mut rng, m, true)
            } else {
                m
            };
            let c = capture(&m, &mut rng);
            // the spikes alone, and as the pod reads them, jointly with the oscillations
            let spikes = if oscillations {
                c.reversals().spikes
            } else {
                [0, 1, 2, 3].map(|p| c.spike(p))
            };
            for (s, truth) in spikes.iter().zip(&m.spike_um) {
                // a turn from a random start crosses every point once, each with its window
                // (the start within a window's reach of a point leaves that one out)
                let Some(s) = s else { continue };
                errors.push((f64::from(s.height_um) - truth, f64::from(s.u_height_um)));
                if *truth > 10.0 * f64::from(s.u_height_um) {
                    tau_ratio.push(f64::from(s.tau_ms) * 1e-3 / m.tau_s);
                }
            }
        }
        let (cov, ratio) = verdict(&errors);
        tau_ratio.sort_by(f64::total_cmp);
        let median = tau_ratio[tau_ratio.len() / 2];
        println!(
            "spikes {label}: {} heights, coverage {cov:.3}, rms u / rms error {ratio:.3}; τ found / τ injected: median {median:.3} of {}",
            errors.len(),
            tau_ratio.len()
        );
        if errors.len() < 200 || !(0.92..=0.98).contains(&cov) || !(0.8..=1.2).contains(&ratio) {
            failed.push(format!(
                "{label}: {} heights, coverage {cov:.3}, ratio {ratio:.3}",
                errors.len()
            ));
        }
        // the τ kept: the truth's, at the median
        if !(0.67..=1.5).contains(&median) {
            failed.push(format!("{label}: τ ratio median {median}"));
        }
    }
    assert!(failed.is_empty(), "{failed:#?}");
}

/// A spike far narrower than a 1° bin (τ 3 ms at F3000 on R 60 mm: 0.14°) is read at its
/// height; the bin's mean would show a fifth of it.
#[test]
fn a_spike_narrower_than_a_bin_is_read_at_its_height() {
    let m = Machine {
        radius_mm: 60.0,
        feed_mm_per_min: 3000.0,
        spike_um: [5.0, 0.0, 0.0, 0.0],
        tau_s: 3e-3,
        start_deg: 200.0,
        dir: 1.0,
        ..Default::default()
    };
    let c = capture(&m, &mut Rng::new(3));
    let s = c.spike(0).expect("crossed");
    assert!(
        (f64::from(s.height_um) - 5.0).abs() <= 3.0 * f64::from(s.u_height_um),
        "{s:?}"
    );
    let quiet = c.spike(1).expect("crossed");
    assert!(
        f64::from(quiet.height_um).abs() <= 3.0 * f64::from(quiet.u_height_um),
        "{quiet:?}"
    );
}

/// One turn of `m` (without spikes unless `others`) through the pod's joint fit: its
/// oscillations.
fn oscillations(
    m: &mut Machine,
    others: bool,
    rng: &mut Rng,
) -> Option<ballpod::metrology::iso230_4::RunOscillations> {
    if !others {
        m.spike_um = [0.0; 4];
    }
    capture(m, rng).reversals().oscillations
}

/// Vibration and stick-slip (issue 45): each kind alone and with every other fault (steps,
/// spikes, squareness, scales and the other kind, at least 31 Hz away), at random amplitude
/// 0.3–3 µm, frequency, phase, radius, feed and start: per run and axis, U = 2u covers the
/// injected amplitude in 95 % ± 3 % and u is within 20 % of the scatter; where the kind is
/// named, U covers the frequency in ≥ 90 %: its u is a few per cent optimistic (the other
/// axis's share, read with the growing sine of the bar's angle, is a phase ramp like a
/// frequency offset, and the frequency is found without it: with it, it is not told).
#[test]
fn monte_carlo_oscillation_amplitudes_cover_the_truth_within_their_u() {
    use ballpod::metrology::iso230_4::OscillationKind;
    let mut rng = Rng::new(20_261_202);
    let mut failed = Vec::new();
    for kind in [OscillationKind::Vibration, OscillationKind::StickSlip] {
        for (label, others) in [("alone", false), ("with every fault", true)] {
            let (mut amplitudes, mut frequencies) = (Vec::new(), Vec::new());
            let mut runs = 0;
            while runs < 200 {
                let m = machine(&mut rng, others);
                let mut m = oscillating(&mut rng, m, others);
                let size = [0.0; 2].map(|_| rng.range(0.3, 3.0));
                let truth_hz = match kind {
                    OscillationKind::Vibration => {
                        m.vib_um = size;
                        m.vib_hz
                    }
                    OscillationKind::StickSlip => {
                        m.slip_um = size;
                        m.slip_hz
                    }
                };
                let Some(o) = oscillations(&mut m, others, &mut rng) else {
                    continue;
                };
                runs += 1;
                let o = o[kind as usize];
                for (axis, truth) in o.axes.iter().zip(size) {
                    let Some(axis) = axis else { continue };
                    let (a, u) = axis.amplitude_um();
                    amplitudes.push((f64::from(a) - truth, f64::from(u)));
                }
                if o.named() {
                    let (f, u) = o.frequency_hz;
                    frequencies.push((f64::from(f) - truth_hz, f64::from(u)));
                }
            }
            let (cov, ratio) = verdict(&amplitudes);
            let (f_cov, f_ratio) = verdict(&frequencies);
            println!(
                "{kind:?} {label}: {} amplitudes, coverage {cov:.3}, rms u / rms error {ratio:.3}; {} frequencies, coverage {f_cov:.3}, ratio {f_ratio:.3}",
                amplitudes.len(),
                frequencies.len()
            );
            if !(0.92..=0.98).contains(&cov) || !(0.8..=1.2).contains(&ratio) {
                failed.push(format!(
                    "{kind:?} {label}: amplitude coverage {cov:.3}, ratio {ratio:.3}"
                ));
            }
            if frequencies.len() < 150 || !(0.90..=0.98).contains(&f_cov) {
                failed.push(format!(
                    "{kind:?} {label}: {} frequencies, coverage {f_cov:.3}, ratio {f_ratio:.3}",
                    frequencies.len()
                ));
            }
        }
    }
    assert!(failed.is_empty(), "{failed:#?}");
}

/// 100 noisy circles without an oscillation — with no fault at all, and with every other
/// fault (steps, spikes, squareness, scales) — name neither vibration nor stick-slip on either
/// axis in ≥ 95 % (issue 45's "done when"; at the false-alarm rate chosen, ≈ 99.9 %).
#[test]
fn circles_without_an_oscillation_name_none() {
    let mut rng = Rng::new(20_261_203);
    let mut failed = Vec::new();
    for (label, others) in [("fault-free", false), ("every other fault", true)] {
        let (mut runs, mut named) = (0, 0);
        while runs < 100 {
            let m = machine(&mut rng, others);
            let mut m = oscillating(&mut rng, m, others);
            m.vib_um = [0.0; 2];
            m.slip_um = [0.0; 2];
            let Some(o) = oscillations(&mut m, others, &mut rng) else {
                continue;
            };
            runs += 1;
            if o.iter().any(|k| k.named()) {
                named += 1;
            }
        }
        println!("{label}: {named} of {runs} circles name an oscillation");
        if named > 5 {
            failed.push(format!("{label}: {named} of {runs} name an oscillation"));
        }
    }
    assert!(failed.is_empty(), "{failed:#?}");
}
