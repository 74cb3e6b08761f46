//! LVDT demodulation against the independent f64 forward model of host-tests/src/lvdt_model.rs
//! and the analytic averaging gain (issue 2, done-when items 1 and 2).
use ballpod::acquisition::lvdt::{ExcitationTable, LvdtCalibration, LvdtStatus, demodulate};
use ballpod_host::lvdt_model::LvdtModel;
use ballpod_host::rng::Rng;

const P: usize = 20;
const PERIODS: usize = 5; // 5 kHz excitation, 100 kS/s, one block per 1 kHz sample

fn cal() -> LvdtCalibration {
    // The model's transfer is x = 2000 µm · r, so the calibration polynomial is [0, 2000, 0, 0].
    LvdtCalibration {
        poly_um: [0.0, 2000.0, 0.0, 0.0],
        max_abs_ratio: 0.55,
        min_signal_level: 200.0,
    }
}

fn position_um(model: &LvdtModel, x_um: f64) -> (f32, LvdtStatus) {
    let table = ExcitationTable::<P>::new();
    let (a, b) = model.block_f32(x_um, P, PERIODS);
    let r = demodulate(&a, &b, &table).unwrap();
    cal().displacement_um(&r)
}

fn stroke() -> impl Iterator<Item = f64> {
    (-100..=100).map(|i| i as f64 * 10.0) // −1000 … 1000 µm in 10 µm steps
}

#[test]
fn noise_free_position_within_10_nm_over_the_stroke() {
    let m = LvdtModel::default();
    for x in stroke() {
        let (p, s) = position_um(&m, x);
        assert_eq!(s, LvdtStatus::Ok);
        assert!((f64::from(p) - x).abs() < 0.01, "x = {x} µm: got {p}");
    }
}

#[test]
fn excitation_amplitude_change_of_20_percent_changes_nothing() {
    let nominal = LvdtModel::default();
    for scale in [0.8, 1.2] {
        let m = LvdtModel {
            amplitude_sum: nominal.amplitude_sum * scale,
            ..nominal
        };
        for x in stroke() {
            let (p0, _) = position_um(&nominal, x);
            let (p1, s) = position_um(&m, x);
            assert_eq!(s, LvdtStatus::Ok);
            assert!((p1 - p0).abs() < 0.01, "scale {scale}, x {x}: {p0} vs {p1}");
        }
    }
}

#[test]
fn phase_shift_of_30_degrees_changes_nothing() {
    let nominal = LvdtModel::default();
    for ph in [30.0f64, -30.0] {
        let m = LvdtModel {
            phase_rad: ph.to_radians(),
            ..nominal
        };
        for x in stroke() {
            let (p0, _) = position_um(&nominal, x);
            let (p1, _) = position_um(&m, x);
            assert!((p1 - p0).abs() < 0.01, "phase {ph}, x {x}: {p0} vs {p1}");
        }
        // and the phase figure reports the shift
        let table = ExcitationTable::<P>::new();
        let (a, b) = m.block_f32(0.0, P, PERIODS);
        let r = demodulate(&a, &b, &table).unwrap();
        assert!(
            (f64::from(r.phase_deg()) - ph).abs() < 1e-3,
            "phase {}",
            r.phase_deg()
        );
    }
}

#[test]
fn quantised_noisy_scatter_matches_the_averaging_gain() {
    // σ_A = σ_v √(2/n) per secondary; σ_r = 2 σ_A √(A² + B²) / (A + B)²; σ_x = G σ_r.
    // σ_v² = σ² + 1/12 (12-bit quantisation, dithered by the noise).
    let m = LvdtModel::default();
    let table = ExcitationTable::<P>::new();
    let mut rng = Rng::new(7);
    for (sigma, x) in [(2.0, 0.0), (5.0, 600.0)] {
        let n = (P * PERIODS) as f64;
        let sigma_v = (sigma * sigma + 1.0 / 12.0f64).sqrt();
        let (a, b) = m.amplitudes(x);
        let sigma_x =
            m.gain_um * 2.0 * sigma_v * (2.0 / n).sqrt() * (a * a + b * b).sqrt() / (a + b).powi(2);
        let runs = 4000;
        let xs: Vec<f64> = (0..runs)
            .map(|_| {
                let (ca, cb) = m.block_adc(x, P, PERIODS, sigma, &mut rng);
                let r = demodulate(&ca, &cb, &table).unwrap();
                f64::from(cal().displacement_um(&r).0)
            })
            .collect();
        let mean = xs.iter().sum::<f64>() / runs as f64;
        let sd = (xs.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (runs - 1) as f64).sqrt();
        // the std of 4000 samples is known to ±1.1 % (1σ); allow 6 %
        assert!(
            (sd / sigma_x - 1.0).abs() < 0.06,
            "σ={sigma}: scatter {sd:.4} µm vs predicted {sigma_x:.4} µm"
        );
        assert!(
            (mean - x).abs() < 4.0 * sigma_x / (runs as f64).sqrt() + 0.01,
            "bias {}",
            mean - x
        );
    }
}

