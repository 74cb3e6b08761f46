//! The run monitor (`ballpod::app::run`) on hand-made samples: each documented limit at and just
//! past its edge, and the accounting against counts the test keeps itself. Lost samples are the
//! gaps in the sample counter (`Sample::seq` counts every sample the pod produced, lost ones
//! included), from the run's first sample on: the tests number their samples themselves and
//! leave the gaps they mean.

use ballpod::acquisition::{Sample, SampleFlags};
use ballpod::app::run::{RunMonitor, SkipReason, Verdict};
use ballpod::app::{AbortReason, RunLimits};
use ballpod_host::rng::Rng;

/// Samples numbered as the pod numbers them: one after the other, unless the test leaves a gap.
struct Feed {
    next_seq: u32,
}

impl Feed {
    fn from(seq: u32) -> Self {
        Self { next_seq: seq }
    }

    /// The next sample, `lost` samples after the previous one was produced.
    fn after_lost(&mut self, lost: u32, dl_um: f32, flags: SampleFlags) -> Sample {
        let seq = self.next_seq.wrapping_add(lost);
        self.next_seq = seq.wrapping_add(1);
        Sample {
            seq,
            delta_l_um: dl_um,
            flags,
            ..Sample::default()
        }
    }

    /// The next sample, none lost.
    fn next(&mut self, dl_um: f32, flags: SampleFlags) -> Sample {
        self.after_lost(0, dl_um, flags)
    }
}

fn started() -> RunMonitor {
    let mut m = RunMonitor::new(RunLimits::DEFAULT);
    m.start();
    m
}

#[test]
fn the_documented_defaults() {
    let l = RunLimits::default();
    assert_eq!(l, RunLimits::DEFAULT);
    assert_eq!(l.max_step_um, 100.0);
    assert_eq!(l.max_lvdt_fault_samples, 100);
    assert_eq!(l.max_lost_samples, 10);
    assert_eq!(l.max_lost_per_mille, 10);
    assert_eq!(l.min_used_samples, 100);
    // max(10, 1 % of the samples produced)
    for (produced, allowed) in [(0, 10), (999, 10), (1099, 10), (1100, 11), (5000, 50)] {
        assert_eq!(l.lost_allowed(produced), allowed, "{produced}");
    }
    // no overflow near the top of the counter
    assert_eq!(l.lost_allowed(u32::MAX), (u64::from(u32::MAX) / 100) as u32);
}

#[test]
fn the_division_free_loss_test_is_the_allowance() {
    // the monitor's per-sample test against the definition, max(n, ⌊produced · ‰ / 1000⌋)
    for per_mille in [0, 1, 10, 37, 999, 1000, u32::MAX] {
        for max_lost_samples in [0, 10, u32::MAX - 1] {
            let l = RunLimits {
                max_lost_per_mille: per_mille,
                max_lost_samples,
                ..RunLimits::DEFAULT
            };
            for produced in [0, 1, 999, 1000, 1001, 1099, 1100, 123_457, u32::MAX] {
                let allowed = l.lost_allowed(produced);
                for lost in [
                    0,
                    1,
                    9,
                    10,
                    11,
                    12,
                    1234,
                    allowed.saturating_sub(1),
                    allowed,
                ]
                .into_iter()
                .chain([allowed.saturating_add(1), u32::MAX])
                {
                    assert_eq!(
                        l.too_many_lost(lost, produced),
                        u64::from(lost)
                            > (u64::from(produced) * u64::from(per_mille) / 1000)
                                .max(u64::from(max_lost_samples)),
                        "{per_mille} ‰, {max_lost_samples}, produced {produced}, lost {lost}"
                    );
                }
            }
        }
    }
}

#[test]
fn a_monitor_that_was_not_started_counts_nothing() {
    let mut m = RunMonitor::new(RunLimits::DEFAULT);
    assert!(!m.is_running());
    let mut f = Feed::from(0);
    assert_eq!(
        m.on_sample(&f.next(0.0, SampleFlags::NONE)),
        Verdict::NotRunning
    );
    assert_eq!(m.counters().seen, 0);
    m.start();
    assert!(m.is_running());
    // ended by command: later samples are not part of the run
    m.on_sample(&f.next(0.0, SampleFlags::NONE));
    m.end();
    assert!(!m.is_running());
    assert_eq!(
        m.on_sample(&f.next(0.0, SampleFlags::NONE)),
        Verdict::NotRunning
    );
    assert_eq!((m.counters().seen, m.counters().used), (1, 1));
}

