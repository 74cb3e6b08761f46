//! SSM: the single socket method (seed 000 eq 1, DESIGN §7) on the pod.
//!
//! During a run every sample updates the dwell detector and, while the machine moves, the
//! streaming estimator (E at the current point from its neighbourhood, per component
//! observable or not: the live ssm_ex/ey/ez; a dwell empties it). At the end the dwell
//! stations give E by eq (1), refined on the exact sphere equation, with its standard
//! uncertainty. Two SSM runs — after the translation, then after
//! the rotation — give the seed 000 two-step orientation errors of the configured machine type
//! (`ts_machine`, exact inversion, [`crate::identify::two_step`]).

use super::live::LIVE_U_EVERY;
use super::results::{CONTRIBUTOR_COUNT, ResultId, ResultSink, Results};
use crate::acquisition::Sample;
use crate::config::{Field, TestSetup, TwoStepMachine, required, required3};
use crate::identify::two_step::{
    self, DEFAULT_MIN_LEVER_ARM_MM, Mode, ReferenceEnd, RotationOrder, RrtttConfig,
    RrtttMeasurement, RtttrSpindleConfig, RtttrTableConfig, SingleAxisMeasurement, TttrrConfig,
    TttrrMeasurement, TwoStepError,
};
use crate::in_place::{self, init_in_place};
use crate::metrology::bar_budget::BarBudget;
use crate::metrology::solve3::{Sym3, dot};
use crate::metrology::ssm::station::{
    BarSensitivity, DwellConfig, DwellEvent, StationCollector, refine, solve_stations,
    station_covariance,
};
use crate::metrology::ssm::streaming::{StreamingConfig, StreamingSsm};
use crate::metrology::ssm::{SsmError, SsmGeometry, SsmSolution};
use core::mem::MaybeUninit;

/// Samples the streaming neighbourhood holds at most (7 KiB: 0.26 s at 1 kHz; a sample that
/// leaves only because the window is full is counted by the estimator).
pub const SSM_WINDOW: usize = 256;
/// Samples between two refreshes of the live E's u while its window grows (from the run's
/// start, a dwell or a rotary move until the first sample leaves it: 150 samples at 2000
/// mm/min in the 5 mm radius, [`SSM_WINDOW`] at most). Its u falls fast then, as the arc
/// lengthens: refreshed every [`LIVE_U_EVERY`] samples, the u held in between was up to a
/// third high (`metrology_ssm.rs`, around dwells). About 300 instructions a refresh.
pub const LIVE_U_EVERY_GROWING: u32 = 4;
// `SsmRun::live` tests the finer period first: the coarser must be a multiple of it
const _: () = assert!(LIVE_U_EVERY.is_multiple_of(LIVE_U_EVERY_GROWING));
/// Dwell stations one SSM run keeps (a dwell beyond is dropped and counted).
pub const MAX_STATIONS: usize = 8;
/// Rotary axis movement that empties the streaming neighbourhood, degrees.
pub const ROTARY_TOL_DEG: f32 = 0.01;
/// Rotary speed below which a dwell counts as still, °/s.
pub const DWELL_ROTARY_SPEED_DEG_PER_S: f32 = 0.1;
/// Gauss–Newton iterations of the station refinement (seed 000 B.2 item 4).
pub const REFINE_ITERATIONS: u32 = 10;
/// Standard uncertainty of a station's ΔL that dwelling does not average away, µm: at a fixed
/// position the 12-bit quantisation of the LVDT secondaries gives the same error in every
/// block (up to ≈ 0.12 µm), and the encoders count 0.1 µm.
pub const FIXED_POSITION_U_UM: f64 = 0.1;

