//! Reversal spikes of a CIRCLE test: the samples about each reversal point the running run
//! crosses ([`SpikeCapture`], 0.8 KiB, here rather than in [`super::circle::CircleRun`], whose
//! both directions a job copies), handed with the run's figures to the job
//! ([`super::job`]: the fit is a few hundred small solves a point, too long for the application
//! task), and each direction's spikes as the job found them; the test's results, the mean over
//! the latest complete CCW and CW runs at each reversal point, are published when the second
//! direction's job is filed: the height (µm) and time constant (ms).

use super::circle::{CircleGeometry, dir_index};
use super::pattern::Direction;
use super::results::{ResultId, ResultSink, Results};
use crate::metrology::iso230_4::{NotDeterminable, Spike, SpikeCapture};

/// Each reversal point's height and time-constant results, in angle order (0°, 90°, 180°,
/// 270°).
const SPIKE_RESULTS: [(ResultId, ResultId); 4] = [
    (ResultId::SpikeUPos, ResultId::SpikeTimeUPos),
    (ResultId::SpikeVPos, ResultId::SpikeTimeVPos),
    (ResultId::SpikeUNeg, ResultId::SpikeTimeUNeg),
    (ResultId::SpikeVNeg, ResultId::SpikeTimeVNeg),
];

/// One run's spikes at the four reversal points (`None`: the run did not cross the point with a
/// whole window on each side, or no fit was possible).
pub type RunSpikes = [Option<Spike>; 4];

/// A direction's latest run, as far as its spikes go.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
enum DirectionSpikes {
    /// No complete run, or its job has not been filed.
    #[default]
    Pending,
    /// The next run began before the run's job took its samples (the job slot was busy): the
    /// run's spikes are unknown.
    Lost,
    /// The run's spikes.
    Found(RunSpikes),
}

/// The test's spikes: the running (or last ended) run's capture, each direction's latest
/// complete run's spikes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Spikes {
    /// The test (a new geometry forgets both directions).
    geometry: Option<CircleGeometry>,
    capture: SpikeCapture,
    /// The direction of the run whose capture ended and is not yet handed to a job.
    ended: Option<Direction>,
    /// Each direction's (CCW, CW) spikes.
    spikes: [DirectionSpikes; 2],
}

impl Spikes {
    /// Forgets the test (a cleared session).
    pub fn clear(&mut self) {
        *self = Self::default();
    }

    /// A run of direction `d` begins with `geometry` (as [`super::circle::CircleRun::begin_run`]).
    pub fn begin_run(&mut self, geometry: CircleGeometry, d: Direction) {
        if self.geometry != Some(geometry) {
            self.geometry = Some(geometry);
            self.spikes = [DirectionSpikes::Pending; 2];
        }
        if let Some(e) = self.ended.take()
            && let Some(s) = self.spikes.get_mut(dir_index(e))
        {
            *s = DirectionSpikes::Lost;
        }
        if let Some(s) = self.spikes.get_mut(dir_index(d)) {
            *s = DirectionSpikes::Pending;
        }
        self.capture = SpikeCapture::new();
    }

    /// One used sample of the run: ΔL (µm), its direction n from the centre, its time (µs).
    pub fn update(&mut self, dl_um: f32, n: [f32; 2], t_us: u64) {
        self.capture.update(dl_um, n, t_us);
    }

    /// The run of direction `d` ended with a fit: its capture waits for the run's figures job;
    /// the test's spike results are invalid until that job is filed.
    pub fn end_run(&mut self, d: Direction, results: &mut Results) {
        self.ended = Some(d);
        results.clear(ResultId::SpikeUPos, ResultId::SpikeTimeVNeg);
    }

    /// The ended run's capture, for the figures job of its direction `d` (once: the job owns
    /// its copy).
    pub fn take_capture(&mut self, d: Direction) -> Option<&SpikeCapture> {
        (self.ended == Some(d)).then(|| {
            self.ended = None;
            &self.capture
        })
    }

    /// Files the spikes the figures job found for the latest run of direction `d` (`None`: the
    /// job had no capture) and publishes the test's results: the mean of both directions at each
    /// point both crossed (u: the two runs' u in quadrature, halved; τ's u is not evaluated).
    pub fn file(&mut self, d: Direction, run: Option<RunSpikes>, results: &mut Results) {
        if let Some(s) = self.spikes.get_mut(dir_index(d)) {
            *s = run.map_or(DirectionSpikes::Lost, DirectionSpikes::Found);
        }
        results.clear(ResultId::SpikeUPos, ResultId::SpikeTimeVNeg);
        let [DirectionSpikes::Found(ccw), DirectionSpikes::Found(cw)] = self.spikes else {
            return;
        };
        for ((a, b), (height, time)) in ccw.iter().zip(cw.iter()).zip(SPIKE_RESULTS) {
            if let (Some(a), Some(b)) = (a, b) {
                let u = crate::num::sqrtf(
                    a.u_height_um * a.u_height_um + b.u_height_um * b.u_height_um,
                ) * 0.5;
                results.set(
                    height,
                    f64::from((a.height_um + b.height_um) * 0.5),
                    f64::from(u),
                );
                results.set(time, f64::from((a.tau_ms + b.tau_ms) * 0.5), f64::NAN);
            }
        }
    }

    /// Why the spike result `id` is invalid (`None`: not a spike result).
    pub fn why_invalid(&self, id: ResultId) -> Option<NotDeterminable> {
        if !SPIKE_RESULTS.iter().any(|(h, t)| *h == id || *t == id) {
            return None;
        }
        Some(match self.spikes {
            [DirectionSpikes::Found(_), DirectionSpikes::Found(_)] => {
                NotDeterminable::ReversalNotCrossed
            }
            s if s.contains(&DirectionSpikes::Lost) => NotDeterminable::SamplesReplaced,
            _ => NotDeterminable::NeedsBothDirections,
        })
    }
}
