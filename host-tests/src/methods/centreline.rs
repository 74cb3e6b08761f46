//! Seed 004 (Yamamoto, NIT Oita): rotary-axis centreline (direction + centre point) of a
//! table-swivel 5-axis machine from dial-gauge readings, and NC-point correction (eq 9).
//!
//! Spec: `design/spec/seed-003-004.md` part B (B3 equations as printed, B4 consistency
//! analysis, C11–C18 test vectors).
//!
//! # Method, in the order of the procedure
//! 1. [`plane_normal`]: a reference face of a block on the table is touched by a dial gauge at
//!    ≥ 3 points; the least-squares plane through them gives the face normal (seed 004 §3.1 uses
//!    exactly 3 points; more points add a residual).
//! 2. Axis **direction** from the normals measured at several axis angles (a rotation keeps the
//!    component of the normal along the axis, so the normal tips lie on a circle about the axis):
//!    - [`axis_direction_half_turn`]: 0° and 180° (the table axis, seed 004 eqs 1–3 in their
//!      corrected form `d = normalize(n1 + n2)`; the printed eqs 1–3 lose the sign and have eqs 2
//!      and 3 inverted, B4);
//!    - [`axis_direction_two_positions`]: two positions at any angle θ — exact closed form, which
//!      has **two** solutions (±k) unless the face normal is exactly perpendicular to the axis
//!      (B4); both are returned with the ambiguity, and the k = 0 member, which is what the
//!      (corrected) printed eqs 5–7 compute;
//!    - [`axis_direction_lsq`]: the general least-squares form for ≥ 3 angles (a plane through
//!      the normal tips), exact whatever the face tilt; this is the recommended primary method.
//! 3. Axis **centre** from one vertex of the block measured at ≥ 2 axis angles
//!    ([`axis_centre`], least squares `p_i = c + R(θ_i)·r`); seed 004 eq 4 (half turn about Z)
//!    and eq 8 (quarter turn about Y) are the two-position special cases, kept literally in
//!    [`paper`].
//! 4. [`nc_correction`]: seed 004 eq 9 — the work point rotated about the actual and about the
//!    NC-set centrelines; the difference is the error and its negative the correction;
//!    [`nc_command_correction`] the same for a program's NC point (V2) instead of the work point.
//!
//! # Conventions (B4, D.2, D.11, D.12)
//! - Directions are unit vectors in machine coordinates, oriented towards the nominal axis
//!   direction (`d · nominal > 0`); centres and points are in mm; uncertainties and residuals of
//!   directions in µrad, of points in µm.
//! - Rotations `R(d, θ)` are right-handed about `d` (Rodrigues). The *physical* angle is the
//!   right-handed rotation of the table about the nominal `+axis`; the NC command maps to it
//!   through [`RotationSense`]. Seed 004's data (eq 8, eqs 5–7 and Table 1) all say that a
//!   commanded +B turns the table by −B about +Y: [`RotationSense::Primed`] (ISO 841 table axis).
//! - Dial gauge: the reading is the surface height along the gauge's reading direction
//!   (+ = towards the gauge), see [`GaugeFrame`].

use nalgebra::{Rotation3, Unit, Vector3};

use ballpod::identify::lsq::{DEFAULT_RANK_TOL, GivensLsq, LsqError};

/// Why a centreline estimate could not be made.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CentrelineError {
    /// An input value was NaN or infinite.
    NonFinite,
    /// Fewer measured points or axis positions than the method needs.
    TooFewInputs {
        /// Inputs given.
        given: usize,
        /// Inputs the method needs.
        needed: usize,
    },
    /// The gauge frame is not a right-handed orthonormal triad (|u|, |v| = 1, u ⟂ v, u × v = w
    /// to 1e-9).
    BadGaugeFrame,
    /// The dial points are (nearly) collinear: the plane is not determined.
    DegeneratePointLayout,
    /// A direction vector (normal, nominal axis, axis line) has (nearly) zero length.
    ZeroVector,
    /// The face normal is (nearly) perpendicular to the axis in a half-turn measurement
    /// (`|n1 + n2| / 2 = |d · n| < 1e-3`): `n1 + n2` carries no direction.
    NormalPerpendicularToAxis,
    /// The axis positions do not rotate the face enough to fix the axis (all normals on a
    /// line, or two distinct positions given to the ≥ 3-angle method), or the rotation angle is
    /// 0 (mod 360°) where a rotation is needed.
    NoRotation,
    /// The two normals are farther apart than a rotation by the stated angle can make them:
    /// `k² < 0` in the two-position closed form by more than 3 standard uncertainties of the
    /// normals' noise (wrong angle, wrong sense, or noise larger than stated).
    InconsistentAngle {
        /// The k² the normals gave.
        k2: f64,
        /// Its standard uncertainty from the stated normal noise.
        u_k2: f64,
    },
    /// A stated input uncertainty (named) is negative or not finite.
    BadUncertainty {
        /// The parameter's name.
        field: &'static str,
    },
    /// The identified direction is more than 60° from the nominal axis (`d · nominal < 0.5`):
    /// wrong nominal axis or wrong normal orientation.
    FarFromNominal,
    /// The underlying least-squares solve failed.
    Lsq(LsqError),
}

impl From<LsqError> for CentrelineError {
    fn from(e: LsqError) -> Self {
        Self::Lsq(e)
    }
}

/// How a commanded NC angle maps to the physical right-handed rotation of the table about the
/// nominal `+axis` (DESIGN: sign conventions are explicit configuration).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RotationSense {
    /// Physical angle = commanded angle.
    RightHanded,
    /// Physical angle = −commanded angle (ISO 841 primed table axis: the table turns the work
    /// the opposite way to the tool's relative motion). Seed 004's B axis (B4 sign evidence).
    Primed,
}

impl RotationSense {
    /// The physical right-handed angle (degrees) for a commanded angle (degrees).
    pub fn physical_deg(self, commanded_deg: f64) -> f64 {
        match self {
            Self::RightHanded => commanded_deg,
            Self::Primed => -commanded_deg,
        }
    }
}

/// Nominal machine axis a rotary axis is parallel to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NominalAxis {
    /// ∥ +X; in-plane coordinates (Y, Z).
    X,
    /// ∥ +Y; in-plane coordinates (X, Z) (seed 004 B axis, eq 8).
    Y,
    /// ∥ +Z; in-plane coordinates (X, Y) (seed 004 A axis = rotary table, eq 4).
    Z,
}

impl NominalAxis {
    /// Unit vector of the nominal axis.
    pub fn unit(self) -> [f64; 3] {
        match self {
            Self::X => [1.0, 0.0, 0.0],
            Self::Y => [0.0, 1.0, 0.0],
            Self::Z => [0.0, 0.0, 1.0],
        }
    }
}

/// Orientation of the dial gauge while it touches a face, in machine coordinates: the two
/// lateral directions along which the gauge is moved between points and the reading
/// direction (a larger reading = the surface is farther along `reading_dir`, i.e. closer to
/// the gauge). Must be right-handed orthonormal: `lateral_u × lateral_v = reading_dir`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GaugeFrame {
    /// First lateral direction (unit, machine coordinates).
    pub lateral_u: [f64; 3],
    /// Second lateral direction (unit, machine coordinates).
    pub lateral_v: [f64; 3],
    /// Reading direction (unit): the direction of increasing surface height.
    pub reading_dir: [f64; 3],
}

