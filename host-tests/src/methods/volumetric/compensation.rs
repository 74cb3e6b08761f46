//! Compensation models of seed 001 §8.2 and the controller-table conventions of §8.4
//! (spec A.5, A.7): 3D grid-point interpolation (eqs 8.101–8.104), thermal interpolation
//! between measured maps (8.105–8.107), and error → compensation tables.
//!
//! Sign: every table here holds **compensation = −error** (controller convention; seed 001
//! prints error values, the controller adds the table value to the command).

use super::VolumetricError;

/// Trilinear interpolation of eq 8.101 inside one grid cell. `corners` = C1..C8 at the
/// normalised corners (0,0,0), (1,0,0), (1,1,0), (0,1,0), (0,0,1), (1,0,1), (1,1,1), (0,1,1)
/// (the numbering the printed weights imply, spec A.5); `frac` = (x, y, z) ∈ [0, 1]³ from
/// [`cell_fraction`]. Works per component: call it for C_x, C_y and C_z.
pub fn trilinear(corners: &[f64; 8], frac: [f64; 3]) -> Result<f64, VolumetricError> {
    if !(ballpod::num::all_finite(corners) && ballpod::num::all_finite(&frac)) {
        return Err(VolumetricError::NonFinite);
    }
    for (axis, f) in frac.iter().enumerate() {
        if !(0.0..=1.0).contains(f) {
            return Err(VolumetricError::OutsideGrid { axis });
        }
    }
    let [x, y, z] = frac;
    let [c1, c2, c3, c4, c5, c6, c7, c8] = *corners;
    Ok(c1 * (1.0 - x) * (1.0 - y) * (1.0 - z)
        + c2 * x * (1.0 - y) * (1.0 - z)
        + c3 * x * y * (1.0 - z)
        + c4 * (1.0 - x) * y * (1.0 - z)
        + c5 * (1.0 - x) * (1.0 - y) * z
        + c6 * x * (1.0 - y) * z
        + c7 * x * y * z
        + c8 * (1.0 - x) * y * z)
}

/// Normalised position of P in the cell whose first corner is P1 (eqs 8.102–8.104, corrected:
/// the denominators are the cell pitches along x, y and z — the printed "P2" in 8.103/8.104
/// cannot be right since P2 differs from P1 only in x). Signed (no absolute value), so a point
/// outside the cell is reported as [`VolumetricError::OutsideGrid`] instead of mirrored.
pub fn cell_fraction(
    p_mm: [f64; 3],
    p1_mm: [f64; 3],
    pitch_mm: [f64; 3],
) -> Result<[f64; 3], VolumetricError> {
    if !(p_mm
        .iter()
        .chain(p1_mm.iter())
        .chain(pitch_mm.iter())
        .all(|v| v.is_finite()))
    {
        return Err(VolumetricError::NonFinite);
    }
    if pitch_mm.iter().any(|&h| h <= 0.0) {
        return Err(VolumetricError::LengthNotPositive);
    }
    let mut f = [0.0; 3];
    for (axis, ((fo, (p, p1)), h)) in f
        .iter_mut()
        .zip(p_mm.iter().zip(p1_mm.iter()))
        .zip(pitch_mm.iter())
        .enumerate()
    {
        let v = (p - p1) / h;
        if !(0.0..=1.0).contains(&v) {
            return Err(VolumetricError::OutsideGrid { axis });
        }
        *fo = v;
    }
    Ok(f)
}

/// A regular 3D compensation grid (Fanuc-style 3D grid-point compensation, §8.2.5): `counts`
/// points along x, y, z from `origin_mm` with `pitch_mm` spacing; values stored x fastest:
/// index = i + nx·(j + ny·k), each an error vector (E_x, E_y, E_z) in µm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid3<'a> {
    /// Position of grid point (0, 0, 0), mm.
    pub origin_mm: [f64; 3],
    /// Grid spacing along x, y, z, mm (> 0).
    pub pitch_mm: [f64; 3],
    /// Number of points along x, y, z (≥ 2 each).
    pub counts: [usize; 3],
    /// Error vectors at the grid points, µm.
    pub values_um: &'a [[f64; 3]],
}

