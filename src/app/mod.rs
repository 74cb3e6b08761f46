//! The pod application (DESIGN §4, §7a): everything the pod decides about a run, the same on the
//! firmware, in the simulator and in replay.
//!
//! [`App`] owns the configuration, the acquisition pipeline, the session state machine, the
//! run monitor, the armed pattern's estimators, the live values with their validity, the
//! results table and the procedures (seed 002, the seed 000 two-step, the touch-probe C and B
//! axes).
//! Its inputs are the sensor readings of each sample period ([`App::on_raw_sample`], or an
//! already calibrated [`Sample`] in replay: [`App::on_sample`]), probe edges and the client
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
//! | BX BY CR CA CR2 | e, r0 of the step's fit | the run's fit; the step's CW/CCW eccentricity | seed 002 identification when every step has CW and CCW ([`seed002`]) |
//! | SSM | E_x, E_y, E_z of the neighbourhood (each or none) | E from the dwell stations, u(E) | seed 000 two-step over two SSM runs ([`ssm`]) |
//! | PROBE | – | the sphere through the touch points | touch-probe C axis over four spheres, B axis over B = 0/90° with two tool lengths ([`probe`]) |
//!
//! What takes long at a run's end — the ISO 230-4 figures, a touch-probe method, the seed 002
//! identification (seconds on the M4: f64 in software) — is a [`job`]: the command that ends the
//! run only marks it wanted (status bit [`StatusWord::COMPUTING`]), and the shell runs it on a
//! copy of its inputs where a long computation does no harm ([`App::start_job`],
//! [`JobSlot::run`], [`App::finish_job`]).

pub mod circle;
pub mod device;
pub mod job;
pub mod live;
pub mod log;
pub mod pattern;
pub mod probe;
pub mod record;
pub mod results;
pub mod run;
pub mod seed002;
pub mod ssm;
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

use crate::acquisition::lvdt::{BlockReading, DemodError, LvdtReading};
use crate::acquisition::probe::{ProbeLatch, TriggerOutcome};
use crate::acquisition::{Acquisition, AcquisitionCounters, MAX_AXES, Sample, SampleFlags};
use crate::config::{AxisName, Config, ConfigError, Field, LvdtInput, RunTrigger};

use crate::metrology::bar_budget::{BarBudget, FigureKind};
use crate::metrology::circle_fit::{CircleEstimate, CircleFit};
use circle::{CircleGeometry, CircleTest, FiguresRequest};
use job::{JobKind, JobOutcome};
use probe::{ProbeAxis, ProbeRun, Spheres};
use run::{RunMonitor, Verdict};
use seed002::{Procedure, Setup};
use ssm::{SsmRun, TwoStep};
use trigger::{ArcTrigger, TriggerEvent};

/// The live values of a running circle fit (CIRCLE and the seed 002 steps).
const LIVE_FIT: u16 = LiveValues::mask(&[Live::EccU, Live::EccV, Live::R0]);
/// From the bit of a live circle-fit value to that of its u.
const LIVE_FIT_U_SHIFT: u16 = Live::UEccU as u16 - Live::EccU as u16;
/// The live values of a running circle fit with their u.
const LIVE_FIT_ALL: u16 = LIVE_FIT | LIVE_FIT << LIVE_FIT_U_SHIFT;
/// The live SSM E.
const LIVE_SSM_E: u16 = LiveValues::mask(&[Live::SsmEx, Live::SsmEy, Live::SsmEz]);
/// From the bit of a component of the live E to that of its u.
const LIVE_U_SHIFT: u16 = Live::USsmEx as u16 - Live::SsmEx as u16;
/// The live values of a running SSM: E and its u.
const LIVE_SSM: u16 = LIVE_SSM_E | LIVE_SSM_E << LIVE_U_SHIFT;

/// The live (r0, e_u, e_v) of a running circle fit, µm (`None` while not observable), and
/// when `with_u` their standard uncertainties as the run's results would state them: the
/// fit's Type A ([`CircleFit::live_with_uncertainty`], σ = `sample_noise_um` or the
/// residual's where NaN) with the bar's shares and the centre's (`socket_um`, µm, for r0,
/// e_u, e_v) (`None` when not refreshed at this sample or not observable).
pub(crate) fn live_fit(
    fit: &CircleFit,
    sample_noise_um: f32,
    socket_um: [f32; 3],
    with_u: bool,
    config: &Config,
) -> (Option<[f32; 3]>, Option<[f32; 3]>) {
    if with_u {
        live_fit_with_u(fit, sample_noise_um, socket_um, config)
    } else {
        (fit.live().ok(), None)
    }
}

