//! SSM: the single socket method (seed 000 eq 1, DESIGN §7) on the pod.
//!
//! During a run every sample updates the streaming estimator (E at the current point from its
//! neighbourhood, per component observable or not: the live ssm_ex/ey/ez) and the dwell
//! detector. At the end the dwell stations give E by eq (1), refined on the exact sphere
//! equation, with its standard uncertainty. Two SSM runs — after the translation, then after
//! the rotation — give the seed 000 two-step orientation errors of the configured machine type
//! (`ts_machine`, exact inversion, [`crate::identify::two_step`]).

use super::results::{ResultId, Results};
use crate::acquisition::Sample;
use crate::config::{Field, TestSetup, TwoStepMachine, required, required3};
use crate::identify::two_step::{
    self, DEFAULT_MIN_LEVER_ARM_MM, Mode, ReferenceEnd, RotationOrder, RrtttConfig,
    RrtttMeasurement, RtttrSpindleConfig, RtttrTableConfig, SingleAxisMeasurement, TttrrConfig,
    TttrrMeasurement, TwoStepError,
};
use crate::in_place::{self, init_in_place};
use crate::metrology::solve3::Sym3;
use crate::metrology::ssm::station::{
    DwellConfig, StationCollector, refine, solve_stations, station_covariance,
};
use crate::metrology::ssm::streaming::{StreamingConfig, StreamingSsm};
use crate::metrology::ssm::{SsmError, SsmGeometry, SsmSolution};
use core::mem::MaybeUninit;

/// Samples the streaming neighbourhood holds at most (7 KiB: 0.26 s at 1 kHz; a sample that
/// leaves only because the window is full is counted by the estimator).
pub const SSM_WINDOW: usize = 256;
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
}

/// E from the stations of an SSM run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SsmMeasurement {
    /// The refined solution (E µm per component, `None` where not observable; cond; residual).
    pub solution: SsmSolution,
    /// Covariance of E, µm²: each station's ΔL with its dwell mean's standard error and
    /// [`FIXED_POSITION_U_UM`], propagated through the least squares
    /// ([`station_covariance`]).
    pub covariance_um2: Sym3,
}

impl SsmMeasurement {
    /// Standard uncertainty of each component of E, µm (NaN where not observable).
    pub fn u_e_um(&self) -> [f64; 3] {
        let c = &self.covariance_um2;
        let mut u = [c.a00, c.a11, c.a22];
        for (u, e) in u.iter_mut().zip(self.solution.e_um) {
            *u = if e.is_some() {
                crate::num::sqrt(*u)
            } else {
                f64::NAN
            };
        }
        u
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
        Self::init_with(slot, NO_RUN, t)
    }

    /// Starts a run in place on the set-up's socket with a bar of `bar_length_mm`, or returns
    /// the first field the set-up lacks (the socket position; the state is then unchanged).
    pub fn restart(&mut self, t: &TestSetup, bar_length_mm: f32) -> Result<(), Field> {
        let geometry = SsmGeometry {
            socket_mm: required3(t.ssm_socket_mm, Field::SsmSocketMm)?,
            bar_length_mm: f64::from(bar_length_mm),
        };
        in_place::reinit(self, |s| Self::init_with(s, geometry, t));
        Ok(())
    }

