//! Encoders, probe, thermistor, thermal correction and the sample pipeline against
//! independent expectations (hand-computed values, a simulated true position, the β equation
//! solved for resistance in f64).
use ballpod::acquisition::encoder::{AxisScale, CountExtender};
use ballpod::acquisition::lvdt::{DemodError, LvdtReading};
use ballpod::acquisition::probe::{ProbeDebouncer, ProbeLatch, ProbeState, TriggerOutcome};
use ballpod::acquisition::thermal::{Thermistor, ThermistorFault, bar_expansion_um};
use ballpod::acquisition::{Acquisition, SampleFlags, periods_lost};
use ballpod::config::Config;
use ballpod_host::rng::Rng;

/// Drives a true position through 10^6 counts forward and back, several times, with random
/// steps, and checks the extension of a `bits`-bit counter is exact at every read.
fn extension_is_exact(bits: u32, max_step: i64, seed: u64) {
    let mut rng = Rng::new(seed);
    let modulus: i128 = 1i128 << bits;
    let start: i64 = 12_345;
    let mut ext = CountExtender::new(bits, 0);
    ext.set((i128::from(start).rem_euclid(modulus)) as u32, start);
    let mut pos = start;
    let mut wraps = 0i64;
    for leg in 0..6 {
        let target = if leg % 2 == 0 {
            start + 1_000_000
        } else {
            start - 1_000_000
        };
        while pos != target {
            let step = (rng.range(0.0, max_step as f64) as i64)
                .min((target - pos).abs())
                .max(1);
            let before = pos.div_euclid(1 << bits.min(62));
            pos += step * (target - pos).signum();
            wraps += (pos.div_euclid(1 << bits.min(62)) - before).abs();
            let raw = i128::from(pos).rem_euclid(modulus) as u32;
            let u = ext.update(raw);
            assert_eq!(u.count, pos, "bits {bits}");
            assert!(!u.glitch);
        }
    }
    if bits == 16 {
        assert!(
            wraps > 150,
            "the test must cross the wrap many times ({wraps})"
        );
    }
}

#[test]
fn count_extension_exact_across_repeated_wraps_16_bit() {
    extension_is_exact(16, 30_000, 1);
}

#[test]
fn count_extension_exact_32_bit() {
    extension_is_exact(32, 1_000_000, 2);
    // and across the 32-bit wrap itself
    let mut ext = CountExtender::new(32, 0);
    ext.set(u32::MAX - 5, 0);
    assert_eq!(ext.update(4).count, 10);
    assert_eq!(ext.update(u32::MAX - 15).count, -10);
}

#[test]
fn implausible_step_is_a_glitch() {
    let mut ext = CountExtender::new(16, 500);
    ext.set(0, 0);
    assert!(!ext.update(400).glitch);
    let u = ext.update(400 + 5000);
    assert!(u.glitch);
    assert_eq!(u.count, 5400, "the count still follows the hardware");
    assert_eq!(ext.glitches(), 1);
}

#[test]
fn axis_scaling_and_sign() {
    let s = AxisScale::new(10_000.0, false);
    assert_eq!(s.position(1_234_567), 123.4567);
    let r = AxisScale::new(10_000.0, true);
    assert!((r.position(20_000) + 2.0).abs() < 1e-6);
}

#[test]
fn axis_position_is_within_one_f32_ulp_of_the_f64_quotient() {
    // Issue 17: the per-sample position in f32 (split count, hi + lo reciprocal, FMA) against
    // the f64 quotient count / counts_per_unit: the same f32 but in rare near-ties, never more
    // than one ulp apart, over linear and rotary scales (integer and not), counts up to 2^40.
    let mut rng = Rng::new(40);
    let scales = [
        1_000.0,
        10_000.0,
        20_000.0,
        2f64.powi(23) / 360.0,
        3_600_000.0 / 360.0,
        1.0,
    ];
    let mut worst_ulp = 0.0f64;
    let (mut differ, mut total) = (0u32, 0u32);
    for &cpu in &scales {
        for reversed in [false, true] {
            let s = AxisScale::new(cpu, reversed);
            for k in 0..20_000 {
                let mag = 2f64.powf(rng.range(0.0, 40.0));
                let c = (mag * if k % 2 == 0 { 1.0 } else { -1.0 }) as i64;
                let exact = c as f64 / cpu * if reversed { -1.0 } else { 1.0 };
                let got = f64::from(s.position(c));
                let ulp =
                    f64::from(f32::EPSILON) * (exact as f32).abs().max(f32::MIN_POSITIVE) as f64;
                let d = (got - exact).abs() / ulp;
                worst_ulp = worst_ulp.max(d);
                total += 1;
                differ += u32::from(s.position(c) != exact as f32);
            }
        }
    }
    assert!(worst_ulp <= 1.0, "worst {worst_ulp} ulp");
    assert!(
        differ * 10_000 < total,
        "{differ} of {total} not the nearest f32"
    );
}