impl GaugeFrame {
    /// Gauge above a horizontal face, touching from +Z (seed 004 §3.1): u = X, v = Y, reading
    /// = height along +Z.
    pub const FROM_PLUS_Z: Self = Self {
        lateral_u: [1.0, 0.0, 0.0],
        lateral_v: [0.0, 1.0, 0.0],
        reading_dir: [0.0, 0.0, 1.0],
    };
}

/// One dial-gauge point: lateral position of the gauge (mm, machine axes along the gauge
/// frame's u and v) and the indicator reading (µm, + = surface towards the gauge).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DialPoint {
    /// Position along the gauge frame's `lateral_u`, mm.
    pub u_mm: f64,
    /// Position along the gauge frame's `lateral_v`, mm.
    pub v_mm: f64,
    /// Indicator reading, µm (+ = surface height towards the gauge).
    pub reading_um: f64,
}

/// A face normal from dial-gauge points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneNormal {
    /// Unit normal in machine coordinates, pointing towards the gauge (`· reading_dir > 0`).
    pub normal: [f64; 3],
    /// RMS of the reading residuals about the fitted plane, µm (0 with exactly 3 points).
    pub residual_rms_um: f64,
    /// Standard uncertainty of the two face slopes (along u, along v), µrad (0 with 3 points).
    pub slope_uncertainty_urad: [f64; 2],
    /// Number of points used.
    pub points: usize,
}

/// An estimated axis direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisDirection {
    /// Unit direction, machine coordinates, oriented with the nominal axis.
    pub direction: [f64; 3],
    /// `d · n` of the (first) face normal: the cosine of the normal-to-axis angle (k in B4).
    pub axial_cos: f64,
    /// Standard uncertainty of the direction's two tilt components, µrad: its components
    /// along the pair (p, q) perpendicular to the nominal axis e with (p, q, e) right-handed —
    /// nominal Z: (X, Y); nominal Y: (X, −Z); nominal X: (Y, Z). The ≥ 3-position method states
    /// it from its residual (0 without redundancy); the half turn propagates the stated normal
    /// noise.
    pub tilt_uncertainty_urad: [f64; 2],
    /// Correlation coefficient of the two tilt components' errors (−1 … 1; 0 where
    /// `tilt_uncertainty_urad` is 0).
    pub tilt_correlation: f64,
    /// Degrees of freedom of `tilt_uncertainty_urad` (GUM G.3): positions − 3 for the
    /// ≥ 3-position method, whose u comes from its residual; `None` where u is propagated from
    /// a stated noise (the half turn).
    pub tilt_degrees_of_freedom: Option<u32>,
    /// RMS of the plane residuals `d · n_i − k` over the positions, µrad (0 without
    /// redundancy).
    pub residual_rms_urad: f64,
    /// RMS of (measured − commanded) rotation between positions, degrees (relative to the first
    /// position, physical sense): catches a wrong [`RotationSense`] or angle. 0 for the
    /// half-turn method, where the angle is not measured.
    pub angle_rms_deg: f64,
    /// Number of axis positions used.
    pub positions: usize,
}

/// Result of the two-position method at a general angle (B4): two exact solutions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TwoPositionAxis {
    /// The two exact solutions of `n4 = R(d, θ)·n3` (the closed form with k = +|k|, then with
    /// k = −|k|), unit, each oriented with the nominal; identical when k = 0.
    pub candidates: [[f64; 3]; 2],
    /// Standard uncertainty of each candidate's two tilt components (about the two directions
    /// perpendicular to the nominal axis), µrad, from the stated normal noise.
    pub tilt_uncertainty_urad: [[f64; 2]; 2],
    /// The k = 0 member (the face normal assumed perpendicular to the axis): what the corrected
    /// printed eqs 5–7 compute at θ = −90°; it is the normalised mid-point of the candidates.
    pub perpendicular_assumption: [f64; 3],
    /// |k| = |d · n3|, the cosine of the normal-to-axis angle (0 when k² is at or below 0).
    pub axial_cos_abs: f64,
    /// k² as the normals gave it (may be slightly negative from noise).
    pub axial_cos_sq: f64,
    /// Standard uncertainty of k² from the stated normal noise.
    pub axial_cos_sq_uncertainty: f64,
    /// Angle between the two candidates at the largest |k| the noise allows
    /// (√(k² + 2u(k²))), µrad: what two positions cannot decide (≈ 2√2·|k| rad at 90°).
    /// Measure ≥ 3 positions ([`axis_direction_lsq`]) to remove it.
    pub ambiguity_urad: f64,
}

/// A face normal measured at one axis position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalAtAngle {
    /// Commanded axis angle, degrees.
    pub commanded_deg: f64,
    /// Unit face normal (machine coordinates), from [`plane_normal`].
    pub normal: [f64; 3],
}

/// A block vertex measured at one axis position (seed 004 §3.2/§3.4).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointAtAngle {
    /// Commanded axis angle, degrees.
    pub commanded_deg: f64,
    /// In-plane coordinates of the vertex, mm, in the order of [`NominalAxis`] ((X, Y) for Z,
    /// (X, Z) for Y, (Y, Z) for X).
    pub point_mm: [f64; 2],
}

/// An estimated axis centre (where the axis pierces the plane of the measured vertex).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisCentre {
    /// Centre, mm, in-plane coordinates in the order of [`NominalAxis`].
    pub centre_mm: [f64; 2],
    /// Standard uncertainty of the centre coordinates from the residual, µm (Type A; 0
    /// without redundancy: [`axis_centre_budget`] states the touches' u for two positions).
    pub centre_uncertainty_um: [f64; 2],
    /// Correlation coefficient of the two centre coordinates' errors (−1 … 1; 0 without
    /// redundancy).
    pub centre_correlation: f64,
    /// Degrees of freedom of `centre_uncertainty_um` (GUM G.3): 2 · positions − 4, the
    /// residual's (0 without redundancy).
    pub centre_degrees_of_freedom: u32,
    /// Distance of the vertex from the axis, mm.
    pub radius_mm: f64,
    /// RMS of the point residuals (per coordinate), µm (0 without redundancy).
    pub residual_rms_um: f64,
    /// Number of positions used.
    pub positions: usize,
}

/// A rotary-axis line: unit direction and a point on it (seed 004's D and P).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisLine {
    /// Direction (need not be normalised; it is normalised before use).
    pub direction: [f64; 3],
    /// A point on the axis, mm (machine coordinates).
    pub point_mm: [f64; 3],
}

/// The two table axes of seed 004's table-swivel machine: the rotary table A is carried by the
/// tilting cradle B, so a work point is rotated about A first, then about B (eq 9).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TableAxes {
    /// Rotary-table axis (seed 004 "A", nominally ∥ Z).
    pub table: AxisLine,
    /// Tilting axis that carries the table (seed 004 "B", nominally ∥ Y).
    pub tilt: AxisLine,
}

