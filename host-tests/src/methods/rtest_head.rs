//! R-test head (seed 003, DESIGN §1): three displacement sensors (LVDTs with flat tips) around
//! a precision sphere, read as three LVDT channels of the acquisition and combined into the
//! sphere-centre displacement vector the R-test identification takes
//! (`methods::rtest::RtestSample::reading_um`).
//!
//! Model: a flat tip touching the sphere reads the component of the sphere-centre displacement
//! along its measuring direction, `r_k = n_k · q` (k = 1…3, `n_k` unit vectors in the head
//! frame, `q` in µm; the sign of `n_k` is the direction in which the sensor's reading grows).
//! With `N` the matrix whose rows are `n_k`, `q = N⁻¹ r`. The flat-tip model is exact for
//! a displacement along the tip's axis and first-order for a sideways one (the tip face
//! stays tangent to the sphere), which is the R-test's measuring principle (seed 003 §2).
//!
//! Written out here (nine multiply-adds per sample with the inverse precomputed) rather than
//! taken from nalgebra: the per-sample path stays f32 and allocation-free, and the
//! constructor needs only a 3×3 cofactor inverse.

use ballpod::acquisition::lvdt::{LvdtCalibration, LvdtReading, LvdtStatus};

/// cos of the tilt of each default sensor axis from the head axis: 1/√3 (54.7356°).
const COS_TILT: f32 = 0.577_350_26;
/// sin of that tilt: √(2/3).
const SIN_TILT: f32 = 0.816_496_6;

/// Why a sensor arrangement was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RtestHeadError {
    /// Sensor `k`'s direction is not a unit vector (|‖n_k‖ − 1| > 1e-3) or not finite.
    NotUnit {
        /// Sensor index 0…2.
        sensor: usize,
    },
    /// The three directions are (nearly) coplanar: |det N| < 0.05, i.e. some displacement
    /// would be read with more than ~20× amplification of the sensor noise.
    Singular,
}

/// The head: three sensor directions and their precomputed inverse.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RtestHead {
    directions: [[f32; 3]; 3],
    inverse: [[f32; 3]; 3],
}

/// One combined reading of the head.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeadReading {
    /// Sphere-centre displacement in the head frame, µm (zero when not valid).
    pub displacement_um: [f32; 3],
    /// Each sensor's own status.
    pub status: [LvdtStatus; 3],
}

impl HeadReading {
    /// True when all three sensors read inside their calibrated stroke with a healthy signal.
    pub fn is_valid(&self) -> bool {
        self.status.iter().all(|s| *s == LvdtStatus::Ok)
    }
}

impl RtestHead {
    /// Default arrangement: three mutually orthogonal sensors, each tilted 54.7356°
    /// (arccos 1/√3) from the head's Z axis, 120° apart in azimuth starting at +X — the
    /// usual R-test head layout, which gives every direction the same sensitivity (N is
    /// orthonormal, so `N⁻¹ = Nᵀ` and the noise of `q` equals the sensors' noise).
    pub const DEFAULT_DIRECTIONS: [[f32; 3]; 3] = [
        [SIN_TILT, 0.0, COS_TILT],
        [-0.5 * SIN_TILT, 0.866_025_4 * SIN_TILT, COS_TILT],
        [-0.5 * SIN_TILT, -0.866_025_4 * SIN_TILT, COS_TILT],
    ];

    /// A head with sensor measuring directions `directions` (unit vectors, head frame).
    pub fn new(directions: [[f32; 3]; 3]) -> Result<Self, RtestHeadError> {
        for (sensor, n) in directions.iter().enumerate() {
            let norm2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
            if !norm2.is_finite() || libm::fabsf(ballpod::num::sqrtf(norm2) - 1.0) > 1e-3 {
                return Err(RtestHeadError::NotUnit { sensor });
            }
        }
        let [a, b, c] = directions;
        // Cofactor inverse: columns of N⁻¹ are (b×c, c×a, a×b) / det.
        let cross = |u: [f32; 3], v: [f32; 3]| {
            [
                u[1] * v[2] - u[2] * v[1],
                u[2] * v[0] - u[0] * v[2],
                u[0] * v[1] - u[1] * v[0],
            ]
        };
        let (bc, ca, ab) = (cross(b, c), cross(c, a), cross(a, b));
        let det = a[0] * bc[0] + a[1] * bc[1] + a[2] * bc[2];
        if !(libm::fabsf(det) >= 0.05) {
            return Err(RtestHeadError::Singular);
        }
        let inverse = [
            [bc[0] / det, ca[0] / det, ab[0] / det],
            [bc[1] / det, ca[1] / det, ab[1] / det],
            [bc[2] / det, ca[2] / det, ab[2] / det],
        ];
        Ok(Self {
            directions,
            inverse,
        })
    }

    /// The sensor measuring directions (rows of N), head frame.
    pub fn directions(&self) -> [[f32; 3]; 3] {
        self.directions
    }

    /// Sphere-centre displacement `q = N⁻¹ r` (µm, head frame) from the three sensor
    /// displacements `readings_um` (µm).
    pub fn displacement_um(&self, readings_um: [f32; 3]) -> [f32; 3] {
        self.inverse
            .map(|row| row[0] * readings_um[0] + row[1] * readings_um[1] + row[2] * readings_um[2])
    }

    /// Combines three demodulated LVDT channels under one calibration `cal` (a head's
    /// sensors are matched; per-sensor calibrations would be a list of three): each channel
    /// to µm with its status, then [`displacement_um`](Self::displacement_um). An invalid
    /// channel (open, over-range) makes the whole reading invalid and its displacement zero —
    /// one sensor's clamped value would corrupt all three components.
    pub fn read(&self, cal: &LvdtCalibration, channels: [Option<LvdtReading>; 3]) -> HeadReading {
        let mut status = [LvdtStatus::Open; 3];
        let mut r = [0.0f32; 3];
        for ((st, x), ch) in status.iter_mut().zip(r.iter_mut()).zip(channels.iter()) {
            if let Some(reading) = ch {
                (*x, *st) = cal.displacement_um(reading);
            }
        }
        let head = HeadReading {
            displacement_um: [0.0; 3],
            status,
        };
        if head.is_valid() {
            HeadReading {
                displacement_um: self.displacement_um(r),
                ..head
            }
        } else {
            head
        }
    }
}

impl Default for RtestHead {
    /// The head with [`RtestHead::DEFAULT_DIRECTIONS`] (N orthonormal, so N⁻¹ = Nᵀ).
    fn default() -> Self {
        let n = Self::DEFAULT_DIRECTIONS;
        Self {
            directions: n,
            inverse: [
                [n[0][0], n[1][0], n[2][0]],
                [n[0][1], n[1][1], n[2][1]],
                [n[0][2], n[1][2], n[2][2]],
            ],
        }
    }
}