#[test]
fn bad_signals_are_flagged_never_nan() {
    let table = ExcitationTable::<P>::new();
    let m = LvdtModel::default();
    // over-range: 1.2 mm is beyond the 0.55 ratio limit
    let (a, b) = m.block_f32(1200.0, P, PERIODS);
    let (p, s) = cal().displacement_um(&demodulate(&a, &b, &table).unwrap());
    assert_eq!(s, LvdtStatus::OverRange);
    assert!(
        (p - 1100.0).abs() < 0.01,
        "clamped to the stroke limit: {p}"
    );
    // open coil: no signal at all (ADC sits at its offset)
    let flat = vec![2048u16; P * PERIODS];
    let (p, s) = cal().displacement_um(&demodulate(&flat, &flat, &table).unwrap());
    assert_eq!((p, s), (0.0, LvdtStatus::Open));
    // weak signal: 5 % of nominal
    let weak = LvdtModel {
        amplitude_sum: 150.0,
        ..m
    };
    let (a, b) = weak.block_f32(0.0, P, PERIODS);
    assert_eq!(
        cal()
            .displacement_um(&demodulate(&a, &b, &table).unwrap())
            .1,
        LvdtStatus::Open
    );
    // clipping: an amplitude that drives the ADC into its rails
    let loud = LvdtModel {
        amplitude_sum: 6000.0,
        ..m
    };
    let (a, b) = loud.block_adc(300.0, P, PERIODS, 0.0, &mut Rng::new(1));
    let r = demodulate(&a, &b, &table).unwrap();
    assert!(r.clipped);
    assert_eq!(cal().displacement_um(&r).1, LvdtStatus::OverRange);
    // NaN input (DC path) and malformed blocks
    let r = ballpod::acquisition::lvdt::dc_reading(f32::NAN, 0.0, 10.0, -10.5, 10.5);
    let (p, s) = cal().displacement_um(&r);
    assert!(p.is_finite() && s != LvdtStatus::Ok);
    assert!(demodulate(&a[..P * 2 + 1], &b[..P * 2 + 1], &table).is_err());
    assert!(demodulate(&a[..P], &b[..2 * P], &table).is_err());
    assert!(demodulate::<u16, P>(&[], &[], &table).is_err());
}

#[test]
fn dc_mode_maps_volts_through_zero_and_span() {
    // conditioner: 0 V at null, 10 V per unit ratio → 2000 µm per 10 V = 200 µm/V
    // in DC mode the open threshold is in volts of span
    let cal = LvdtCalibration {
        min_signal_level: 1.0,
        ..cal()
    };
    let r = ballpod::acquisition::lvdt::dc_reading(2.5, 0.0, 10.0, -10.5, 10.5);
    let (p, s) = cal.displacement_um(&r);
    assert_eq!(s, LvdtStatus::Ok);
    assert!((p - 500.0).abs() < 1e-3);
    let r = ballpod::acquisition::lvdt::dc_reading(11.0, 0.0, 10.0, -10.5, 10.5);
    assert_eq!(cal.displacement_um(&r).1, LvdtStatus::OverRange);
}

#[test]
fn dac_table_is_a_mid_scale_sine() {
    let t = ExcitationTable::<P>::new();
    let codes = t.dac_codes(1000);
    for (k, &c) in codes.iter().enumerate() {
        let want = 2048.0 + 1000.0 * (2.0 * std::f64::consts::PI * k as f64 / P as f64).sin();
        assert!(
            (f64::from(c) - want).abs() <= 0.5 + 1e-6,
            "k {k}: {c} vs {want}"
        );
    }
}

/// The ratio of the f64 projection of the same codes on exact sin/cos (the textbook equations
/// of the module doc, independent of the core's Q14 table and integer sums).
fn f64_ratio(a: &[u16], b: &[u16]) -> f64 {
    let amp = |v: &[u16]| {
        let (mut i, mut q) = (0.0f64, 0.0f64);
        for (k, &x) in v.iter().enumerate() {
            let ph = 2.0 * std::f64::consts::PI * (k % P) as f64 / P as f64;
            i += f64::from(x) * ph.sin();
            q += f64::from(x) * ph.cos();
        }
        (i * i + q * q).sqrt()
    };
    let (aa, ab) = (amp(a), amp(b));
    (aa - ab) / (aa + ab)
}