/// Whether the live u of a circle fit is due at `used` samples of its run: at every
/// [`LIVE_U_EVERY`]th, once (samples the fit does not use, e.g. flagged ones, do not refresh it
/// again); `last` is the count of the last refresh.
pub(crate) fn live_u_due(used: u32, last: &mut u32) -> bool {
    let due = used.is_multiple_of(LIVE_U_EVERY) && used != *last;
    if due {
        *last = used;
    }
    due
}

/// A run's fit into `results`: e and r0 with their u (the bar's share of `bar` and the centre's
/// `[s_r0, s_eu, s_ev]`), the residual RMS and the arc, degrees.
fn publish_fit(
    results: &mut impl ResultSink,
    e: &CircleEstimate,
    arc_deg: f32,
    bar: &BarBudget,
    [s_r0, s_eu, s_ev]: [f32; 3],
) {
    for (id, v, u, kind, socket) in [
        (
            ResultId::EccU,
            e.e_um[0],
            e.u_e_um[0],
            FigureKind::Shape,
            s_eu,
        ),
        (
            ResultId::EccV,
            e.e_um[1],
            e.u_e_um[1],
            FigureKind::Shape,
            s_ev,
        ),
        (ResultId::R0, e.r0_um, e.u_r0_um, FigureKind::Radial, s_r0),
    ] {
        results.set_with_bar(id, v, [u, socket], bar, kind);
    }
    results.set(
        ResultId::ResidualRms,
        f64::from(e.residual_rms_um),
        f64::NAN,
    );
    results.set(ResultId::Arc, f64::from(arc_deg), f64::NAN);
}

/// Sets the live values of a running circle fit (`fit`: r0, e_u, e_v) and, when refreshed,
/// their u (held otherwise, but never where its value is not valid); the bits it keeps.
fn set_live_fit(live: &mut LiveValues, fit: Option<[f32; 3]>, u: Option<[f32; 3]>) -> u16 {
    live.set(Live::EccU, fit.map(|[_, eu, _]| eu));
    live.set(Live::EccV, fit.map(|[_, _, ev]| ev));
    live.set(Live::R0, fit.map(|[r0, _, _]| r0));
    if let Some([u_r0, u_eu, u_ev]) = u {
        live.set(Live::UEccU, Some(u_eu));
        live.set(Live::UEccV, Some(u_ev));
        live.set(Live::UR0, Some(u_r0));
    }
    // a u is never valid where its value is not
    live.invalidate((!live.valid & LIVE_FIT) << LIVE_FIT_U_SHIFT);
    LIVE_FIT_ALL
}

/// [`live_fit`] at a refresh of the u.
#[inline(never)] // off the per-sample path: one used sample in [`LIVE_U_EVERY`]
fn live_fit_with_u(
    fit: &CircleFit,
    sample_noise_um: f32,
    [s_r0, s_eu, s_ev]: [f32; 3],
    config: &Config,
) -> (Option<[f32; 3]>, Option<[f32; 3]>) {
    match fit.live_with_uncertainty(sample_noise_um) {
        Ok(([r0, eu, ev], [u_r0, u_eu, u_ev])) => {
            let bar = BarBudget::from_config(config);
            let with = |kind, v, u: f32, s: f32| {
                let b = bar.combined(kind, v, u);
                crate::num::sqrtf(b * b + s * s)
            };
            let u = [
                with(FigureKind::Radial, r0, u_r0, s_r0),
                with(FigureKind::Shape, eu, u_eu, s_eu),
                with(FigureKind::Shape, ev, u_ev, s_ev),
            ];
            (Some([r0, eu, ev]), Some(u))
        }
        Err(_) => (None, None),
    }
}

/// Session state (DESIGN §7a: configure → arm → run → results).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(u8)]
pub enum SessionState {
    /// Nothing armed.
    #[default]
    Idle = 0,
    /// Armed: waiting for start.
    Armed = 1,
    /// Running: samples go into the estimators.
    Running = 2,
    /// Stopped normally: the run's results are valid.
    Done = 3,
    /// Aborted (by command or a fault): see [`App::abort_reason`].
    Aborted = 4,
}

