//! The machine's three axis scales from circles in its three planes (the three-plane summary):
//! each plane's circle gives the mean scale of its two axes, (k_u + k_v)/2, from the joint
//! fit's radius ([`super::Diagnosis::Radius`]) on any arc, and on a full circle their mismatch
//! k_u − k_v too ([`super::Diagnosis::ScaleMismatch`]). With the planes XY, YZ, ZX the three
//! means alone determine k_x, k_y, k_z:
//!
//! k_x = m_XY + m_ZX − m_YZ, k_y = m_XY + m_YZ − m_ZX, k_z = m_YZ + m_ZX − m_XY,
//!
//! and each mismatch read adds a row; the scales are the weighted least-squares solution of all
//! the rows read (weights 1/u², u each reading's own). Everything is relative to the bar's
//! calibrated length: an error δL of it reads as δL/R in every mean, so as δL/R in each scale —
//! the caller propagates it as one input common to the three radii (the sensitivities below).
//!
//! The squarenesses of the three planes need no combination: each plane's circle reads its own.

use crate::metrology::solve3::Sym3;

/// The planes of the summary, in order, as (u, v) axis indices (0 X, 1 Y, 2 Z): XY, YZ, ZX
/// (ISO 230-4's planes, `config::CirclePlane`'s order).
pub const SUMMARY_PLANES: [(usize, usize); 3] = [(0, 1), (1, 2), (2, 0)];

/// Readings of the summary: each plane's mean scale, then each plane's mismatch.
pub const SCALE_READINGS: usize = 6;

/// One reading of a plane: value and the standard uncertainty that weights it (µm/m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScaleReading {
    /// The value, µm/m.
    pub value: f32,
    /// Its standard uncertainty without the bar's length (common to every plane), µm/m.
    pub u: f32,
}

/// What one plane's circle gives the summary.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneScales {
    /// The mean scale (k_u + k_v)/2 of the plane's axes, µm/m.
    pub mean: ScaleReading,
    /// The scale mismatch k_u − k_v, µm/m, where the arc determines it (a full circle).
    pub mismatch: Option<ScaleReading>,
}

/// The axis scales and how each depends on the readings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisScales {
    /// k_x, k_y, k_z, µm/m.
    pub scale_um_per_m: [f32; 3],
    /// ∂k_i/∂reading_r, readings in order [mean XY, YZ, ZX, mismatch XY, YZ, ZX] (0 for a
    /// mismatch not read): what the caller propagates each input's share through.
    pub sensitivity: [[f32; SCALE_READINGS]; 3],
}

/// Why the axis scales are not available.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AxisScalesError {
    /// A reading is not finite or its u is not positive.
    BadReading,
    /// The normal equations are singular (cannot happen with the three means; kept typed).
    Singular,
}

/// The weighted least-squares scales k_x, k_y, k_z from the three planes' readings
/// (`planes` in [`SUMMARY_PLANES`] order; the module doc).
pub fn axis_scales(planes: &[PlaneScales; 3]) -> Result<AxisScales, AxisScalesError> {
    // each reading's row (coefficients of k_x, k_y, k_z), value and weight
    let mut rows = [([0.0f64; 3], 0.0f64, 0.0f64); SCALE_READINGS];
    for (p, (plane, &(u, v))) in planes.iter().zip(SUMMARY_PLANES.iter()).enumerate() {
        let readings = [
            (Some(plane.mean), 0.5, 0.5, p),
            (plane.mismatch, 1.0, -1.0, p + 3),
        ];
        for (reading, cu, cv, r) in readings {
            let Some(x) = reading else { continue };
            if !(x.value.is_finite() && x.u.is_finite() && x.u > 0.0) {
                return Err(AxisScalesError::BadReading);
            }
            let mut a = [0.0f64; 3];
            for (axis, c) in [(u, cu), (v, cv)] {
                if let Some(x) = a.get_mut(axis) {
                    *x += c;
                }
            }
            let w = 1.0 / (f64::from(x.u) * f64::from(x.u));
            if let Some(row) = rows.get_mut(r) {
                *row = (a, f64::from(x.value), w);
            }
        }
    }
    let mut n = Sym3::default();
    for (a, _, w) in rows {
        n.add_outer(a, w);
    }
    let inv = n
        .cholesky()
        .map_err(|_| AxisScalesError::Singular)?
        .inverse()
        .rows();
    // sensitivity = N⁻¹ Aᵀ W: column r is N⁻¹ a_r w_r
    let mut sensitivity = [[0.0f32; SCALE_READINGS]; 3];
    let mut k = [0.0f64; 3];
    for (r, (a, y, w)) in rows.iter().enumerate() {
        for (i, (s, ki)) in sensitivity.iter_mut().zip(k.iter_mut()).enumerate() {
            let row = inv.get(i).copied().unwrap_or([0.0; 3]);
            let g = (row[0] * a[0] + row[1] * a[1] + row[2] * a[2]) * w;
            if let Some(s) = s.get_mut(r) {
                *s = g as f32;
            }
            *ki += g * y;
        }
    }
    Ok(AxisScales {
        scale_um_per_m: k.map(|x| x as f32),
        sensitivity,
    })
}
