//! The feed-rate sweep on the virtual machine tool (issue 45): one XY circle at five feeds, CCW
//! and CW each, on the simulated pod. The injected servo mismatch (X following its command
//! later than Y) comes back at every feed and over the sweep within its U, and the feed limit
//! is where G(b) of the machine's own forward model (`CircleMachine::pose`, noise-free, its 1°
//! bin means about one least-squares circle of both directions: the host's f64 oracle, not the
//! pod's code) crosses the stated growth.

use ballpod_host::simulate::{SimOptions, SimSession, simulate};
use ballpod_host::vmt::machine::{CircleMachine, MachineFile};
use ballpod_host::vmt::sensors::Instrument;

const FEEDS: [f64; 5] = [250.0, 500.0, 1000.0, 2000.0, 4000.0];

fn machine() -> MachineFile {
    MachineFile {
        circle: CircleMachine {
            squareness_urad: 10.0,
            backlash_x_um: 2.0,
            backlash_y_um: 1.0,
            servo_lag_x_ms: 0.8,
            servo_lag_y_ms: 0.3,
            ..CircleMachine::perfect()
        },
        instrument: Instrument {
            sample_rate_hz: 250.0,
            ..Instrument::default()
        },
        ..MachineFile::default()
    }
}

fn session(m: &MachineFile) -> SimSession {
    let o = SimOptions {
        seed: 9,
        repeats: 1,
        seed002: false,
        circle: false,
        three_planes: false,
        feed_sweep: FEEDS.to_vec(),
        ..SimOptions::default()
    };
    simulate(m, &o, &mut |_, _, _| {}).expect("simulated session")
}

/// G(b) of the noise-free forward model at `feed`: each direction's 1° bin means of ΔL by the
/// commanded angle, one least-squares circle r0 + e·n through both, max − min of the residuals.
fn g_bidir_oracle(c: &CircleMachine, feed: f64) -> f64 {
    let c = CircleMachine {
        feed_mm_per_min: feed,
        ..*c
    };
    let n = 36_000;
    let (mut rows, mut y) = (Vec::new(), Vec::new());
    for dir in [1.0, -1.0] {
        let mut bins = vec![(0.0, 0usize); 360];
        for i in 0..n {
            let th = dir * std::f64::consts::TAU * i as f64 / n as f64;
            let (dl, _) = c.pose(th, dir);
            let b = (th.to_degrees().rem_euclid(360.0) as usize).min(359);
            bins[b].0 += dl;
            bins[b].1 += 1;
        }
        for (k, (sum, count)) in bins.into_iter().enumerate() {
            let a = (k as f64 + 0.5).to_radians();
            rows.push(vec![1.0, a.cos(), a.sin()]);
            y.push(sum / count as f64);
        }
    }
    ballpod_host::oracle::peak_to_valley_about_lstsq(&rows, &y)
}

#[test]
fn the_sweep_recovers_the_servo_mismatch_at_every_feed_and_the_feed_limit_of_the_forward_model() {
    let m = machine();
    let s = session(&m);
    let tau = m.circle.servo_mismatch_ms();
    assert_eq!(s.sweep.len(), FEEDS.len());
    // a lag is a time: the same τ at every feed (the squareness it makes grows with the feed)
    for r in &s.sweep {
        let [t, u] = r.servo_mismatch_ms;
        println!(
            "F{}: G(b) {:.3} ± {:.3} µm, servo mismatch {t:.4} ± {u:.4} ms",
            r.feed_mm_per_min, r.g_bidir_um[0], r.g_bidir_um[1]
        );
        assert!(
            (t - tau).abs() <= 3.0 * u,
            "F{}: {t} ± {u}",
            r.feed_mm_per_min
        );
    }
    let result = |n: &str| {
        let v = s
            .report
            .result(n)
            .unwrap_or_else(|| panic!("{n} not valid"));
        (f64::from(v.value), f64::from(v.u.expect("u")))
    };
    assert_eq!(result("sweep_feeds").0, FEEDS.len() as f64);
    let (t, u) = result("sweep_servo_mismatch");
    assert!((t - tau).abs() <= 2.0 * u, "sweep: {t} ± {u} vs {tau}");
    // the feed limit of the forward model's G(b) at the default growth (20 %)
    let g: Vec<f64> = FEEDS
        .iter()
        .map(|f| g_bidir_oracle(&m.circle, *f))
        .collect();
    let threshold = 1.2 * g[0];
    let k = g.iter().position(|x| *x > threshold).expect("G(b) grows");
    let want =
        FEEDS[k - 1] + (threshold - g[k - 1]) / (g[k] - g[k - 1]) * (FEEDS[k] - FEEDS[k - 1]);
    let (f, u_f) = result("sweep_feed_limit");
    println!("oracle G(b) {g:?}; feed limit {f:.1} ± {u_f:.1} vs the forward model's {want:.1}");
    assert!((f - want).abs() <= 3.0 * u_f, "{f} ± {u_f} vs {want}");
}

/// Without a servo mismatch nor anything else growing with the feed, G(b) stays: the limit is
/// not reached (invalid), the servo mismatch over the sweep is zero within its U.
#[test]
fn a_machine_whose_contour_does_not_grow_with_the_feed_reaches_no_limit() {
    let mut m = machine();
    m.circle.servo_lag_x_ms = 0.0;
    m.circle.servo_lag_y_ms = 0.0;
    let s = session(&m);
    assert!(s.report.result("sweep_feed_limit").is_none());
    let t = s.report.result("sweep_servo_mismatch").expect("valid");
    assert!(
        f64::from(t.value).abs() <= 2.0 * f64::from(t.u.unwrap()),
        "{t:?}"
    );
}
