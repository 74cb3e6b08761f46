//! The pod application (DESIGN §4, §7a): everything the pod decides about a run, the same on the
//! firmware, in the simulator and in replay.
//!
//! [`App`] owns the configuration, the acquisition pipeline, the session state machine, the
//! run monitor, the armed pattern's estimators, the live values with their validity, the
//! results table and the procedures (seed 002, the seed 000 two-step, the touch-probe C and B
//! axes).
//! Its inputs are the sensor readings of each sample period ([`App::on_raw_sample`], or an
//! already calibrated [`Sample`](crate::acquisition::Sample) in replay: [`App::on_sample`]), probe edges and the client
//! commands ([`App::execute`], [`App::set_field`], …); its outputs are read by the protocols
//! (live values, state, results) and written to a [`Recorder`] (the log, the USB stream). A
//! shell — the firmware's compute task, the simulated pod, replay — moves readings, bytes and
//! samples; it takes no decision of its own.
//!
//! # A run
//!
//! configure (set-up fields) → [`Command::Arm`] (the pattern's geometry must be set: the
//! missing field is named) → [`Command::Start`] → samples: each goes through the run monitor
//! ([`run`]), a used one into the estimators, and the live values are refreshed → [`Command::Stop`]
//! (results, or an abort with the reason if the run has none) or [`Command::Abort`].
//!
//! | pattern | per sample (live) | at stop (results) | procedure |
//! |---|---|---|---|
//! | CIRCLE | e_u, e_v, r0 of the direction's limaçon fit | the run's fit, G, F; with both directions G(b), H, radial, diagnoses | latest CCW and CW runs ([`circle`]) |
//! | BX BY CR CA CR2 | e, r0 of the step's fit | the run's fit; the step's CW/CCW eccentricity | seed 002 identification when every step has CW and CCW ([`bc_ballbar`]) |
//! | SSM | E_x, E_y, E_z of the neighbourhood (each or none) | E from the dwell stations, u(E) | seed 000 two-step over two SSM runs ([`ssm`]) |
//! | PROBE | – | the sphere through the touch points | touch-probe C axis over four spheres, B axis over B = 0/90° with two tool lengths ([`probe`]) |
//!
//! What takes long at a run's end — the ISO 230-4 figures, a touch-probe method, the seed 002
//! identification (seconds on the M4: f64 in software) — is a [`job`]: the command that ends the
//! run only marks it wanted (status bit [`StatusWord::COMPUTING`]), and the shell runs it on a
//! copy of its inputs where a long computation does no harm ([`App::start_job`],
//! [`JobSlot::run`], [`App::finish_job`]).

mod axes;
pub mod bc_ballbar;
pub mod circle;
mod commands;
mod configure;
pub mod device;
mod inputs;
pub mod job;
pub mod live;
mod live_fit;
pub mod log;
pub mod pattern;
mod patterns;
pub mod planes;
pub mod probe;
pub mod record;
pub mod results;
pub mod run;
pub mod session;
pub mod spikes;
pub mod ssm;
mod status;
pub mod sweep;
pub mod trigger;

pub use device::{DEVICE_COUNTER_COUNT, DEVICE_COUNTERS, DeviceCounter, DeviceCounters};
pub use job::JobSlot;
pub use live::{LIVE, LIVE_COUNT, LIVE_U_EVERY, Live, LiveValues, StatusWord};
pub use pattern::{Direction, Pattern};
pub use record::{Recorder, RunEnd, RunMeta, Touch};
pub use results::{
    CONTRIBUTOR_COUNT, CONTRIBUTORS, Contributor, RESULT_COUNT, ResultEntry, ResultId, ResultInfo,
    ResultPatch, ResultSink, Results,
};
pub use run::{AbortReason, RunCounters, RunLimits};
pub use session::{
    Command, CommandError, Needs, ProcedureNote, SessionState, SettingsRequest, field_name,
};

