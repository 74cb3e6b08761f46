//! The run monitor (`ballpod::session::run`) on hand-made samples: each documented limit at
//! and just past its edge, and the accounting against counts the test keeps itself.

use ballpod::acquisition::{Sample, SampleFlags};
use ballpod::protocol::pod::AbortReason;
use ballpod::session::run::{RunLimits, RunMonitor, SkipReason, Verdict};
use ballpod_host::rng::Rng;

fn sample(dl_um: f32, flags: SampleFlags) -> Sample {
    Sample {
        delta_l_um: dl_um,
        flags,
        ..Sample::default()
    }
}

fn started() -> RunMonitor {
    let mut m = RunMonitor::new(RunLimits::DEFAULT);
    m.start(0);
    m
}

#[test]
fn the_documented_defaults() {
    let l = RunLimits::default();
    assert_eq!(l.max_step_um, 100.0);
    assert_eq!(l.max_lvdt_fault_samples, 100);
    assert_eq!(l.min_used_samples, 100);
    // max(10, 1 % of the samples produced)
    for (produced, allowed) in [(0, 10), (999, 10), (1099, 10), (1100, 11), (5000, 50)] {
        assert_eq!(l.lost_allowed(produced), allowed, "{produced}");
    }
}

#[test]
fn a_step_of_100_um_is_motion_a_step_beyond_is_a_dropped_bar() {
    let mut m = started();
    assert_eq!(
        m.on_sample(&sample(0.0, SampleFlags::NONE), 0),
        Verdict::Use
    );
    assert_eq!(
        m.on_sample(&sample(100.0, SampleFlags::NONE), 0),
        Verdict::Use
    );
    assert_eq!(
        m.on_sample(&sample(0.0, SampleFlags::NONE), 0),
        Verdict::Use
    );
    assert_eq!(
        m.on_sample(&sample(-100.01, SampleFlags::NONE), 0),
        Verdict::Abort(SkipReason::Jump, AbortReason::LvdtFault)
    );
    assert_eq!(m.abort_reason(), Some(AbortReason::LvdtFault));
    // the run is over: later samples are not counted
    assert_eq!(
        m.on_sample(&sample(0.0, SampleFlags::NONE), 0),
        Verdict::NotRunning
    );
    let c = m.counters();
    assert_eq!((c.seen, c.used, c.skipped_jump), (4, 3, 1));
    assert_eq!(m.stop(), Err(AbortReason::LvdtFault));
}

#[test]
fn a_non_finite_dl_is_never_used() {
    let mut m = started();
    assert_eq!(
        m.on_sample(&sample(f32::NAN, SampleFlags::NONE), 0),
        Verdict::Abort(SkipReason::Jump, AbortReason::LvdtFault)
    );
    assert_eq!(m.counters().used, 0);
}

#[test]
fn the_jump_is_measured_from_the_last_valid_sample() {
    // flagged samples in between do not move the reference, whatever their ΔL
    let mut m = started();
    assert_eq!(
        m.on_sample(&sample(10.0, SampleFlags::NONE), 0),
        Verdict::Use
    );
    for _ in 0..5 {
        assert_eq!(
            m.on_sample(&sample(900.0, SampleFlags::QUADRATURE_ERROR), 0),
            Verdict::Skip(SkipReason::Quadrature)
        );
    }
    assert_eq!(
        m.on_sample(&sample(60.0, SampleFlags::NONE), 0),
        Verdict::Use
    );
}

#[test]
fn lvdt_faults_abort_on_the_100th_in_a_row() {
    let mut m = started();
    // 99 open, one good, 99 over-range: the streak restarts, no abort
    for _ in 0..99 {
        assert_eq!(
            m.on_sample(&sample(0.0, SampleFlags::LVDT_OPEN), 0),
            Verdict::Skip(SkipReason::LvdtOpen)
        );
    }
    assert_eq!(
        m.on_sample(&sample(0.0, SampleFlags::NONE), 0),
        Verdict::Use
    );
    let both = SampleFlags::LVDT_OPEN.with(SampleFlags::LVDT_OVER_RANGE);
    for k in 0..100 {
        let f = if k % 2 == 0 {
            SampleFlags::LVDT_OVER_RANGE
        } else {
            both
        };
        let v = m.on_sample(&sample(0.0, f), 0);
        if k < 99 {
            assert!(matches!(v, Verdict::Skip(_)), "{k}: {v:?}");
        } else {
            assert_eq!(
                v,
                Verdict::Abort(SkipReason::LvdtOpen, AbortReason::LvdtFault)
            );
        }
    }
    let c = m.counters();
    // open wins over over-range when both are set: 99 + 50 open, 50 over-range
    assert_eq!(
        (
            c.seen,
            c.used,
            c.skipped_lvdt_open,
            c.skipped_lvdt_over_range
        ),
        (200, 1, 149, 50)
    );
}