/// NC-point correction of one work point (seed 004 eq 9 and §4.3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NcPointCorrection {
    /// V1: where the work point actually is after the rotations (actual centrelines), mm.
    pub actual_mm: [f64; 3],
    /// V2: where the NC believes it is (NC-set centrelines), mm.
    pub nominal_mm: [f64; 3],
    /// Error of the uncorrected tool position relative to the work point, machine axes, µm:
    /// `V2 − V1` (tool at V2, work point at V1; error = actual − nominal of the tool-to-work
    /// position, the sign of seed 003's probe − ball).
    pub error_machine_um: [f64; 3],
    /// The same error in the rotated work frame, µm: `R_r·(V2 − V1)` with
    /// `R_r = (R(D_NB, φ)·R(D_NA, ε))ᵀ` (eq 9's V_E1; R_r is undefined in the seed, this choice
    /// is documented in spec B4).
    pub error_work_um: [f64; 3],
    /// Correction to add to the nominal machine command, µm: `V1 − V2` (= −error).
    pub correction_um: [f64; 3],
    /// Corrected machine command (no TCPM in the controller), mm: `V1`. Only the tool-centre
    /// position is corrected, not the orientation — sufficient for a ball end mill (B6).
    pub corrected_command_mm: [f64; 3],
}

/// Smallest |k| = |d·n| for which the half-turn sum `n1 + n2` is accepted.
pub const MIN_AXIAL_COS: f64 = 1e-3;

fn v3(a: [f64; 3]) -> Vector3<f64> {
    Vector3::new(a[0], a[1], a[2])
}

fn arr(v: &Vector3<f64>) -> [f64; 3] {
    [v.x, v.y, v.z]
}

/// Normalises `v`, or `ZeroVector` if |v| < 1e-12 (or non-finite).
fn unit(v: Vector3<f64>) -> Result<Unit<Vector3<f64>>, CentrelineError> {
    let n = ballpod::num::sqrt(v.dot(&v));
    if !n.is_finite() {
        return Err(CentrelineError::NonFinite);
    }
    if n < 1e-12 {
        return Err(CentrelineError::ZeroVector);
    }
    Ok(Unit::new_unchecked(v / n))
}

/// Default relative standard uncertainty of a dial gauge's scale (its calibration, Type B):
/// 1 % of the reading. A dial test indicator's error of indication over the small strokes of
/// seed 004 (a few µm on a face) and its cosine error (the stylus a few degrees off the
/// square: 1 − cos 8° = 1 %) are each about that; seed 004 names neither.
pub const U_GAUGE_SCALE: f64 = 0.01;

impl AxisDirection {
    /// The gauge's calibration share of each tilt component's u, same components as
    /// [`Self::tilt_uncertainty_urad`] (µrad, Type B): the readings give the faces' slopes,
    /// the slopes the normals and the normals the axis, each step linear and homogeneous, so
    /// a scale error k of the gauge moves each tilt by k times itself. `nominal` is the
    /// nominal axis the tilts are taken from (unit), `u_scale` the gauge scale's relative
    /// standard uncertainty (1 = 100 %, [`U_GAUGE_SCALE`]).
    pub fn gauge_scale_share_urad(
        &self,
        nominal: [f64; 3],
        u_scale: f64,
    ) -> Result<[f64; 2], CentrelineError> {
        if !(u_scale.is_finite() && u_scale >= 0.0) {
            return Err(CentrelineError::BadUncertainty { field: "u_scale" });
        }
        let e = unit(Vector3::from(nominal))?;
        let (p, q) = perpendicular_pair(&e);
        let d = Vector3::from(self.direction);
        Ok([p, q].map(|a| libm::fabs(d.dot(&a)) * 1e6 * u_scale))
    }
}

/// Two unit vectors perpendicular to `e` (unit) forming a right-handed triad (p, q, e).
fn perpendicular_pair(e: &Unit<Vector3<f64>>) -> (Vector3<f64>, Vector3<f64>) {
    // Pick the machine axis least parallel to e as seed.
    let seed = if libm::fabs(e.x) <= libm::fabs(e.y) && libm::fabs(e.x) <= libm::fabs(e.z) {
        Vector3::x()
    } else if libm::fabs(e.y) <= libm::fabs(e.z) {
        Vector3::y()
    } else {
        Vector3::z()
    };
    let p = seed - e.into_inner() * e.dot(&seed);
    let p = p / ballpod::num::sqrt(p.dot(&p));
    let q = e.cross(&p);
    (p, q)
}

/// Orients `d` with the nominal and checks it is within 60° of it.
fn orient(d: Vector3<f64>, nominal: &Unit<Vector3<f64>>) -> Result<Vector3<f64>, CentrelineError> {
    let d = if d.dot(nominal) < 0.0 { -d } else { d };
    if d.dot(nominal) < 0.5 {
        return Err(CentrelineError::FarFromNominal);
    }
    Ok(d)
}

/// Face normal from ≥ 3 dial-gauge points by the least-squares plane
/// `reading = h0 + s_u·u + s_v·v` (seed 004 §3.1 uses 3 points: exact plane).
///
/// Normal = normalize(w − s_u·u − s_v·v) with the slopes in rad (µm/mm · 1e-3), pointing
/// towards the gauge. C12: points (0,0), (100,0), (0,100) mm with readings 0, −40, 30 µm from
/// +Z give n = (4e-4, −3e-4, 1)/|·|.
pub fn plane_normal(
    points: &[DialPoint],
    frame: &GaugeFrame,
) -> Result<PlaneNormal, CentrelineError> {
    let (u, v, w) = (
        v3(frame.lateral_u),
        v3(frame.lateral_v),
        v3(frame.reading_dir),
    );
    if !(ballpod::num::all_finite(&frame.lateral_u)
        && ballpod::num::all_finite(&frame.lateral_v)
        && ballpod::num::all_finite(&frame.reading_dir))
    {
        return Err(CentrelineError::NonFinite);
    }
    let tol = 1e-9;
    if libm::fabs(u.norm() - 1.0) > tol
        || libm::fabs(v.norm() - 1.0) > tol
        || libm::fabs(u.dot(&v)) > tol
        || (u.cross(&v) - w).norm() > tol
    {
        return Err(CentrelineError::BadGaugeFrame);
    }
    if points.len() < 3 {
        return Err(CentrelineError::TooFewInputs {
            given: points.len(),
            needed: 3,
        });
    }
    // Centre the lateral coordinates for conditioning (the plane is the same).
    let n = points.len() as f64;
    let (mut cu, mut cv) = (0.0, 0.0);
    for p in points {
        if !(p.u_mm.is_finite() && p.v_mm.is_finite() && p.reading_um.is_finite()) {
            return Err(CentrelineError::NonFinite);
        }
        cu += p.u_mm / n;
        cv += p.v_mm / n;
    }
    let mut lsq = GivensLsq::<3>::new();
    for p in points {
        lsq.add_row(&[1.0, p.u_mm - cu, p.v_mm - cv], p.reading_um, 1.0)?;
    }
    let sol = match lsq.solve_full_rank(DEFAULT_RANK_TOL) {
        Ok(s) => s,
        Err(LsqError::RankDeficient { .. }) => return Err(CentrelineError::DegeneratePointLayout),
        Err(e) => return Err(e.into()),
    };
    // slopes in µm/mm = mrad → rad
    let (su, sv) = (sol.x[1] * 1e-3, sol.x[2] * 1e-3);
    let nrm = unit(w - u * su - v * sv)?;
    Ok(PlaneNormal {
        normal: arr(&nrm),
        residual_rms_um: if points.len() > 3 {
            sol.residual_rms
        } else {
            0.0
        },
        slope_uncertainty_urad: [sol.std_uncertainty[1] * 1e3, sol.std_uncertainty[2] * 1e3],
        points: points.len(),
    })
}