impl Grid3<'_> {
    /// Error vector at P, µm, by eq 8.101 in the cell containing P. Points outside the grid
    /// are an error (no extrapolation).
    pub fn error_at_um(&self, p_mm: [f64; 3]) -> Result<[f64; 3], VolumetricError> {
        let [nx, ny, nz] = self.counts;
        if nx < 2
            || ny < 2
            || nz < 2
            || nx.saturating_mul(ny).saturating_mul(nz) != self.values_um.len()
        {
            return Err(VolumetricError::GridShape);
        }
        if self.pitch_mm.iter().any(|&h| !(h > 0.0)) {
            return Err(VolumetricError::LengthNotPositive);
        }
        if !p_mm
            .iter()
            .chain(self.origin_mm.iter())
            .all(|v| v.is_finite())
        {
            return Err(VolumetricError::NonFinite);
        }
        // cell index and fraction per axis
        let mut cell = [0usize; 3];
        let mut frac = [0.0f64; 3];
        for (axis, (((c, f), n), (p, (o, h)))) in cell
            .iter_mut()
            .zip(frac.iter_mut())
            .zip(self.counts.iter())
            .zip(
                p_mm.iter()
                    .zip(self.origin_mm.iter().zip(self.pitch_mm.iter())),
            )
            .enumerate()
        {
            let t = (p - o) / h;
            let last = (*n - 1) as f64;
            if !(0.0..=last).contains(&t) {
                return Err(VolumetricError::OutsideGrid { axis });
            }
            // the last point belongs to the last cell
            let i = libm::floor(t).min(last - 1.0);
            *c = i as usize;
            *f = t - i;
        }
        let [i, j, k] = cell;
        let at = |di: usize, dj: usize, dk: usize| -> Result<[f64; 3], VolumetricError> {
            self.values_um
                .get((i + di) + nx * ((j + dj) + ny * (k + dk)))
                .copied()
                .ok_or(VolumetricError::GridShape)
        };
        // C1..C8 in the numbering of 8.101
        let c = [
            at(0, 0, 0)?,
            at(1, 0, 0)?,
            at(1, 1, 0)?,
            at(0, 1, 0)?,
            at(0, 0, 1)?,
            at(1, 0, 1)?,
            at(1, 1, 1)?,
            at(0, 1, 1)?,
        ];
        let mut out = [0.0; 3];
        for (comp, o) in out.iter_mut().enumerate() {
            let corners = c.map(|v| v.get(comp).copied().unwrap_or(f64::NAN));
            *o = trilinear(&corners, frac)?;
        }
        Ok(out)
    }
}

/// Thermal interpolation between two maps, eq 8.105 (8.106/8.107 the same; the printed "T_w"
/// of 8.107 is T_n): E(T_u) = (E(T_m) − E(T_n))·(T_u − T_n)/(T_m − T_n) + E(T_n), µm.
/// Valid for T_u between T_n and T_m (inclusive); outside it is an error, not extrapolated.
pub fn thermal_interpolate_um(
    e_m_um: f64,
    t_m_c: f64,
    e_n_um: f64,
    t_n_c: f64,
    t_u_c: f64,
) -> Result<f64, VolumetricError> {
    if !(e_m_um.is_finite()
        && t_m_c.is_finite()
        && e_n_um.is_finite()
        && t_n_c.is_finite()
        && t_u_c.is_finite())
    {
        return Err(VolumetricError::NonFinite);
    }
    if t_m_c == t_n_c {
        return Err(VolumetricError::EqualTemperatures);
    }
    let (lo, hi) = if t_m_c < t_n_c {
        (t_m_c, t_n_c)
    } else {
        (t_n_c, t_m_c)
    };
    if !(lo..=hi).contains(&t_u_c) {
        return Err(VolumetricError::OutsideTemperatureRange);
    }
    Ok((e_m_um - e_n_um) * (t_u_c - t_n_c) / (t_m_c - t_n_c) + e_n_um)
}

