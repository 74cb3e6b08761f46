//! Reversal spikes of a CIRCLE test: the samples about each reversal point the running run
//! crosses ([`SpikeCapture`], 0.7 KiB, here rather than in [`super::circle::CircleRun`], which
//! a job copies), each direction's spikes at the run's end, and their mean over the latest
//! complete CCW and CW runs of the test, published at once (a few hundred small solves, no
//! job): the height (µm) and time constant (ms) at each reversal point.

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

/// The test's spikes: the running run's capture, each direction's latest complete run's spikes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Spikes {
    /// The test (a new geometry forgets both directions).
    geometry: Option<CircleGeometry>,
    capture: SpikeCapture,
    /// Each direction's (CCW, CW) spikes at each point; `None`: not complete.
    spikes: [Option<[Option<Spike>; 4]>; 2],
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
            self.spikes = [None; 2];
        }
        if let Some(s) = self.spikes.get_mut(dir_index(d)) {
            *s = None;
        }
        self.capture = SpikeCapture::new();
    }

    /// One used sample of the run: ΔL (µm), its direction n from the centre, its time (µs).
    pub fn update(&mut self, dl_um: f32, n: [f32; 2], t_us: u64) {
        self.capture.update(dl_um, n, t_us);
    }

    /// The run of direction `d` ended with a fit: its spikes, and the test's results (the mean
    /// of both directions at each point both crossed; the rest invalid).
    pub fn finish_run(&mut self, d: Direction, results: &mut Results) {
        let run = [0, 1, 2, 3].map(|p| self.capture.spike(p));
        if let Some(s) = self.spikes.get_mut(dir_index(d)) {
            *s = Some(run);
        }
        results.clear(ResultId::SpikeUPos, ResultId::SpikeTimeVNeg);
        let [Some(ccw), Some(cw)] = self.spikes else {
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
        SPIKE_RESULTS
            .iter()
            .any(|(h, t)| *h == id || *t == id)
            .then_some(if self.spikes.iter().all(Option::is_some) {
                NotDeterminable::ReversalNotCrossed
            } else {
                NotDeterminable::NeedsBothDirections
            })
    }
}