/// An SSM run in progress (state ≈ 7.6 KiB).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SsmRun {
    geometry: SsmGeometry,
    stream: StreamingSsm<SSM_WINDOW>,
    stations: StationCollector<MAX_STATIONS>,
    /// The bar's inputs to the live E's u (the configuration's at the run's start).
    bar: BarBudget,
    /// The socket's standard uncertainty per coordinate as entered, µm (the configuration's
    /// at the run's start; E moves with it one to one: seed 000 B.2 item 5).
    u_socket_um: f32,
}

/// E from the stations of an SSM run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SsmMeasurement {
    /// The refined solution (E µm per component, `None` where not observable; cond; residual).
    pub solution: SsmSolution,
    /// Covariance of E, µm²: each station's ΔL with its dwell mean's standard error and
    /// [`FIXED_POSITION_U_UM`], propagated through the least squares
    /// ([`station_covariance`]). Type A and the positions' floor only; the bar's share is in
    /// `bar`.
    pub covariance_um2: Sym3,
    /// How E moves with the bar's offset and scale (common to every station and every run).
    pub bar: BarSensitivity,
}

impl SsmMeasurement {
    /// The shares of each component of E's standard uncertainty, µm, by
    /// [`super::results::Contributor`]: the stations' covariance (Type A), with `bar` the
    /// bar's offset and scale, and the socket's `u_socket_um` per coordinate as entered, which
    /// moves every observable component one to one (the least squares reproduces a common
    /// shift of the rows exactly; NaN where the component is not observable).
    pub fn shares_um(&self, bar: &BarBudget, u_socket_um: f32) -> [[f32; CONTRIBUTOR_COUNT]; 3] {
        let c = &self.covariance_um2;
        let mut out = [[f32::NAN; CONTRIBUTOR_COUNT]; 3];
        for (((o, var), e), [off, scale]) in out
            .iter_mut()
            .zip([c.a00, c.a11, c.a22])
            .zip(self.solution.e_um)
            .zip(self.bar.shares_um(bar))
        {
            if e.is_some() {
                let a = crate::num::sqrt(var) as f32;
                *o = [a, off, scale, 0.0, 0.0, 0.0, u_socket_um];
            }
        }
        out
    }

    /// Standard uncertainty of each component of E, µm (NaN where not observable): the
    /// [`Self::shares_um`] in quadrature ([`BarBudget::NONE`] and a `u_socket_um` of 0 leave
    /// the stations' share alone).
    pub fn u_e_um(&self, bar: &BarBudget, u_socket_um: f32) -> [f64; 3] {
        self.shares_um(bar, u_socket_um)
            .map(|s| f64::from(crate::num::sqrtf(s.iter().map(|v| v * v).sum())))
    }
}

/// The geometry of the state before the first SSM run (never fed: no run is armed).
const NO_RUN: SsmGeometry = SsmGeometry {
    socket_mm: [f64::NAN; 3],
    bar_length_mm: f64::NAN,
};

