//! Measuring patterns of the thesis (Tables 2.2/2.3, spec seed-002 §3): axis commands, NC
//! blocks (TV-6), sensitive directions (§3.5) and the simulated eccentricity of a pattern on the
//! literal model ([`super::model`]).
//!
//! Eccentricity convention (§3.5, the one that reproduces the thesis's signs): each ΔL sample
//! (µm, positive = bar longer) is a radial deviation on the commanded path; the fit
//! `ΔL ≈ r0 + e1·n1 + e2·n2` by linear least squares gives the eccentricity (e1, e2):
//! - B patterns: n(φ) = (sin φ, cos φ) in the (X, Z) plane, (e1, e2) = (ex, ez);
//! - CR: n(θ) = sign(R_C − L_B)·(cos θ, sin θ), (e1, e2) = (ex, ey);
//! - other C patterns (CA, CT, CX, CY): n(θ) = (cos θ, sin θ), (e1, e2) = (ex, ey).
//!
//! The metrology engineer's fit must use the same directions; r0 is discarded.
use crate::identify::lsq::{DEFAULT_RANK_TOL, GivensLsq, LsqError};

use super::Deviations;
use super::model::{AxisCommand, bar_deviation_um, r_bt_mm, r_ct_mm, t_ball_mm, w_ball_mm};

/// A measuring pattern of Tables 2.2 (B, φ ∈ [0°, 90°], C = 0) and 2.3 (C, θ ∈ [0°, 360°), B = 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BallbarPattern {
    /// B radial: T-ball on a radius-L_B arc about the W-ball.
    Br,
    /// B tangential.
    Bt,
    /// B axial (same motion as BY).
    Ba,
    /// B, bar along X (T-ball stationary at (L_B, 0, Z_C)); used for identification.
    Bx,
    /// B, bar along Y (T-ball stationary at (0, L_B, Z_C)); used for identification.
    By,
    /// B, bar along Z.
    Bz,
    /// C radial (bar along a diameter when R_C < L_B); used for identification.
    Cr,
    /// C tangential.
    Ct,
    /// C axial (bar along Z); used for identification.
    Ca,
    /// C, bar along X.
    Cx,
    /// C, bar along Y.
    Cy,
}

impl BallbarPattern {
    /// True for the B-axis patterns (quarter arc, E_B moves), false for the C-axis ones.
    pub const fn is_b(self) -> bool {
        matches!(
            self,
            BallbarPattern::Br
                | BallbarPattern::Bt
                | BallbarPattern::Ba
                | BallbarPattern::Bx
                | BallbarPattern::By
                | BallbarPattern::Bz
        )
    }
}

/// Set-up lengths of a pattern (mm), thesis §2.2 symbols.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BallbarLengths {
    /// L_B: ball-bar reference length (mm).
    pub l_b_mm: f64,
    /// R_B: B rotation centre → T-ball centre ("tool length", mm).
    pub r_b_mm: f64,
    /// R_C: W-ball distance from the C centreline (mm; C patterns).
    pub r_c_mm: f64,
    /// Z_C: W-ball centre height above the C-table surface (mm).
    pub z_c_mm: f64,
}

/// Why a pattern could not be generated or simulated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PatternError {
    /// A length that must be positive is ≤ 0 or not finite (names which).
    NonPositiveLength {
        /// `"L_B"`, `"R_B"`, `"R_C"`.
        what: &'static str,
    },
    /// An input value is NaN or infinite.
    NonFinite,
    /// CR with R_C = L_B puts the T-ball on the C axis: the sensitive direction is undefined.
    DegenerateRadialPattern,
    /// Fewer samples than the fit needs (B arcs ≥ 3, C circles ≥ 3) or zero NC steps.
    TooFewSamples {
        /// Samples requested.
        samples: usize,
    },
    /// The eccentricity fit failed (singular sampling).
    Fit(LsqError),
}

impl BallbarLengths {
    /// Checks every length: L_B, R_B > 0, R_C > 0 for C patterns, Z_C finite.
    pub fn validate(&self, pattern: BallbarPattern) -> Result<(), PatternError> {
        let pos = |v: f64, what| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(PatternError::NonPositiveLength { what })
            }
        };
        pos(self.l_b_mm, "L_B")?;
        pos(self.r_b_mm, "R_B")?;
        if !pattern.is_b() {
            pos(self.r_c_mm, "R_C")?;
        }
        if !self.z_c_mm.is_finite() {
            return Err(PatternError::NonFinite);
        }
        if pattern == BallbarPattern::Cr && self.r_c_mm == self.l_b_mm {
            return Err(PatternError::DegenerateRadialPattern);
        }
        Ok(())
    }
}

