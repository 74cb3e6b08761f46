//! Seed 001 (C. Wang, ch. 8 of *Introduction to Precision Machine Design and Error Assessment*,
//! spec `seed-000-001.md` part A): the 21-error rigid-body volumetric model of the four
//! three-axis configurations, laser body-diagonal and vector (sequential-step) diagonal
//! measurements, 3D grid and thermal compensation interpolation, volumetric-error definitions,
//! and controller compensation-table conventions.
//!
//! Units: positions and Abbé offsets in mm, linear errors D in µm, angular errors A and
//! squareness S in µrad (1 µrad × 1 mm = 1 nm, so `A·offset` contributes `A_urad·offset_mm·1e-3`
//! µm). Error = actual − nominal; a compensation value is −error ([`compensation`]).
//!
//! Naming (seed 001 §8.1.1): `D_i(u)` is the error in direction `i` caused by motion of axis
//! `u`; `A_i(u)` the rotation about `i` caused by motion of `u` (roll, pitch, yaw). In
//! [`AxisErrors`] of axis `u`, `d_um[i]` is `D_i(u)` and `a_urad[i]` is `A_i(u)`, with
//! i = 0, 1, 2 for x, y, z. Squareness is folded into straightness (eqs 8.58–8.60):
//! D_x(y) += S_xy·y, D_x(z) += S_zx·z, D_y(z) += S_yz·z.
//!
//! - [`position_error_um`]: eqs 8.68–8.82 with the tool-offset terms 8.71–8.73 (first order,
//!   checked against the matrix forms 8.63–8.66 in the tests).
//! - [`body_diagonal_reading_um`]: eqs 8.108–8.111 (corrected, spec A.6), for any configuration.
//! - [`vector`]: the sequential-step diagonal inversion (spec A.6 derivation).
//! - [`compensation`]: 3D grid interpolation (8.101–8.104), thermal interpolation (8.105–8.107),
//!   controller table conventions (§8.4 / spec A.7).
//! - [`metrics`]: volumetric-error definitions 8.112–8.129, Ed and ESd (8.130–8.133).

pub mod compensation;
pub mod metrics;
pub mod vector;

use ballpod::identify::lsq::LsqError;

/// Why a volumetric computation could not be done.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum VolumetricError {
    /// An input is NaN or infinite.
    NonFinite,
    /// A data set that must hold values is empty.
    EmptyData,
    /// A length, pitch, step or diagonal component that must be positive is not.
    LengthNotPositive,
    /// A point lies outside the compensation grid along the axis given (0 = x, 1 = y, 2 = z);
    /// the grid is not extrapolated.
    OutsideGrid {
        /// Axis index (0 = x, 1 = y, 2 = z).
        axis: usize,
    },
    /// The grid's value slice does not hold `nx·ny·nz` points, or a count is below 2.
    GridShape,
    /// The two thermal maps were measured at the same temperature.
    EqualTemperatures,
    /// The use temperature lies outside the measured maps' range (8.105 holds for
    /// T_n ≤ T_u ≤ T_m only; it is not extrapolated).
    OutsideTemperatureRange,
    /// Thermal maps are not in strictly increasing temperature order.
    UnsortedTemperatures,
    /// (MAX − MIN)/STEP of a controller table is not a whole number of intervals.
    TableSpacing,
    /// The output slice is too short for the table; `needed` points are required.
    TableTooSmall {
        /// Points needed.
        needed: usize,
    },
    /// The vector-method diagonals cannot separate the error increment of the direction given
    /// (0 = x, 1 = y, 2 = z): fewer than 3 independent diagonals were read, or a diagonal
    /// component is zero.
    CannotSeparate {
        /// Direction index (0 = x, 1 = y, 2 = z) most involved in the unobservable combination.
        direction: usize,
    },
    /// The least-squares solver failed for another reason.
    Lsq(LsqError),
}

/// The four three-axis configurations of seed 001 §8.1.3: the letters before F move the
/// workpiece relative to the base, those after F move the tool.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Configuration {
    /// Fixed workpiece, tool moved by X, Y, Z (eq 8.63 / 8.68–8.70).
    Fxyz,
    /// Workpiece on X, tool on Y, Z (usual horizontal machining centre; 8.64 / 8.74–8.76).
    Xfyz,
    /// Workpiece on X, Y, tool on Z (usual vertical machining centre; 8.65 / 8.77–8.79).
    Xyfz,
    /// Workpiece on X, Y, Z, fixed tool (8.66 / 8.80–8.82).
    Xyzf,
}

/// The six errors of one linear axis at its current position.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AxisErrors {
    /// (D_x(u), D_y(u), D_z(u)): displacement / straightness errors of axis u, µm.
    pub d_um: [f64; 3],
    /// (A_x(u), A_y(u), A_z(u)): rotations about x, y, z caused by axis u, µrad.
    pub a_urad: [f64; 3],
}

/// The three squareness errors (seed 001 eqs 8.58–8.60), µrad; positive S_xy makes the y
/// travel drift towards +x (D_x(y) += S_xy·y).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Squareness {
    /// S_xy, folded into D_x(y), µrad.
    pub xy_urad: f64,
    /// S_yz, folded into D_y(z), µrad.
    pub yz_urad: f64,
    /// S_zx, folded into D_x(z), µrad.
    pub zx_urad: f64,
}

