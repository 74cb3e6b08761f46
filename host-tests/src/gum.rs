//! The expanded uncertainty of a combined standard uncertainty whose inputs are Type A
//! estimates with few degrees of freedom (GUM, JCGM 100:2008, Annex G): the effective degrees of
//! freedom by the Welch–Satterthwaite formula (G.2b) and the coverage factor from Student's t
//! for the pod's coverage probability, 95.45 % (k = 2 for a u known exactly). Written here, not
//! taken from a crate: a table of 27 numbers and one sum (statrs would bring its own nalgebra).

/// Student's t for a two-sided 95.45 % interval (GUM Table G.2, to three decimals: the values
/// of `scipy.stats.t.ppf(0.97725, ν)`), by degrees of freedom ν.
const T_9545: [(u32, f64); 27] = [
    (1, 13.968),
    (2, 4.527),
    (3, 3.307),
    (4, 2.869),
    (5, 2.649),
    (6, 2.517),
    (7, 2.429),
    (8, 2.366),
    (9, 2.320),
    (10, 2.284),
    (11, 2.255),
    (12, 2.231),
    (13, 2.212),
    (14, 2.195),
    (15, 2.181),
    (16, 2.169),
    (17, 2.158),
    (18, 2.149),
    (19, 2.140),
    (20, 2.133),
    (25, 2.105),
    (30, 2.087),
    (35, 2.074),
    (40, 2.064),
    (45, 2.057),
    (50, 2.051),
    (100, 2.025),
];

/// The coverage factor k for 95.45 % at `nu` effective degrees of freedom (`None`: infinite,
/// k = 2). A ν between the table's entries takes the lower entry (GUM G.4.1: truncate to the
/// next lower integer; above 20 the next lower tabulated ν, which is conservative; from 100 on
/// 2.025); ν < 1 has no coverage factor (`None`).
pub fn coverage_factor(nu: Option<f64>) -> Option<f64> {
    let Some(nu) = nu else {
        return Some(2.0);
    };
    if nu.is_nan() || nu < 1.0 {
        return None;
    }
    Some(
        T_9545
            .iter()
            .take_while(|(n, _)| f64::from(*n) <= nu)
            .last()
            .map_or(2.0, |&(_, k)| k),
    )
}

/// The Welch–Satterthwaite effective degrees of freedom (GUM G.2b) of a combined variance whose
/// contributions `u_i²` (any unit²) have `ν_i` degrees of freedom each (`None`: infinite, a
/// Type B input or a u computed from a stated noise); `None` when every input is infinite.
pub fn effective_dof(contributions: &[(f64, Option<u32>)]) -> Option<f64> {
    let total: f64 = contributions.iter().map(|(v, _)| v).sum();
    let denominator: f64 = contributions
        .iter()
        .filter_map(|&(v, nu)| nu.map(|nu| v * v / f64::from(nu.max(1))))
        .sum();
    (denominator > 0.0).then(|| total * total / denominator)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Student's t at ν = 1 and 2 in closed form (Cauchy: tan(π(p − ½)); ν = 2:
    /// (2p − 1)/√(2p(1 − p))), p = 0.97725.
    #[test]
    fn the_table_agrees_with_closed_forms() {
        let p: f64 = 0.5 + 0.9545 / 2.0;
        let t1 = (std::f64::consts::PI * (p - 0.5)).tan();
        let t2 = (2.0 * p - 1.0) / (2.0 * p * (1.0 - p)).sqrt();
        assert!(
            (coverage_factor(Some(1.0)).unwrap() - t1).abs() < 0.01,
            "{t1}"
        );
        assert!(
            (coverage_factor(Some(2.9)).unwrap() - t2).abs() < 0.001,
            "{t2}"
        );
        assert_eq!(coverage_factor(Some(27.0)), Some(2.105));
        assert_eq!(coverage_factor(None), Some(2.0));
        assert_eq!(coverage_factor(Some(0.5)), None);
        assert_eq!(coverage_factor(Some(1e9)), Some(2.025));
    }

    /// G.2b on two inputs of equal variance, 4 and infinite dof: ν_eff = (2v)²/(v²/4) = 16.
    #[test]
    fn welch_satterthwaite() {
        assert_eq!(effective_dof(&[(0.5, Some(4)), (0.5, None)]), Some(16.0));
        assert_eq!(effective_dof(&[(0.5, None)]), None);
    }
}