/// Model-frame axis command of `pattern` at angle `angle_rad` (φ for B patterns, θ for C),
/// Tables 2.2 and 2.3 (mm from O_M). Raw equations: inputs are not validated here (see
/// [`BallbarLengths::validate`]; [`nc_block`], [`PatternProgram`] and
/// [`simulate_eccentricity`] validate).
#[inline(never)] // flash: one body for the model's callers
pub fn command(pattern: BallbarPattern, g: &BallbarLengths, angle_rad: f64) -> AxisCommand {
    let (s, c) = (crate::num::sin(angle_rad), crate::num::cos(angle_rad));
    let (lb, rb, rc, zc) = (g.l_b_mm, g.r_b_mm, g.r_c_mm, g.z_c_mm);
    let b = |x, y, z| AxisCommand {
        x_mm: x,
        y_mm: y,
        z_mm: z,
        b_rad: angle_rad,
        c_rad: 0.0,
    };
    let cc = |x, y, z| AxisCommand {
        x_mm: x,
        y_mm: y,
        z_mm: z,
        b_rad: 0.0,
        c_rad: angle_rad,
    };
    match pattern {
        BallbarPattern::Br => b((lb + rb) * s, 0.0, zc + (lb + rb) * c),
        BallbarPattern::Bt => {
            let (rbt, a) = (r_bt_mm(rb, lb), libm::atan2(lb, rb));
            b(
                rbt * crate::num::sin(angle_rad + a),
                0.0,
                zc + rbt * crate::num::cos(angle_rad + a),
            )
        }
        BallbarPattern::Ba | BallbarPattern::By => b(rb * s, lb, zc + rb * c),
        BallbarPattern::Bx => b(lb + rb * s, 0.0, zc + rb * c),
        BallbarPattern::Bz => b(rb * s, 0.0, lb + zc + rb * c),
        BallbarPattern::Cr => cc((rc - lb) * c, (rc - lb) * s, zc + rb),
        BallbarPattern::Ct => {
            let (rct, a) = (r_ct_mm(rc, lb), libm::atan2(lb, rc));
            cc(
                rct * crate::num::cos(angle_rad + a),
                rct * crate::num::sin(angle_rad + a),
                zc + rb,
            )
        }
        BallbarPattern::Ca => cc(rc * c, rc * s, zc + lb + rb),
        BallbarPattern::Cx => cc(lb + rc * c, rc * s, zc + rb),
        BallbarPattern::Cy => cc(rc * c, lb + rc * s, zc + rb),
    }
}

/// Sensitive direction (n1, n2) of `pattern` at `angle_rad` (§3.5; see the module doc).
#[inline(never)] // flash: one body for the model's callers
pub fn sensitive_direction(
    pattern: BallbarPattern,
    g: &BallbarLengths,
    angle_rad: f64,
) -> (f64, f64) {
    let (s, c) = (crate::num::sin(angle_rad), crate::num::cos(angle_rad));
    if pattern.is_b() {
        (s, c)
    } else if pattern == BallbarPattern::Cr && g.r_c_mm < g.l_b_mm {
        (-c, -s)
    } else {
        (c, s)
    }
}

/// Angle (rad) of sample `i` of `samples`: B arcs from 0 to 90° inclusive, C circles
/// `2π·i/samples` (end point excluded so no angle counts twice).
pub fn sample_angle_rad(pattern: BallbarPattern, i: usize, samples: usize) -> f64 {
    if pattern.is_b() {
        core::f64::consts::FRAC_PI_2 * i as f64 / (samples.max(2) - 1) as f64
    } else {
        2.0 * core::f64::consts::PI * i as f64 / samples.max(1) as f64
    }
}

/// Ball mounting offsets (µm): T-ball in the spindle frame (eq 2.20), W-ball in the C frame
/// (clamping shift, eq 2.21).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Mounting {
    /// T-ball offset (x_T, y_T, z_T) in the spindle frame (µm).
    pub t_offset_um: [f64; 3],
    /// W-ball offset (x_W, y_W, z_W) in the C frame (µm).
    pub w_offset_um: [f64; 3],
}

/// Eccentricity of one pattern (µm), §3.5 convention.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Eccentricity {
    /// First component: ex (all patterns).
    pub e1_um: f64,
    /// Second component: ez for B patterns, ey for C patterns.
    pub e2_um: f64,
    /// Radius change r0 (µm; discarded by identification).
    pub r0_um: f64,
    /// RMS of the fit residual (µm): the non-circular part of the trace.
    pub residual_rms_um: f64,
}

/// Simulated eccentricity of `pattern` on the literal model (eqs 2.10–2.17) for deviations
/// `dev`, over `samples` equally spaced angles ([`sample_angle_rad`]), fitted with the §3.5
/// convention. This is the forward map the model-based identification inverts.
#[inline(never)] // flash: one body for the model's callers
pub fn simulate_eccentricity(
    pattern: BallbarPattern,
    g: &BallbarLengths,
    dev: &Deviations,
    mounting: &Mounting,
    samples: usize,
) -> Result<Eccentricity, PatternError> {
    g.validate(pattern)?;
    if !dev.is_finite()
        || !mounting
            .t_offset_um
            .iter()
            .chain(mounting.w_offset_um.iter())
            .all(|v| v.is_finite())
    {
        return Err(PatternError::NonFinite);
    }
    if samples < 3 {
        return Err(PatternError::TooFewSamples { samples });
    }
    let x_mount = if pattern.is_b() { 0.0 } else { g.r_c_mm };
    let mut lsq = GivensLsq::<3>::new();
    for i in 0..samples {
        let a = sample_angle_rad(pattern, i, samples);
        let cmd = command(pattern, g, a);
        let t = t_ball_mm(dev, &cmd, g.r_b_mm, mounting.t_offset_um);
        let w = w_ball_mm(
            dev,
            cmd.c_rad,
            g.z_c_mm,
            g.r_b_mm,
            x_mount,
            mounting.w_offset_um,
        );
        let dl = bar_deviation_um(&t, &w, g.l_b_mm);
        let (n1, n2) = sensitive_direction(pattern, g, a);
        lsq.add_row(&[1.0, n1, n2], dl, 1.0)
            .map_err(PatternError::Fit)?;
    }
    let sol = lsq
        .solve_full_rank(DEFAULT_RANK_TOL)
        .map_err(PatternError::Fit)?;
    let [r0_um, e1_um, e2_um] = sol.x;
    Ok(Eccentricity {
        e1_um,
        e2_um,
        r0_um,
        residual_rms_um: sol.residual_rms,
    })
}