/// Piecewise thermal interpolation over ≥ 2 maps (§8.2.9: the change is not linear over a large
/// range, so interpolate between the two neighbouring maps). `maps` = (temperature °C, error
/// µm) in strictly increasing temperature.
pub fn thermal_interpolate_maps_um(
    maps: &[(f64, f64)],
    t_u_c: f64,
) -> Result<f64, VolumetricError> {
    if maps.len() < 2 {
        return Err(VolumetricError::EmptyData);
    }
    if maps.windows(2).any(|w| matches!(w, [a, b] if !(a.0 < b.0))) {
        return Err(VolumetricError::UnsortedTemperatures);
    }
    let pair = maps
        .windows(2)
        .find(|w| matches!(w, [a, b] if a.0 <= t_u_c && t_u_c <= b.0));
    match pair {
        Some([n, m]) => thermal_interpolate_um(m.1, m.0, n.1, n.0, t_u_c),
        _ => {
            if !t_u_c.is_finite() {
                Err(VolumetricError::NonFinite)
            } else {
                Err(VolumetricError::OutsideTemperatureRange)
            }
        }
    }
}

/// A linear axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axis {
    /// X.
    X,
    /// Y.
    Y,
    /// Z.
    Z,
}

/// One compensation table: the error in direction `comp` caused by motion of axis `moving`,
/// i.e. seed 001's D_comp(moving); a pitch table when the two are the same axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TableKind {
    /// The axis whose position indexes the table.
    pub moving: Axis,
    /// The axis whose command is corrected.
    pub comp: Axis,
}

impl TableKind {
    /// True for a pitch (displacement) table D_u(u).
    pub fn is_pitch(&self) -> bool {
        self.moving == self.comp
    }

    /// Fanuc 30i/31i/32i name, `D<moving><comp>` (DXX, DYY, DZZ pitch; DXY = D_y(x), DYX = D_x(y),
    /// DZX = D_x(z), DZY = D_y(z), DXZ = D_z(x), DYZ = D_z(y); spec A.7 with the two "sic"
    /// moving-axis typos of the seed's list corrected).
    pub fn fanuc_name(&self) -> &'static str {
        match (self.moving, self.comp) {
            (Axis::X, Axis::X) => "DXX",
            (Axis::Y, Axis::Y) => "DYY",
            (Axis::Z, Axis::Z) => "DZZ",
            (Axis::X, Axis::Y) => "DXY",
            (Axis::Y, Axis::X) => "DYX",
            (Axis::Z, Axis::X) => "DZX",
            (Axis::Z, Axis::Y) => "DZY",
            (Axis::X, Axis::Z) => "DXZ",
            (Axis::Y, Axis::Z) => "DYZ",
        }
    }
}

/// Controllers of seed 001 §8.4 and which tables each accepts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Controller {
    /// Siemens 840D CEC ("sag") tables: pitch and both straightnesses per axis, a table per
    /// travel direction ($AN_CEC_DIRECTION ±1), values in mm.
    Siemens840D,
    /// Fanuc 30i/31i/32i 128-point option: 3 pitch + 6 straightness tables.
    Fanuc30i,
    /// Heidenhain nonlinear compensation: 3 pitch + 6 straightness (.com files + .cma).
    Heidenhain,
    /// Fagor 8055 cross compensation: 3 pitch + D_x(y), D_x(z), D_y(z) only.
    Fagor8055,
    /// MDSI OpenCNC leadscrew error compensation: pitch only, per direction.
    MdsiOpenCnc,
}

impl Controller {
    /// Whether the controller has a table for `kind`.
    pub fn supports(&self, kind: TableKind) -> bool {
        match self {
            Self::Siemens840D | Self::Fanuc30i | Self::Heidenhain => true,
            Self::Fagor8055 => {
                kind.is_pitch()
                    || matches!(
                        (kind.moving, kind.comp),
                        (Axis::Y, Axis::X) | (Axis::Z, Axis::X) | (Axis::Z, Axis::Y)
                    )
            }
            Self::MdsiOpenCnc => kind.is_pitch(),
        }
    }
}

/// Number of points of an equally spaced table from MIN to MAX with STEP (Siemens
/// $AN_CEC_MIN/MAX/STEP): (MAX − MIN)/STEP intervals + 1. The span must be a whole number of
/// steps (to 1e-9 of a step).
pub fn table_point_count(min_mm: f64, max_mm: f64, step_mm: f64) -> Result<usize, VolumetricError> {
    if !(min_mm.is_finite() && max_mm.is_finite() && step_mm.is_finite()) {
        return Err(VolumetricError::NonFinite);
    }
    if !(step_mm > 0.0 && max_mm > min_mm) {
        return Err(VolumetricError::LengthNotPositive);
    }
    let n = (max_mm - min_mm) / step_mm;
    let r = libm::round(n);
    if libm::fabs(n - r) > 1e-9 || r > 1e6 {
        return Err(VolumetricError::TableSpacing);
    }
    Ok(r as usize + 1)
}