#[test]
fn thermal_correction_hand_computed() {
    // 150 mm steel bar (11.5 µm/m/K) at 23.4 °C: 150 mm · 11.5e-6/K · 3.4 K = 5.865 µm.
    assert!((bar_expansion_um(150.0, 11.5, 23.4) - 5.865).abs() < 1e-4);
    assert_eq!(bar_expansion_um(300.0, 11.5, 20.0), 0.0);
    // below 20 °C the bar is shorter: the correction is negative. 300 mm, 0.5 ppm/K (carbon
    // fibre), 17 °C: 300 · 0.5e-6 · (−3) mm = −0.45 µm.
    assert!((bar_expansion_um(300.0, 0.5, 17.0) + 0.45).abs() < 1e-5);
}

fn ntc() -> Thermistor {
    Thermistor {
        r0_ohm: 10_000.0,
        t0_c: 25.0,
        beta_k: 3950.0,
        r_fixed_ohm: 10_000.0,
        min_c: -10.0,
        max_c: 60.0,
    }
}

#[test]
fn thermistor_reads_the_beta_curve() {
    // Independent: resistance of the β model at T, then the divider code, then back.
    for t in [0.0f64, 20.0, 25.0, 37.5, 50.0] {
        let r = 10_000.0 * (3950.0 * (1.0 / (t + 273.15) - 1.0 / 298.15)).exp();
        let code = (4095.0 * r / (r + 10_000.0)).round() as u16;
        let got = f64::from(ntc().temperature_c(code, 4095).unwrap());
        // one code step is ≤ 0.05 K in this range
        assert!((got - t).abs() < 0.05, "{t} °C: got {got}");
    }
}

#[test]
fn thermistor_faults() {
    assert_eq!(ntc().temperature_c(4095, 4095), Err(ThermistorFault::Open));
    assert_eq!(ntc().temperature_c(0, 4095), Err(ThermistorFault::Short));
    assert_eq!(
        ntc().temperature_c(50, 4095),
        Err(ThermistorFault::OutOfRange)
    );
}

fn latch(t_us: u64) -> ProbeLatch {
    ProbeLatch {
        counts: [1, 2, 3, 4, 5],
        t_us,
    }
}

#[test]
fn probe_debounce_and_reseat() {
    let mut p = ProbeDebouncer::new(2_000, 50_000);
    assert_eq!(
        p.trigger(latch(1_000)),
        TriggerOutcome::Accepted(latch(1_000))
    );
    // bounce within 2 ms
    assert_eq!(p.trigger(latch(1_500)), TriggerOutcome::Bounce);
    assert_eq!(p.trigger(latch(2_900)), TriggerOutcome::Bounce);
    // seated only briefly, then touched again: a missed re-seat, rejected
    p.poll(10_000, true);
    p.poll(40_000, true);
    assert_eq!(p.trigger(latch(45_000)), TriggerOutcome::NotReseated);
    assert!(matches!(p.state(), ProbeState::LockedOut { .. }));
    // seated long enough: re-armed
    p.poll(50_000, true);
    p.poll(99_000, true);
    assert!(matches!(p.state(), ProbeState::LockedOut { .. }));
    p.poll(100_000, true);
    assert_eq!(p.state(), ProbeState::Armed);
    assert!(matches!(
        p.trigger(latch(120_000)),
        TriggerOutcome::Accepted(_)
    ));
    assert_eq!((p.accepted, p.bounces, p.not_reseated), (2, 2, 1));
    // deflected while waiting restarts the seated stretch
    p.poll(130_000, true);
    p.poll(160_000, false);
    p.poll(170_000, true);
    p.poll(200_000, true);
    assert!(matches!(p.state(), ProbeState::LockedOut { .. }));
    p.poll(220_000, true);
    assert_eq!(p.state(), ProbeState::Armed);
}

fn good_reading(ratio: f32) -> Result<LvdtReading, DemodError> {
    Ok(LvdtReading {
        ratio,
        signal_level: 3000.0,
        iq_a: [0.0; 2],
        clipped: false,
    })
}

