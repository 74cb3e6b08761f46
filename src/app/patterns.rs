//! Each pattern's run, the one place that dispatches on the armed pattern: arm from its set-up
//! (a missing field named), feed the used samples, refresh the live values, finish into the
//! results (or abort when it has none). The estimators themselves are the pattern modules':
//! [`super::circle`], [`super::bc_ballbar`], [`super::ssm`], [`super::probe`].
//!
//! One enum ([`RunEstimator`]) with a match per phase, not a trait object per pattern: the
//! phases of the four patterns touch different procedure state of the [`App`] (the circle's
//! figure requests, the seed 002 procedure, the two-step, the probe spheres), which a trait
//! would have to take as one context of everything; here each phase shows every pattern's
//! step side by side, and the enum costs no allocation or vtable on the sample path.

use super::bc_ballbar::Setup;
use super::circle::{self, CircleGeometry};
use super::live::Live;
use super::live_fit::{
    LIVE_FIT_ALL, LIVE_SSM, LIVE_SSM_E, LIVE_U_SHIFT, live_fit, live_u_due, publish_fit,
    set_live_fit,
};
use super::probe::{self, ProbeRun};
use super::results::ResultSink;
use super::run::{AbortReason, RunMonitor};
use super::session::{CommandError, Needs, ProcedureNote, SessionState, probe_note};
use super::ssm;
use super::trigger::ArcTrigger;
use super::{App, Direction, Pattern, Pending, ResultId, RunMeta};
use crate::acquisition::Sample;
use crate::config::RunTrigger;
use crate::metrology::bar_budget::{BarBudget, FigureKind};
use crate::metrology::circle_fit::SampleUse;
use crate::metrology::circle_fit::{CircleEstimate, CircleFit};

/// The armed run's estimator.
#[derive(Clone, Copy, Debug, PartialEq)]
#[allow(clippy::large_enum_variant)] // one lives in the App; its size is the largest pattern's
pub(super) enum RunEstimator {
    /// Nothing armed (or the last run is over).
    None,
    /// CIRCLE: the samples go into [`App::circle`] (both directions live there).
    Circle,
    /// A seed 002 step's running fit.
    Step(Pattern, CircleFit),
    /// SSM: the samples go into [`App::ssm`].
    Ssm,
    /// PROBE.
    Probe(ProbeRun),
}

impl App {
    pub(super) fn arm(&mut self) -> Result<(), CommandError> {
        let setup = self.config.setup;
        let mut trigger = None;
        let est = match self.pattern {
            Pattern::Circle => {
                let g = match CircleGeometry::from_config(&setup) {
                    Ok(g) => g,
                    Err(f) => return self.refuse(CommandError::Missing(f)),
                };
                if setup.run_trigger == RunTrigger::FeedIn {
                    trigger = Some(ArcTrigger::new(&g, self.direction, setup.circle_arc_deg));
                }
                self.circle.begin_run(g, self.direction);
                self.spikes.begin_run(g, self.direction);
                self.live_u_at = u32::MAX;
                RunEstimator::Circle
            }
            Pattern::Ssm => match self.ssm.restart(
                &setup,
                self.config.bar_length_mm,
                BarBudget::from_config(&self.config),
            ) {
                Ok(()) => RunEstimator::Ssm,
                Err(f) => return self.refuse(CommandError::Missing(f)),
            },
            Pattern::Probe => RunEstimator::Probe(ProbeRun::new(f64::from(setup.probe_length_mm))),
            step @ (Pattern::Bx | Pattern::By | Pattern::Cr | Pattern::Ca | Pattern::Cr2) => {
                let s = match Setup::from_config(&setup) {
                    Ok(s) => s,
                    Err(f) => return self.refuse(CommandError::Missing(f)),
                };
                match self.seed002_begun.then_some(&mut self.seed002) {
                    // a new budget applies to the runs measured so far
                    Some(p) if p.setup().same_measurement(&s) => p.set_mounting(s.mounting),
                    _ => {
                        // a new set-up starts a new procedure
                        self.new_procedure(s);
                        self.seed002_epoch = self.seed002_epoch.wrapping_add(1);
                        self.identify_pending = false;
                        self.results.clear(ResultId::EBxX, ResultId::CorrBetaCz);
                    }
                }
                let fit = match self.seed002() {
                    Some(p) => p.run_fit(step),
                    None => return self.refuse(CommandError::WrongState(Needs::Procedure)),
                };
                self.live_u_at = u32::MAX;
                RunEstimator::Step(step, fit)
            }
        };
        self.estimator = est;
        self.trigger = trigger;
        if trigger.is_some() {
            self.procedure_note = Some(ProcedureNote::WaitingForFeedIn);
        }
        self.session = SessionState::Armed;
        self.abort_reason = None;
        self.monitor = RunMonitor::new(self.limits);
        self.results.clear(ResultId::EccU, ResultId::Arc);
        match self.pattern {
            Pattern::Ssm => self.results.clear(ResultId::SsmEx, ResultId::SsmStations),
            Pattern::Probe => self
                .results
                .clear(ResultId::SphereX, ResultId::SphereResidualRms),
            Pattern::Circle
            | Pattern::Bx
            | Pattern::By
            | Pattern::Cr
            | Pattern::Ca
            | Pattern::Cr2 => {}
        }
        self.meta = RunMeta {
            run: self.meta.run.wrapping_add(1),
            pattern: self.pattern,
            direction: self.direction,
            config: self.config,
        };
        self.queue(Pending::Begin(self.meta.run));
        Ok(())
    }