impl SsmRun {
    /// No run yet, built in place in `slot` (the 7.8 KiB state never passes through the
    /// stack); [`SsmRun::restart`] starts one.
    pub fn init<'a>(slot: &'a mut MaybeUninit<Self>, t: &TestSetup) -> &'a mut Self {
        Self::init_with(slot, NO_RUN, t, BarBudget::NONE)
    }

    /// Starts a run in place on the set-up's socket with a bar of `bar_length_mm` whose
    /// uncertainty is `bar`, or returns the first field the set-up lacks (the socket position;
    /// the state is then unchanged).
    pub fn restart(
        &mut self,
        t: &TestSetup,
        bar_length_mm: f32,
        bar: BarBudget,
    ) -> Result<(), Field> {
        let geometry = SsmGeometry {
            socket_mm: required3(t.ssm_socket_mm, Field::SsmSocketMm)?,
            bar_length_mm: f64::from(bar_length_mm),
        };
        in_place::reinit(self, |s| Self::init_with(s, geometry, t, bar));
        Ok(())
    }

    fn init_with<'a>(
        slot: &'a mut MaybeUninit<Self>,
        geometry: SsmGeometry,
        t: &TestSetup,
        bar: BarBudget,
    ) -> &'a mut Self {
        init_in_place!(slot, Self {
            geometry: geometry,
            bar: bar,
            u_socket_um: t.ssm_u_socket_um,
            stations: StationCollector::new(DwellConfig {
                max_speed_mm_per_s: t.ssm_dwell_speed_mm_per_s,
                max_rotary_speed_deg_per_s: DWELL_ROTARY_SPEED_DEG_PER_S,
                settle_us: (f64::from(t.ssm_settle_ms) * 1e3) as u64,
                min_samples: t.ssm_min_dwell_samples,
            }),
        } in place {
            stream: |s| StreamingSsm::init(s, StreamingConfig {
                geometry,
                radius_mm: t.ssm_window_radius_mm,
                rotary_tol_deg: ROTARY_TOL_DEG,
            }),
        })
    }

    /// Feeds one used sample: to the dwell detection, and to the live window unless the
    /// machine is still (settling or dwelling), which empties the window: the live E restarts
    /// with the next move. Samples at one position add no direction and share the reading
    /// error dwelling does not average away ([`FIXED_POSITION_U_UM`]), which the window's
    /// residual would count as if it averaged over each of them; and a window kept across a
    /// dwell turns from the approach's arc to the departure's faster than its u is refreshed
    /// ([`LIVE_U_EVERY`]). Restarted, the window grows for a while and its u is refreshed
    /// more often ([`LIVE_U_EVERY_GROWING`]) (`metrology_ssm.rs`, the samples after a dwell,
    /// stopping dead: the refreshed u covered 91.3 % with dwell samples in the window; the held
    /// u 93.1 % with the window held across the dwell, rms(error / u) 2.0; restarted and
    /// refreshed every 4 samples while it grows 94.5–95.8 %).
    pub fn update(&mut self, s: &Sample) {
        let still = matches!(
            self.stations.update(s),
            DwellEvent::Settling | DwellEvent::Averaging
        );
        if still {
            self.stream.clear();
        } else {
            self.stream.update(s);
        }
    }

    /// E at the current point from its neighbourhood, µm, for the sample numbered
    /// `sample_counter`: each component, or `None` where it is not observable (yet); and at
    /// every [`LIVE_U_EVERY`]th sample (every [`LIVE_U_EVERY_GROWING`]th while the window
    /// grows) its standard uncertainty with the bar's and the socket's shares, µm (`None` where
    /// not stated:
    /// [`StreamingSsm::live_with_uncertainty`]; the socket's moves a stated component one to
    /// one, as the stations').
    pub fn live(&self, sample_counter: u32) -> ([Option<f32>; 3], Option<[Option<f32>; 3]>) {
        // the common sample leaves at the first test
        let due = sample_counter.is_multiple_of(LIVE_U_EVERY_GROWING)
            && (sample_counter.is_multiple_of(LIVE_U_EVERY) || self.stream.is_growing());
        if due {
            self.live_with_u()
        } else {
            (self.stream.live().unwrap_or([None; 3]), None)
        }
    }

    #[inline(never)] // off the per-sample path: one sample in [`LIVE_U_EVERY`] (in 4 while growing)
    fn live_with_u(&self) -> ([Option<f32>; 3], Option<[Option<f32>; 3]>) {
        let mut u = [None; 3];
        let e = self
            .stream
            .live_with_uncertainty(&self.bar, self.u_socket_um, &mut u)
            .unwrap_or([None; 3]);
        (e, Some(u))
    }

    /// Ends the run: the stations' E, refined.
    pub fn finish(&mut self) -> Result<SsmMeasurement, SsmError> {
        self.stations.finish();
        let st = self.stations.stations();
        let s0 = solve_stations(st, &self.geometry)?;
        let solution = refine(st, &self.geometry, &s0, REFINE_ITERATIONS)?;
        let (covariance_um2, bar) =
            station_covariance(st, &self.geometry, &solution, FIXED_POSITION_U_UM)?;
        Ok(SsmMeasurement {
            solution,
            covariance_um2,
            bar,
        })
    }
}