/// Axis direction from face normals at 0° and 180° (seed 004 eqs 1–3, corrected, B4):
/// a half turn maps n1 to `n2 = 2(d·n1)d − n1`, hence `d = normalize(n1 + n2)`, oriented with
/// the nominal axis. Needs `|d·n1| ≥` [`MIN_AXIAL_COS`] (a face not parallel to the axis).
/// No redundancy: the uncertainty is propagated from `normal_std_urad`, the standard
/// uncertainty of each normal's two tilt components (µrad; e.g. the gauge's noise × √2 / the
/// point spacing, or [`PlaneNormal::slope_uncertainty_urad`] with more than 3 points).
pub fn axis_direction_half_turn(
    n1: [f64; 3],
    n2: [f64; 3],
    nominal: [f64; 3],
    normal_std_urad: f64,
) -> Result<AxisDirection, CentrelineError> {
    if !(ballpod::num::all_finite(&n1)
        && ballpod::num::all_finite(&n2)
        && ballpod::num::all_finite(&nominal))
    {
        return Err(CentrelineError::NonFinite);
    }
    let sigma = normal_sigma(normal_std_urad)?;
    let (n1, n2) = (unit(v3(n1))?, unit(v3(n2))?);
    let e = unit(v3(nominal))?;
    let s = n1.into_inner() + n2.into_inner();
    if s.norm() / 2.0 < MIN_AXIAL_COS {
        return Err(CentrelineError::NormalPerpendicularToAxis);
    }
    let d = orient(s / s.norm(), &e)?;
    let half_turn = |a: &Vector3<f64>, b: &Vector3<f64>| orient((a + b).normalize(), &e);
    let (u, rho) = propagate(&n1.into_inner(), &n2.into_inner(), sigma, &e, half_turn)?;
    Ok(AxisDirection {
        direction: arr(&d),
        axial_cos: d.dot(&n1),
        tilt_uncertainty_urad: u,
        tilt_correlation: rho,
        tilt_degrees_of_freedom: None,
        residual_rms_urad: 0.0,
        angle_rms_deg: 0.0,
        positions: 2,
    })
}

/// Axis direction from face normals at two positions a physical right-handed angle θ apart,
/// `n4 = R(d, θ)·n3` (B4 closed form):
/// `d ∝ cos(θ/2)·(n3 × n4) + k·sin(θ/2)·(n3 + n4)`, `k² = (n3·n4 − cos θ)/(1 − cos θ)`.
///
/// Two positions leave the sign of k open: both solutions fit exactly. The k = 0 member is the
/// corrected printed eqs 5–7 (θ = −90°, a face exactly perpendicular to the axis).
/// `commanded_deg` is the angle of the second position minus the first, mapped by `sense`.
///
/// Noise: `normal_std_urad` is the standard uncertainty of each normal's two tilt components
/// (µrad, as for [`axis_direction_half_turn`]). It gives u(k²) = σ·√(2(1 − (n3·n4)²))/(1 − cos θ);
/// a k² below −3·u(k²) is refused (`InconsistentAngle` with both numbers), a k² within the noise
/// of 0 is taken as 0, and the ambiguity is that of the largest |k| the noise allows
/// (√(k² + 2u(k²))), so a face nearly perpendicular to the axis does not read "no ambiguity".
/// Each candidate's tilt uncertainty combines σ propagated by perturbing the normals (k fixed)
/// with the spread of the candidate over k² ± 2u(k²).
pub fn axis_direction_two_positions(
    n3: [f64; 3],
    n4: [f64; 3],
    commanded_deg: f64,
    sense: RotationSense,
    nominal: [f64; 3],
    normal_std_urad: f64,
) -> Result<TwoPositionAxis, CentrelineError> {
    if !(ballpod::num::all_finite(&n3)
        && ballpod::num::all_finite(&n4)
        && ballpod::num::all_finite(&nominal)
        && commanded_deg.is_finite())
    {
        return Err(CentrelineError::NonFinite);
    }
    let sigma = normal_sigma(normal_std_urad)?;
    let (n3, n4) = (unit(v3(n3))?, unit(v3(n4))?);
    let e = unit(v3(nominal))?;
    let theta = sense.physical_deg(commanded_deg).to_radians();
    let cos_t = ballpod::num::cos(theta);
    if 1.0 - cos_t < 1e-12 {
        return Err(CentrelineError::NoRotation);
    }
    let c = n3.dot(&n4);
    let k2 = (c - cos_t) / (1.0 - cos_t);
    let u_k2 = sigma * ballpod::num::sqrt(2.0 * (1.0 - c * c).max(0.0)) / (1.0 - cos_t);
    // n3·n4 = k² + (1 − k²)·cos θ ≥ cos θ: a more negative k² means the normals moved more
    // than a rotation by θ can move them (small negative values are measurement noise).
    if k2 < -3.0 * u_k2 - 1e-12 {
        return Err(CentrelineError::InconsistentAngle { k2, u_k2 });
    }
    let (ch, sh) = (
        ballpod::num::cos(theta / 2.0),
        ballpod::num::sin(theta / 2.0),
    );
    let solve = |a: &Vector3<f64>, b: &Vector3<f64>, sign: f64, k: Option<f64>| {
        let k = k.unwrap_or_else(|| {
            let k2 = (a.dot(b) - cos_t) / (1.0 - cos_t);
            ballpod::num::sqrt(k2.clamp(0.0, 1.0))
        });
        let v = a.cross(b) * ch + (a + b) * (sh * k * sign);
        orient(unit(v)?.into_inner(), &e)
    };
    let (n3v, n4v) = (n3.into_inner(), n4.into_inner());
    let plus = solve(&n3v, &n4v, 1.0, None)?;
    let minus = solve(&n3v, &n4v, -1.0, None)?;
    // At θ = ±180° the cross term vanishes and both candidates are ∥ n3 + n4.
    let mid = match unit(n3.cross(&n4) * ch) {
        Ok(m) => orient(m.into_inner(), &e)?,
        Err(_) => plus,
    };
    // k within the noise: k² ± 2u(k²), at least 0
    let k = ballpod::num::sqrt(k2.clamp(0.0, 1.0));
    let k_lo = ballpod::num::sqrt((k2 - 2.0 * u_k2).clamp(0.0, 1.0));
    let k_wide = ballpod::num::sqrt((k2.max(0.0) + 2.0 * u_k2).min(1.0));
    let wide = [1.0, -1.0].map(|sign| solve(&n3v, &n4v, sign, Some(k_wide)));
    let ambiguity = match wide {
        [Ok(p), Ok(m)] => libm::atan2(p.cross(&m).norm(), p.dot(&m)),
        _ => libm::atan2(plus.cross(&minus).norm(), plus.dot(&minus)),
    };
    // each candidate's u: the normals' noise at fixed k, and k's own range (half the way to
    // the farther end of k² ± 2u(k²)): near k = 0 the square root makes k far less certain
    // than a linearisation says
    let (p, q) = perpendicular_pair(&e);
    let tilt = |d: &Vector3<f64>| [p.dot(d), q.dot(d)];
    let candidate_u = |sign: f64| -> Result<[f64; 2], CentrelineError> {
        let (at_k, _) = propagate(&n3v, &n4v, sigma, &e, |a, b| solve(a, b, sign, Some(k)))?;
        let t = tilt(&solve(&n3v, &n4v, sign, Some(k))?);
        let lo = tilt(&solve(&n3v, &n4v, sign, Some(k_lo))?);
        let hi = tilt(&solve(&n3v, &n4v, sign, Some(k_wide))?);
        let mut u = [0.0; 2];
        for (((u, a), t), (l, h)) in u.iter_mut().zip(at_k).zip(t).zip(lo.into_iter().zip(hi)) {
            let from_k = libm::fabs(h - t).max(libm::fabs(t - l)) / 2.0 * 1e6;
            *u = ballpod::num::sqrt(a * a + from_k * from_k);
        }
        Ok(u)
    };
    Ok(TwoPositionAxis {
        candidates: [arr(&plus), arr(&minus)],
        tilt_uncertainty_urad: [candidate_u(1.0)?, candidate_u(-1.0)?],
        perpendicular_assumption: arr(&mid),
        axial_cos_abs: k,
        axial_cos_sq: k2,
        axial_cos_sq_uncertainty: u_k2,
        ambiguity_urad: ambiguity * 1e6,
    })
}