    /// A new seed 002 procedure with set-up `s`, in place.
    pub(super) fn new_procedure(&mut self, s: Setup) {
        self.seed002.restart(s);
        self.seed002_begun = true;
    }

    /// Publishes a run's circle fit with the bar's shares and the centre's (µm, for r0, e_u,
    /// e_v: [`circle::CircleRun::finish_run`]; zero for a seed 002 step, whose centre's inputs
    /// are in the procedure's budget).
    pub(super) fn stop(&mut self) {
        if let Err(reason) = self.monitor.stop() {
            self.abort(reason);
            return;
        }
        let d = self.direction;
        let setup = self.config.setup;
        // the bar's share of every u (`metrology::bar_budget`)
        let bar = BarBudget::from_config(&self.config);
        self.procedure_note = None;
        let ok = match &mut self.estimator {
            RunEstimator::None => false,
            // the run's fit and figures: a job (`CircleRun::figures`)
            RunEstimator::Circle => {
                match self.circle.finish_run(
                    d,
                    &mut self.results,
                    setup.circle_u_centre_um,
                    bar,
                    self.config.bar_length_mm,
                ) {
                    Ok(request) => {
                        if let Some(r) = self.figures_requests.get_mut(circle::dir_index(d)) {
                            *r = Some(request);
                        }
                        self.spikes.end_run(d, &mut self.results);
                        true
                    }
                    Err(_) => false,
                }
            }
            RunEstimator::Step(step, fit) => {
                let (step, fit) = (*step, *fit);
                match fit.estimate() {
                    Ok(e) => {
                        publish_fit(&mut self.results, &e, fit.arc_deg(), &bar, [0.0; 3]);
                        self.record_step(step, d, e, &bar);
                        true
                    }
                    Err(_) => false,
                }
            }
            RunEstimator::Ssm => match self.ssm.finish() {
                Ok(m) => {
                    ssm::publish(&m, &bar, setup.ssm_u_socket_um, &mut self.results);
                    match self
                        .two_step
                        .on_measurement(&setup, &m, &bar, &mut self.results)
                    {
                        Err(ssm::TwoStepFailure::Missing(f)) => {
                            self.procedure_note = Some(ProcedureNote::Missing(f));
                        }
                        Err(ssm::TwoStepFailure::Identify(_)) => {
                            self.procedure_note = Some(ProcedureNote::TwoStepFailed);
                        }
                        Ok(_) => {}
                    }
                    true
                }
                Err(_) => false,
            },
            RunEstimator::Probe(run) => match run.finish() {
                Ok(fit) => {
                    probe::publish(&fit, &mut self.results);
                    match self.spheres.on_sphere(run, &fit, &setup) {
                        Err(e) => self.procedure_note = Some(probe_note(e)),
                        Ok(Some(axis)) => {
                            // the method's results are recomputed: invalid until the job ends
                            let (first, last) = axis.results();
                            self.results.clear(first, last);
                            if let Some(r) = self.probe_requests.get_mut(axis as usize) {
                                *r = true;
                            }
                        }
                        Ok(None) => {}
                    }
                    true
                }
                Err(_) => false,
            },
        };
        if ok {
            self.session = SessionState::Done;
            self.end_run(None);
        } else {
            self.abort(AbortReason::NotObservable);
        }
    }