    fn init_with<'a>(
        slot: &'a mut MaybeUninit<Self>,
        geometry: SsmGeometry,
        t: &TestSetup,
    ) -> &'a mut Self {
        init_in_place!(slot, Self {
            geometry: geometry,
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

    /// Feeds one used sample.
    pub fn update(&mut self, s: &Sample) {
        self.stream.update(s);
        self.stations.update(s);
    }

    /// E at the current point from its neighbourhood: each component, or `None` where it is not
    /// observable (yet).
    pub fn live(&self) -> [Option<f32>; 3] {
        self.stream.live().unwrap_or([None; 3])
    }

    /// Ends the run: the stations' E, refined.
    pub fn finish(&mut self) -> Result<SsmMeasurement, SsmError> {
        self.stations.finish();
        let st = self.stations.stations();
        let s0 = solve_stations(st, &self.geometry)?;
        let solution = refine(st, &self.geometry, &s0, REFINE_ITERATIONS)?;
        let covariance_um2 =
            station_covariance(st, &self.geometry, &solution, FIXED_POSITION_U_UM)?;
        Ok(SsmMeasurement {
            solution,
            covariance_um2,
        })
    }
}

/// Writes an SSM measurement into the results.
pub fn publish(m: &SsmMeasurement, results: &mut Results) {
    let [ex, ey, ez] = m.solution.e_um;
    let [ux, uy, uz] = m.u_e_um();
    for (id, e, u) in [
        (ResultId::SsmEx, ex, ux),
        (ResultId::SsmEy, ey, uy),
        (ResultId::SsmEz, ez, uz),
    ] {
        results.set(id, e.unwrap_or(f64::NAN), u);
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
    dv1: Option<([f64; 3], f64)>,
}

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
    pub fn on_measurement(
        &mut self,
        t: &TestSetup,
        m: &SsmMeasurement,
        results: &mut Results,
    ) -> Result<bool, TwoStepFailure> {
        let [Some(x), Some(y), Some(z)] = m.solution.e_um else {
            return Ok(false);
        };
        if t.ts_machine == TwoStepMachine::None {
            return Ok(false);
        }
        // each run's u: its largest component's (the two-step takes one per run)
        let e = (
            [x, y, z],
            m.u_e_um().iter().fold(0.0, |a: f64, &b| a.max(b)),
        );
        let Some((dv1, u1)) = self.dv1.take() else {
            self.dv1 = Some(e);
            results.clear(ResultId::TsDeltaAlpha, ResultId::TsDeltaGamma);
            return Ok(false);
        };
        let (dv2, u2) = e;
        identify(t, dv1, dv2, [u1, u2], results)?;
        Ok(true)
    }
}

impl From<Field> for TwoStepFailure {
    fn from(f: Field) -> Self {
        Self::Missing(f)
    }
}

/// The two-step identification of the configured machine (exact mode, seed 000 B.3–B.5;
/// the SSM socket on the member that does not carry the rotated point, α-then-β order).
fn identify(
    t: &TestSetup,
    dv1_um: [f64; 3],
    dv2_um: [f64; 3],
    dv_std_um: [f64; 2],
    results: &mut Results,
) -> Result<(), TwoStepFailure> {
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
    match t.ts_machine {
        TwoStepMachine::None => {}
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
            let [ua, ub] = r.std_uncertainty_urad;
            results.set(ResultId::TsDeltaAlpha, r.delta_alpha_urad, ua);
            results.set(ResultId::TsDeltaBeta, r.delta_beta_urad, ub);
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
            let [ua, ug] = r.std_uncertainty_urad;
            results.set(ResultId::TsDeltaAlpha, r.delta_alpha_urad, ua);
            results.set(ResultId::TsDeltaGamma, r.delta_gamma_urad, ug);
        }
        TwoStepMachine::RtttrSpindle => {
            let cfg = RtttrSpindleConfig {
                tool_z_mm: required(t.ts_tool_z_mm, Field::TsToolZMm)?,
                reference_end: ReferenceEnd::OtherMember,
                min_lever_arm_mm: DEFAULT_MIN_LEVER_ARM_MM,
            };
            let m = single(required(a1, Field::TsAngleDeg(0))?);
            let r = two_step::identify_rtttr_spindle(&cfg, &m, Mode::Exact).map_err(fail)?;
            results.set(ResultId::TsDeltaBeta, r.delta_urad, r.std_uncertainty_urad);
        }
        TwoStepMachine::RtttrTable => {
            let cfg = RtttrTableConfig {
                reference_point_mm: required3(t.ts_reference_mm, Field::TsReferenceMm)?,
                reference_end: ReferenceEnd::OtherMember,
                min_lever_arm_mm: DEFAULT_MIN_LEVER_ARM_MM,
            };
            let m = single(required(a1, Field::TsAngleDeg(0))?);
            let r = two_step::identify_rtttr_table(&cfg, &m, Mode::Exact).map_err(fail)?;
            results.set(ResultId::TsDeltaAlpha, r.delta_urad, r.std_uncertainty_urad);
        }
    }
    Ok(())
}