/// Writes an SSM measurement into the results, E with the bar's (`bar`) and the socket's
/// (`u_socket_um` per coordinate, µm) shares in its u.
pub fn publish(m: &SsmMeasurement, bar: &BarBudget, u_socket_um: f32, results: &mut Results) {
    let [ex, ey, ez] = m.solution.e_um;
    let [ux, uy, uz] = m.shares_um(bar, u_socket_um);
    for (id, e, u) in [
        (ResultId::SsmEx, ex, ux),
        (ResultId::SsmEy, ey, uy),
        (ResultId::SsmEz, ez, uz),
    ] {
        results.set_budget(id, e.unwrap_or(f64::NAN), u);
    }
    results.set(ResultId::SsmCond, m.solution.cond, f64::NAN);
    results.set(
        ResultId::SsmResidualRms,
        m.solution.residual_rms_um,
        f64::NAN,
    );
    results.set(
        ResultId::SsmStations,
        f64::from(m.solution.observations),
        f64::NAN,
    );
}

/// The seed 000 two-step pairing: the first complete SSM run is ΔV1 (after the translation),
/// the next ΔV2 (after the rotation); then the orientation errors, and the next SSM run starts
/// a new pair.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TwoStep {
    dv1: Option<PairRun>,
}

/// One run of a pair: E, its covariance (the stations' share) and how it moves with the bar.
#[derive(Clone, Copy, Debug, PartialEq)]
struct PairRun {
    dv_um: [f64; 3],
    covariance_um2: Sym3,
    bar: BarSensitivity,
}

/// The step of the two-step's Jacobian by finite differences, µm of ΔV: small against the
/// lever arms (≥ 1 mm: the relative error of the slope is about step / lever arm, ≤ 10⁻³),
/// large against the rounding of the identification (f64, 10⁻¹⁶ of the coordinates in mm).
const JACOBIAN_STEP_UM: f64 = 1.0;

/// Why the two-step gave no result.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TwoStepFailure {
    /// The set-up lacks this field for the configured machine type.
    Missing(Field),
    /// The identification failed.
    Identify(TwoStepError),
}

impl TwoStep {
    /// Forgets a pending ΔV1.
    pub fn clear(&mut self) {
        self.dv1 = None;
    }

    /// True when the next complete SSM run is ΔV2.
    pub fn has_dv1(&self) -> bool {
        self.dv1.is_some()
    }

