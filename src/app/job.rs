//! Jobs: the application's long computations, run by the shell apart from samples and
//! commands.
//!
//! | job | wanted when | publishes | on the pod (170 MHz) |
//! |---|---|---|---|
//! | circle figures | a CIRCLE run ends | G, F of its direction; once both directions are complete G(b), H, the radial deviation, the diagnoses; the run's reversal spikes | 0.1–0.3 s |
//! | seed 002 identification | every step has its CW and CCW runs | the model mode's deviations and corrections, the thesis mode's | 2.6 s |
//! | touch-probe identification | a PROBE run files the last sphere of the B or the C method | that axis's deviations with their lobing shares | tens of ms |
//!
//! A job never runs inside a command or a sample: the command that ends a run is answered at
//! once, and the results the job publishes stay invalid, with status bit
//! [`StatusWord::COMPUTING`](super::StatusWord::COMPUTING) set and
//! [`StatusWord::RESULTS_READY`](super::StatusWord::RESULTS_READY) clear, until it has. Three
//! steps, so that the middle one can run at the lowest priority while the application goes
//! on with samples, frames and bytes:
//! 1. [`App::start_job`](super::App::start_job) copies the job's inputs into a [`JobSlot`]
//!    (the circle test, 14.4 KiB, with the run's samples about its reversal points, 0.8 KiB;
//!    the procedure's eccentricities, 0.6 KiB; the spheres, 2.8
//!    KiB — one at a time, in one place);
//! 2. [`JobSlot::run`] computes on that copy into a [`ResultPatch`] and touches nothing of the
//!    application;
//! 3. [`App::finish_job`](super::App::finish_job) applies the patch if the runs it came from
//!    are still the latest.
//!
//! The same three steps run on the pod, in the simulated pod and in replay
//! ([`App::run_jobs`](super::App::run_jobs) runs them back to back), so the results are the
//! same bit for bit wherever they run.

use super::bc_ballbar::Procedure;
use super::bc_ballbar::{IdentificationInput, Setup, StepEccentricity, publish_identification};
use super::circle::{CircleRun, FiguresRequest};
use super::probe::{ProbeAxis, ProbeFailure, Spheres};
use super::results::ResultPatch;
use super::session::{ProcedureNote, probe_note};
use super::{App, ResultId};
use crate::config::TestSetup;
use crate::identify::mill_turn::model_lsq::IdentificationScratch;
use crate::in_place::{self, init_in_place};
use crate::metrology::bar_budget::BarBudget;
use crate::metrology::iso230_4::{RunReversals, SpikeCapture};
use core::mem::MaybeUninit;

/// Which job a slot holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JobKind {
    /// The ISO 230-4 figures of a CIRCLE run ([`CircleRun::figures`]).
    CircleFigures,
    /// The seed 002 identification ([`IdentificationInput::identify`]).
    Seed002Identification,
    /// A touch-probe method's identification ([`Spheres::identify`]).
    ProbeIdentification,
}

/// What a slot's job is about to compute, or computed; the number is the application's count
/// of procedures begun (or spheres cleared) when it started: its results go only there.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Work {
    Figures(FiguresRequest),
    Identification(u32),
    Probe(ProbeAxis, u32),
}