/// Fills a controller compensation table: point i at position MIN + i·STEP gets
/// **−error/1000** (mm; compensation = −error, error given in µm by `error_um_at(position_mm)`).
/// Returns the number of points written; `out_mm` must hold [`table_point_count`] points.
/// Nothing is written if any error value is non-finite.
pub fn fill_compensation_table_mm(
    min_mm: f64,
    max_mm: f64,
    step_mm: f64,
    error_um_at: impl Fn(f64) -> f64,
    out_mm: &mut [f64],
) -> Result<usize, VolumetricError> {
    let n = table_point_count(min_mm, max_mm, step_mm)?;
    let slots = out_mm
        .get_mut(..n)
        .ok_or(VolumetricError::TableTooSmall { needed: n })?;
    let pos = |i: usize| min_mm + i as f64 * step_mm;
    if (0..n).any(|i| !error_um_at(pos(i)).is_finite()) {
        return Err(VolumetricError::NonFinite);
    }
    for (i, o) in slots.iter_mut().enumerate() {
        *o = -error_um_at(pos(i)) * 1e-3;
    }
    Ok(n)
}

/// Linear interpolation of a measured error curve (`positions_mm` strictly increasing, paired
/// with `errors_um`) at `x_mm`, µm. Outside the measured range is an error (no extrapolation).
pub fn curve_value_um(
    positions_mm: &[f64],
    errors_um: &[f64],
    x_mm: f64,
) -> Result<f64, VolumetricError> {
    if positions_mm.len() != errors_um.len() || positions_mm.len() < 2 {
        return Err(VolumetricError::EmptyData);
    }
    if !x_mm.is_finite()
        || positions_mm
            .iter()
            .chain(errors_um.iter())
            .any(|v| !v.is_finite())
    {
        return Err(VolumetricError::NonFinite);
    }
    if positions_mm
        .windows(2)
        .any(|w| matches!(w, [a, b] if !(a < b)))
    {
        return Err(VolumetricError::LengthNotPositive);
    }
    let seg = positions_mm
        .windows(2)
        .zip(errors_um.windows(2))
        .find(|(p, _)| matches!(p, [a, b] if *a <= x_mm && x_mm <= *b));
    match seg {
        Some(([p0, p1], [e0, e1])) => Ok(e0 + (e1 - e0) * (x_mm - p0) / (p1 - p0)),
        _ => Err(VolumetricError::OutsideGrid { axis: 0 }),
    }
}

/// Fills a controller table (MIN..MAX by STEP, see [`table_point_count`]) from a measured error
/// curve (e.g. a vector-method curve of [`super::vector::error_curves_um`]) by linear
/// interpolation: value = −error/1000 mm (compensation = −error). The table range must lie
/// inside the measured range. Nothing is written on error.
pub fn fill_compensation_table_from_curve_mm(
    min_mm: f64,
    max_mm: f64,
    step_mm: f64,
    positions_mm: &[f64],
    errors_um: &[f64],
    out_mm: &mut [f64],
) -> Result<usize, VolumetricError> {
    let n = table_point_count(min_mm, max_mm, step_mm)?;
    // validate every point before writing
    for i in 0..n {
        curve_value_um(positions_mm, errors_um, min_mm + i as f64 * step_mm)?;
    }
    fill_compensation_table_mm(
        min_mm,
        max_mm,
        step_mm,
        |x| curve_value_um(positions_mm, errors_um, x).unwrap_or(f64::NAN),
        out_mm,
    )
}

/// Travel direction a direction-dependent table applies to (Siemens `$AN_CEC_DIRECTION`,
/// MDSI `axLSCompDirPos/Neg`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TravelDirection {
    /// Both directions (one table).
    Both,
    /// Positive travel only.
    Positive,
    /// Negative travel only.
    Negative,
}

impl TravelDirection {
    /// Siemens 840D `$AN_CEC_DIRECTION` code: 0 both, 1 positive, −1 negative (Table 8.3).
    pub fn siemens_code(&self) -> i8 {
        match self {
            Self::Both => 0,
            Self::Positive => 1,
            Self::Negative => -1,
        }
    }
}