#[test]
fn integer_projection_matches_an_f64_projection_of_the_same_codes() {
    // Issue 17: the Q14 integer projection (the M4's DSP kernel's twin) against f64 sums on
    // exact sin/cos, over the unclipped stroke, every phase, secondaries 0–8° apart, noisy 12-bit codes:
    // within 2 nm of position (the quantised reference's gain error cancels in the ratio).
    let table = ExcitationTable::<P>::new();
    let mut rng = Rng::new(17);
    let mut worst = 0.0f64;
    for trial in 0..400 {
        let x = rng.range(-600.0, 600.0); // the ADC clips beyond ±680 µm at this amplitude
        let phase = rng.range(-180.0, 180.0).to_radians();
        let skew = rng.range(0.0, 8.0).to_radians();
        let m = LvdtModel::default();
        let (amp_a, amp_b) = m.amplitudes(x);
        let code = |v: f64| v.round().clamp(0.0, 4095.0) as u16;
        let n = P * PERIODS;
        let (mut a, mut b) = (vec![0u16; n], vec![0u16; n]);
        for k in 0..n {
            let ph = 2.0 * std::f64::consts::PI * (k % P) as f64 / P as f64 + phase;
            a[k] = code(m.offset + amp_a * ph.sin() + 2.0 * rng.normal());
            b[k] = code(m.offset + amp_b * (ph + skew).sin() + 2.0 * rng.normal());
        }
        let r = demodulate(&a, &b, &table).unwrap();
        assert!(!r.clipped, "trial {trial}");
        let d_um = (f64::from(r.ratio) - f64_ratio(&a, &b)).abs() * m.gain_um;
        worst = worst.max(d_um);
    }
    assert!(worst < 0.002, "worst position difference {worst} µm");
}

