//! The encoder counters as the pod reads them, against a counter model: each input's hardware
//! counter is the true count modulo 2^bits (16-bit TIM1/3/4, 32-bit TIM2/5), read by the
//! board's block latch twice a sample ([`CounterLatch`]) and by the pipeline once a sample
//! ([`Acquisition::update_counts`]). The true count is integrated here in i64 from the speed
//! profile; nothing of the pod's arithmetic is reused.
use ballpod::acquisition::Acquisition;
use ballpod::acquisition::MAX_AXES;
use ballpod::acquisition::encoder::{CounterLatch, LATCHED_COUNTER_BITS};
use ballpod::config::{
    AxisName, COUNTER_READS_PER_SAMPLE, Config, ConfigError, ENCODER_COUNTER_BITS, Field,
    GLITCH_MARGIN,
};

/// The true counts of the five inputs at each counter read of a job of `samples` samples: every
/// axis runs back and forth between ±`travel` counts at `speed_factor` × its configured maximum
/// speed, turning at once at each end (the worst case for the extension: full speed at every
/// read). Yields (read number, true counts).
fn job(cfg: &Config, samples: u64, speed_factor: f64) -> impl Iterator<Item = [i64; MAX_AXES]> {
    let reads_per_s = f64::from(cfg.sample_rate_hz) * f64::from(COUNTER_READS_PER_SAMPLE);
    // counts per read of each axis, rounded to a whole count (the model stays in integers)
    let step: [i64; MAX_AXES] = std::array::from_fn(|i| {
        let a = &cfg.axes[i];
        (speed_factor * f64::from(a.max_speed_per_s) * a.counts_per_unit / reads_per_s).round()
            as i64
    });
    // a stroke of 1 000 reads, so each axis turns every half second at 1 kHz
    let travel: [i64; MAX_AXES] = step.map(|s| s * 500);
    let mut pos = [0i64; MAX_AXES];
    let mut dir = [1i64; MAX_AXES];
    let reads = samples * u64::from(COUNTER_READS_PER_SAMPLE);
    (0..reads).map(move |_| {
        for i in 0..MAX_AXES {
            pos[i] += dir[i] * step[i];
            if pos[i].abs() >= travel[i] {
                dir[i] = -dir[i];
            }
        }
        pos
    })
}

/// The hardware counters of the true counts `c`.
fn hardware(c: [i64; MAX_AXES], bits: [u32; MAX_AXES]) -> [u32; MAX_AXES] {
    std::array::from_fn(|i| (i128::from(c[i]).rem_euclid(1i128 << bits[i])) as u32)
}

/// Runs `samples` samples of the job through the pod's two stages; returns the first sample
/// (if any) at which an input's extended count differs from the truth, and the glitches flagged.
fn through_the_pod(cfg: &Config, samples: u64, speed_factor: f64) -> (Option<(u64, usize)>, u32) {
    let mut latch = CounterLatch::new(ENCODER_COUNTER_BITS);
    let mut acq = Acquisition::new(cfg, LATCHED_COUNTER_BITS);
    let mut first_wrong = None;
    let mut glitches = 0;
    // the first read defines count 0 in both stages: the truth starts at 0 too
    acq.update_counts(latch.read(hardware([0; MAX_AXES], ENCODER_COUNTER_BITS)));
    for (n, truth) in job(cfg, samples, speed_factor).enumerate() {
        let latched = latch.read(hardware(truth, ENCODER_COUNTER_BITS));
        // the block's centre is every second read
        if n % 2 == 1 {
            let (counts, glitch) = acq.update_counts(latched);
            glitches += u32::from(glitch);
            if first_wrong.is_none() {
                first_wrong = (0..MAX_AXES)
                    .find(|&i| counts[i] != truth[i])
                    .map(|i| (n as u64 / 2, i));
            }
        }
    }
    (first_wrong, glitches)
}