/// The normals' stated standard uncertainty, µrad → rad; refused if negative or not finite.
fn normal_sigma(normal_std_urad: f64) -> Result<f64, CentrelineError> {
    if normal_std_urad.is_finite() && normal_std_urad >= 0.0 {
        Ok(normal_std_urad * 1e-6)
    } else {
        Err(CentrelineError::BadUncertainty {
            field: "normal_std_urad",
        })
    }
}

/// Standard uncertainty (µrad) of the two tilt components (about the pair perpendicular to the
/// nominal `e`) of a direction `f(a, b)` computed from two unit normals, and their correlation
/// coefficient; each normal has two independent tilt components of standard uncertainty
/// `sigma` (rad): central differences with a step of σ itself, so a non-linear method (the
/// square root of a k² near 0) is followed over the noise's range rather than at a point.
fn propagate(
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    sigma: f64,
    e: &Unit<Vector3<f64>>,
    f: impl Fn(&Vector3<f64>, &Vector3<f64>) -> Result<Vector3<f64>, CentrelineError>,
) -> Result<([f64; 2], f64), CentrelineError> {
    if sigma == 0.0 {
        return Ok(([0.0; 2], 0.0));
    }
    let (p, q) = perpendicular_pair(e);
    let tilt = |d: Vector3<f64>| [p.dot(&d), q.dot(&d)];
    let (mut var, mut cov) = ([0.0f64; 2], 0.0);
    for which in 0..2 {
        let n = if which == 0 { a } else { b };
        let (t1, t2) = perpendicular_pair(&Unit::new_normalize(*n));
        for t in [t1, t2] {
            let step = |s: f64| {
                let m = (n + t * (s * sigma)).normalize();
                if which == 0 { f(&m, b) } else { f(a, &m) }
            };
            let (hi, lo) = (tilt(step(1.0)?), tilt(step(-1.0)?));
            let dv = [(hi[0] - lo[0]) / 2.0, (hi[1] - lo[1]) / 2.0];
            for (v, d) in var.iter_mut().zip(dv) {
                *v += d * d;
            }
            cov += dv[0] * dv[1];
        }
    }
    let d = ballpod::num::sqrt(var[0] * var[1]);
    let rho = if d > 0.0 { cov / d } else { 0.0 };
    Ok((var.map(|v| ballpod::num::sqrt(v) * 1e6), rho))
}

/// Signed angle (rad) from `a` to `b` about unit `d`, after projecting both onto the plane
/// perpendicular to `d`.
fn signed_angle_about(d: &Vector3<f64>, a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    let pa = a - d * d.dot(a);
    let pb = b - d * d.dot(b);
    libm::atan2(d.dot(&pa.cross(&pb)), pa.dot(&pb))
}

/// Wraps an angle in degrees into (−180°, 180°].
fn wrap_deg(x: f64) -> f64 {
    let mut y = libm::fmod(x, 360.0);
    if y > 180.0 {
        y -= 360.0;
    } else if y <= -180.0 {
        y += 360.0;
    }
    y
}

/// Axis direction from face normals at ≥ 3 axis positions (B4 recommendation; the general
/// least-squares form): a rotation keeps `d·n`, so the normal tips lie on a plane
/// `d·n_i = k`. With `d' = e + a·p + b·q` (e nominal, p, q ⟂ e) the equations
/// `a·(p·n_i) + b·(q·n_i) − k' = −e·n_i` are linear and exact, whatever the face tilt; then
/// `d = normalize(d')`. The commanded angles are used only for the angle check
/// ([`AxisDirection::angle_rms_deg`]), not for the direction.
///
/// Rank check: the normals must span a circle (≥ 3 distinct positions), else `NoRotation`.
/// A face whose normal is nearly along the axis gives a tiny circle and a large (reported)
/// uncertainty; use [`axis_direction_half_turn`] for it.
pub fn axis_direction_lsq(
    positions: &[NormalAtAngle],
    sense: RotationSense,
    nominal: [f64; 3],
) -> Result<AxisDirection, CentrelineError> {
    if positions.len() < 3 {
        return Err(CentrelineError::TooFewInputs {
            given: positions.len(),
            needed: 3,
        });
    }
    if !ballpod::num::all_finite(&nominal)
        || positions
            .iter()
            .any(|p| !(ballpod::num::all_finite(&p.normal) && p.commanded_deg.is_finite()))
    {
        return Err(CentrelineError::NonFinite);
    }
    let e = unit(v3(nominal))?;
    let (p, q) = perpendicular_pair(&e);
    let mut lsq = GivensLsq::<3>::new();
    for pos in positions {
        let n = unit(v3(pos.normal))?;
        lsq.add_row(&[p.dot(&n), q.dot(&n), -1.0], -e.dot(&n), 1.0)?;
    }
    let sol = match lsq.solve_full_rank(DEFAULT_RANK_TOL) {
        Ok(s) => s,
        Err(LsqError::RankDeficient { .. }) => return Err(CentrelineError::NoRotation),
        Err(err) => return Err(err.into()),
    };
    let dp = e.into_inner() + p * sol.x[0] + q * sol.x[1];
    let scale = dp.norm();
    let d = orient(unit(dp)?.into_inner(), &e)?;
    let mut first: Option<(Vector3<f64>, f64)> = None;
    let (mut sum_sq, mut k_first) = (0.0, 0.0);
    for pos in positions {
        let n = v3(pos.normal);
        let n = n / n.norm();
        match first {
            None => {
                first = Some((n, sense.physical_deg(pos.commanded_deg)));
                k_first = d.dot(&n);
            }
            Some((n0, a0)) => {
                let measured = signed_angle_about(&d, &n0, &n).to_degrees();
                let expected = sense.physical_deg(pos.commanded_deg) - a0;
                let r = wrap_deg(measured - expected);
                sum_sq += r * r;
            }
        }
    }
    let redundant = positions.len() > 3;
    Ok(AxisDirection {
        direction: arr(&d),
        axial_cos: k_first,
        tilt_uncertainty_urad: [
            sol.std_uncertainty[0] / scale * 1e6,
            sol.std_uncertainty[1] / scale * 1e6,
        ],
        tilt_correlation: sol.correlation(0, 1),
        tilt_degrees_of_freedom: Some(sol.rows.saturating_sub(3)),
        residual_rms_urad: if redundant {
            sol.residual_rms / scale * 1e6
        } else {
            0.0
        },
        angle_rms_deg: ballpod::num::sqrt(sum_sq / (positions.len() - 1) as f64),
        positions: positions.len(),
    })
}

