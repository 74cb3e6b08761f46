//! Volumetric-error definitions of seed 001 §8.5 (spec A.8): the sums 8.112–8.117,
//! Definition 8.1 (8.118–8.121), Definition 8.2 (8.122–8.129), and the body-diagonal figures
//! Ed and ESd (8.130–8.133). ELv and ELSv have no formula in the seed and are not provided.

use super::{RigidBodyErrors, VolumetricError};

/// Volumetric deviation at one point: linear (V_X, V_Y, V_Z) in µm and angular
/// (V_A, V_B, V_C) in µrad.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VolumetricPoint {
    /// (V(XYZ,X), V(XYZ,Y), V(XYZ,Z)), µm.
    pub linear_um: [f64; 3],
    /// (V(XYZ,A), V(XYZ,B), V(XYZ,C)), µrad.
    pub angular_urad: [f64; 3],
}

/// Eqs 8.112–8.117 (rigid body, squareness folded into straightness, no Abbé offsets):
/// V(XYZ,X) = EXX + EXY + EXZ = D_x(x) + D_x(y) + D_x(z), …, V(XYZ,A) = A_x(x) + A_x(y) + A_x(z), …
/// `pos_mm` gives the signed positions for the squareness folding (8.58–8.60).
pub fn deviation_sums(e: &RigidBodyErrors, pos_mm: [f64; 3]) -> VolumetricPoint {
    let [_, y, z] = pos_mm.map(|v| v * 1e-3);
    let mut p = VolumetricPoint::default();
    for ax in [e.x, e.y, e.z] {
        for (l, d) in p.linear_um.iter_mut().zip(ax.d_um.iter()) {
            *l += d;
        }
        for (l, a) in p.angular_urad.iter_mut().zip(ax.a_urad.iter()) {
            *l += a;
        }
    }
    let [vx, vy, _] = &mut p.linear_um;
    *vx += e.squareness.xy_urad * y + e.squareness.zx_urad * z;
    *vy += e.squareness.yz_urad * z;
    p
}

/// Definition 8.1: R_max = max over points of √(V_X² + V_Y² + V_Z²) (µm) and
/// W_max = max of √(V_A² + V_B² + V_C²) (µrad).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Definition81 {
    /// R_max, µm (8.120).
    pub r_max_um: f64,
    /// W_max, µrad (8.121).
    pub w_max_urad: f64,
}

/// Definition 8.2: ranges per direction and their root sum of squares.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Definition82 {
    /// X_max, Y_max, Z_max = max − min of V_X, V_Y, V_Z over the points, µm (8.122–8.124).
    pub linear_ranges_um: [f64; 3],
    /// A_max, B_max, C_max, µrad (8.125–8.127).
    pub angular_ranges_urad: [f64; 3],
    /// R_max = √(X_max² + Y_max² + Z_max²), µm (8.128).
    pub r_max_um: f64,
    /// W_max = √(A_max² + B_max² + C_max²), µrad (8.129).
    pub w_max_urad: f64,
}

fn norm3(v: &[f64; 3]) -> f64 {
    ballpod::num::sqrt(v.iter().map(|x| x * x).sum())
}

fn check_points(points: &[VolumetricPoint]) -> Result<(), VolumetricError> {
    if points.is_empty() {
        return Err(VolumetricError::EmptyData);
    }
    if points.iter().any(|p| {
        p.linear_um
            .iter()
            .chain(p.angular_urad.iter())
            .any(|v| !v.is_finite())
    }) {
        return Err(VolumetricError::NonFinite);
    }
    Ok(())
}

/// Definition 8.1 (eqs 8.118–8.121) over the measured points.
pub fn definition_8_1(points: &[VolumetricPoint]) -> Result<Definition81, VolumetricError> {
    check_points(points)?;
    let r = points
        .iter()
        .map(|p| norm3(&p.linear_um))
        .fold(0.0, f64::max);
    let w = points
        .iter()
        .map(|p| norm3(&p.angular_urad))
        .fold(0.0, f64::max);
    Ok(Definition81 {
        r_max_um: r,
        w_max_urad: w,
    })
}

fn range(values: impl Iterator<Item = f64> + Clone) -> f64 {
    let max = values.clone().fold(f64::NEG_INFINITY, f64::max);
    let min = values.fold(f64::INFINITY, f64::min);
    max - min
}

/// Definition 8.2 (eqs 8.122–8.129) over the measured points.
pub fn definition_8_2(points: &[VolumetricPoint]) -> Result<Definition82, VolumetricError> {
    check_points(points)?;
    let mut lin = [0.0; 3];
    let mut ang = [0.0; 3];
    for (k, (l, a)) in lin.iter_mut().zip(ang.iter_mut()).enumerate() {
        *l = range(
            points
                .iter()
                .map(move |p| p.linear_um.get(k).copied().unwrap_or(0.0)),
        );
        *a = range(
            points
                .iter()
                .map(move |p| p.angular_urad.get(k).copied().unwrap_or(0.0)),
        );
    }
    Ok(Definition82 {
        linear_ranges_um: lin,
        angular_ranges_urad: ang,
        r_max_um: norm3(&lin),
        w_max_urad: norm3(&ang),
    })
}

/// Body-diagonal volumetric figures (eqs 8.130–8.133, ISO 230-6 / ASME B5.54).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiagonalFigures {
    /// Range max − min of Dr(r) per diagonal pair (ppp/nnn, npp/pnn, pnp/npn, ppn/nnp), µm.
    pub ranges_um: [f64; 4],
    /// Ed = the largest per-diagonal range, µm (does not include squareness, per the text).
    pub ed_um: f64,
    /// ESd = max − min over all data of all four diagonals, µm (includes squareness).
    pub esd_um: f64,
}

/// Ed and ESd from the displacement-error data Dr(r) (µm) of the four diagonal pairs
/// (ppp/nnn, npp/pnn, pnp/npn, ppn/nnp). Every diagonal must hold data.
pub fn diagonal_figures(diagonals_um: [&[f64]; 4]) -> Result<DiagonalFigures, VolumetricError> {
    if diagonals_um.iter().any(|d| d.is_empty()) {
        return Err(VolumetricError::EmptyData);
    }
    if diagonals_um
        .iter()
        .any(|d| d.iter().any(|v| !v.is_finite()))
    {
        return Err(VolumetricError::NonFinite);
    }
    let ranges_um = diagonals_um.map(|d| range(d.iter().copied()));
    let ed_um = ranges_um.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let esd_um = range(diagonals_um.iter().flat_map(|d| d.iter().copied()));
    Ok(DiagonalFigures {
        ranges_um,
        ed_um,
        esd_um,
    })
}

/// Multiple factors of Table 8.2: (M1, M2, M3) = (ELSv/ELv, ELSv/Ed, ELSv/ESd); every
/// denominator must be positive.
pub fn multiple_factors(
    elsv_um: f64,
    elv_um: f64,
    ed_um: f64,
    esd_um: f64,
) -> Result<[f64; 3], VolumetricError> {
    let all = [elsv_um, elv_um, ed_um, esd_um];
    if all.iter().any(|v| !v.is_finite()) {
        return Err(VolumetricError::NonFinite);
    }
    if [elv_um, ed_um, esd_um].iter().any(|&v| v <= 0.0) {
        return Err(VolumetricError::LengthNotPositive);
    }
    Ok([elsv_um / elv_um, elsv_um / ed_um, elsv_um / esd_um])
}