fn code_for(t: f64) -> u16 {
    let r = 10_000.0 * (3950.0 * (1.0 / (t + 273.15) - 1.0 / 298.15)).exp();
    (4095.0 * r / (r + 10_000.0)).round() as u16
}

#[test]
fn pipeline_builds_a_calibrated_sample() {
    let cfg = Config::default(); // 150 mm bar, 11.5 ppm/K, 2000 µm/ratio, 10 000 counts/mm
    let mut acq = Acquisition::new(&cfg, [16; 5]);
    let t = f64::from(acq.update_temperature(code_for(23.0)).unwrap());
    let raw = [0, 0, 0, 0, 0];
    let s0 = acq.calibrate(0, good_reading(0.0), raw, 0, false);
    assert_eq!(s0.flags, SampleFlags::NONE);
    let s = acq.calibrate(
        1_000,
        good_reading(0.005),
        [10_000, 65_536 - 20_000, 5, 0, 0],
        0,
        false,
    );
    // ΔL = 2000 µm · 0.005 + 150 mm · 11.5 ppm/K · (T − 20 K) · 1e-3
    let want = 10.0 + 150.0 * 11.5 * (t - 20.0) * 1e-3;
    assert!(
        (f64::from(s.delta_l_um) - want).abs() < 1e-4,
        "{} vs {want}",
        s.delta_l_um
    );
    assert_eq!(s.axes, [1.0, -2.0, 0.0005, 0.0, 0.0]);
    assert_eq!((s0.seq, s.seq), (0, 1));
    assert_eq!(s.flags, SampleFlags::NONE);
}

#[test]
fn standing_axes_keep_their_position_and_follow_a_new_scale() {
    // samples whose counters do not move reuse the last position; a reconfiguration with a new
    // counts-per-unit must not reuse a position of the old scale
    let mut cfg = Config::default(); // 10 000 counts/mm
    let mut acq = Acquisition::new(&cfg, [16; 5]);
    let raw = [10_000, 65_536 - 20_000, 5, 0, 1];
    acq.calibrate(0, good_reading(0.0), [0; 5], 0, false); // the first read is count 0
    let first = acq.calibrate(500, good_reading(0.0), raw, 0, false);
    for k in 1..4 {
        let s = acq.calibrate(k * 1000, good_reading(0.0), raw, 0, false);
        assert_eq!(s.axes, first.axes);
    }
    assert_eq!(first.axes, [1.0, -2.0, 0.0005, 0.0, 0.0001]);
    for a in cfg.axes.iter_mut() {
        a.counts_per_unit = 4_000.0;
    }
    acq.reconfigure(&cfg, [16; 5]);
    let s = acq.calibrate(9_000, good_reading(0.0), raw, 0, false);
    let want = [10_000.0, -20_000.0, 5.0, 0.0, 1.0].map(|c: f64| (c / 4_000.0) as f32);
    assert_eq!(s.axes, want);
    // and an axis that moves again is scaled again
    let s = acq.calibrate(
        10_000,
        good_reading(0.0),
        [10_004, 65_536 - 20_000, 5, 0, 1],
        0,
        false,
    );
    assert_eq!(s.axes[0], (10_004.0f64 / 4_000.0) as f32);
}

#[test]
fn homing_references_the_axes() {
    let mut acq = Acquisition::new(&Config::default(), [16; 5]);
    // X homed at 150 mm where its 16-bit counter reads 1 500 000 mod 65 536
    let raw_x = (1_500_000u32) % 65_536;
    acq.reference_axes([raw_x, 0, 0, 0, 0], [150.0, -20.0, 0.0, 0.0, 0.0]);
    let (counts, _) = acq.update_counts([(raw_x + 30_000) % 65_536, 65_535, 0, 0, 0]);
    let p = acq.positions(&counts);
    assert_eq!(p[0], 153.0);
    assert!((p[1] - -20.0001).abs() < 1e-6);
}

