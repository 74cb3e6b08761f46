//! What an arc supports: which ball-bar diagnoses a run's angular coverage can determine, the
//! reason where it cannot, when a diagnosis is named as a fault, and each fault's share of the
//! circular deviation G (the ranking a report leads with).
//!
//! Rules (Ballbar 20 reports neither scale nor straightness from a partial arc; we follow it and
//! extend it to the cyclic error, whose orders are orthogonal only on the full circle):
//! - every diagnosis needs bins in all four quadrants ([`super::IsoError::NotFullCircle`]);
//! - squareness: that alone (its u grows as the arc shrinks);
//! - scale mismatch, straightness, cyclic error, lateral play: a full circle (no gap wider
//!   than [`FULL_CIRCLE_GAP_DEG`]);
//! - a reversal point's step: the arc crosses it ([`REVERSAL_SIDE_DEG`] each side, half covered);
//!   an axis's mean step: both of its points crossed.
//!
//! A diagnosis that is not determinable stays in the joint fit (so it does not leak into the
//! others) but is never reported as a number: its result stays invalid and the reason is
//! [`NotDeterminable::as_str`].

use super::diagnostics::{Diagnosed, Diagnostics};
use super::{Bin, Direction};

/// The widest gap of empty bins a full circle may have, degrees.
pub const FULL_CIRCLE_GAP_DEG: f32 = 10.0;

/// A reversal point is crossed when at least half of the bins within this angle on each side
/// of it hold samples, degrees.
pub const REVERSAL_SIDE_DEG: f32 = 20.0;

/// A linear fault (squareness, scale mismatch, a reversal step, straightness) is named when it
/// is at least this many standard uncertainties (its noise's and the centre's in quadrature)
/// from zero: white noise passes one of the ten with probability ≈ 10 × 0.27 % ≈ 2.7 %.
/// The cyclic error keeps [`super::CYCLIC_SIGNIFICANCE`] (a maximum over 13 orders).
pub const FAULT_SIGNIFICANCE: f32 = 3.0;

/// The angular coverage of one run (or, [`ArcSupport::both`], of the two directions).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ArcSupport {
    /// Bins in every quadrant of the plane.
    pub quadrants: bool,
    /// No gap of empty bins wider than [`FULL_CIRCLE_GAP_DEG`].
    pub full_circle: bool,
    /// Each reversal point crossed, in angle order: u at 0° (its + end), v at 90°, u at 180°,
    /// v at 270°.
    pub reversal_crossed: [bool; 4],
}

impl ArcSupport {
    /// The coverage of the angular `bins` (`BINS` from +u, a multiple of 4).
    pub(super) fn of(bins: &[Bin]) -> Self {
        let n = bins.len();
        let per_q = (n / 4).max(1);
        let filled = |i: usize| bins.get(i % n.max(1)).is_some_and(|b| b.n > 0);
        let mut quadrants = [false; 4];
        let mut gap = 0usize;
        let mut widest = 0usize;
        // twice round, so a gap across the 0° bin is counted whole
        for i in 0..2 * n {
            if filled(i) {
                if let Some(q) = quadrants.get_mut((i % n.max(1)) / per_q) {
                    *q = true;
                }
                gap = 0;
            } else {
                gap += 1;
                widest = widest.max(gap.min(n));
            }
        }
        let bins_per_deg = n as f32 / 360.0;
        let side = ((REVERSAL_SIDE_DEG * bins_per_deg) as usize).max(1);
        let crossed = |p: usize| {
            let edge = p * per_q + n;
            let before = (1..=side).filter(|k| filled(edge - k)).count();
            let after = (0..side).filter(|k| filled(edge + k)).count();
            2 * before >= side && 2 * after >= side
        };
        Self {
            quadrants: quadrants.iter().all(|q| *q),
            full_circle: (widest as f32) <= FULL_CIRCLE_GAP_DEG * bins_per_deg,
            reversal_crossed: [0, 1, 2, 3].map(crossed),
        }
    }