use crate::acquisition::{Acquisition, AcquisitionCounters, MAX_AXES, SampleFlags};
use crate::config::{Config, LvdtInput};
use axes::AxisMap;
use bc_ballbar::{Procedure, Setup};
use circle::{CircleRun, FiguresRequest};
use job::JobKind;
use patterns::RunEstimator;
use planes::PlaneRecords;
use probe::Spheres;
use run::RunMonitor;
use spikes::Spikes;
use ssm::{SsmRun, TwoStep};
use sweep::FeedSweep;
use trigger::ArcTrigger;

/// Recorder events waiting for the next sample (commands arrive between samples, without the
/// recorder at hand).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Pending {
    Begin(u32),
    End(RunEnd),
}

/// The pod application (module doc). State size: see `cargo bench-m4` / the size report.
#[derive(Clone, Debug)]
pub struct App {
    config: Config,
    counter_bits: [u32; MAX_AXES],
    acq: Acquisition,
    axes: AxisMap,
    limits: RunLimits,
    session: SessionState,
    pattern: Pattern,
    direction: Direction,
    abort_reason: Option<AbortReason>,
    monitor: RunMonitor,
    estimator: RunEstimator,
    meta: RunMeta,
    circle: CircleRun,
    /// The three-plane summary's latest complete circle of each plane.
    planes: PlaneRecords,
    /// The feed-rate sweep's circle and its feeds.
    sweep: FeedSweep,
    /// The circle test's reversal spikes.
    spikes: Spikes,
    ssm: SsmRun,
    /// The seed 002 procedure (meaningful once `seed002_begun`): in place, never rebuilt on
    /// the stack (3.3 KiB).
    seed002: Procedure,
    /// A seed 002 step was armed since the last `CLEAR`.
    seed002_begun: bool,
    seed002_runs_not_kept: u32,
    /// Procedures begun or cleared since boot: an identification publishes only into the
    /// procedure it identified.
    seed002_epoch: u32,
    identify_pending: bool,
    /// The figures each circle direction's last run left to a job (CCW, CW).
    figures_requests: [Option<FiguresRequest>; 2],
    /// The touch-probe methods (B, C) whose identification is wanted.
    probe_requests: [bool; 2],
    /// Sphere sets cleared since boot: a probe identification publishes only into the set it
    /// identified.
    spheres_epoch: u32,
    /// The job a shell is running ([`App::start_job`] to [`App::finish_job`]).
    job: Option<JobKind>,
    two_step: TwoStep,
    spheres: Spheres,
    touches_outside_run: u32,
    probe_event: bool,
    last_touch: Option<Touch>,
    live: LiveValues,
    /// The used samples of the running circle fit at the last refresh of its live u
    /// ([`live_u_due`]).
    live_u_at: u32,
    results: Results,
    pending: heapless::Deque<Pending, 4>,
    /// The recorders are inside a run (its begin flushed, its end not), with the samples and
    /// touch points recorded so far ([`App::recording`]).
    recorded: Option<u32>,
    refusal: Option<CommandError>,
    procedure_note: Option<ProcedureNote>,
    /// The armed CIRCLE run's own start and stop (`run_trigger = FEED_IN`).
    trigger: Option<ArcTrigger>,
    settings_request: Option<SettingsRequest>,
    /// A client asked for the ROM bootloader ([`App::request_bootloader`]).
    bootloader_request: bool,
    /// The LVDT input mode the board is to acquire in, until the shell takes it
    /// ([`App::take_lvdt_input`]): at start, and whenever a change of the configuration
    /// changes it.
    lvdt_input_change: Option<LvdtInput>,
    settings_failures: u32,
    /// Settings slots the boot found unreadable.
    settings_unreadable: u32,
    settings_failed: bool,
    /// The status word's bits no sample changes ([`App::update_status`]).
    status_fixed: u16,
    last_flags: SampleFlags,
    device: DeviceCounters,
    /// The [`AT_RESET`](crate::config::AT_RESET) fields as the pod started (excitation Hz,
    /// samples per period, sample rate Hz): they stay in force until the next reset.
    boot: (f32, u16, f32),
}

