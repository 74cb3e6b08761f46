//! What the shells feed the application: axis references, the thermistor, probe levels and
//! edges, each sample period's readings (or a calibrated sample in replay), and the run
//! begins and ends waiting for the recorders.

use super::live::Live;
use super::run::Verdict;
use super::session::{CommandError, Needs, ProcedureNote, SessionState};
use super::trigger::TriggerEvent;
use super::{App, Pending, Recorder, RunEstimator, Touch};
use crate::acquisition::lvdt::{BlockReading, DemodError, LvdtReading};
use crate::acquisition::probe::{ProbeLatch, TriggerOutcome};
use crate::acquisition::{MAX_AXES, Sample, SampleFlags};
use crate::config::LvdtInput;

impl App {
    /// Homes the axes: the hardware counters reading `raw` are at `positions` (input order,
    /// mm / degrees).
    pub fn reference_axes(&mut self, raw: [u32; MAX_AXES], positions: [f64; MAX_AXES]) {
        self.acq.reference_axes(raw, positions);
    }

    /// References encoder input `k` (0-based) where the axis stands: it is at `position` (mm /
    /// degrees, machine coordinates), and its later counts extend from there (CANopen 0x300C,
    /// SCPI `AXIS<n>:POSition`). The CNC tells the pod where the machine is, once the axes
    /// stand still; the set-up of every pattern is in the same coordinates. Not while a run is
    /// armed or running; the procedures' runs and the results are forgotten (as command 5:
    /// runs measured in the old coordinates must not mix with new ones). Refused before the
    /// axis has been read and for a position that is not a count.
    pub fn reference_axis(&mut self, k: usize, position: f64) -> Result<(), CommandError> {
        if !self.idle() {
            return self.refuse(CommandError::Busy);
        }
        if !self.acq.reference_axis(k, position) {
            return self.refuse(CommandError::WrongState(Needs::AxisReadable));
        }
        self.clear_procedures();
        Ok(())
    }

    /// The position of encoder input `k` (0-based) at the last sample or reference, mm /
    /// degrees.
    pub fn axis_position(&self, k: usize) -> Option<f32> {
        self.acq.axis_position(k)
    }

    /// A thermistor ADC code (12-bit) from the thermistor task.
    pub fn on_thermistor(
        &mut self,
        code: u16,
    ) -> Result<f32, crate::acquisition::thermal::ThermistorFault> {
        self.acq.update_temperature(code)
    }

    /// The probe input level at `t_us` (`true` = seated), once per sample period.
    pub fn on_probe_level(&mut self, t_us: u64, seated: bool) {
        self.acq.probe.poll(t_us, seated);
    }

    /// A probe trigger edge whose raw counters were latched at `t_us`. An accepted touch
    /// during a PROBE run is kept and recorded; the next sample carries `PROBE_EVENT`.
    pub fn on_probe_edge<R: Recorder>(
        &mut self,
        t_us: u64,
        raw: [u32; MAX_AXES],
        rec: &mut R,
    ) -> TriggerOutcome {
        let outcome = self.acq.probe_trigger(t_us, raw);
        if let TriggerOutcome::Accepted(latch) = outcome {
            self.on_touch(&latch, rec);
        }
        outcome
    }

    pub(super) fn on_touch<R: Recorder>(&mut self, latch: &ProbeLatch, rec: &mut R) {
        self.flush(rec);
        self.probe_event = true;
        let t = Touch {
            t_us: latch.t_us,
            axes: self.acq.positions(&latch.counts),
        };
        self.last_touch = Some(t);
        self.touch(&t, rec);
    }

    /// A recorded touch point (replay): as an accepted probe edge of the run.
    pub fn on_recorded_touch<R: Recorder>(&mut self, t: &Touch, rec: &mut R) {
        self.flush(rec);
        self.last_touch = Some(*t);
        self.touch(t, rec);
    }

    pub(super) fn touch<R: Recorder>(&mut self, t: &Touch, rec: &mut R) {
        let running = self.session == SessionState::Running;
        match &mut self.estimator {
            RunEstimator::Probe(run) if running => {
                let a = self.axes.canonical(&t.axes);
                let at = |k: Option<usize>| {
                    k.and_then(|k| a.get(k))
                        .copied()
                        .map_or(f64::NAN, f64::from)
                };
                let [x, y, z, _, _] = a;
                run.touch(
                    [f64::from(x), f64::from(y), f64::from(z)],
                    at(self.axes.b),
                    at(self.axes.c),
                );
                rec.touch(t);
                if let Some(n) = &mut self.recorded {
                    *n = n.saturating_add(1);
                }
            }
            _ => self.touches_outside_run = self.touches_outside_run.saturating_add(1),
        }
    }