/// What [`super::App::finish_job`] takes from a slot whose job ran.
pub(crate) enum JobOutcome<'a> {
    /// The figures, and the run's spikes and oscillations (`None`: the job had no capture of
    /// the run).
    Figures(FiguresRequest, &'a mut ResultPatch, Option<RunReversals>),
    Identification(u32, Result<&'a mut ResultPatch, ()>),
    Probe(u32, Result<&'a mut ResultPatch, ProbeFailure>),
}

/// Why a job gave no result.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Failure {
    /// The seed 002 identification failed (the procedure note says so).
    Identification,
    /// The touch-probe identification failed.
    Probe(ProbeFailure),
}

/// The spheres and the set-up a touch-probe identification reads.
#[derive(Clone, Copy)]
struct ProbeInput {
    spheres: Spheres,
    setup: TestSetup,
}

/// The identification's inputs and the model fit's scratch (its 4.8 KiB of sensitivities
/// here, not on the worker's stack, where the identification is the deepest job).
#[derive(Clone, Copy)]
struct IdentificationJob {
    input: IdentificationInput,
    scratch: IdentificationScratch,
}

/// The circle figures' inputs: the test, and the ended run's samples about its reversal points
/// (`None`: replaced by the next run before the job began).
#[derive(Clone, Copy)]
struct FiguresJob {
    circle: CircleRun,
    reversals: Reversals,
}

/// The run's samples about its reversal points, then what the job found in them (in their
/// place: the samples are not needed after).
#[derive(Clone, Copy)]
#[allow(clippy::large_enum_variant)] // one at a time, in the job slot: the point of the enum
enum Reversals {
    /// The job had no capture of the run.
    None,
    /// The capture, before the job ran.
    Captured(SpikeCapture),
    /// The spikes and oscillations the job found.
    Found(RunReversals),
}

/// A job's copy of its inputs: one job at a time, so one place for all (the circle test is
/// the largest).
#[derive(Clone, Copy)]
union Inputs {
    figures: FiguresJob,
    identification: IdentificationJob,
    probe: ProbeInput,
}

impl Inputs {
    /// Inputs of no job, built in place.
    fn init(s: &mut MaybeUninit<Self>) -> &mut Self {
        let p = s.as_mut_ptr();
        // SAFETY: `p` comes from a `&mut MaybeUninit<Inputs>`: valid for writes and aligned;
        // a union's variants start at its start, so writing one initialises the union (its
        // other bytes are never read: a slot's `work` names the variant in use).
        // The scratch (9 KiB of f64, all zero: `IdentificationScratch::EMPTY`) is zeroed in
        // place: a value of it would be a temporary of its size in the caller's frame (main's,
        // at boot).
        unsafe {
            (&raw mut (*p).identification.input).write(IdentificationInput {
                setup: Setup::thesis_table_4_3(),
                steps: [StepEccentricity::default(); 5],
            });
            (&raw mut (*p).identification.scratch).write_bytes(0, 1);
            s.assume_init_mut()
        }
    }
}

/// The place a job runs in: a copy of its inputs and the results it computes (17.4 KiB: on the
/// pod a `static` in CCM SRAM beside the sample log, built in place).
pub struct JobSlot {
    work: Option<Work>,
    /// The job ran ([`JobSlot::run`]).
    ran: bool,
    /// Why the job gave no result.
    failed: Option<Failure>,
    /// The inputs of `work` (the variant `work` names).
    inputs: Inputs,
    /// The bar's budget (identification; the figures carry theirs).
    bar: BarBudget,
    patch: ResultPatch,
}

impl JobSlot {
    /// An empty slot, built in place in `slot` (it never passes through the stack).
    pub fn init(slot: &mut MaybeUninit<Self>) -> &mut Self {
        init_in_place!(slot, Self {
            work: None,
            ran: false,
            failed: None,
            bar: BarBudget::NONE,
            patch: ResultPatch::new(),
        } in place {
            inputs: Inputs::init,
        })
    }

    /// An empty slot (host and tests; the pod builds its own in place with [`JobSlot::init`]).
    pub fn new() -> Self {
        in_place::build(Self::init)
    }

    /// True when the slot holds no job.
    pub fn is_empty(&self) -> bool {
        self.work.is_none()
    }

    /// The job the slot holds.
    pub fn kind(&self) -> Option<JobKind> {
        self.work.map(|w| match w {
            Work::Figures(_) => JobKind::CircleFigures,
            Work::Identification(_) => JobKind::Seed002Identification,
            Work::Probe(..) => JobKind::ProbeIdentification,
        })
    }

    /// Takes a copy of `circle` (the test as its run ended) and of the run's `capture` for
    /// `request`'s figures and spikes.
    pub(crate) fn load_figures(
        &mut self,
        circle: &CircleRun,
        capture: Option<&SpikeCapture>,
        request: FiguresRequest,
    ) {
        let p = &raw mut self.inputs;
        // SAFETY: `p` is valid for writes and aligned (from `&mut self.inputs`); writing the
        // union's `figures` variant field by field (place-to-place copies, memcpy: no
        // temporary of the 14 KiB test on the stack) initialises it, and the slot's `work`
        // names that variant from here on.
        unsafe {
            (&raw mut (*p).figures.circle).write(*circle);
            (&raw mut (*p).figures.reversals)
                .write(capture.map_or(Reversals::None, |c| Reversals::Captured(*c)));
        }
        self.start(Work::Figures(request));
    }

    /// Takes the identification's inputs, for the procedure of `epoch`.
    pub(crate) fn load_identification(
        &mut self,
        input: IdentificationInput,
        bar: BarBudget,
        epoch: u32,
    ) {
        // (the scratch is set when the job runs: in place, no 4.8 KiB temporary here; the
        // slot's `work` names the identification variant from here on)
        self.inputs.identification.input = input;
        self.bar = bar;
        self.start(Work::Identification(epoch));
    }

    /// Takes a copy of the spheres and the set-up for `axis`'s identification, for the spheres
    /// of `epoch`.
    pub(crate) fn load_probe(
        &mut self,
        spheres: &Spheres,
        setup: &TestSetup,
        axis: ProbeAxis,
        epoch: u32,
    ) {
        self.inputs.probe = ProbeInput {
            spheres: *spheres,
            setup: *setup,
        };
        self.start(Work::Probe(axis, epoch));
    }

    fn start(&mut self, work: Work) {
        self.patch.clear();
        self.ran = false;
        self.failed = None;
        self.work = Some(work);
    }

    /// Computes the slot's job on its copy of the inputs (the long part; nothing of the
    /// application is touched). Nothing happens if the slot is empty or its job ran already.
    pub fn run(&mut self) {
        if self.ran {
            return;
        }
        // SAFETY (each arm): `work` names the variant of `inputs` its `load_*` wrote.
        match self.work {
            None => return,
            Some(Work::Figures(request)) => {
                let job = unsafe { &mut self.inputs.figures };
                figures(&job.circle, &request, &mut self.patch);
                if let Reversals::Captured(c) = &job.reversals {
                    let found = c.reversals();
                    job.reversals = Reversals::Found(found);
                }
            }
            Some(Work::Identification(_)) => {
                let job = unsafe { &mut self.inputs.identification };
                if !identification(job, &self.bar, &mut self.patch) {
                    self.failed = Some(Failure::Identification);
                }
            }
            Some(Work::Probe(axis, _)) => {
                let p = unsafe { &self.inputs.probe };
                self.failed = probe(p, axis, &mut self.patch).err().map(Failure::Probe);
            }
        }
        self.ran = true;
    }

    /// The outcome of a job that ran, for the application to publish; the slot is empty after
    /// (its patch is applied or dropped by the caller before the next job starts).
    pub(crate) fn take_outcome(&mut self) -> Option<JobOutcome<'_>> {
        if !self.ran {
            return None;
        }
        self.ran = false;
        let work = self.work.take()?;
        let (patch, failed) = (&mut self.patch, self.failed);
        Some(match work {
            Work::Figures(request) => {
                // SAFETY: `work` names the figures variant, which `load_figures` wrote
                let found = match unsafe { &self.inputs.figures.reversals } {
                    Reversals::Found(r) => Some(*r),
                    _ => None,
                };
                JobOutcome::Figures(request, patch, found)
            }
            Work::Identification(epoch) => JobOutcome::Identification(
                epoch,
                match failed {
                    None => Ok(patch),
                    Some(_) => Err(()),
                },
            ),
            Work::Probe(_, epoch) => JobOutcome::Probe(
                epoch,
                match failed {
                    Some(Failure::Probe(e)) => Err(e),
                    _ => Ok(patch),
                },
            ),
        })
    }

    /// Results a job set beyond the patch's room (0: a test holds it).
    pub fn patch_overflowed(&self) -> u32 {
        self.patch.overflowed()
    }
}