    /// What both runs support (each diagnosis is the mean of the two directions').
    pub fn both(&self, other: &Self) -> Self {
        let mut crossed = self.reversal_crossed;
        for (c, o) in crossed.iter_mut().zip(other.reversal_crossed) {
            *c &= o;
        }
        Self {
            quadrants: self.quadrants && other.quadrants,
            full_circle: self.full_circle && other.full_circle,
            reversal_crossed: crossed,
        }
    }

    /// Whether `which` is determinable from this coverage, or why not.
    pub fn determinable(&self, which: Diagnosis) -> Result<(), NotDeterminable> {
        use Diagnosis as D;
        if !self.quadrants {
            return Err(NotDeterminable::NotEveryQuadrant);
        }
        let crossed = |points: &[usize]| {
            let all = points
                .iter()
                .all(|p| self.reversal_crossed.get(*p).copied().unwrap_or(false));
            if all {
                Ok(())
            } else {
                Err(NotDeterminable::ReversalNotCrossed)
            }
        };
        match which {
            D::Squareness | D::Radius => Ok(()),
            D::ScaleMismatch
            | D::Cyclic
            | D::StraightnessU
            | D::StraightnessV
            | D::LateralPlayU
            | D::LateralPlayV => {
                if self.full_circle {
                    Ok(())
                } else {
                    Err(NotDeterminable::NeedsFullCircle)
                }
            }
            D::ReversalU => crossed(&[0, 2]),
            D::ReversalV => crossed(&[1, 3]),
            D::ReversalUPos => crossed(&[0]),
            D::ReversalVPos => crossed(&[1]),
            D::ReversalUNeg => crossed(&[2]),
            D::ReversalVNeg => crossed(&[3]),
        }
    }
}

/// Why a diagnosis is not determinable from the runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NotDeterminable {
    /// The diagnoses are the mean of the latest complete CCW and CW runs: one is missing.
    NeedsBothDirections,
    /// A direction has no samples in some quadrant of the plane (or has not run).
    NotEveryQuadrant,
    /// Scale mismatch, straightness and the cyclic error need a full circle.
    NeedsFullCircle,
    /// The arcs do not cross the reversal point (both sides of it, in both directions).
    ReversalNotCrossed,
    /// The next run began before the run's job read its samples about the reversal points
    /// (reversal spikes: the job slot was busy with a longer job).
    SamplesReplaced,
    /// An oscillation's frequency: no oscillation of that kind is named on either axis.
    NoOscillation,
}

impl NotDeterminable {
    /// The reason, as the protocols state it (after the result's name).
    pub const fn as_str(self) -> &'static str {
        match self {
            Self::NeedsBothDirections => {
                " not determinable yet: needs the latest CCW and CW runs, both complete"
            }
            Self::NotEveryQuadrant => {
                " not determinable: both directions need samples in all four quadrants"
            }
            Self::NeedsFullCircle => " not determinable from a partial arc: needs a full circle",
            Self::ReversalNotCrossed => {
                " not determinable: the arcs do not cross that reversal point"
            }
            Self::SamplesReplaced => {
                " not determinable: the next run began before the last run's samples were read; run that direction again"
            }
            Self::NoOscillation => " not determinable: none is named",
        }
    }
}