/// In-plane rotation matrix entries (c, s) for a physical right-handed angle θ about the
/// nominal axis, written in that axis's in-plane coordinate order: returns the 2×2 matrix
/// `[[m00, m01], [m10, m11]]` acting on `(first, second)` coordinates.
/// About Z on (X, Y): [[c, −s], [s, c]]; about Y on (X, Z): [[c, s], [−s, c]];
/// about X on (Y, Z): [[c, −s], [s, c]].
fn in_plane_rotation(axis: NominalAxis, theta_rad: f64) -> [[f64; 2]; 2] {
    let (s, c) = (ballpod::num::sin(theta_rad), ballpod::num::cos(theta_rad));
    match axis {
        NominalAxis::Z | NominalAxis::X => [[c, -s], [s, c]],
        NominalAxis::Y => [[c, s], [-s, c]],
    }
}

impl AxisCentre {
    /// The centre as a point of the axis line (mm, machine coordinates): its in-plane
    /// coordinates, and the out-of-plane one where the plane through `vertex_mm` (the vertex
    /// at any of its positions, machine coordinates) perpendicular to the axis `direction`
    /// meets the line, `(vertex − point)·direction = 0`. `axis` is the nominal axis of the
    /// fit. Error when the direction is more than 60° from the nominal or a value is not
    /// finite.
    pub fn point_on_axis(
        &self,
        axis: NominalAxis,
        direction: [f64; 3],
        vertex_mm: [f64; 3],
    ) -> Result<[f64; 3], CentrelineError> {
        if !(ballpod::num::all_finite(&direction) && ballpod::num::all_finite(&vertex_mm)) {
            return Err(CentrelineError::NonFinite);
        }
        // (in-plane indices, out-of-plane index) in the order of `NominalAxis`
        let ([i, j], k) = match axis {
            NominalAxis::X => ([1, 2], 0),
            NominalAxis::Y => ([0, 2], 1),
            NominalAxis::Z => ([0, 1], 2),
        };
        let at = |v: &[f64; 3], n: usize| v.get(n).copied().unwrap_or(0.0);
        let (d, v) = (direction, vertex_mm);
        let dk = at(&d, k);
        if !(libm::fabs(dk) >= 0.5 * v3(d).norm()) {
            return Err(CentrelineError::FarFromNominal);
        }
        let [ci, cj] = self.centre_mm;
        let mut p = [0.0; 3];
        let out = at(&v, k) + ((at(&v, i) - ci) * at(&d, i) + (at(&v, j) - cj) * at(&d, j)) / dk;
        for (n, value) in [(i, ci), (j, cj), (k, out)] {
            if let Some(slot) = p.get_mut(n) {
                *slot = value;
            }
        }
        Ok(p)
    }
}

/// Axis centre from one physical vertex measured at ≥ 2 axis positions (seed 004 §3.2, §3.4;
/// eqs 4 and 8 are the two-position cases): least squares on `p_i = c + R(θ_i − θ_0)·r`,
/// unknowns c (centre) and r (vertex − centre at the first position), `θ` physical (via
/// `sense`). Two positions: exact; more: residual and uncertainty.
///
/// The measured points are taken in the plane perpendicular to the nominal axis. The fitted
/// centre is the projection of the vertex circle's centre, which lies on the axis in the plane
/// through the vertex perpendicular to the **actual** axis: on an axis tilted by τ, that is
/// τ·radius away from the vertex's own height, and taking the centre at the vertex's height
/// misplaces the line by τ²·radius (0.2 µm at 1.6 mrad and 80 mm).
/// [`AxisCentre::point_on_axis`] places it from the identified direction. All positions must
/// show the **same physical vertex** (D.11).
pub fn axis_centre(
    positions: &[PointAtAngle],
    axis: NominalAxis,
    sense: RotationSense,
) -> Result<AxisCentre, CentrelineError> {
    let origin = positions.first().map(|p| p.point_mm).unwrap_or([0.0; 2]);
    // the data centred on the first point, for conditioning
    let lsq = centre_rows(positions, axis, sense, |p, k| {
        p.point_mm.get(k).copied().unwrap_or(0.0) - origin.get(k).copied().unwrap_or(0.0)
    })?;
    let sol = solve_centre(&lsq)?;
    let redundant = positions.len() > 2;
    Ok(AxisCentre {
        centre_mm: [sol.x[0] + origin[0], sol.x[1] + origin[1]],
        centre_uncertainty_um: [sol.std_uncertainty[0] * 1e3, sol.std_uncertainty[1] * 1e3],
        centre_correlation: if redundant {
            sol.correlation(0, 1)
        } else {
            0.0
        },
        centre_degrees_of_freedom: sol.rows.saturating_sub(4),
        radius_mm: ballpod::num::hypot(sol.x[2], sol.x[3]),
        residual_rms_um: if redundant {
            sol.residual_rms * 1e3
        } else {
            0.0
        },
        positions: positions.len(),
    })
}

/// The rows of [`axis_centre`]'s least squares `p_i = c + R(θ_i − θ_0)·r`, unknowns
/// (c, r), with the right-hand side `rhs(position, component)`. Refuses fewer than two
/// positions and values that are not finite.
fn centre_rows(
    positions: &[PointAtAngle],
    axis: NominalAxis,
    sense: RotationSense,
    rhs: impl Fn(&PointAtAngle, usize) -> f64,
) -> Result<GivensLsq<4>, CentrelineError> {
    if positions.len() < 2 {
        return Err(CentrelineError::TooFewInputs {
            given: positions.len(),
            needed: 2,
        });
    }
    if positions
        .iter()
        .any(|p| !(p.commanded_deg.is_finite() && ballpod::num::all_finite(&p.point_mm)))
    {
        return Err(CentrelineError::NonFinite);
    }
    let theta0 = positions
        .first()
        .map(|p| sense.physical_deg(p.commanded_deg))
        .unwrap_or(0.0);
    let mut lsq = GivensLsq::<4>::new();
    for pos in positions {
        let m = in_plane_rotation(
            axis,
            (sense.physical_deg(pos.commanded_deg) - theta0).to_radians(),
        );
        // p = c + M r  ->  [1, 0, m00, m01]·x = p0 ; [0, 1, m10, m11]·x = p1
        lsq.add_row(&[1.0, 0.0, m[0][0], m[0][1]], rhs(pos, 0), 1.0)?;
        lsq.add_row(&[0.0, 1.0, m[1][0], m[1][1]], rhs(pos, 1), 1.0)?;
    }
    Ok(lsq)
}

/// Solves [`centre_rows`]; positions that do not turn the vertex are `NoRotation`.
fn solve_centre(
    lsq: &GivensLsq<4>,
) -> Result<ballpod::identify::lsq::LsqSolution<4>, CentrelineError> {
    match lsq.solve_full_rank(DEFAULT_RANK_TOL) {
        Ok(s) => Ok(s),
        Err(LsqError::RankDeficient { .. }) => Err(CentrelineError::NoRotation),
        Err(err) => Err(err.into()),
    }
}

/// Default standard uncertainty of one vertex coordinate as touched off (µm, Type B, random
/// from position to position): seed 004 §3.2 reads the vertex "with a reference tool and
/// reference block", jogging the tool until the block just slides; that feel, at a 1 µm
/// handwheel step, repeats to about 2 µm. Seed 004 states no figure.
pub const U_TOUCH_UM: f64 = 2.0;