/// Offset from the model frame (Tables 2.2/2.3, origin O_M) to the NC program's frame (mm):
/// NC position = model command + offset. E.g. Fig 4.30 (TV-6) puts the C centreline at NC
/// X = −490, so x_mm = −490, and the BX start (φ = 0) at NC Z = −112.2605, so
/// z_mm = −112.2605 − (Z_C + R_B).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NcOffset {
    /// X offset (mm).
    pub x_mm: f64,
    /// Y offset (mm).
    pub y_mm: f64,
    /// Z offset (mm).
    pub z_mm: f64,
}

/// One G01 block of a pattern program: linear axes in mm, rotary axes in degrees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NcBlock {
    /// X (mm).
    pub x_mm: f64,
    /// Y (mm).
    pub y_mm: f64,
    /// Z (mm).
    pub z_mm: f64,
    /// B (degrees).
    pub b_deg: f64,
    /// C (degrees).
    pub c_deg: f64,
}

/// NC block of `pattern` at angle `angle_deg` (B angle for B patterns, C angle for C
/// patterns): Table 2.2/2.3 command plus `offset`. Validates the geometry and the inputs.
pub fn nc_block(
    pattern: BallbarPattern,
    g: &BallbarLengths,
    offset: &NcOffset,
    angle_deg: f64,
) -> Result<NcBlock, PatternError> {
    g.validate(pattern)?;
    if !(angle_deg.is_finite()
        && offset.x_mm.is_finite()
        && offset.y_mm.is_finite()
        && offset.z_mm.is_finite())
    {
        return Err(PatternError::NonFinite);
    }
    Ok(nc_block_unchecked(pattern, g, offset, angle_deg))
}

fn nc_block_unchecked(
    pattern: BallbarPattern,
    g: &BallbarLengths,
    offset: &NcOffset,
    angle_deg: f64,
) -> NcBlock {
    let cmd = command(pattern, g, angle_deg.to_radians());
    NcBlock {
        x_mm: cmd.x_mm + offset.x_mm,
        y_mm: cmd.y_mm + offset.y_mm,
        z_mm: cmd.z_mm + offset.z_mm,
        b_deg: cmd.b_rad.to_degrees(),
        c_deg: cmd.c_rad.to_degrees(),
    }
}

/// Allocation-free iterator over the `steps + 1` blocks of a pattern program from
/// `start_deg` to `end_deg` (both included; e.g. Fig 4.30: BX 0 → 90° in 324 steps of
/// 0.2778°). Run it reversed (start 90, end 0) for the CCW direction.
#[derive(Clone, Copy, Debug)]
pub struct PatternProgram {
    pattern: BallbarPattern,
    geometry: BallbarLengths,
    offset: NcOffset,
    start_deg: f64,
    end_deg: f64,
    steps: usize,
    next: usize,
}

impl PatternProgram {
    /// Validates the geometry (lengths > 0, finite angles, ≥ 1 step) and builds the program.
    pub fn new(
        pattern: BallbarPattern,
        geometry: BallbarLengths,
        offset: NcOffset,
        start_deg: f64,
        end_deg: f64,
        steps: usize,
    ) -> Result<Self, PatternError> {
        geometry.validate(pattern)?;
        if !(start_deg.is_finite()
            && end_deg.is_finite()
            && offset.x_mm.is_finite()
            && offset.y_mm.is_finite()
            && offset.z_mm.is_finite())
        {
            return Err(PatternError::NonFinite);
        }
        if steps == 0 {
            return Err(PatternError::TooFewSamples { samples: 0 });
        }
        Ok(Self {
            pattern,
            geometry,
            offset,
            start_deg,
            end_deg,
            steps,
            next: 0,
        })
    }
}

impl Iterator for PatternProgram {
    type Item = NcBlock;

    fn next(&mut self) -> Option<NcBlock> {
        if self.next > self.steps {
            return None;
        }
        let f = self.next as f64 / self.steps as f64;
        self.next += 1;
        let a = self.start_deg + (self.end_deg - self.start_deg) * f;
        Some(nc_block_unchecked(
            self.pattern,
            &self.geometry,
            &self.offset,
            a,
        ))
    }
}