#[test]
fn every_input_keeps_its_count_at_its_maximum_speed_through_a_long_job() {
    let cfg = Config::default();
    cfg.validate().unwrap();
    // 20 minutes at 1 kHz, every axis at its maximum speed (B and C at 3 600 °/s:
    // 36 000 counts a sample, beyond what a 16-bit counter read once a sample follows)
    let samples = 20 * 60 * 1000;
    assert_eq!(through_the_pod(&cfg, samples, 1.0), (None, 0));
    // at the glitch limit (twice the maximum speed) the counts still hold; the steps are
    // flagged, since no axis is meant to move so fast
    let (wrong, glitches) = through_the_pod(&cfg, 60_000, GLITCH_MARGIN * 0.999);
    assert_eq!(wrong, None);
    assert_eq!(glitches, 0, "below the glitch limit nothing is flagged");
    let (wrong, glitches) = through_the_pod(&cfg, 60_000, GLITCH_MARGIN * 1.01);
    assert_eq!(wrong, None);
    assert!(glitches > 50_000, "{glitches}");
}

#[test]
fn the_sixteen_bit_counters_read_once_a_sample_lost_the_rotary_axes() {
    // the scheme this replaces: every counter read as 16 bits, only by the pipeline, once a
    // sample — the default B axis at its maximum speed steps 36 000 counts a sample, more than
    // the ±32 768 the difference of two 16-bit reads can say, and the count is lost at once
    let cfg = Config::default();
    let mut acq = Acquisition::new(&cfg, [16; MAX_AXES]);
    acq.update_counts([0; MAX_AXES]);
    let mut lost = None;
    for (n, truth) in job(&cfg, 1000, 1.0).enumerate() {
        if n % 2 == 1 {
            let (counts, _) = acq.update_counts(hardware(truth, [16; MAX_AXES]));
            if let Some(i) = (0..MAX_AXES).find(|&i| counts[i] != truth[i]) {
                lost = Some((n / 2, i, counts[i] - truth[i]));
                break;
            }
        }
    }
    let (sample, input, error) = lost.expect("the old scheme loses the rotary axis");
    assert_eq!((sample, input), (0, 3));
    assert_eq!(error.abs(), 65_536);
}

#[test]
fn a_configuration_the_counters_cannot_follow_is_refused_naming_its_fields() {
    let cfg = Config::default();
    // at 1 kHz: X (1 000 mm/s × 10 000 counts/mm) moves 2 × 10 000 / 2 = 10 000 counts a read
    // at the glitch limit, of 32 767; B (3 600 °/s) 36 000 of 2³¹ − 1
    let r = cfg.counter_reach(0);
    assert_eq!(
        (r.counts_per_read, r.max_counts_per_read),
        (10_000.0, 32_767.0)
    );
    let r = cfg.counter_reach(3);
    assert_eq!(
        (r.counts_per_read, r.max_counts_per_read),
        (36_000.0, 2_147_483_647.0)
    );
    // at 200 Hz the linear axes' defaults are beyond a 16-bit counter read at 400 Hz
    let mut slow = cfg;
    let e = slow
        .try_update(|c| {
            c.excitation_hz = 1000.0;
            c.sample_rate_hz = 200.0;
        })
        .unwrap_err();
    assert_eq!(
        e,
        ConfigError::OutOfRange {
            field: Field::AxisCounterReach(0),
            value: 50_000.0,
            min: 0.0,
            max: 32_767.0,
        }
    );
    // a refused change changes nothing
    assert_eq!((slow.excitation_hz, slow.sample_rate_hz), (5000.0, 1000.0));
    // with the linear axes at 650 mm/s it fits (32 500 counts a read) …
    slow.try_update(|c| {
        c.excitation_hz = 1000.0;
        c.sample_rate_hz = 200.0;
        for a in &mut c.axes[..3] {
            a.max_speed_per_s = 650.0;
        }
    })
    .unwrap();
    // … and the model agrees: at the glitch limit the counts hold …
    assert_eq!(through_the_pod(&slow, 20_000, GLITCH_MARGIN).0, None);
    // … and at 660 mm/s (33 000 counts a read) the rule refuses what the model shows lost
    let mut fast = slow;
    for a in &mut fast.axes[..3] {
        a.max_speed_per_s = 660.0;
    }
    assert!(matches!(
        fast.validate(),
        Err(ConfigError::OutOfRange {
            field: Field::AxisCounterReach(0),
            ..
        })
    ));
    assert_eq!(
        through_the_pod(&fast, 20_000, GLITCH_MARGIN).0,
        Some((0, 0))
    );
    // an input with no axis is not held to it
    let mut unused = slow;
    unused.axes[0].name = AxisName::Unused;
    unused.axes[0].max_speed_per_s = 10_000.0;
    assert_eq!(unused.validate(), Ok(()));
}