    /// Takes a finished SSM run; returns `Ok(true)` when the pair was complete and the
    /// results were written. Nothing happens for `ts_machine = NONE` or an incomplete E.
    ///
    /// The angles' u, first order (GUM §5.1.2) with the identification's Jacobian
    /// ∂angle/∂ΔV of each run (finite differences: one identification per component, moved by
    /// 1 µm): the stations' share jᵣᵀ Σᵣ jᵣ of each run with its full
    /// covariance Σᵣ (the runs independent), and the bar's. One bar measures both runs, so its
    /// offset and scale errors move ΔV1 and ΔV2 together — fully correlated, Σᵣ jᵣ·bᵣ before
    /// squaring (bᵣ the run's [`BarSensitivity`]): an offset cancels where the two runs'
    /// station layouts match. The socket as entered has no share: one socket serves both runs
    /// (run 2's `ssm_socket` is run 1's plus a nominal offset, as `ncgen two-step` writes
    /// them: one entry error), so its error moves ΔV1 and ΔV2 alike, and the exact mode reads
    /// ΔV2 − ΔV1 only.
    #[inline(never)] // flash (32 B); and the Jacobian on the stack only while a pair ends
    pub fn on_measurement(
        &mut self,
        t: &TestSetup,
        m: &SsmMeasurement,
        bar: &BarBudget,
        results: &mut Results,
    ) -> Result<bool, TwoStepFailure> {
        let [Some(x), Some(y), Some(z)] = m.solution.e_um else {
            return Ok(false);
        };
        if t.ts_machine == TwoStepMachine::None {
            return Ok(false);
        }
        let run2 = PairRun {
            dv_um: [x, y, z],
            covariance_um2: m.covariance_um2,
            bar: m.bar,
        };
        let Some(run1) = self.dv1.take() else {
            self.dv1 = Some(run2);
            results.clear(ResultId::TsDeltaAlpha, ResultId::TsDeltaGamma);
            return Ok(false);
        };
        let runs = [run1, run2];
        let angles = identify(t, &runs, None)?;
        // Jacobian: per run, per component of its ΔV, the change of each angle (µrad/µm)
        let mut jacobian = [[[0.0f64; 2]; 3]; 2];
        for (r, run) in jacobian.iter_mut().enumerate() {
            for (k, column) in run.iter_mut().enumerate() {
                let moved = identify(t, &runs, Some((r, k)))?;
                for ((d, m), a) in column.iter_mut().zip(moved).zip(angles) {
                    *d = (m - a) / JACOBIAN_STEP_UM;
                }
            }
        }
        let (u_offset, u_scale) = (f64::from(bar.offset_um), f64::from(bar.scale));
        for (i, (id, value)) in angle_results(t.ts_machine)
            .into_iter()
            .zip(angles)
            .enumerate()
        {
            let Some(id) = id else { continue };
            let (mut var, mut by_offset, mut by_scale) = (0.0, 0.0, 0.0);
            for (run, jr) in runs.iter().zip(&jacobian) {
                let j = jr.map(|c| c.get(i).copied().unwrap_or(f64::NAN));
                var += dot(j, run.covariance_um2.mul(j));
                by_offset += dot(j, run.bar.per_offset.map(f64::from));
                by_scale += dot(j, run.bar.per_scale_um.map(f64::from));
            }
            let shares = [
                crate::num::sqrt(var),
                by_offset * u_offset,
                by_scale * u_scale,
            ];
            let [a, o, k] = shares.map(|v| v as f32);
            results.set_budget(id, value, [a, o, k, 0.0, 0.0, 0.0, 0.0]);
        }
        Ok(true)
    }
}

impl From<Field> for TwoStepFailure {
    fn from(f: Field) -> Self {
        Self::Missing(f)
    }
}

/// The results of a machine type's angles, in [`identify`]'s order.
fn angle_results(m: TwoStepMachine) -> [Option<ResultId>; 2] {
    use ResultId::{TsDeltaAlpha, TsDeltaBeta, TsDeltaGamma};
    match m {
        TwoStepMachine::None => [None; 2],
        TwoStepMachine::Rrttt => [Some(TsDeltaAlpha), Some(TsDeltaBeta)],
        TwoStepMachine::Tttrr => [Some(TsDeltaAlpha), Some(TsDeltaGamma)],
        TwoStepMachine::RtttrSpindle => [Some(TsDeltaBeta), None],
        TwoStepMachine::RtttrTable => [Some(TsDeltaAlpha), None],
    }
}