/// A ball-bar diagnosis (its discriminant indexes [`Diagnostics::values`] and the columns of
/// [`Diagnostics::centre_moves`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Diagnosis {
    /// Out-of-squareness of u and v, µrad.
    Squareness = 0,
    /// Scale mismatch k_u − k_v, µm/m.
    ScaleMismatch = 1,
    /// Mean reversal step of u (its two points), µm.
    ReversalU = 2,
    /// Mean reversal step of v, µm.
    ReversalV = 3,
    /// Cyclic error amplitude, µm.
    Cyclic = 4,
    /// Reversal step of u at its + end (θ = 0°), µm.
    ReversalUPos = 5,
    /// Reversal step of v at its + end (θ = 90°), µm.
    ReversalVPos = 6,
    /// Reversal step of u at its − end (θ = 180°), µm.
    ReversalUNeg = 7,
    /// Reversal step of v at its − end (θ = 270°), µm.
    ReversalVNeg = 8,
    /// Straightness of u over the test diameter (its path's bow in v), µm.
    StraightnessU = 9,
    /// Straightness of v over the test diameter (its path's bow in u), µm.
    StraightnessV = 10,
    /// The radius change r0 of the joint fit, µm: R·(k_u + k_v)/2 plus the bar's length error
    /// (every fault's shape fitted alongside, so a partial arc reads it without the others'
    /// bias; the mean scale of the plane's axes, [`crate::app`]'s `scale_mean`).
    Radius = 11,
    /// Lateral play of u's carriage across its guideway, switching with u's direction, µm
    /// ([`CircularTest::lateral_play`](super::CircularTest::lateral_play): from the difference of the two directions; not a column of one
    /// direction's fit, where it reads NaN).
    LateralPlayU = 12,
    /// Lateral play of v's carriage, µm.
    LateralPlayV = 13,
}

/// Number of [`Diagnosis`] kinds.
pub const DIAGNOSES: usize = 14;

impl Diagnosis {
    /// Every diagnosis, in discriminant order.
    pub const ALL: [Diagnosis; DIAGNOSES] = [
        Self::Squareness,
        Self::ScaleMismatch,
        Self::ReversalU,
        Self::ReversalV,
        Self::Cyclic,
        Self::ReversalUPos,
        Self::ReversalVPos,
        Self::ReversalUNeg,
        Self::ReversalVNeg,
        Self::StraightnessU,
        Self::StraightnessV,
        Self::Radius,
        Self::LateralPlayU,
        Self::LateralPlayV,
    ];

    /// The reversal point diagnoses, in angle order (0°, 90°, 180°, 270°).
    pub const REVERSAL_POINTS: [Diagnosis; 4] = [
        Self::ReversalUPos,
        Self::ReversalVPos,
        Self::ReversalUNeg,
        Self::ReversalVNeg,
    ];
}

/// A machine fault the diagnoses rank by its share of G ([`Diagnostics::share_of_g`]); the bit
/// of [`Diagnostics::named_faults`] is `1 << discriminant`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Fault {
    /// Out-of-squareness.
    Squareness = 0,
    /// Scale mismatch.
    ScaleMismatch = 1,
    /// Reversal steps (backlash, lost motion) of u.
    ReversalU = 2,
    /// Reversal steps of v.
    ReversalV = 3,
    /// Straightness of u.
    StraightnessU = 4,
    /// Straightness of v.
    StraightnessV = 5,
    /// Cyclic error.
    Cyclic = 6,
    /// Lateral play of u.
    LateralPlayU = 7,
    /// Lateral play of v.
    LateralPlayV = 8,
}

impl Fault {
    /// Every fault, in discriminant order.
    pub const ALL: [Fault; 9] = [
        Self::Squareness,
        Self::ScaleMismatch,
        Self::ReversalU,
        Self::ReversalV,
        Self::StraightnessU,
        Self::StraightnessV,
        Self::Cyclic,
        Self::LateralPlayU,
        Self::LateralPlayV,
    ];

    /// The diagnoses that make up the fault, the one whose determinability decides its share
    /// first (a reversal's: its mean, then its two points).
    pub const fn diagnoses(self) -> &'static [Diagnosis] {
        use Diagnosis as D;
        match self {
            Self::Squareness => &[D::Squareness],
            Self::ScaleMismatch => &[D::ScaleMismatch],
            Self::ReversalU => &[D::ReversalU, D::ReversalUPos, D::ReversalUNeg],
            Self::ReversalV => &[D::ReversalV, D::ReversalVPos, D::ReversalVNeg],
            Self::StraightnessU => &[D::StraightnessU],
            Self::StraightnessV => &[D::StraightnessV],
            Self::Cyclic => &[D::Cyclic],
            Self::LateralPlayU => &[D::LateralPlayU],
            Self::LateralPlayV => &[D::LateralPlayV],
        }
    }
}