#[test]
fn every_bad_input_sets_its_flag() {
    let cfg = Config::default();
    let mut acq = Acquisition::new(&cfg, [16; 5]);
    let raw = [0u32; 5];
    // no temperature yet: flagged, 20 °C used
    let s = acq.calibrate(0, good_reading(0.0), raw, 0, false);
    assert!(s.flags.contains(SampleFlags::TEMPERATURE_FAULT));
    assert_eq!(s.temp_c, 20.0);
    acq.update_temperature(code_for(21.0)).unwrap();
    assert_eq!(
        acq.calibrate(1, good_reading(0.0), raw, 0, false).flags,
        SampleFlags::NONE
    );
    // thermistor open: flagged, last good temperature kept
    assert!(acq.update_temperature(4095).is_err());
    let s = acq.calibrate(2, good_reading(0.0), raw, 0, false);
    assert!(s.flags.contains(SampleFlags::TEMPERATURE_FAULT));
    assert!((s.temp_c - 21.0).abs() < 0.05);
    acq.update_temperature(code_for(21.0)).unwrap();
    // over-range
    let s = acq.calibrate(3, good_reading(0.7), raw, 0, false);
    assert_eq!(s.flags, SampleFlags::LVDT_OVER_RANGE);
    assert!(s.delta_l_um.is_finite());
    // open
    let s = acq.calibrate(
        4,
        Ok(LvdtReading {
            ratio: 0.1,
            signal_level: 10.0,
            iq_a: [0.0; 2],
            clipped: false,
        }),
        raw,
        0,
        false,
    );
    assert_eq!(s.flags, SampleFlags::LVDT_OPEN);
    let s = acq.calibrate(5, Err(DemodError::LengthMismatch), raw, 0, false);
    assert_eq!(s.flags, SampleFlags::LVDT_OPEN);
    // NaN from a broken conditioner
    let s = acq.calibrate(6, Ok(acq.dc_reading(f32::NAN)), raw, 0, false);
    assert!(!s.flags.is_valid_for_metrology() && s.delta_l_um.is_finite());
    // quadrature glitch: 1000 mm/s · 10 000 counts/mm / 1000 Hz · 2 = 20 000 counts max step
    let s = acq.calibrate(7, good_reading(0.0), [25_000, 0, 0, 0, 0], 0, false);
    assert_eq!(s.flags, SampleFlags::QUADRATURE_ERROR);
    // overrun: the queue lost 3 items since the last sample
    let s = acq.calibrate(8, good_reading(0.0), [25_000, 0, 0, 0, 0], 3, false);
    assert_eq!(s.flags, SampleFlags::OVERRUN);
    let s = acq.calibrate(9, good_reading(0.0), [25_000, 0, 0, 0, 0], 3, false);
    assert_eq!(s.flags, SampleFlags::NONE);
    // probe event
    let s = acq.calibrate(10, good_reading(0.0), [25_000, 0, 0, 0, 0], 3, true);
    assert_eq!(s.flags, SampleFlags::PROBE_EVENT);
    assert!(s.flags.is_valid_for_metrology());
    let c = acq.counters;
    assert_eq!(
        (
            c.samples,
            c.lvdt_over_range,
            c.lvdt_open,
            c.quadrature_errors,
            c.temperature_faults,
            c.lost_upstream
        ),
        (11, 1, 3, 1, 2, 3)
    );
}

/// The loss derived from block times: a stream of 1 ms blocks stamped with interrupt latency
/// (0–40 µs, as an ISR delayed by a masked section would see), runs of blocks dropped at random
/// (the DMA ring overran, for 1 to 60 periods); the sum of `periods_lost` over the received
/// blocks equals the number dropped, and each gap gives its own run's length.
#[test]
fn lost_periods_follow_from_the_block_times() {
    let mut rng = Rng::new(0x105e);
    let period_us = 1000u32;
    let mut dropped_total = 0u32;
    let mut counted_total = 0u32;
    let mut prev = None;
    let mut k = 0u64;
    while k < 200_000 {
        let drop = if prev.is_some() && rng.uniform() < 0.01 {
            1 + (rng.uniform() * 60.0) as u64
        } else {
            0
        };
        k += drop;
        dropped_total += drop as u32;
        let t = 5_000_000 + k * u64::from(period_us) + (rng.uniform() * 40.0) as u64;
        if let Some(p) = prev {
            let n = periods_lost(p, t, period_us);
            assert_eq!(u64::from(n), drop, "block {k}");
            counted_total += n;
        }
        prev = Some(t);
        k += 1;
    }
    assert!(
        dropped_total > 1000,
        "the test dropped blocks: {dropped_total}"
    );
    assert_eq!(counted_total, dropped_total);
    // edge cases: no time passed, a zero period, a gap beyond u32 periods
    assert_eq!(periods_lost(10, 10, 1000), 0);
    assert_eq!(periods_lost(10, 5, 1000), 0);
    assert_eq!(periods_lost(0, 1_000_000, 0), 0);
    assert_eq!(periods_lost(0, u64::MAX, 1), u32::MAX);
}