    /// Files a seed 002 step's run; its eccentricity (mean of the step's runs) goes into the
    /// results with the LVDT scale's share of `bar` in its u.
    pub(super) fn record_step(
        &mut self,
        step: Pattern,
        d: Direction,
        e: CircleEstimate,
        bar: &BarBudget,
    ) {
        let Some(p) = self.seed002_begun.then_some(&mut self.seed002) else {
            return;
        };
        if p.record(step, d, e).is_err() {
            self.seed002_runs_not_kept = self.seed002_runs_not_kept.saturating_add(1);
            return;
        }
        if let (Ok(se), Some(k)) = (p.step_eccentricity(step), step.seed002_step()) {
            let ids = [
                (ResultId::EBxX, ResultId::EBxZ),
                (ResultId::EByX, ResultId::EByZ),
                (ResultId::ECrX, ResultId::ECrY),
                (ResultId::ECaX, ResultId::ECaY),
                (ResultId::ECr2X, ResultId::ECr2Y),
            ];
            if let Some(&(a, b)) = ids.get(k) {
                for (id, e, u) in [(a, se.e_um[0], se.u_e_um[0]), (b, se.e_um[1], se.u_e_um[1])] {
                    let shape = FigureKind::Shape;
                    self.results
                        .set_with_bar(id, e as f32, [u as f32, 0.0], bar, shape);
                }
            }
        }
        if p.missing().is_none() {
            self.identify_pending = true;
        }
    }

    pub(super) fn feed(&mut self, s: &Sample) {
        let d = self.direction;
        match &mut self.estimator {
            RunEstimator::Circle => {
                if self.circle.update(s, d) == SampleUse::Used
                    && let Some(n) = self.circle.direction_of(&s.axes)
                {
                    self.spikes.update(s.delta_l_um, n, s.t_us);
                }
            }
            RunEstimator::Step(_, fit) => {
                fit.update(s);
            }
            RunEstimator::Ssm => self.ssm.update(s),
            RunEstimator::Probe(_) | RunEstimator::None => {}
        }
    }

    pub(super) fn refresh_live(&mut self) {
        let running = self.session == SessionState::Running;
        let counter = self.live.sample_counter;
        let kept = match (&self.estimator, running) {
            (RunEstimator::Circle, true) => {
                let (fit, u) = self
                    .circle
                    .live(self.direction, &self.config, &mut self.live_u_at);
                set_live_fit(&mut self.live, fit, u)
            }
            // a seed 002 step's result takes the residual's u: no noise is given
            (RunEstimator::Step(_, f), true) => {
                let with_u = live_u_due(f.samples(), &mut self.live_u_at);
                let (fit, u) = live_fit(f, f32::NAN, [0.0; 3], with_u, &self.config);
                set_live_fit(&mut self.live, fit, u)
            }
            (RunEstimator::Ssm, true) => {
                let ([ex, ey, ez], u) = self.ssm.live(counter);
                let live = &mut self.live;
                live.set(Live::SsmEx, ex);
                live.set(Live::SsmEy, ey);
                live.set(Live::SsmEz, ez);
                match u {
                    Some([ux, uy, uz]) => {
                        live.set(Live::USsmEx, ux);
                        live.set(Live::USsmEy, uy);
                        live.set(Live::USsmEz, uz);
                    }
                    // held from the last refresh, but not where E is not valid
                    None => live.invalidate((!live.valid & LIVE_SSM_E) << LIVE_U_SHIFT),
                }
                LIVE_SSM
            }
            _ => 0,
        };
        let live = &mut self.live;
        // the values of no running estimator: invalid (a test of the mask on most samples)
        live.invalidate((LIVE_FIT_ALL | LIVE_SSM) & !kept);
    }
}