impl SessionState {
    /// The name (SCPI `SESSion:STATe?`): `IDLE`, `ARMED`, `RUNNING`, `DONE`, `ABORTED`.
    pub const fn name(self) -> &'static str {
        match self {
            SessionState::Idle => "IDLE",
            SessionState::Armed => "ARMED",
            SessionState::Running => "RUNNING",
            SessionState::Done => "DONE",
            SessionState::Aborted => "ABORTED",
        }
    }
}

/// A session command (CANopen 0x3002 code = the discriminant; SCPI `SESSion:…`, `*RST`,
/// `*SAV`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Command {
    /// Arm a run of the selected pattern and direction (needs Idle, Done or Aborted and the
    /// pattern's geometry).
    Arm = 1,
    /// Start the armed run.
    Start = 2,
    /// Stop the running run: results, or an abort if it has none.
    Stop = 3,
    /// Abort the armed or running run (no results).
    Abort = 4,
    /// Forget the procedures' runs (circle directions, seed 002 steps, two-step, probe
    /// spheres) and every result (not while a run is armed or running).
    Clear = 5,
    /// Reset the application state: a run in progress is aborted, procedures and results are
    /// forgotten, the state is Idle; the configuration stays (`*RST`, NMT reset node).
    Reset = 6,
    /// Store the configuration in non-volatile memory (the shell does it: [`App::take_settings_request`];
    /// not while a run is armed or running: the flash work would stall the sampling).
    StoreSettings = 7,
    /// Restore the default configuration at the next reset (CiA 301 0x1011; not while a run
    /// is armed or running).
    RestoreDefaults = 8,
}

impl Command {
    /// The command of a code.
    pub const fn from_u8(v: u8) -> Option<Self> {
        Some(match v {
            1 => Command::Arm,
            2 => Command::Start,
            3 => Command::Stop,
            4 => Command::Abort,
            5 => Command::Clear,
            6 => Command::Reset,
            7 => Command::StoreSettings,
            8 => Command::RestoreDefaults,
            _ => return None,
        })
    }
}

/// Why a command was refused (nothing changed). Its words are the protocols'
/// (`protocol::text`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CommandError {
    /// The command does not fit the state of the session or the pod.
    WrongState(Needs),
    /// Pattern, direction, configuration and procedures do not change while a run is armed
    /// or running.
    Busy,
    /// The armed pattern needs this set-up field, which is not set.
    Missing(Field),
    /// The configuration refused the value.
    Config(ConfigError),
}

/// What a refused command needed that the pod did not offer ([`CommandError::WrongState`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Needs {
    /// ARM: the session IDLE, DONE or ABORTED.
    Idle,
    /// START: a run armed.
    Armed,
    /// STOP: a run running.
    Running,
    /// ABORT: a run armed or running.
    ArmedOrRunning,
    /// A seed 002 step: its procedure (the set-up armed first).
    Procedure,
    /// The worker free (no computation running).
    NoComputation,
    /// An axis position: within the axis' range, the axis read at least once.
    AxisReadable,
}

/// What the last procedure step could not do although its run had results, or what an armed
/// self-triggered run waits for (`procedure_note`). Its words are the protocols'
/// (`protocol::text`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ProcedureNote {
    /// The step needs this set-up field, which is not set.
    Missing(Field),
    /// An armed FEED_IN run waits for the feed-in.
    WaitingForFeedIn,
    /// A FEED_IN run fed in waits for its data arc.
    WaitingForDataArc,
    /// The touch-probe C-axis identification gave no result.
    CAxisFailed,
    /// The touch-probe B-axis identification gave no result.
    BAxisFailed,
    /// The seed 002 identification gave no result.
    Seed002Failed,
    /// The SSM two-step identification gave no result.
    TwoStepFailed,
}

/// The procedure note of a touch-probe method that gave no result.
fn probe_note(e: probe::ProbeFailure) -> ProcedureNote {
    match e {
        probe::ProbeFailure::Missing(f) => ProcedureNote::Missing(f),
        probe::ProbeFailure::CAxis(_) => ProcedureNote::CAxisFailed,
        probe::ProbeFailure::BAxis(_) => ProcedureNote::BAxisFailed,
    }
}