/// Default standard uncertainty of the touch-off's offset (µm, Type B, the same at every
/// position): what the reference tool's radius (across the spindle) or its length (along
/// it) and the reference block's thickness add to each touched coordinate, each known to
/// about 2 µm from the tool's certificate, its run-out in the spindle and the tool setter.
pub const U_TOUCH_OFFSET_UM: f64 = 2.0;

/// The standard uncertainties of reading a vertex by touching it off (µm): the inputs of
/// [`axis_centre_budget`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TouchUncertainty {
    /// One touched coordinate's random error, µm ([`U_TOUCH_UM`]).
    pub repeatability_um: f64,
    /// The touch-off's offset, µm, one for the touches across the spindle (the tool's radius)
    /// and one, independent, for those along it (its length) ([`U_TOUCH_OFFSET_UM`]).
    pub offset_um: f64,
}

impl Default for TouchUncertainty {
    fn default() -> Self {
        Self {
            repeatability_um: U_TOUCH_UM,
            offset_um: U_TOUCH_OFFSET_UM,
        }
    }
}

/// An axis centre with its uncertainty budget (µm, the centre's in-plane components in the
/// order of [`NominalAxis`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CentreBudget {
    /// The fit ([`axis_centre`]).
    pub centre: AxisCentre,
    /// Combined standard uncertainty of each centre component, µm.
    pub u_um: [f64; 2],
    /// The touches' random share, µm: Type A from the fit's residual when the positions are
    /// redundant (`random_is_type_a`), else the stated repeatability propagated.
    pub random_um: [f64; 2],
    /// Whether `random_um` is the residual's Type A (else the stated repeatability).
    pub random_is_type_a: bool,
    /// The touch-off offset's share, µm (Type B; NaN, and so `u_um`, where the positions are
    /// not quarter turns apart: the model does not hold there).
    pub offset_um: [f64; 2],
    /// Correlation coefficient of the two components' errors, both shares together (−1 … 1;
    /// 0 where a u is 0): with `u_um`, what `ncgen correct-centrelines` takes.
    pub correlation: f64,
    /// Effective degrees of freedom of each `u_um` (Welch–Satterthwaite, GUM G.4; `None`:
    /// infinite, the u is all Type B).
    pub degrees_of_freedom: [Option<u32>; 2],
}

/// [`axis_centre`] with its uncertainty budget (seed 004 §3.2, §3.4; the touches as
/// [`TouchUncertainty`]).
///
/// - **Random:** redundant positions (three or more) give the centre's Type A from the
///   residual, with 2·positions − 4 degrees of freedom. Two positions (eqs 4 and 8) have no
///   residual; the stated repeatability is propagated through the fit instead
///   (`u·√((AᵀA)⁻¹)`: u/√2 per component for a half turn) rather than a u of 0.
/// - **Offset:** a touch-off that stops ε further out along the touched face's outward
///   normal moves each coordinate by ±ε. Across the spindle (X, Y on seed 004's vertical
///   spindle) one ε serves both coordinates (the tool's radius), along it (Z) another (its
///   length), taken as independent (the block's thickness is common to both and cancels in
///   their difference: independence errs large). The faces turn with the block, so an ε that
///   turns with them is absorbed by the fitted vertex offset r: a table axis about Z, touched
///   across the spindle only, has no offset share. A B axis at B0 and B90 is touched along Z
///   on the face it touched along X before, and the difference of the two ε moves the centre
///   (along Z where the corner's X and Z signs agree, along X where they differ). Each face is
///   taken to face away from the axis: the touched coordinate's sign is that of the vertex
///   about the fitted centre (the vertex is the apex of a block near the axis, seed 004
///   Fig. 3), and square to a machine axis: the positions must be quarter turns apart (to
///   0.5°), else the offset's share and u are NaN (not evaluated). With three or more
///   positions the part of the offset the fit does not absorb also shows in the residual,
///   so it counts twice (u errs large).
pub fn axis_centre_budget(
    positions: &[PointAtAngle],
    axis: NominalAxis,
    sense: RotationSense,
    touch: TouchUncertainty,
) -> Result<CentreBudget, CentrelineError> {
    for (u, field) in [
        (touch.repeatability_um, "repeatability_um"),
        (touch.offset_um, "offset_um"),
    ] {
        if !(u.is_finite() && u >= 0.0) {
            return Err(CentrelineError::BadUncertainty { field });
        }
    }
    let centre = axis_centre(positions, axis, sense)?;
    let random_is_type_a = centre.centre_degrees_of_freedom > 0;
    let (random_um, random_cov) = if random_is_type_a {
        let [a, b] = centre.centre_uncertainty_um;
        ([a, b], centre.centre_correlation * a * b)
    } else {
        let sol = solve_centre(&centre_rows(positions, axis, sense, |_, _| 0.0)?)?;
        let u2 = touch.repeatability_um * touch.repeatability_um;
        (
            [0, 1].map(|k| ballpod::num::sqrt(u2 * sol.cofactor(k, k))),
            u2 * sol.cofactor(0, 1),
        )
    };
    // the faces square to the machine axes at every position: quarter turns from the first
    let theta0 = positions
        .first()
        .map(|p| sense.physical_deg(p.commanded_deg))
        .unwrap_or(0.0);
    let quarter_turns = positions.iter().all(|p| {
        let turn = (sense.physical_deg(p.commanded_deg) - theta0) / 90.0;
        libm::fabs(turn - libm::round(turn)) * 90.0 <= 0.5
    });
    // the in-plane component read along the spindle (Z), if any
    let along_spindle = match axis {
        NominalAxis::Z => None,
        NominalAxis::X | NominalAxis::Y => Some(1),
    };
    let (mut offset_sq, mut offset_cov) = ([0.0; 2], 0.0);
    for class_along in [false, true] {
        let lsq = centre_rows(positions, axis, sense, |p, k| {
            let outward = p.point_mm.get(k).copied().unwrap_or(0.0)
                - centre.centre_mm.get(k).copied().unwrap_or(0.0);
            if (along_spindle == Some(k)) == class_along {
                libm::copysign(touch.offset_um, outward)
            } else {
                0.0
            }
        })?;
        let shift = solve_centre(&lsq)?.x;
        for (sq, s) in offset_sq.iter_mut().zip(shift) {
            *sq += s * s;
        }
        offset_cov += shift[0] * shift[1];
    }
    let offset_um = if quarter_turns {
        offset_sq.map(ballpod::num::sqrt)
    } else {
        [f64::NAN; 2]
    };
    let mut u_um = [0.0; 2];
    let mut degrees_of_freedom = [None; 2];
    for k in 0..2 {
        let (a, b) = (
            random_um.get(k).copied().unwrap_or(0.0),
            offset_um.get(k).copied().unwrap_or(0.0),
        );
        let u = ballpod::num::hypot(a, b);
        if let Some(slot) = u_um.get_mut(k) {
            *slot = u;
        }
        if random_is_type_a && let Some(slot) = degrees_of_freedom.get_mut(k) {
            // GUM G.4: ν_eff = u⁴ / (u_A⁴ / ν_A), the Type B share's ν infinite
            let nu_a = f64::from(centre.centre_degrees_of_freedom);
            let a4 = a * a * a * a;
            *slot = if a4 > 0.0 {
                Some(libm::fmin(u * u * u * u * nu_a / a4, f64::from(u32::MAX)) as u32)
            } else {
                None
            };
        }
    }
    let [u0, u1] = u_um;
    let correlation = if u0 > 0.0 && u1 > 0.0 {
        (random_cov + offset_cov) / (u0 * u1)
    } else {
        0.0
    };
    Ok(CentreBudget {
        centre,
        u_um,
        random_um,
        random_is_type_a,
        offset_um,
        correlation,
        degrees_of_freedom,
    })
}