// One function per job, out of line: the worker's stack holds the frame of the job that runs,
// not of all three (`.ci/stack-report`).

#[inline(never)]
fn figures(circle: &CircleRun, request: &FiguresRequest, patch: &mut ResultPatch) {
    circle.figures(request, patch);
}

/// Whether the identification gave a result.
#[inline(never)]
fn identification(job: &mut IdentificationJob, bar: &BarBudget, patch: &mut ResultPatch) -> bool {
    match job.input.identify_in(bar, &mut job.scratch) {
        Ok(id) => {
            publish_identification(&id, bar, patch);
            true
        }
        Err(_) => false,
    }
}

#[inline(never)]
fn probe(p: &ProbeInput, axis: ProbeAxis, patch: &mut ResultPatch) -> Result<bool, ProbeFailure> {
    p.spheres.identify(axis, &p.setup, patch)
}

impl Default for JobSlot {
    fn default() -> Self {
        Self::new()
    }
}

// ------------------------------------------------------------- the application's side

impl App {
    /// True while a job is wanted or running ([`job`](super::job): the ISO 230-4 figures of a run that
    /// ended, a touch-probe method, the seed 002 identification): the results it publishes are
    /// invalid until then (status bit [`StatusWord::COMPUTING`](super::StatusWord::COMPUTING)).
    pub fn job_pending(&self) -> bool {
        self.job.is_some()
            || self.figures_requests.iter().any(Option::is_some)
            || self.probe_requests.iter().any(|&r| r)
            || self.identify_pending
    }

