//! What the pod records of a run, for the technician's PC and for replay: the run's header
//! (number, pattern, direction, the configuration it was measured with), every sample the run
//! saw (used or skipped), every touch point, and how it ended. The application drives a
//! [`Recorder`] in that order; the sample log ([`super::log::SampleLog`]) and the USB sample
//! stream are recorders, and replay feeds what they wrote back into the same application.

use super::pattern::{Direction, Pattern};
use super::run::{AbortReason, RunCounters};
use crate::acquisition::{MAX_AXES, Sample};
use crate::config::Config;

/// The header of a recorded run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunMeta {
    /// Run number since boot (1 for the first armed run).
    pub run: u32,
    /// Pattern.
    pub pattern: Pattern,
    /// Direction.
    pub direction: Direction,
    /// The configuration the run is measured with (test set-up included; it cannot change
    /// while the run is armed or running).
    pub config: Config,
}

impl RunMeta {
    /// Placeholder (an empty log's header: run 0, the default configuration).
    pub const ZERO: Self = Self {
        run: 0,
        pattern: Pattern::Circle,
        direction: Direction::Ccw,
        config: Config::DEFAULT,
    };
}

/// A touch point: the encoder positions latched at a probe edge the debouncer accepted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Touch {
    /// Time of the edge, µs since boot.
    pub t_us: u64,
    /// The latched positions in input order, mm / degrees (as [`Sample::axes`]).
    pub axes: [f32; MAX_AXES],
}

/// How a recorded run ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RunEnd {
    /// Run number.
    pub run: u32,
    /// `None`: stopped normally with results; else why it was aborted.
    pub abort: Option<AbortReason>,
    /// The run's accounting.
    pub counters: RunCounters,
}

/// Receives a run as the application records it. Every method has an empty default, so a
/// recorder implements what it keeps.
pub trait Recorder {
    /// A run was armed: its header. Samples and touches of the run follow.
    fn begin_run(&mut self, _meta: &RunMeta) {}
    /// A sample the run saw (used or skipped; its flags say which faults it had).
    fn sample(&mut self, _s: &Sample) {}
    /// A touch point of the run.
    fn touch(&mut self, _t: &Touch) {}
    /// The run ended.
    fn end_run(&mut self, _end: &RunEnd) {}
}

/// Records nothing.
impl Recorder for () {}

/// Two recorders side by side (the firmware's log and USB stream).
impl<A: Recorder, B: Recorder> Recorder for (A, B) {
    fn begin_run(&mut self, meta: &RunMeta) {
        self.0.begin_run(meta);
        self.1.begin_run(meta);
    }
    fn sample(&mut self, s: &Sample) {
        self.0.sample(s);
        self.1.sample(s);
    }
    fn touch(&mut self, t: &Touch) {
        self.0.touch(t);
        self.1.touch(t);
    }
    fn end_run(&mut self, end: &RunEnd) {
        self.0.end_run(end);
        self.1.end_run(end);
    }
}

impl<R: Recorder + ?Sized> Recorder for &mut R {
    fn begin_run(&mut self, meta: &RunMeta) {
        (**self).begin_run(meta);
    }
    fn sample(&mut self, s: &Sample) {
        (**self).sample(s);
    }
    fn touch(&mut self, t: &Touch) {
        (**self).touch(t);
    }
    fn end_run(&mut self, end: &RunEnd) {
        (**self).end_run(end);
    }
}