/// The two-step identification of the configured machine (exact mode, seed 000 B.3–B.5;
/// the SSM socket on the member that does not carry the rotated point, α-then-β order) from
/// the pair's ΔV, with component k of run r moved by [`JACOBIAN_STEP_UM`] for `step` =
/// `Some((r, k))`: the angles of [`angle_results`], µrad (NaN where the machine type has no
/// second angle).
#[inline(never)] // flash: one body for the seven calls of a pair's end
fn identify(
    t: &TestSetup,
    runs: &[PairRun; 2],
    step: Option<(usize, usize)>,
) -> Result<[f64; 2], TwoStepFailure> {
    let [mut dv1_um, mut dv2_um] = runs.map(|r| r.dv_um);
    if let Some((r, k)) = step {
        let dv = if r == 0 { &mut dv1_um } else { &mut dv2_um };
        if let Some(v) = dv.get_mut(k) {
            *v += JACOBIAN_STEP_UM;
        }
    }
    // u is propagated by the caller, with the runs' full covariances
    let dv_std_um = [0.0; 2];
    let [a1, a2] = t.ts_angles_deg;
    let origin = required3(t.ts_origin_mm, Field::TsOriginMm)?;
    let fail = TwoStepFailure::Identify;
    let single = |angle_deg| SingleAxisMeasurement {
        origin_mm: origin,
        angle_deg,
        dv1_um,
        dv2_um,
        dv_std_um,
    };
    Ok(match t.ts_machine {
        TwoStepMachine::None => [f64::NAN; 2],
        TwoStepMachine::Rrttt => {
            let cfg = RrtttConfig {
                tool_z_mm: required(t.ts_tool_z_mm, Field::TsToolZMm)?,
                rotation_order: RotationOrder::AlphaThenBeta,
                reference_end: ReferenceEnd::OtherMember,
                min_lever_arm_mm: DEFAULT_MIN_LEVER_ARM_MM,
            };
            let m = RrtttMeasurement {
                pivot_mm: origin,
                alpha_deg: required(a1, Field::TsAngleDeg(0))?,
                beta_deg: required(a2, Field::TsAngleDeg(1))?,
                dv1_um,
                dv2_um,
                dv_std_um,
            };
            let r = two_step::identify_rrttt(&cfg, &m, Mode::Exact).map_err(fail)?;
            [r.delta_alpha_urad, r.delta_beta_urad]
        }
        TwoStepMachine::Tttrr => {
            let cfg = TttrrConfig {
                z_alpha_gamma_mm: required(t.ts_z_alpha_gamma_mm, Field::TsZAlphaGammaMm)?,
                reference_point_mm: required3(t.ts_reference_mm, Field::TsReferenceMm)?,
                reference_end: ReferenceEnd::OtherMember,
                min_lever_arm_mm: DEFAULT_MIN_LEVER_ARM_MM,
            };
            let m = TttrrMeasurement {
                origin_mm: origin,
                alpha_deg: required(a1, Field::TsAngleDeg(0))?,
                gamma_deg: required(a2, Field::TsAngleDeg(1))?,
                dv1_um,
                dv2_um,
                dv_std_um,
            };
            let r = two_step::identify_tttrr(&cfg, &m, Mode::Exact).map_err(fail)?;
            [r.delta_alpha_urad, r.delta_gamma_urad]
        }
        TwoStepMachine::RtttrSpindle => {
            let cfg = RtttrSpindleConfig {
                tool_z_mm: required(t.ts_tool_z_mm, Field::TsToolZMm)?,
                reference_end: ReferenceEnd::OtherMember,
                min_lever_arm_mm: DEFAULT_MIN_LEVER_ARM_MM,
            };
            let m = single(required(a1, Field::TsAngleDeg(0))?);
            let r = two_step::identify_rtttr_spindle(&cfg, &m, Mode::Exact).map_err(fail)?;
            [r.delta_urad, f64::NAN]
        }
        TwoStepMachine::RtttrTable => {
            let cfg = RtttrTableConfig {
                reference_point_mm: required3(t.ts_reference_mm, Field::TsReferenceMm)?,
                reference_end: ReferenceEnd::OtherMember,
                min_lever_arm_mm: DEFAULT_MIN_LEVER_ARM_MM,
            };
            let m = single(required(a1, Field::TsAngleDeg(0))?);
            let r = two_step::identify_rtttr_table(&cfg, &m, Mode::Exact).map_err(fail)?;
            [r.delta_urad, f64::NAN]
        }
    })
}