/// Rotation of a work point about an axis line: `R(D, θ)(p − P) + P` (right-handed).
fn rotate_about_line(
    line: &AxisLine,
    p: &Vector3<f64>,
    theta_rad: f64,
) -> Result<Vector3<f64>, CentrelineError> {
    let d = unit(v3(line.direction))?;
    let c = v3(line.point_mm);
    Ok(Rotation3::from_axis_angle(&d, theta_rad) * (p - c) + c)
}

/// Seed 004 eq 9: the work point `P_p + P_w` (mm, machine coordinates at A0B0) rotated by the
/// table axis (ε) first, then by the tilting axis (φ):
/// `V = R(D_B, φ)·((R(D_A, ε)(P − P_A) + P_A) − P_B) + P_B`, for the actual (V1) and the
/// NC-set (V2) centrelines. `eps_deg`, `phi_deg` are **physical** right-handed angles (map NC
/// commands with [`RotationSense::physical_deg`]). Error, correction and corrected command as
/// documented on [`NcPointCorrection`].
pub fn nc_correction(
    actual: &TableAxes,
    nominal: &TableAxes,
    work_point_mm: [f64; 3],
    eps_deg: f64,
    phi_deg: f64,
) -> Result<NcPointCorrection, CentrelineError> {
    let all = [
        actual.table.direction,
        actual.table.point_mm,
        actual.tilt.direction,
        actual.tilt.point_mm,
        nominal.table.direction,
        nominal.table.point_mm,
        nominal.tilt.direction,
        nominal.tilt.point_mm,
        work_point_mm,
    ];
    if !(ballpod::num::all_finite(all.as_flattened()) && eps_deg.is_finite() && phi_deg.is_finite())
    {
        return Err(CentrelineError::NonFinite);
    }
    let p = v3(work_point_mm);
    let (eps, phi) = (eps_deg.to_radians(), phi_deg.to_radians());
    let v1 = rotate_about_line(
        &actual.tilt,
        &rotate_about_line(&actual.table, &p, eps)?,
        phi,
    )?;
    let v2 = rotate_about_line(
        &nominal.tilt,
        &rotate_about_line(&nominal.table, &p, eps)?,
        phi,
    )?;
    let r_r = (Rotation3::from_axis_angle(&unit(v3(nominal.tilt.direction))?, phi)
        * Rotation3::from_axis_angle(&unit(v3(nominal.table.direction))?, eps))
    .inverse();
    let err = (v2 - v1) * 1e3;
    Ok(NcPointCorrection {
        actual_mm: arr(&v1),
        nominal_mm: arr(&v2),
        error_machine_um: arr(&err),
        error_work_um: arr(&(r_r * err)),
        correction_um: arr(&(-err)),
        corrected_command_mm: arr(&v1),
    })
}

/// Seed 004 §4.3 applied to a program: `command_mm` is an NC point the post-processor
/// computed with the NC-set centrelines (V2 of eq 9, machine coordinates, no TCPM) at the
/// physical angles `eps_deg` (table) and `phi_deg` (tilt). The work point is recovered by
/// undoing the nominal rotations (`P = R(D_NA, −ε)((R(D_NB, −φ)(V2 − P_NB) + P_NB) − P_NA) +
/// P_NA`) and rotated about the actual centrelines: [`nc_correction`] of that point, whose
/// `corrected_command_mm` (V1) is the point to command instead.
pub fn nc_command_correction(
    actual: &TableAxes,
    nominal: &TableAxes,
    command_mm: [f64; 3],
    eps_deg: f64,
    phi_deg: f64,
) -> Result<NcPointCorrection, CentrelineError> {
    if !(ballpod::num::all_finite(&command_mm) && eps_deg.is_finite() && phi_deg.is_finite()) {
        return Err(CentrelineError::NonFinite);
    }
    let untilted = rotate_about_line(&nominal.tilt, &v3(command_mm), -phi_deg.to_radians())?;
    let work = rotate_about_line(&nominal.table, &untilted, -eps_deg.to_radians())?;
    nc_correction(actual, nominal, arr(&work), eps_deg, phi_deg)
}

/// Seed 004's printed two-position formulas in their corrected literal form (paper mode).
/// The primary results are the general functions above; these exist to show that the paper's
/// special cases are reproduced and where they stop being valid.
pub mod paper {
    use super::CentrelineError;

    /// Eqs 5–7 as corrected in B4 (eq 5: c3/c4 swapped back; eq 6: denominator a3 + a4):
    /// `B_a = −2(b3·c4 − b4·c3)/|n3+n4|²`, `B_b = (B_a(b3+b4) − c3 + c4)/(a3+a4)`,
    /// `B_c = (B_a(c3+c4) + b3 − b4)/(a3+a4)`. Exact only for `n4 = R(d, −90°)·n3` with the face
    /// normal exactly perpendicular to the axis (k = 0); otherwise off by ≈ √2·|k| rad.
    /// Not normalised (as printed). Error when `a3 + a4` or `|n3 + n4|` vanishes.
    pub fn eq5_7_corrected(n3: [f64; 3], n4: [f64; 3]) -> Result<[f64; 3], CentrelineError> {
        let [a3, b3, c3] = n3;
        let [a4, b4, c4] = n4;
        let s2 = (a3 + a4) * (a3 + a4) + (b3 + b4) * (b3 + b4) + (c3 + c4) * (c3 + c4);
        let den = a3 + a4;
        if !(s2.is_finite() && den.is_finite()) {
            return Err(CentrelineError::NonFinite);
        }
        if s2 < 1e-12 || libm::fabs(den) < 1e-12 {
            return Err(CentrelineError::NoRotation);
        }
        let ba = -2.0 * (b3 * c4 - b4 * c3) / s2;
        Ok([
            ba,
            (ba * (b3 + b4) - c3 + c4) / den,
            (ba * (c3 + c4) + b3 - b4) / den,
        ])
    }

    /// Eq 4 (half turn about Z): centre = mid-point of the vertex at A0 (i) and A180 (j), mm.
    pub fn eq4_centre(i_xy_mm: [f64; 2], j_xy_mm: [f64; 2]) -> [f64; 2] {
        [
            0.5 * (i_xy_mm[0] + j_xy_mm[0]),
            0.5 * (i_xy_mm[1] + j_xy_mm[1]),
        ]
    }

    /// Eq 8 (quarter turn about Y, physical −90°: x' = −z, z' = x about the centre): centre
    /// `X = ½(X1 + X2 + Z1 − Z2)`, `Z = ½(−X1 + X2 + Z1 + Z2)` from the vertex at B0 (k) and
    /// commanded B90 (l), (X, Z) in mm.
    pub fn eq8_centre(k_xz_mm: [f64; 2], l_xz_mm: [f64; 2]) -> [f64; 2] {
        let [x1, z1] = k_xz_mm;
        let [x2, z2] = l_xz_mm;
        [0.5 * (x1 + x2 + z1 - z2), 0.5 * (-x1 + x2 + z1 + z2)]
    }
}