#[test]
fn a_step_of_100_um_is_motion_a_step_beyond_is_a_dropped_bar() {
    let mut m = started();
    let mut f = Feed::from(0);
    assert_eq!(m.on_sample(&f.next(0.0, SampleFlags::NONE)), Verdict::Use);
    assert_eq!(m.on_sample(&f.next(100.0, SampleFlags::NONE)), Verdict::Use);
    assert_eq!(m.on_sample(&f.next(0.0, SampleFlags::NONE)), Verdict::Use);
    assert_eq!(
        m.on_sample(&f.next(-100.01, SampleFlags::NONE)),
        Verdict::Abort(SkipReason::Jump, AbortReason::LvdtFault)
    );
    assert_eq!(m.abort_reason(), Some(AbortReason::LvdtFault));
    assert!(!m.is_running());
    // the run is over: later samples are not counted
    assert_eq!(
        m.on_sample(&f.next(0.0, SampleFlags::NONE)),
        Verdict::NotRunning
    );
    let c = m.counters();
    assert_eq!((c.seen, c.used, c.skipped_jump), (4, 3, 1));
    assert_eq!(m.stop(), Err(AbortReason::LvdtFault));
}

#[test]
fn a_non_finite_dl_is_never_used() {
    for dl in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let mut m = started();
        let mut f = Feed::from(0);
        assert_eq!(
            m.on_sample(&f.next(dl, SampleFlags::NONE)),
            Verdict::Abort(SkipReason::Jump, AbortReason::LvdtFault),
            "{dl}"
        );
        assert_eq!(m.counters().used, 0);
    }
}

#[test]
fn the_jump_is_measured_from_the_last_valid_sample() {
    // flagged samples in between do not move the reference, whatever their ΔL
    let mut m = started();
    let mut f = Feed::from(0);
    assert_eq!(m.on_sample(&f.next(10.0, SampleFlags::NONE)), Verdict::Use);
    for _ in 0..5 {
        assert_eq!(
            m.on_sample(&f.next(900.0, SampleFlags::QUADRATURE_ERROR)),
            Verdict::Skip(SkipReason::Quadrature)
        );
    }
    assert_eq!(m.on_sample(&f.next(60.0, SampleFlags::NONE)), Verdict::Use);
    // 60 → 160.5: 100.5 µm from the last valid sample (not from the flagged 900)
    assert_eq!(
        m.on_sample(&f.next(160.5, SampleFlags::QUADRATURE_ERROR)),
        Verdict::Skip(SkipReason::Quadrature)
    );
    assert_eq!(
        m.on_sample(&f.next(160.5, SampleFlags::NONE)),
        Verdict::Abort(SkipReason::Jump, AbortReason::LvdtFault)
    );
}