    /// Hands the next wanted job to `slot` (empty: no job of this application is running), with
    /// a copy of its inputs; returns whether it did. The shell then runs
    /// [`JobSlot::run`] where a long computation does no harm (the pod: the lowest priority)
    /// and gives the slot back with [`App::finish_job`]. Shortest first: the figures of a run
    /// (tenths of a second), a touch-probe method, then the seed 002 identification (seconds).
    #[inline(never)] // off the command's and the sample's chains of calls (stack)
    pub fn start_job(&mut self, slot: &mut JobSlot) -> bool {
        if self.job.is_some() || !slot.is_empty() {
            return false;
        }
        for k in 0..self.figures_requests.len() {
            let Some(request) = self.figures_requests.get_mut(k).and_then(Option::take) else {
                continue;
            };
            // a run begun again since (or a new test) replaced the runs the request read
            if self.circle.current(&request) {
                let capture = self.spikes.take_capture(request.direction);
                slot.load_figures(&self.circle, capture, request);
                self.job = Some(JobKind::CircleFigures);
                self.update_status();
                return true;
            }
        }
        for axis in [ProbeAxis::B, ProbeAxis::C] {
            if self
                .probe_requests
                .get_mut(axis as usize)
                .is_some_and(core::mem::take)
            {
                let epoch = self.spheres_epoch;
                slot.load_probe(&self.spheres, &self.config.setup, axis, epoch);
                self.job = Some(JobKind::ProbeIdentification);
                self.update_status();
                return true;
            }
        }
        if core::mem::take(&mut self.identify_pending) {
            let input = self.seed002().map(Procedure::identification_input);
            self.results.clear(ResultId::DxBt, ResultId::CorrBetaCz);
            match input {
                Some(Ok(input)) => {
                    let bar = BarBudget::from_config(&self.config);
                    slot.load_identification(input, bar, self.seed002_epoch);
                    self.job = Some(JobKind::Seed002Identification);
                    self.update_status();
                    return true;
                }
                _ => self.procedure_note = Some(ProcedureNote::Seed002Failed),
            }
        }
        self.update_status();
        false
    }

    /// Takes back a slot whose job ran ([`JobSlot::run`]): its results are published if the runs
    /// they came from are still the latest (a run of the same direction begun again, a new
    /// test or procedure, `CLEAR` or `RESET` since the job started make them stale: they are
    /// dropped, and the newer runs' own jobs publish theirs); the slot is empty after. A slot
    /// whose job has not run is left as it is.
    #[inline(never)] // off the command's and the sample's chains of calls (stack)
    pub fn finish_job(&mut self, slot: &mut JobSlot) {
        let Some(outcome) = slot.take_outcome() else {
            return;
        };
        match outcome {
            JobOutcome::Figures(request, patch, spikes) => {
                if self.circle.current(&request) {
                    patch.apply(&mut self.results);
                    self.spikes
                        .file(request.direction, spikes, &mut self.results);
                    if let (true, Some(g)) = (request.both_directions, request.geometry) {
                        self.planes.file(
                            g.fit.geometry.plane,
                            request.bar_length_mm,
                            &mut self.results,
                        );
                        self.sweep.file(g, &mut self.results);
                    }
                }
            }
            JobOutcome::Identification(epoch, Ok(patch)) => {
                if epoch == self.seed002_epoch {
                    patch.apply(&mut self.results);
                }
            }
            JobOutcome::Identification(epoch, Err(())) => {
                if epoch == self.seed002_epoch {
                    self.procedure_note = Some(ProcedureNote::Seed002Failed);
                }
            }
            JobOutcome::Probe(epoch, result) if epoch == self.spheres_epoch => match result {
                Ok(patch) => patch.apply(&mut self.results),
                Err(e) => self.procedure_note = Some(probe_note(e)),
            },
            JobOutcome::Probe(..) => {}
        }
        self.job = None;
        self.update_status();
    }

    /// Runs every wanted job here and now in `slot` ([`App::start_job`], [`JobSlot::run`],
    /// [`App::finish_job`]): the host's and replay's way (the pod runs them at the lowest
    /// priority). Returns whether there was one.
    pub fn run_jobs(&mut self, slot: &mut JobSlot) -> bool {
        let mut any = false;
        while self.start_job(slot) {
            slot.run();
            self.finish_job(slot);
            any = true;
        }
        any
    }
}