/// The 21 rigid-body errors, evaluated at the current axis positions.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RigidBodyErrors {
    /// Errors of the x axis at x.
    pub x: AxisErrors,
    /// Errors of the y axis at y.
    pub y: AxisErrors,
    /// Errors of the z axis at z.
    pub z: AxisErrors,
    /// Squareness errors.
    pub squareness: Squareness,
}

/// µrad × mm → µm.
const URAD_MM_TO_UM: f64 = 1e-3;

fn finite_errors(e: &RigidBodyErrors) -> bool {
    [e.x, e.y, e.z]
        .iter()
        .all(|a| a.d_um.iter().chain(a.a_urad.iter()).all(|v| v.is_finite()))
        && e.squareness.xy_urad.is_finite()
        && e.squareness.yz_urad.is_finite()
        && e.squareness.zx_urad.is_finite()
}

/// Positioning error E = P − (x, y, z) − T of the tool point relative to the workpiece, µm,
/// first order (seed 001 eqs 8.68–8.82 plus the tool-offset terms 8.71–8.73, squareness folded
/// by 8.58–8.60 with the signed positions). `pos_mm` = (x, y, z) are the axis positions (also
/// the Abbé offsets), `tool_mm` = (X_t, Y_t, Z_t) the tool offset (eq 8.61). Sign of each Abbé
/// term as in the equations (spec A.4: "use the equations, not the prose").
pub fn position_error_um(
    cfg: Configuration,
    e: &RigidBodyErrors,
    pos_mm: [f64; 3],
    tool_mm: [f64; 3],
) -> Result<[f64; 3], VolumetricError> {
    if !(finite_errors(e) && pos_mm.iter().chain(tool_mm.iter()).all(|v| v.is_finite())) {
        return Err(VolumetricError::NonFinite);
    }
    let [x, y, z] = pos_mm.map(|v| v * URAD_MM_TO_UM); // offsets scaled so that A·offset is µm
    let [xt, yt, zt] = tool_mm.map(|v| v * URAD_MM_TO_UM);
    let [dxx, dyx, dzx] = e.x.d_um;
    let [dxy0, dyy, dzy] = e.y.d_um;
    let [dxz0, dyz0, dzz] = e.z.d_um;
    // squareness folded into straightness, eqs 8.58–8.60 (S µrad × position mm → µm)
    let dxy = dxy0 + e.squareness.xy_urad * y;
    let dxz = dxz0 + e.squareness.zx_urad * z;
    let dyz = dyz0 + e.squareness.yz_urad * z;
    let [axx, ayx, azx] = e.x.a_urad;
    let [axy, ayy, azy] = e.y.a_urad;
    let [axz, ayz, azz] = e.z.a_urad;
    let (ex, ey, ez) = match cfg {
        // 8.68–8.70
        Configuration::Fxyz => (
            (dxx - y * azx + z * ayx) + (dxy + z * ayy) + dxz,
            (dyx - z * axx) + (dyy - z * axy) + dyz,
            (dzx + y * axx) + dzy + dzz,
        ),
        // 8.74–8.76
        Configuration::Xfyz => (
            (dxx - y * azx + z * ayx) + (dxy + z * ayy) + dxz,
            (dyx + x * azx - z * axx) + (dyy - z * axy) + dyz,
            (dzx - x * ayx + y * axx) + dzy + dzz,
        ),
        // 8.77–8.79
        Configuration::Xyfz => (
            (dxx + z * ayx) + (dxy - y * azy + z * ayy) + dxz,
            (dyx + x * azx - z * axx) + (dyy + x * azy - z * axy) + dyz,
            (dzx - x * ayx) + (dzy - x * ayy + y * axy) + dzz,
        ),
        // 8.80–8.82
        Configuration::Xyzf => (
            dxx + (dxy - y * azy) + (dxz - y * azz + z * ayz),
            (dyx + x * azx) + (dyy + x * azy) + (dyz + x * azz - z * axz),
            (dzx - x * ayx) + (dzy - x * ayy + y * axy) + (dzz - x * ayz + y * axz),
        ),
    };
    // tool-offset terms, the same for all four configurations, 8.71–8.73
    let sax = axx + axy + axz;
    let say = ayx + ayy + ayz;
    let saz = azx + azy + azz;
    Ok([
        ex - yt * saz + zt * say,
        ey + xt * saz - zt * sax,
        ez - xt * say + yt * sax,
    ])
}

/// Laser body-diagonal reading DR = u·E(P), µm (seed 001 eqs 8.108–8.111, corrected per spec
/// A.6; generalised to every configuration). `offset_mm` = (s_x a, s_y b, s_z c) is the signed
/// offset of the measured point from the diagonal's start (these are the Abbé offsets and the
/// signed coordinates in the squareness terms); the beam direction is u = offset/|offset|.
/// `e` holds the errors at that point, zero-referenced at the start. Tool offset zero (the
/// retroreflector is the reference point).
pub fn body_diagonal_reading_um(
    cfg: Configuration,
    e: &RigidBodyErrors,
    offset_mm: [f64; 3],
) -> Result<f64, VolumetricError> {
    let [a, b, c] = offset_mm;
    let r = ballpod::num::sqrt(a * a + b * b + c * c);
    if !r.is_finite() {
        return Err(VolumetricError::NonFinite);
    }
    if r <= 0.0 {
        return Err(VolumetricError::LengthNotPositive);
    }
    let [ex, ey, ez] = position_error_um(cfg, e, offset_mm, [0.0; 3])?;
    Ok((a * ex + b * ey + c * ez) / r)
}