#[test]
fn integer_projection_sums_are_the_exact_products_and_rails_are_found_anywhere() {
    use ballpod::acquisition::projection::{Q14Sums, RailTest, add_periods};
    let add_periods = |acc: &mut Q14Sums, a: &[u16], b: &[u16], words: &[u32]| {
        add_periods(acc, a, b, words, RailTest::PerCode)
    };
    let table = ExcitationTable::<P>::new();
    // the reference: antisymmetric Q14 sine and cosine within ½ LSB of the exact values
    let lane = |w: u32, hi: bool| i64::from((if hi { w >> 16 } else { w }) as u16 as i16);
    let refs: Vec<(i64, i64)> = (0..P)
        .map(|k| {
            let (ws, wc) = (table.q14[k / 2 * 2], table.q14[k / 2 * 2 + 1]);
            (lane(ws, k % 2 == 1), lane(wc, k % 2 == 1))
        })
        .collect();
    for (k, &(s, c)) in refs.iter().enumerate() {
        let ph = 2.0 * std::f64::consts::PI * k as f64 / P as f64;
        assert!((s as f64 - 16384.0 * ph.sin()).abs() <= 0.5 + 1e-9, "s_{k}");
        assert!((c as f64 - 16384.0 * ph.cos()).abs() <= 0.5 + 1e-9, "c_{k}");
    }
    assert_eq!(refs.iter().map(|r| r.0).sum::<i64>(), 0);
    assert_eq!(refs.iter().map(|r| r.1).sum::<i64>(), 0);
    // the sums are Σ v·s exactly (i64 oracle), for random full-range codes
    let mut rng = Rng::new(5);
    for _ in 0..200 {
        let a: Vec<u16> = (0..P)
            .map(|_| (rng.uniform() * 4094.0) as u16 + 1)
            .collect();
        let b: Vec<u16> = (0..P)
            .map(|_| (rng.uniform() * 4094.0) as u16 + 1)
            .collect();
        let mut acc = Q14Sums::default();
        assert!(add_periods(&mut acc, &a, &b, &table.q14));
        let dot = |v: &[u16], c: bool| -> i64 {
            v.iter()
                .zip(&refs)
                .map(|(&x, r)| i64::from(x) * if c { r.1 } else { r.0 })
                .sum()
        };
        assert_eq!(i64::from(acc.ia), dot(&a, false));
        assert_eq!(i64::from(acc.qa), dot(&a, true));
        assert_eq!(i64::from(acc.ib), dot(&b, false));
        assert_eq!(i64::from(acc.qb), dot(&b, true));
        assert!(!acc.clipped(), "codes 1…4094 are not rails");
        // without the rail test (the ADC watchdogs did it): the same sums, the rail maximum
        // left as it was
        let mut quiet = Q14Sums::default();
        quiet.rail_max = 0x0FFE_0FFE;
        assert!(ballpod::acquisition::projection::add_periods(
            &mut quiet,
            &a,
            &b,
            &table.q14,
            RailTest::WatchdogQuiet
        ));
        assert_eq!(
            (quiet.ia, quiet.qa, quiet.ib, quiet.qb, quiet.rail_max),
            (acc.ia, acc.qa, acc.ib, acc.qb, 0x0FFE_0FFE)
        );
    }
    // a rail code (0 or 4095, or anything above: not a 12-bit code) at any position of either
    // channel flags the block; 1 and 4094 do not
    for rail in [0u16, 4095, 4096, 65535] {
        for k in 0..2 * P {
            let (mut a, mut b) = (vec![2048u16; P], vec![2048u16; P]);
            if k < P {
                a[k] = rail
            } else {
                b[k - P] = rail
            }
            let mut acc = Q14Sums::default();
            add_periods(&mut acc, &a, &b, &table.q14);
            assert!(acc.clipped(), "rail {rail} at {k}");
        }
    }
    for edge in [1u16, 4094] {
        let mut acc = Q14Sums::default();
        add_periods(&mut acc, &[edge; P], &[edge; P], &table.q14);
        assert!(!acc.clipped());
    }
    // five periods at once are the five periods one by one
    let a: Vec<u16> = (0..5 * P).map(|k| (k * 37 % 4000 + 10) as u16).collect();
    let b: Vec<u16> = (0..5 * P).map(|k| (k * 53 % 4000 + 10) as u16).collect();
    let (mut whole, mut parts) = (Q14Sums::default(), Q14Sums::default());
    assert!(add_periods(&mut whole, &a, &b, &table.q14));
    for (pa, pb) in a.chunks(P).zip(b.chunks(P)) {
        add_periods(&mut parts, pa, pb, &table.q14);
    }
    assert_eq!(
        (whole.ia, whole.qa, whole.ib, whole.qb, whole.rail_max),
        (parts.ia, parts.qa, parts.ib, parts.qb, parts.rail_max)
    );
    // lengths the kernel cannot take add nothing
    let mut acc = Q14Sums::default();
    assert!(!add_periods(&mut acc, &[1; 6], &[1; 6], &table.q14[..6]));
    assert!(!add_periods(&mut acc, &[1; P], &[1; P - 4], &table.q14));
    assert_eq!(acc, Q14Sums::default());
}

#[test]
fn a_block_the_adc_watchdogs_watched_reads_as_the_per_code_test_says() {
    // The pod's usual block: the ADCs' analog watchdogs (window 1…4094) watched every
    // conversion. Quiet: the reading is the per-code demodulation's, bit for bit. Tripped: the
    // per-code test runs and finds the rail wherever it is.
    use ballpod::acquisition::lvdt::demodulate_watched;
    let table = ExcitationTable::<P>::new();
    let m = LvdtModel::default();
    let mut rng = Rng::new(41);
    for _ in 0..100 {
        let (fa, fb) = m.block_f32(rng.range(-600.0, 600.0), P, PERIODS);
        let mut code = |v: &f32| {
            (f64::from(*v) + 2.0 * rng.normal())
                .round()
                .clamp(1.0, 4094.0) as u16
        };
        let a: Vec<u16> = fa.iter().map(&mut code).collect();
        let b: Vec<u16> = fb.iter().map(&mut code).collect();
        let reference = demodulate(&a, &b, &table).unwrap();
        assert!(!reference.clipped);
        assert_eq!(
            demodulate_watched(&a, &b, &table, false).unwrap(),
            reference
        );
        assert_eq!(demodulate_watched(&a, &b, &table, true).unwrap(), reference);
        let mut railed = a.clone();
        let k = (rng.uniform() * railed.len() as f64) as usize % railed.len();
        railed[k] = if k.is_multiple_of(2) { 0 } else { 4095 };
        let r = demodulate_watched(&railed, &b, &table, true).unwrap();
        assert!(r.clipped, "rail at {k}");
        assert_eq!(r, demodulate(&railed, &b, &table).unwrap());
    }
    // bad lengths are refused on this path too
    assert!(demodulate_watched(&[2048; P + 1], &[2048; P + 1], &table, false).is_err());
}