/// The user-facing name of a field.
pub fn field_name(f: Field) -> &'static str {
    match f {
        Field::PeriodsPerSample => "excitation / sample_rate (whole periods, 1 to 5)",
        Field::AxisNameDuplicate(_) => "axis name",
        Field::AxisCounterReach(i) => COUNTER_REACH
            .get(usize::from(i))
            .copied()
            .unwrap_or("axis_counts * axis_max_speed / sample_rate"),
        f => Config::field_info(f).map_or("field", |i| i.name),
    }
}

/// The refusal of each input's counter-reach rule ([`Config::counter_reach`]), naming its fields.
const COUNTER_REACH: [&str; MAX_AXES] = [
    "encoder input 1: axis_counts * axis_max_speed / sample_rate (counts per counter read)",
    "encoder input 2: axis_counts * axis_max_speed / sample_rate (counts per counter read)",
    "encoder input 3: axis_counts * axis_max_speed / sample_rate (counts per counter read)",
    "encoder input 4: axis_counts * axis_max_speed / sample_rate (counts per counter read)",
    "encoder input 5: axis_counts * axis_max_speed / sample_rate (counts per counter read)",
];

/// The armed run's estimator.
#[derive(Clone, Copy, Debug, PartialEq)]
#[allow(clippy::large_enum_variant)] // one lives in the App; its size is the largest pattern's
enum RunEstimator {
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

/// Recorder events waiting for the next sample (commands arrive between samples, without the
/// recorder at hand).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Pending {
    Begin(u32),
    End(RunEnd),
}

/// Settings the shell is asked to store.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SettingsRequest {
    /// Store the running configuration ([`App::config`]).
    Store,
    /// Store the defaults, to take effect at the next reset.
    RestoreDefaults,
}

/// Where each machine axis is among the encoder inputs: the estimators see samples in the
/// canonical order X, Y, Z, then the other inputs in input order (the rotary axes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct AxisMap {
    /// `order[k]` = the input read for canonical slot k.
    order: [usize; MAX_AXES],
    identity: bool,
    /// Canonical slots of the B and C axes, if configured.
    b: Option<usize>,
    c: Option<usize>,
}

impl AxisMap {
    fn new(cfg: &Config) -> Self {
        let find = |n: AxisName| cfg.axes.iter().position(|a| a.name == n);
        let mut order = [0usize; MAX_AXES];
        let mut used = [false; MAX_AXES];
        let mut k = 0;
        for n in [AxisName::X, AxisName::Y, AxisName::Z] {
            // an unconfigured linear axis reads NaN (slot points at no input)
            let i = find(n).unwrap_or(MAX_AXES);
            if let Some(o) = order.get_mut(k) {
                *o = i;
            }
            if let Some(u) = used.get_mut(i) {
                *u = true;
            }
            k += 1;
        }
        for (i, u) in used.iter().enumerate() {
            if !u && k < MAX_AXES {
                if let Some(o) = order.get_mut(k) {
                    *o = i;
                }
                k += 1;
            }
        }
        let slot = |n: AxisName| {
            let i = find(n)?;
            order.iter().position(|&o| o == i)
        };
        Self {
            order,
            identity: order == [0, 1, 2, 3, 4],
            b: slot(AxisName::B),
            c: slot(AxisName::C),
        }
    }

    fn canonical(&self, axes: &[f32; MAX_AXES]) -> [f32; MAX_AXES] {
        if self.identity {
            return *axes;
        }
        self.order.map(|i| axes.get(i).copied().unwrap_or(f32::NAN))
    }
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
    circle: CircleTest,
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
            results: Results::new(),
            pending: heapless::Deque::new(),
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
            circle: CircleTest::init,
            ssm: |s| SsmRun::init(s, &config.setup),
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
    /// [`seed002::MAX_REPEATS`] runs of that direction.
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

    // ------------------------------------------------------------------ commands

    fn refuse<T>(&mut self, e: CommandError) -> Result<T, CommandError> {
        self.refusal = Some(e);
        Err(e)
    }

    fn idle(&self) -> bool {
        !matches!(self.session, SessionState::Armed | SessionState::Running)
    }

    /// Selects the pattern of the next run (not while a run is armed or running).
    pub fn set_pattern(&mut self, p: Pattern) -> Result<(), CommandError> {
        if !self.idle() {
            return self.refuse(CommandError::Busy);
        }
        self.pattern = p;
        Ok(())
    }