impl App {
    /// The application with configuration `config` (validated: a configuration that fails
    /// [`Config::validate`] is replaced by the defaults) and hardware counters of
    /// `counter_bits` bits per encoder input. Idle, no results.
    pub fn new(config: Config, counter_bits: [u32; MAX_AXES]) -> Self {
        crate::in_place::build(|s| Self::init(s, config, counter_bits))
    }

    /// [`App::new`] built in place in `slot` (the firmware's `static`): the application never
    /// passes through the stack, which could not hold it.
    pub fn init(
        slot: &mut core::mem::MaybeUninit<Self>,
        config: Config,
        counter_bits: [u32; MAX_AXES],
    ) -> &mut Self {
        let config = if config.validate().is_ok() {
            config
        } else {
            Config::default()
        };
        crate::in_place::init_in_place!(slot, Self {
            config: config,
            counter_bits: counter_bits,
            acq: Acquisition::new(&config, counter_bits),
            axes: AxisMap::new(&config),
            limits: RunLimits::DEFAULT,
            session: SessionState::Idle,
            pattern: Pattern::Circle,
            direction: Direction::Ccw,
            abort_reason: None,
            monitor: RunMonitor::new(RunLimits::DEFAULT),
            estimator: RunEstimator::None,
            meta: RunMeta {
                config,
                ..RunMeta::ZERO
            },
            seed002: Procedure::new(Setup::thesis_table_4_3()),
            seed002_begun: false,
            seed002_runs_not_kept: 0,
            seed002_epoch: 0,
            identify_pending: false,
            figures_requests: [None; 2],
            planes: PlaneRecords::default(),
            sweep: FeedSweep::default(),
            spikes: Spikes::default(),
            probe_requests: [false; 2],
            spheres_epoch: 0,
            job: None,
            two_step: TwoStep::default(),
            spheres: Spheres::default(),
            touches_outside_run: 0,
            probe_event: false,
            last_touch: None,
            live: LiveValues::default(),
            live_u_at: u32::MAX,
            pending: heapless::Deque::new(),
            recorded: None,
            refusal: None,
            procedure_note: None,
            trigger: None,
            settings_request: None,
            bootloader_request: false,
            lvdt_input_change: Some(config.lvdt_input),
            settings_failures: 0,
            settings_unreadable: 0,
            device: DeviceCounters::START,
            boot: (
                config.excitation_hz,
                config.samples_per_period,
                config.sample_rate_hz,
            ),
            settings_failed: false,
            status_fixed: 0,
            last_flags: SampleFlags::NONE,
        } in place {
            circle: CircleRun::init,
            ssm: |s| SsmRun::init(s, &config.setup),
            results: Results::init,
        })
    }

    // ------------------------------------------------------------------ read access