    /// One sample period's readings: the LVDT block (its demodulation, or a DC voltage:
    /// [`lvdt_reading`](Self::lvdt_reading)), the raw encoder counters, the cumulative count
    /// of samples lost upstream. Turns them into a calibrated [`Sample`] and processes it
    /// ([`on_sample`](Self::on_sample)).
    pub fn on_raw_sample<R: Recorder>(
        &mut self,
        t_us: u64,
        block: BlockReading,
        raw: [u32; MAX_AXES],
        lost_total: u32,
        rec: &mut R,
    ) -> Sample {
        let probe_event = core::mem::take(&mut self.probe_event);
        let lvdt = self.lvdt_reading(block);
        let s = self.acq.calibrate(t_us, lvdt, raw, lost_total, probe_event);
        self.on_sample(&s, rec);
        s
    }

    /// The LVDT reading of a DC conditioner voltage under the configured zero and span.
    pub fn dc_reading(&self, volts: f32) -> LvdtReading {
        self.acq.dc_reading(volts)
    }

    /// The reading of a block under the configured input mode, zero and span; a block
    /// acquired in the other mode (the mode changed since) is [`DemodError::ModeChanged`]: that
    /// sample is flagged LVDT open.
    pub fn lvdt_reading(&self, block: BlockReading) -> Result<LvdtReading, DemodError> {
        match (block, self.config.lvdt_input) {
            (BlockReading::Ac(r), LvdtInput::AcRatiometric) => r,
            (BlockReading::DcVolts(v), LvdtInput::DcConditioner) => Ok(self.dc_reading(v)),
            _ => Err(DemodError::ModeChanged),
        }
    }

    /// Hands the run begins and ends pending since the last sample to `rec`. Samples do it
    /// themselves; a shell calls it after the commands it passed on, so that a stopped run's
    /// end reaches the log and the stream without waiting for the next sample.
    #[inline(always)]
    pub fn flush<R: Recorder>(&mut self, rec: &mut R) {
        // the sample path's case: nothing pending (the queue's pop is ~40 instructions)
        if !self.pending.is_empty() {
            self.flush_pending(rec);
        }
    }

    pub(super) fn flush_pending<R: Recorder>(&mut self, rec: &mut R) {
        let mut skipped_run = None;
        while let Some(p) = self.pending.pop_front() {
            match p {
                Pending::Begin(run) if run == self.meta.run => {
                    rec.begin_run(&self.meta);
                    self.recorded = Some(0);
                }
                // armed and over before its first sample, then re-armed: nothing to record
                Pending::Begin(run) => skipped_run = Some(run),
                Pending::End(end) if Some(end.run) != skipped_run => {
                    rec.end_run(&end);
                    self.recorded = None;
                }
                Pending::End(_) => {}
            }
        }
    }

    /// Processes one calibrated sample: the run monitor, the armed pattern's estimators, the
    /// live values; a sample of the run is recorded.
    pub fn on_sample<R: Recorder>(&mut self, s: &Sample, rec: &mut R) {
        self.flush(rec);
        let session = self.session;
        self.last_flags = s.flags;
        let live = &mut self.live;
        live.sample_counter = s.seq;
        let lvdt_ok = !s
            .flags
            .intersects(SampleFlags::LVDT_OPEN.with(SampleFlags::LVDT_OVER_RANGE));
        live.set(Live::DeltaL, lvdt_ok.then_some(s.delta_l_um));
        live.set(
            Live::Temp,
            (!s.flags.contains(SampleFlags::TEMPERATURE_FAULT)).then_some(s.temp_c),
        );
        if self.trigger.is_some() {
            self.on_trigger(&s.axes);
        }
        if self.session == SessionState::Running {
            let verdict = self.monitor.on_sample(s);
            if verdict != Verdict::NotRunning {
                rec.sample(s);
                if let Some(n) = &mut self.recorded {
                    *n = n.saturating_add(1);
                }
            }
            match verdict {
                Verdict::Use => {
                    let c = Sample {
                        axes: self.axes.canonical(&s.axes),
                        ..*s
                    };
                    self.feed(&c);
                }
                Verdict::Abort(_, reason) => {
                    self.abort(reason);
                    self.flush(rec);
                }
                Verdict::Skip(_) | Verdict::NotRunning => {}
            }
        }
        self.refresh_live();
        // a run begun, stopped or aborted at this sample changed more than the sample's bits
        if self.session == session {
            self.update_sample_status();
        } else {
            self.update_status();
        }
    }

    /// The self-triggered run's decision at a sample, carried out before the sample is used:
    /// the run starts with it or ends before it. Inlined: it is on every sample's path (the
    /// live pipeline's row of `cargo bench-m4` counts it).
    #[inline(always)]
    pub(super) fn on_trigger(&mut self, raw_axes: &[f32; MAX_AXES]) {
        let axes = self.axes.canonical(raw_axes);
        let armed_or_running = !self.idle();
        let event = match self.trigger.as_mut() {
            Some(t) if armed_or_running => t.on_sample(&axes),
            _ => TriggerEvent::None,
        };
        match (event, self.session) {
            (TriggerEvent::Start, SessionState::Armed) => self.begin_running(),
            (TriggerEvent::Stop, SessionState::Running) => self.stop(),
            (TriggerEvent::None, SessionState::Armed)
                if self.trigger.is_some_and(|t| t.fed_in()) =>
            {
                self.procedure_note = Some(ProcedureNote::WaitingForDataArc);
            }
            _ => {}
        }
    }
}