impl Diagnostics {
    /// The estimate of `which` if the runs' coverage determines it, else why not.
    pub fn determined(&self, which: Diagnosis) -> Result<Diagnosed, NotDeterminable> {
        self.support.determinable(which).map(|()| self.get(which))
    }

    /// Whether `which` is named as a fault: determinable and at least [`FAULT_SIGNIFICANCE`]
    /// (the cyclic error [`super::CYCLIC_SIGNIFICANCE`]) standard uncertainties from zero,
    /// the noise's and the centre's in quadrature.
    pub fn is_named(&self, which: Diagnosis) -> bool {
        let Ok(d) = self.determined(which) else {
            return false;
        };
        let u =
            crate::num::sqrtf(d.std_uncertainty * d.std_uncertainty + d.centre_um * d.centre_um);
        let k = if which == Diagnosis::Cyclic {
            super::CYCLIC_SIGNIFICANCE
        } else {
            FAULT_SIGNIFICANCE
        };
        let v = libm::fabsf(d.value);
        v.is_finite() && v > 0.0 && v >= k * u
    }

    /// The faults named ([`Self::is_named`] for any of their diagnoses), bit `1 << Fault as u8`.
    pub fn named_faults(&self) -> u32 {
        Fault::ALL
            .iter()
            .filter(|f| f.diagnoses().iter().any(|d| self.is_named(*d)))
            .fold(0, |m, f| m | 1 << (*f as u8))
    }

    /// `fault`'s share of the circular deviation G, µm: the peak-to-valley its signature alone
    /// gives the profile about the least-squares circle on radius `radius_mm`, with u (a
    /// share scales with |value|, so u is the value's u times the same factor) — squareness
    /// S·R, scale mismatch Δk·R (µm/m × m), a reversal the larger |B| of its two points, a
    /// straightness |s|/2 (its sin 3θ/4 part; the sin θ part moves the circle), a cyclic
    /// error twice its amplitude, a lateral play |p|/2 (its cusp (p/2)·|sin θ|: 0 at the
    /// axis's reversal points, p/2 at the other axis's). `None` where the fault's diagnosis is not determinable (a
    /// reversal: either point). Shares do not add up to G: the signatures overlap.
    pub fn share_of_g(&self, fault: Fault, radius_mm: f32) -> Option<Diagnosed> {
        use Diagnosis as D;
        let scaled = |which: Diagnosis, k: f32| {
            self.determined(which).ok().map(|d| Diagnosed {
                value: libm::fabsf(d.value) * k,
                std_uncertainty: d.std_uncertainty * k,
                centre_um: d.centre_um * k,
            })
        };
        let per_m = radius_mm * 1e-3;
        match fault {
            Fault::Squareness => scaled(D::Squareness, per_m),
            Fault::ScaleMismatch => scaled(D::ScaleMismatch, per_m),
            Fault::StraightnessU => scaled(D::StraightnessU, 0.5),
            Fault::StraightnessV => scaled(D::StraightnessV, 0.5),
            Fault::Cyclic => scaled(D::Cyclic, 2.0),
            Fault::LateralPlayU => scaled(D::LateralPlayU, 0.5),
            Fault::LateralPlayV => scaled(D::LateralPlayV, 0.5),
            Fault::ReversalU | Fault::ReversalV => {
                let (pos, neg) = if fault == Fault::ReversalU {
                    (D::ReversalUPos, D::ReversalUNeg)
                } else {
                    (D::ReversalVPos, D::ReversalVNeg)
                };
                let (a, b) = (scaled(pos, 1.0)?, scaled(neg, 1.0)?);
                Some(if a.value >= b.value { a } else { b })
            }
        }
    }
}

impl<const BINS: usize> super::CircularTest<BINS> {
    /// What the run in direction `d` supports (its angular coverage).
    pub fn support(&self, d: Direction) -> ArcSupport {
        ArcSupport::of(&self.run(d).bins)
    }
}
