//! Measuring-pattern geometry: the plane of a circular pattern, its centre, and the sensitive
//! direction n of the bar at a commanded position (seed 002 §3.5).
//!
//! n is the unit vector from the pattern centre to the position, in the pattern plane, times the
//! pattern's sign. It is computed from the geometry (a difference, a hardware square root and a
//! division: no trigonometry per sample):
//! - a circle about the socket (ISO 230-4): centre = socket, n radial;
//! - seed 002 CR/CA: centre = the C-axis centre, positions = the commanded T-ball (spindle)
//!   positions; n then *is* sign(R_C − L_B)·(cos θ, sin θ) of seed 002 §3.5 with
//!   [`Sensitivity::Outward`] (the CR T-ball sits on the far side of the centre when R_C < L_B);
//! - the BX/BY arcs: centre = the commanded (X,Z) arc centre, n = (sin φ, cos φ);
//! - [`Sensitivity::Inward`] flips n, for patterns described from the other ball.

use crate::acquisition::MAX_AXES;

/// The plane of a pattern: its first (u) and second (v) machine linear axis. θ is measured from
/// +u towards +v; "counter-clockwise" (CCW) means θ increasing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Plane {
    /// u = X, v = Y (C patterns, XY circles).
    XY,
    /// u = X, v = Z (B patterns: n = (sin φ, cos φ) = (n_x, n_z)).
    XZ,
    /// u = Y, v = Z.
    YZ,
    /// u = Z, v = X (ISO 230-4's ZX plane: counter-clockwise is positive about +Y).
    ZX,
}

impl Plane {
    /// (u, v) machine coordinates of `axes`, mm.
    #[inline(always)]
    pub fn uv(self, axes: &[f32; MAX_AXES]) -> (f32, f32) {
        let [x, y, z, _, _] = *axes;
        match self {
            Plane::XY => (x, y),
            Plane::XZ => (x, z),
            Plane::YZ => (y, z),
            Plane::ZX => (z, x),
        }
    }
}

/// Direction of a run along its pattern: counter-clockwise = the pattern angle θ increasing
/// (from +u towards +v; for the C circles C increasing; for the seed 002 B arcs, in the XZ plane
/// with n = (sin φ, cos φ), θ = 90° − φ: B 90° → 0° — ISO 230-4's ZX plane, u = Z, would call
/// that turn clockwise).
/// The one direction type of the pod: metrology, the application, both protocols, the logs and
/// replay use it and its [`name`](Direction::name).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u8)]
pub enum Direction {
    /// Counter-clockwise: θ increasing (code 0).
    #[default]
    Ccw = 0,
    /// Clockwise: θ decreasing (code 1).
    Cw = 1,
}

impl Direction {
    /// Both directions, in code order.
    pub const ALL: [Direction; 2] = [Direction::Ccw, Direction::Cw];

    /// The name: `"CCW"` or `"CW"`.
    pub const fn name(self) -> &'static str {
        match self {
            Direction::Ccw => "CCW",
            Direction::Cw => "CW",
        }
    }

    /// The direction of a name, in any letter case.
    pub fn from_name(name: &[u8]) -> Option<Self> {
        Self::ALL
            .into_iter()
            .find(|d| d.name().as_bytes().eq_ignore_ascii_case(name))
    }

    /// The direction of a code (0 CCW, 1 CW).
    pub const fn from_u8(v: u8) -> Option<Self> {
        match v {
            0 => Some(Direction::Ccw),
            1 => Some(Direction::Cw),
            _ => None,
        }
    }

    /// +1 for CCW, −1 for CW.
    pub const fn sign(self) -> f64 {
        match self {
            Direction::Ccw => 1.0,
            Direction::Cw => -1.0,
        }
    }
}

/// Sign of the sensitive direction relative to centre → position.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sensitivity {
    /// n points from the centre to the commanded position (ΔL > 0 moves the path outward).
    Outward,
    /// n points from the position to the centre (seed 002 CR with R_C < L_B).
    Inward,
}

/// Geometry of a circular measuring pattern.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArcGeometry {
    /// Plane of the pattern.
    pub plane: Plane,
    /// Centre of the commanded circle or arc, u coordinate, mm (machine coordinates).
    pub centre_u_mm: f32,
    /// Centre of the commanded circle or arc, v coordinate, mm.
    pub centre_v_mm: f32,
    /// Sign of n.
    pub sensitivity: Sensitivity,
}

impl Sensitivity {
    /// +1 outward, −1 inward: n = sign · (p − c)/|p − c|.
    pub const fn sign(self) -> f32 {
        match self {
            Sensitivity::Outward => 1.0,
            Sensitivity::Inward => -1.0,
        }
    }
}

impl ArcGeometry {
    /// The sensitive unit direction n = ±(p − c)/|p − c| in the pattern plane at the axis
    /// positions `axes` (mm), or `None` if the position is at the centre (|p − c| < 1 µm) or not
    /// finite. The difference p − c is formed first so that only the deviation (≤ the radius) is
    /// scaled: f32 keeps n to ~1e-7.
    #[inline]
    pub fn direction(&self, axes: &[f32; MAX_AXES]) -> Option<[f32; 2]> {
        self.direction_and_radius(axes).map(|(n, _)| n)
    }

    /// [`Self::direction`] and the position's distance |p − c| from the centre, mm.
    #[inline]
    pub fn direction_and_radius(&self, axes: &[f32; MAX_AXES]) -> Option<([f32; 2], f32)> {
        let (u, v) = self.plane.uv(axes);
        let du = u - self.centre_u_mm;
        let dv = v - self.centre_v_mm;
        let r2 = du * du + dv * dv;
        // also false for NaN
        if !(r2 > 1e-6 && r2 < f32::INFINITY) {
            return None;
        }
        let r = crate::num::sqrtf(r2);
        let inv = self.sensitivity.sign() / r;
        Some(([du * inv, dv * inv], r))
    }
}