    /// Selects the direction of the next run (not while a run is armed or running).
    pub fn set_direction(&mut self, d: Direction) -> Result<(), CommandError> {
        if !self.idle() {
            return self.refuse(CommandError::Busy);
        }
        self.direction = d;
        Ok(())
    }

    /// Changes the configuration (not while a run is armed or running): `edit` works on a copy,
    /// which replaces the configuration only if it is valid. The acquisition follows at once,
    /// keeping the axis references, sample counter, temperature and counters.
    pub fn configure(&mut self, edit: impl FnOnce(&mut Config)) -> Result<(), CommandError> {
        if !self.idle() {
            return self.refuse(CommandError::Busy);
        }
        let mut next = self.config;
        if let Err(e) = next.try_update(edit) {
            return self.refuse(CommandError::Config(e));
        }
        // until the reset the counters are read at the sample rate the pod runs with: the
        // counter-reach rule holds there too
        if let Err(e) = self.running(next).check_counter_reach() {
            return self.refuse(CommandError::Config(e));
        }
        self.apply_config(next);
        Ok(())
    }

    /// Sets one numeric field ([`Config::set`]: range, whole numbers, codes) — the common case
    /// of [`configure`](Self::configure).
    pub fn set_field(&mut self, f: Field, v: f64) -> Result<(), CommandError> {
        if let Err(e) = Config::check_write(f, v) {
            return self.refuse(CommandError::Config(e));
        }
        self.configure(|c| c.set_field(f, v))
    }

    fn apply_config(&mut self, next: Config) {
        if next.lvdt_input != self.config.lvdt_input {
            self.lvdt_input_change = Some(next.lvdt_input);
        }
        self.config = next;
        let running = self.running_config();
        self.acq.reconfigure(&running, self.counter_bits);
        self.axes = AxisMap::new(&next);
        self.update_status();
    }

    /// True when an [`AT_RESET`](crate::config::AT_RESET) field differs from the value the pod
    /// runs with (status word bit 14).
    pub fn reset_pending(&self) -> bool {
        let c = &self.config;
        (c.excitation_hz, c.samples_per_period, c.sample_rate_hz) != self.boot
    }

    /// The configuration the pod runs with: [`config`](Self::config) with the
    /// [`AT_RESET`](crate::config::AT_RESET) fields as they were at start.
    pub fn running_config(&self) -> Config {
        self.running(self.config)
    }

    /// `config` with the [`AT_RESET`](crate::config::AT_RESET) fields the pod started with.
    fn running(&self, config: Config) -> Config {
        let (excitation_hz, samples_per_period, sample_rate_hz) = self.boot;
        Config {
            excitation_hz,
            samples_per_period,
            sample_rate_hz,
            ..config
        }
    }

    /// Carries out a session command, or refuses it (nothing changes; the reason is kept for
    /// [`last_refusal`](Self::last_refusal)).
    pub fn execute(&mut self, cmd: Command) -> Result<(), CommandError> {
        let r = self.execute_inner(cmd);
        self.update_status();
        r
    }

    fn execute_inner(&mut self, cmd: Command) -> Result<(), CommandError> {
        use SessionState as S;
        match cmd {
            Command::Arm => {
                if !self.idle() {
                    return self.refuse(CommandError::WrongState(Needs::Idle));
                }
                self.arm()
            }
            Command::Start => {
                if self.session != S::Armed {
                    return self.refuse(CommandError::WrongState(Needs::Armed));
                }
                self.begin_running();
                Ok(())
            }
            Command::Stop => {
                if self.session != S::Running {
                    return self.refuse(CommandError::WrongState(Needs::Running));
                }
                self.stop();
                Ok(())
            }
            Command::Abort => {
                if self.idle() {
                    return self.refuse(CommandError::WrongState(Needs::ArmedOrRunning));
                }
                self.abort(AbortReason::ByCommand);
                Ok(())
            }
            Command::Clear => {
                if !self.idle() {
                    return self.refuse(CommandError::Busy);
                }
                self.clear_procedures();
                Ok(())
            }
            Command::Reset => {
                if !self.idle() {
                    self.abort(AbortReason::ByCommand);
                }
                self.clear_procedures();
                self.session = S::Idle;
                self.abort_reason = None;
                Ok(())
            }
            // a save erases and programs a flash page (~26 ms with the bus stalled): between
            // runs only, whichever port asks (SCPI -221, SDO abort 0x0800 0022, LSS error)
            Command::StoreSettings | Command::RestoreDefaults if !self.idle() => {
                self.refuse(CommandError::Busy)
            }
            Command::StoreSettings => {
                self.settings_request = Some(SettingsRequest::Store);
                Ok(())
            }
            Command::RestoreDefaults => {
                self.settings_request = Some(SettingsRequest::RestoreDefaults);
                Ok(())
            }
        }
    }