    /// The active configuration.
    pub fn config(&self) -> &Config {
        &self.config
    }
    /// Session state.
    pub fn session(&self) -> SessionState {
        self.session
    }
    /// Pattern of the current / next run.
    pub fn pattern(&self) -> Pattern {
        self.pattern
    }
    /// Direction of the current / next run.
    pub fn direction(&self) -> Direction {
        self.direction
    }
    /// Why the last run was aborted, if it was.
    pub fn abort_reason(&self) -> Option<AbortReason> {
        self.abort_reason
    }
    /// Accounting of the current / last run.
    pub fn run_counters(&self) -> RunCounters {
        self.monitor.counters()
    }
    /// The run monitor's limits.
    pub fn run_limits(&self) -> &RunLimits {
        &self.limits
    }
    /// Number of the current / last run (0 before the first).
    pub fn run_number(&self) -> u32 {
        self.meta.run
    }
    /// The live values of the latest sample.
    pub fn live(&self) -> &LiveValues {
        &self.live
    }
    /// The results table.
    pub fn results(&self) -> &Results {
        &self.results
    }
    /// One result.
    pub fn result(&self, id: ResultId) -> ResultEntry {
        self.results.get(id)
    }
    /// Why the invalid result `id` has no value, where the application can tell: a ball-bar
    /// diagnosis the latest circle runs do not determine, a three-plane summary result whose
    /// planes have not all run, a feed sweep's (the text after its name), else `None`.
    pub fn why_invalid(&self, id: ResultId) -> Option<&'static str> {
        if self.results.get(id).valid {
            return None;
        }
        self.circle
            .not_determinable(id)
            .or_else(|| self.spikes.why_invalid(id))
            .map(|r| r.as_str())
            .or_else(|| self.planes.why_invalid(id))
            .or_else(|| self.sweep.why_invalid(id))
    }
    /// What the acquisition counted (samples, faults, lost upstream).
    pub fn acquisition_counters(&self) -> AcquisitionCounters {
        self.acq.counters
    }
    /// The touch-probe debouncer's counters: (accepted, bounces, not re-seated).
    pub fn probe_counts(&self) -> (u32, u32, u32) {
        let p = &self.acq.probe;
        (p.accepted, p.bounces, p.not_reseated)
    }
    /// Accepted touches that came while no PROBE run was running (not used).
    pub fn touches_outside_run(&self) -> u32 {
        self.touches_outside_run
    }
    /// The touch points of the current / last PROBE run, mm (X, Y, Z).
    pub fn touch_points(&self) -> &[[f64; 3]] {
        match &self.estimator {
            RunEstimator::Probe(p) => p.points(),
            _ => &[],
        }
    }
    /// The latest accepted touch point (any run), input order.
    pub fn last_touch(&self) -> Option<Touch> {
        self.last_touch
    }
    /// Why the last command was refused (for CANopen's diagnostic object), if one was.
    pub fn last_refusal(&self) -> Option<CommandError> {
        self.refusal
    }
    /// What the last procedure step could not do although its run had results (e.g. the
    /// two-step or C-axis identification lacked a set-up field).
    pub fn procedure_note(&self) -> Option<ProcedureNote> {
        self.procedure_note
    }
    /// Seed 002 runs with results that were not kept because the step already held
    /// [`bc_ballbar::MAX_REPEATS`] runs of that direction.
    pub fn seed002_runs_not_kept(&self) -> u32 {
        self.seed002_runs_not_kept
    }
    /// The seed 002 procedure of the present set-up, once a step was armed.
    pub fn seed002(&self) -> Option<&Procedure> {
        self.seed002_begun.then_some(&self.seed002)
    }
    /// The device counters as the shell last set them, with the settings saves that failed
    /// (which the application counts itself from [`settings_stored`](Self::settings_stored)).
    pub fn device_counters(&self) -> DeviceCounters {
        let mut c = self.device;
        c.set(DeviceCounter::SettingsStoreFailures, self.settings_failures);
        c.set(
            DeviceCounter::SettingsSlotsUnreadable,
            self.settings_unreadable,
        );
        c
    }

    /// The settings slots the boot found unreadable (`settings::Loaded::unreadable`), for the
    /// device counters.
    pub fn set_settings_unreadable(&mut self, slots: u32) {
        self.settings_unreadable = slots;
    }
    /// The shell's device counters (its queues, watchdog, DMA, masked time, stack).
    pub fn set_device_counters(&mut self, c: DeviceCounters) {
        self.device = c;
    }
    /// The header of the current / last run.
    pub fn run_meta(&self) -> &RunMeta {
        &self.meta
    }

    /// The run the recorders are inside (its header written to them, its end not), and whether
    /// samples or touch points of it have been recorded already: a recorder that joins now
    /// (a stream reader connecting) writes this header, marked partial if so
    /// ([`crate::protocol::stream::SampleStream::join_run`]).
    pub fn recording(&self) -> Option<(&RunMeta, bool)> {
        self.recorded.map(|n| (&self.meta, n > 0))
    }

    // ------------------------------------------------------------------ commands

    fn refuse<T>(&mut self, e: CommandError) -> Result<T, CommandError> {
        self.refusal = Some(e);
        Err(e)
    }

    fn idle(&self) -> bool {
        self.session.between_runs()
    }
}