#[test]
fn lvdt_faults_abort_on_the_100th_in_a_row() {
    let mut m = started();
    let mut f = Feed::from(0);
    // 99 open, one good, 99 over-range: the streak restarts, no abort
    for _ in 0..99 {
        assert_eq!(
            m.on_sample(&f.next(0.0, SampleFlags::LVDT_OPEN)),
            Verdict::Skip(SkipReason::LvdtOpen)
        );
    }
    assert_eq!(m.on_sample(&f.next(0.0, SampleFlags::NONE)), Verdict::Use);
    let both = SampleFlags::LVDT_OPEN.with(SampleFlags::LVDT_OVER_RANGE);
    for k in 0..100 {
        let flags = if k % 2 == 0 {
            SampleFlags::LVDT_OVER_RANGE
        } else {
            both
        };
        let v = m.on_sample(&f.next(0.0, flags));
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
    assert_eq!(m.stop(), Err(AbortReason::LvdtFault));
}

#[test]
fn a_quadrature_streak_does_not_abort() {
    // only LVDT faults in a row abort: the encoders come back by themselves
    let mut m = started();
    let mut f = Feed::from(0);
    for _ in 0..1000 {
        assert_eq!(
            m.on_sample(&f.next(0.0, SampleFlags::QUADRATURE_ERROR)),
            Verdict::Skip(SkipReason::Quadrature)
        );
    }
    assert!(m.is_running());
    assert_eq!(m.counters().skipped_quadrature, 1000);
}

#[test]
fn lost_samples_abort_past_the_limit() {
    // the run starts in the middle of the pod's sample count: the samples before the run's
    // first one (here 7000 of them, whatever was lost among them) are none of its business
    let mut m = started();
    let mut f = Feed::from(7000);
    let ok = SampleFlags::NONE;
    let after = SampleFlags::OVERRUN;
    for _ in 0..1000 {
        assert_eq!(m.on_sample(&f.next(0.0, ok)), Verdict::Use);
    }
    assert_eq!(m.counters().lost, 0);
    // 10 lost: allowed (max(10, 1 % of 1011) = 10)
    assert_eq!(m.on_sample(&f.after_lost(10, 0.0, after)), Verdict::Use);
    assert_eq!(m.counters().lost, 10);
    for _ in 0..99 {
        assert_eq!(m.on_sample(&f.next(0.0, ok)), Verdict::Use);
    }
    // 1101 seen + 11 lost = 1112 produced: max(10, 11) = 11 allowed
    assert_eq!(m.on_sample(&f.after_lost(1, 0.0, after)), Verdict::Use);
    // one more: 12 lost > 11 allowed (1102 seen + 12 lost = 1114 produced)
    assert_eq!(
        m.on_sample(&f.after_lost(1, 0.0, after)),
        Verdict::Abort(SkipReason::Overrun, AbortReason::Overrun)
    );
    let c = m.counters();
    assert_eq!(
        (c.seen, c.used, c.skipped_overrun, c.lost),
        (1102, 1101, 1, 12)
    );
    assert_eq!(c.after_overrun, 3);
    assert_eq!(m.stop(), Err(AbortReason::Overrun));
}

#[test]
fn eleven_lost_at_once_at_the_start_abort_ten_do_not() {
    for (lost, aborts) in [(10, false), (11, true)] {
        let mut m = started();
        let mut f = Feed::from(123);
        assert_eq!(m.on_sample(&f.next(0.0, SampleFlags::NONE)), Verdict::Use);
        let v = m.on_sample(&f.after_lost(lost, 0.0, SampleFlags::OVERRUN));
        if aborts {
            assert_eq!(v, Verdict::Abort(SkipReason::Overrun, AbortReason::Overrun));
        } else {
            assert_eq!(v, Verdict::Use);
        }
        assert_eq!(m.counters().lost, lost);
    }
}

#[test]
fn a_flagged_sample_on_which_the_loss_passes_the_limit_keeps_its_own_reason() {
    // the sample after the gap is also an encoder glitch (the count jumped over the gap): it is
    // counted as a quadrature skip, and the run aborts for the lost samples
    let mut m = started();
    let mut f = Feed::from(0);
    for _ in 0..500 {
        m.on_sample(&f.next(0.0, SampleFlags::NONE));
    }
    let flags = SampleFlags::OVERRUN.with(SampleFlags::QUADRATURE_ERROR);
    assert_eq!(
        m.on_sample(&f.after_lost(50, 0.0, flags)),
        Verdict::Abort(SkipReason::Quadrature, AbortReason::Overrun)
    );
    let c = m.counters();
    assert_eq!(
        (
            c.seen,
            c.used,
            c.lost,
            c.skipped_quadrature,
            c.skipped_overrun
        ),
        (501, 500, 50, 1, 0)
    );
    assert_eq!(c.seen, c.used + c.skipped());
}

#[test]
fn the_sample_counter_wraps_without_a_loss_and_a_restart_is_no_loss() {
    // through u32::MAX → 0: no gap
    let mut m = started();
    let mut f = Feed::from(u32::MAX - 4);
    for _ in 0..10 {
        assert_eq!(m.on_sample(&f.next(0.0, SampleFlags::NONE)), Verdict::Use);
    }
    assert_eq!(m.counters().lost, 0);
    // a gap of 3 across the wrap
    let mut m = started();
    let mut f = Feed::from(u32::MAX - 1);
    m.on_sample(&f.next(0.0, SampleFlags::NONE));
    m.on_sample(&f.after_lost(3, 0.0, SampleFlags::OVERRUN));
    assert_eq!(f.next_seq, 3, "the test's own numbering wrapped");
    assert_eq!(m.counters().lost, 3);
    // the counter went backwards (the acquisition restarted): nothing lost
    let mut m = started();
    let mut f = Feed::from(5000);
    for _ in 0..10 {
        m.on_sample(&f.next(0.0, SampleFlags::NONE));
    }
    let mut back = Feed::from(0);
    for _ in 0..10 {
        assert_eq!(
            m.on_sample(&back.next(0.0, SampleFlags::NONE)),
            Verdict::Use
        );
    }
    assert_eq!((m.counters().seen, m.counters().lost), (20, 0));
}

#[test]
fn stop_needs_100_used_samples() {
    let mut m = started();
    let mut f = Feed::from(0);
    for _ in 0..99 {
        m.on_sample(&f.next(1.0, SampleFlags::NONE));
    }
    for _ in 0..50 {
        m.on_sample(&f.next(1.0, SampleFlags::QUADRATURE_ERROR));
    }
    assert_eq!(m.stop(), Err(AbortReason::NotObservable));
    assert_eq!(m.abort_reason(), Some(AbortReason::NotObservable));
    let mut m = started();
    let mut f = Feed::from(0);
    for _ in 0..100 {
        m.on_sample(&f.next(1.0, SampleFlags::TEMPERATURE_FAULT));
    }
    assert_eq!(m.stop(), Ok(()));
    assert_eq!(m.abort_reason(), None);
    assert_eq!(m.counters().temperature_faults, 100, "flagged but used");
}

#[test]
fn start_clears_the_last_run() {
    let mut m = started();
    let mut f = Feed::from(0);
    for _ in 0..100 {
        m.on_sample(&f.next(f32::NAN, SampleFlags::LVDT_OPEN));
    }
    assert_eq!(m.abort_reason(), Some(AbortReason::LvdtFault));
    m.start();
    assert_eq!(m.abort_reason(), None);
    assert_eq!(m.counters(), ballpod::app::RunCounters::ZERO);
    // losses are counted from the new run's first sample, not from the old run's last
    assert_eq!(
        m.on_sample(&f.after_lost(500, 0.0, SampleFlags::NONE)),
        Verdict::Use
    );
    assert_eq!(m.counters().lost, 0);
}

#[test]
fn random_flags_and_gaps_add_up() {
    // 20 000 samples with random flags and random small gaps (no LVDT streak long enough to
    // abort, no jumps, losses well inside 1 %); the test counts what it made.
    let mut rng = Rng::new(7);
    let mut m = started();
    let mut f = Feed::from(rng.next_u64() as u32);
    let (mut open, mut over, mut quad, mut used, mut temp, mut lost, mut overrun) =
        (0, 0, 0, 0, 0, 0, 0);
    for k in 0..20_000 {
        let mut flags = SampleFlags::NONE;
        for (bit, p) in [
            (SampleFlags::LVDT_OPEN, 0.05),
            (SampleFlags::LVDT_OVER_RANGE, 0.05),
            (SampleFlags::QUADRATURE_ERROR, 0.05),
            (SampleFlags::TEMPERATURE_FAULT, 0.1),
            (SampleFlags::PROBE_EVENT, 0.01),
        ] {
            if rng.uniform() < p {
                flags.insert(bit);
            }
        }
        // a gap of 1–3 now and then, never before the run's first sample
        let gap = if k > 0 && rng.uniform() < 0.002 {
            1 + (rng.uniform() * 3.0) as u32
        } else {
            0
        };
        if gap > 0 {
            flags.insert(SampleFlags::OVERRUN);
            lost += gap;
            overrun += 1;
        }
        if flags.contains(SampleFlags::LVDT_OPEN) {
            open += 1;
        } else if flags.contains(SampleFlags::LVDT_OVER_RANGE) {
            over += 1;
        } else if flags.contains(SampleFlags::QUADRATURE_ERROR) {
            quad += 1;
        } else {
            used += 1;
            if flags.contains(SampleFlags::TEMPERATURE_FAULT) {
                temp += 1;
            }
        }
        let v = m.on_sample(&f.after_lost(gap, 0.0, flags));
        assert!(matches!(v, Verdict::Use | Verdict::Skip(_)), "{k}: {v:?}");
    }
    assert!(lost > 10, "the test made gaps: {lost}");
    let c = m.counters();
    assert_eq!(
        (
            c.seen,
            c.used,
            c.skipped_lvdt_open,
            c.skipped_lvdt_over_range,
            c.skipped_quadrature,
            c.temperature_faults,
            c.lost,
            c.after_overrun
        ),
        (20_000, used, open, over, quad, temp, lost, overrun)
    );
    assert_eq!(c.seen, c.used + c.skipped());
}