    /// A client asks to update the firmware: the shell restarts the pod into the STM32's ROM
    /// bootloader (USB DFU, `dfu-util`; book: Hardware, "Updating the firmware") once a
    /// settings save in progress has ended. Not while a run is armed or running, nor while a
    /// job computes (its result would be lost with the restart).
    pub fn request_bootloader(&mut self) -> Result<(), CommandError> {
        if !self.idle() {
            return self.refuse(CommandError::Busy);
        }
        if self.job.is_some() {
            return self.refuse(CommandError::WrongState(Needs::NoComputation));
        }
        self.bootloader_request = true;
        Ok(())
    }

    /// The LVDT input mode the board must acquire in, once after start and once after each
    /// configuration change that changes it (taken once; the firmware's LVDT task demodulates
    /// in this mode from its next block on).
    pub fn take_lvdt_input(&mut self) -> Option<LvdtInput> {
        self.lvdt_input_change.take()
    }

    /// The ROM bootloader was asked for ([`App::request_bootloader`]; taken once).
    pub fn take_bootloader_request(&mut self) -> bool {
        core::mem::take(&mut self.bootloader_request)
    }

    /// The settings the shell is asked to store (taken once).
    pub fn take_settings_request(&mut self) -> Option<SettingsRequest> {
        self.settings_request.take()
    }

    /// The shell reports how a settings save went (a failure sets the status word's error bit
    /// until the next successful save, and is counted).
    pub fn settings_stored(&mut self, ok: bool) {
        self.settings_failed = !ok;
        if !ok {
            self.settings_failures = self.settings_failures.saturating_add(1);
        }
        self.update_status();
    }

    fn clear_procedures(&mut self) {
        self.circle.clear();
        self.seed002_begun = false;
        self.seed002_epoch = self.seed002_epoch.wrapping_add(1);
        self.identify_pending = false;
        self.figures_requests = [None; 2];
        self.two_step.clear();
        self.spheres.clear();
        self.spheres_epoch = self.spheres_epoch.wrapping_add(1);
        self.probe_requests = [false; 2];
        self.estimator = RunEstimator::None;
        self.results.clear_all();
        self.procedure_note = None;
    }

    /// The armed run starts (a client's START or the trigger).
    fn begin_running(&mut self) {
        self.session = SessionState::Running;
        self.monitor.start();
        if let Some(t) = self.trigger.as_mut() {
            t.started();
            self.procedure_note = None;
        }
    }