#[test]
fn lost_samples_abort_past_the_limit() {
    // the acquisition's lost counter starts at 7 when the run starts: only later losses count
    let mut m = RunMonitor::new(RunLimits::DEFAULT);
    m.start(7);
    let ok = sample(0.0, SampleFlags::NONE);
    let after = sample(0.0, SampleFlags::OVERRUN);
    for _ in 0..1000 {
        assert_eq!(m.on_sample(&ok, 7), Verdict::Use);
    }
    // 10 lost: allowed (max(10, 1 % of 1011) = 10)
    assert_eq!(m.on_sample(&after, 17), Verdict::Use);
    assert_eq!(m.counters().lost, 10);
    for _ in 0..99 {
        assert_eq!(m.on_sample(&ok, 17), Verdict::Use);
    }
    // 1101 seen + 11 lost = 1112 produced: max(10, 11) = 11 allowed
    assert_eq!(m.on_sample(&after, 18), Verdict::Use);
    // one more: 12 lost > 11 allowed
    assert_eq!(
        m.on_sample(&after, 19),
        Verdict::Abort(SkipReason::Overrun, AbortReason::Overrun)
    );
    let c = m.counters();
    assert_eq!(
        (c.seen, c.used, c.skipped_overrun, c.lost),
        (1102, 1101, 1, 12)
    );
    assert_eq!(c.after_overrun, 3);
}

#[test]
fn stop_needs_100_used_samples() {
    let mut m = started();
    for _ in 0..99 {
        m.on_sample(&sample(1.0, SampleFlags::NONE), 0);
    }
    for _ in 0..50 {
        m.on_sample(&sample(1.0, SampleFlags::QUADRATURE_ERROR), 0);
    }
    assert_eq!(m.stop(), Err(AbortReason::NotObservable));
    let mut m = started();
    for _ in 0..100 {
        m.on_sample(&sample(1.0, SampleFlags::TEMPERATURE_FAULT), 0);
    }
    assert_eq!(m.stop(), Ok(()));
    assert_eq!(m.counters().temperature_faults, 100, "flagged but used");
}

#[test]
fn random_flags_add_up() {
    // 20 000 samples with random flags (no LVDT streak long enough to abort, no jumps); the
    // test counts what it made.
    let mut rng = Rng::new(7);
    let mut m = started();
    let (mut open, mut over, mut quad, mut used, mut temp) = (0, 0, 0, 0, 0);
    for _ in 0..20_000 {
        let mut f = SampleFlags::NONE;
        for (bit, p) in [
            (SampleFlags::LVDT_OPEN, 0.05),
            (SampleFlags::LVDT_OVER_RANGE, 0.05),
            (SampleFlags::QUADRATURE_ERROR, 0.05),
            (SampleFlags::TEMPERATURE_FAULT, 0.1),
            (SampleFlags::PROBE_EVENT, 0.01),
        ] {
            if rng.uniform() < p {
                f.insert(bit);
            }
        }
        if f.contains(SampleFlags::LVDT_OPEN) {
            open += 1;
        } else if f.contains(SampleFlags::LVDT_OVER_RANGE) {
            over += 1;
        } else if f.contains(SampleFlags::QUADRATURE_ERROR) {
            quad += 1;
        } else {
            used += 1;
            if f.contains(SampleFlags::TEMPERATURE_FAULT) {
                temp += 1;
            }
        }
        assert_ne!(m.on_sample(&sample(0.0, f), 0), Verdict::NotRunning);
    }
    let c = m.counters();
    assert_eq!(
        (
            c.seen,
            c.used,
            c.skipped_lvdt_open,
            c.skipped_lvdt_over_range,
            c.skipped_quadrature,
            c.temperature_faults
        ),
        (20_000, used, open, over, quad, temp)
    );
    assert_eq!(c.seen, c.used + c.skipped());
}
