//! Reversal spikes of a CIRCLE test: the samples about each reversal point the running run
//! crosses ([`SpikeCapture`], 0.8 KiB, here rather than in [`super::circle::CircleRun`], whose
//! both directions a job copies), handed with the run's figures to the job
//! ([`super::job`]: the fit is a few hundred small solves a point, too long for the application
//! task), and each direction's spikes as the job found them; the test's results, the mean over
//! the latest complete CCW and CW runs at each reversal point, are published when the second
//! direction's job is filed: the height (µm) and time constant (ms); and from the same samples
//! the vibration and stick-slip of each axis (amplitude µm, frequency Hz, which are named).

use super::circle::{CircleGeometry, dir_index};
use super::pattern::Direction;
use super::results::{ResultId, ResultSink, Results};
use crate::metrology::iso230_4::{NotDeterminable, Oscillation, RunReversals, SpikeCapture};

/// Each reversal point's height and time-constant results, in angle order (0°, 90°, 180°,
/// 270°).
const SPIKE_RESULTS: [(ResultId, ResultId); 4] = [
    (ResultId::SpikeUPos, ResultId::SpikeTimeUPos),
    (ResultId::SpikeVPos, ResultId::SpikeTimeVPos),
    (ResultId::SpikeUNeg, ResultId::SpikeTimeUNeg),
    (ResultId::SpikeVNeg, ResultId::SpikeTimeVNeg),
];

/// Each kind's results (by [`crate::metrology::iso230_4::OscillationKind`]): the amplitude along u, along v, the frequency.
const OSCILLATION_RESULTS: [[ResultId; 3]; 2] = [
    [
        ResultId::VibrationU,
        ResultId::VibrationV,
        ResultId::VibrationFrequency,
    ],
    [
        ResultId::StickSlipU,
        ResultId::StickSlipV,
        ResultId::StickSlipFrequency,
    ],
];

/// A direction's latest run, as far as its spikes go.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
enum DirectionSpikes {
    /// No complete run, or its job has not been filed.
    #[default]
    Pending,
    /// The next run began before the run's job took its samples (the job slot was busy): the
    /// run's spikes are unknown.
    Lost,
    /// The run's spikes and oscillations.
    Found(RunReversals),
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
        clear(results);
    }

    /// The ended run's capture, for the figures job of its direction `d` (once: the job owns
    /// its copy).
    pub fn take_capture(&mut self, d: Direction) -> Option<&SpikeCapture> {
        (self.ended == Some(d)).then(|| {
            self.ended = None;
            &self.capture
        })
    }

    /// Files the spikes and oscillations the figures job found for the latest run of direction
    /// `d` (`None`: the job had no capture) and publishes the test's results: the spikes' mean
    /// of both directions at each point both crossed (u: the two runs' u in quadrature, halved;
    /// τ's u is not evaluated), each axis's oscillations from both runs
    /// ([`Oscillation::both`]), their frequency where one is named.
    pub fn file(&mut self, d: Direction, run: Option<RunReversals>, results: &mut Results) {
        if let Some(s) = self.spikes.get_mut(dir_index(d)) {
            *s = run.map_or(DirectionSpikes::Lost, DirectionSpikes::Found);
        }
        clear(results);
        let [DirectionSpikes::Found(ccw), DirectionSpikes::Found(cw)] = self.spikes else {
            return;
        };
        for ((a, b), (height, time)) in ccw.spikes.iter().zip(cw.spikes.iter()).zip(SPIKE_RESULTS) {
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
        let (Some(ccw), Some(cw)) = (ccw.oscillations, cw.oscillations) else {
            return;
        };
        let mut named = 0u32;
        for (k, ((a, b), [along_u, along_v, frequency])) in ccw
            .iter()
            .zip(cw.iter())
            .zip(OSCILLATION_RESULTS)
            .enumerate()
        {
            let o = Oscillation::both(a, b);
            for (i, (axis, id)) in o.axes.iter().zip([along_u, along_v]).enumerate() {
                if let Some(axis) = axis {
                    let (amplitude, u) = axis.amplitude_um();
                    results.set(id, f64::from(amplitude), f64::from(u));
                    if axis.named() {
                        named |= 1 << (2 * k + i);
                    }
                }
            }
            let (f, u) = o.frequency_hz;
            if o.named() && f.is_finite() {
                results.set(frequency, f64::from(f), f64::from(u));
            }
        }
        results.set(ResultId::OscillationsNamed, f64::from(named), 0.0);
    }

    /// Why the spike or oscillation result `id` is invalid (`None`: not one of theirs).
    pub fn why_invalid(&self, id: ResultId) -> Option<NotDeterminable> {
        let spike = SPIKE_RESULTS.iter().any(|(h, t)| *h == id || *t == id);
        let oscillation = OSCILLATION_RESULTS.iter().flatten().any(|r| *r == id)
            || id == ResultId::OscillationsNamed;
        if !(spike || oscillation) {
            return None;
        }
        Some(match self.spikes {
            [DirectionSpikes::Found(a), DirectionSpikes::Found(b)] => {
                let frequency = OSCILLATION_RESULTS.iter().any(|[.., f]| *f == id);
                if oscillation && (a.oscillations.is_none() || b.oscillations.is_none()) {
                    NotDeterminable::ReversalNotCrossed
                } else if frequency {
                    NotDeterminable::NoOscillation
                } else {
                    NotDeterminable::ReversalNotCrossed
                }
            }
            s if s.contains(&DirectionSpikes::Lost) => NotDeterminable::SamplesReplaced,
            _ => NotDeterminable::NeedsBothDirections,
        })
    }
}

/// Invalidates the spike and oscillation results.
fn clear(results: &mut Results) {
    results.clear(ResultId::SpikeUPos, ResultId::SpikeTimeVNeg);
    results.clear(ResultId::VibrationU, ResultId::OscillationsNamed);
}