    fn arm(&mut self) -> Result<(), CommandError> {
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
            step => {
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
            _ => {}
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
    fn new_procedure(&mut self, s: Setup) {
        self.seed002.restart(s);
        self.seed002_begun = true;
    }

    fn queue(&mut self, p: Pending) {
        if self.pending.is_full() {
            // only runs without a single sample can pile up here: the oldest goes
            self.pending.pop_front();
        }
        let _ = self.pending.push_back(p);
    }

    fn end_run(&mut self, abort: Option<AbortReason>) {
        self.queue(Pending::End(RunEnd {
            run: self.meta.run,
            abort,
            counters: self.monitor.counters(),
        }));
    }

    fn abort(&mut self, reason: AbortReason) {
        self.monitor.end();
        self.session = SessionState::Aborted;
        self.abort_reason = Some(reason);
        self.results.clear(ResultId::EccU, ResultId::Arc);
        self.end_run(Some(reason));
    }

    /// Publishes a run's circle fit with the bar's shares and the centre's (µm, for r0, e_u,
    /// e_v: [`circle::CircleTest::finish_run`]; zero for a seed 002 step, whose centre's inputs
    /// are in the procedure's budget).
    fn stop(&mut self) {
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
            // the run's fit and figures: a job (`CircleTest::figures`)
            RunEstimator::Circle => {
                match self
                    .circle
                    .finish_run(d, &mut self.results, setup.circle_u_centre_um, bar)
                {
                    Ok(request) => {
                        if let Some(r) = self.figures_requests.get_mut(circle::dir_index(d)) {
                            *r = Some(request);
                        }
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
    fn record_step(&mut self, step: Pattern, d: Direction, e: CircleEstimate, bar: &BarBudget) {
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

    /// True while a job is wanted or running ([`job`]: the ISO 230-4 figures of a run that
    /// ended, a touch-probe method, the seed 002 identification): the results it publishes are
    /// invalid until then (status bit [`StatusWord::COMPUTING`]).
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
                slot.load_figures(&self.circle, request);
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
            JobOutcome::Figures(request, patch) => {
                if self.circle.current(&request) {
                    patch.apply(&mut self.results);
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

    // ------------------------------------------------------------------ samples

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

    fn on_touch<R: Recorder>(&mut self, latch: &ProbeLatch, rec: &mut R) {
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

    fn touch<R: Recorder>(&mut self, t: &Touch, rec: &mut R) {
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
        let s = self.acq.sample(t_us, lvdt, raw, lost_total, probe_event);
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

    fn flush_pending<R: Recorder>(&mut self, rec: &mut R) {
        let mut skipped_run = None;
        while let Some(p) = self.pending.pop_front() {
            match p {
                Pending::Begin(run) if run == self.meta.run => rec.begin_run(&self.meta),
                // armed and over before its first sample, then re-armed: nothing to record
                Pending::Begin(run) => skipped_run = Some(run),
                Pending::End(end) if Some(end.run) != skipped_run => rec.end_run(&end),
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
    /// the run starts with it or ends before it. Inlined: as a call it cost every sample 17
    /// instructions of the live pipeline (bench-m4), inlined 11, and 40 B less flash.
    #[inline(always)]
    fn on_trigger(&mut self, raw_axes: &[f32; MAX_AXES]) {
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

    fn feed(&mut self, s: &Sample) {
        let d = self.direction;
        match &mut self.estimator {
            RunEstimator::Circle => {
                self.circle.update(s, d);
            }
            RunEstimator::Step(_, fit) => {
                fit.update(s);
            }
            RunEstimator::Ssm => self.ssm.update(s),
            RunEstimator::Probe(_) | RunEstimator::None => {}
        }
    }

    fn refresh_live(&mut self) {
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

    /// Computes the status word: the bits of the session, the jobs, a pending reset and a
    /// failed save (kept in `status_fixed`), then a sample's ([`Self::update_sample_status`]).
    /// Called wherever one of the former changes: a command, a configuration, a job, a save.
    fn update_status(&mut self) {
        let mut fixed = StatusWord::new(SampleFlags::NONE, self.session, 0).0;
        if self.identify_pending || self.job == Some(JobKind::Seed002Identification) {
            fixed |= StatusWord::IDENTIFYING;
        }
        if self.job_pending() {
            // the results are not all there until the job has published them
            fixed = (fixed | StatusWord::COMPUTING) & !StatusWord::RESULTS_READY;
        }
        if self.reset_pending() {
            fixed |= StatusWord::RESET_PENDING;
        }
        if self.settings_failed {
            fixed |= StatusWord::ERROR;
        }
        self.status_fixed = fixed;
        self.update_sample_status();
    }

    /// The status word's bits a sample changes — its flags, [`StatusWord::LIVE_VALID`], a
    /// fault's [`StatusWord::ERROR`] — over the fixed ones (the sample path: ~40 instructions
    /// where the whole word took ~100).
    #[inline(always)]
    fn update_sample_status(&mut self) {
        let live_valid = match self.pattern {
            _ if self.session != SessionState::Running => false,
            Pattern::Ssm => self.live.all_valid(LIVE_SSM_E),
            Pattern::Probe => false,
            _ => self.live.all_valid(LIVE_FIT),
        };
        let mut w = self.status_fixed | (self.last_flags.0 & StatusWord::SAMPLE_FLAGS_MASK);
        if live_valid {
            w |= StatusWord::LIVE_VALID;
        }
        if self
            .last_flags
            .intersects(SampleFlags::INVALID_FOR_METROLOGY.with(SampleFlags::TEMPERATURE_FAULT))
        {
            w |= StatusWord::ERROR;
        }
        self.live.status = StatusWord(w);
    }
}
