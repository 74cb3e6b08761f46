//! Conformance decisions that respect the measurement uncertainty (ISO 14253-1:2017 §5, the
//! default rule): conformance is proven only when the value lies inside the specification zone
//! by more than its expanded uncertainty U, non-conformance only when it lies outside by more
//! than U; in between the measurement decides nothing.

use serde::{Deserialize, Serialize};

/// A figure's specification zone, in the figure's unit; a side left `None` is open (a
/// circularity G has only an upper limit).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Tolerance {
    /// Lower specification limit.
    pub lower: Option<f64>,
    /// Upper specification limit.
    pub upper: Option<f64>,
}

/// What a measured value with its expanded uncertainty proves about a [`Tolerance`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Decision {
    /// Inside the zone by at least U on every limited side: conformance is proven.
    Conforms,
    /// Outside the zone by more than U: non-conformance is proven.
    DoesNotConform,
    /// Within U of a limit: neither is proven (the uncertainty range).
    Undecided,
    /// The figure has no stated uncertainty: nothing is proven (the rule needs U).
    NoUncertainty,
    /// The tolerance limits nothing (both sides open) or its lower limit exceeds its upper.
    NoTolerance,
}

impl Decision {
    /// The words a report prints.
    pub fn words(self) -> &'static str {
        match self {
            Self::Conforms => "conforms",
            Self::DoesNotConform => "does not conform",
            Self::Undecided => "undecided (within U of a limit)",
            Self::NoUncertainty => "not decided: no uncertainty stated",
            Self::NoTolerance => "no tolerance set",
        }
    }
}

/// The decision for `value` with expanded uncertainty `expanded_u` (same unit, k·u; `None` or
/// not finite: not stated) against `tol` (ISO 14253-1:2017 §5.2, §5.3).
pub fn decide(value: f64, expanded_u: Option<f64>, tol: Tolerance) -> Decision {
    if tol.lower.is_none() && tol.upper.is_none() {
        return Decision::NoTolerance;
    }
    if let (Some(l), Some(h)) = (tol.lower, tol.upper)
        && l > h
    {
        return Decision::NoTolerance;
    }
    let Some(u) = expanded_u.filter(|u| u.is_finite() && *u >= 0.0) else {
        return Decision::NoUncertainty;
    };
    let outside =
        tol.upper.is_some_and(|h| value - u > h) || tol.lower.is_some_and(|l| value + u < l);
    if outside {
        return Decision::DoesNotConform;
    }
    let inside =
        tol.upper.is_none_or(|h| value + u <= h) && tol.lower.is_none_or(|l| value - u >= l);
    if inside {
        Decision::Conforms
    } else {
        Decision::Undecided
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const G: Tolerance = Tolerance {
        lower: None,
        upper: Some(10.0),
    };

    /// ISO 14253-1:2017 Figure 4's zones for an upper limit of 10 and U = 1.
    #[test]
    fn the_three_zones_of_an_upper_limit() {
        assert_eq!(decide(8.5, Some(1.0), G), Decision::Conforms);
        assert_eq!(decide(9.0, Some(1.0), G), Decision::Conforms);
        assert_eq!(decide(9.5, Some(1.0), G), Decision::Undecided);
        assert_eq!(decide(10.5, Some(1.0), G), Decision::Undecided);
        assert_eq!(decide(11.5, Some(1.0), G), Decision::DoesNotConform);
        assert_eq!(decide(8.5, None, G), Decision::NoUncertainty);
        assert_eq!(decide(8.5, Some(f64::NAN), G), Decision::NoUncertainty);
    }

    #[test]
    fn a_two_sided_zone_and_bad_tolerances() {
        let t = Tolerance {
            lower: Some(-5.0),
            upper: Some(5.0),
        };
        assert_eq!(decide(0.0, Some(2.0), t), Decision::Conforms);
        assert_eq!(decide(-4.0, Some(2.0), t), Decision::Undecided);
        assert_eq!(decide(-7.5, Some(2.0), t), Decision::DoesNotConform);
        // U wider than the zone: nothing is ever proven conforming
        assert_eq!(decide(0.0, Some(6.0), t), Decision::Undecided);
        assert_eq!(
            decide(0.0, Some(1.0), Tolerance::default()),
            Decision::NoTolerance
        );
        let upside_down = Tolerance {
            lower: Some(1.0),
            upper: Some(0.0),
        };
        assert_eq!(decide(0.5, Some(0.1), upside_down), Decision::NoTolerance);
    }
}
