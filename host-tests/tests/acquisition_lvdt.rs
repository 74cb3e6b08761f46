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
            (f64::from(r.phase_deg) - ph).abs() < 1e-3,
            "phase {}",
            r.phase_deg
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
