//! `identify::lsq` against an independent f64 oracle: normal equations solved by Gauss–Jordan
//! elimination written here, and exact polynomial fits whose coefficients are known.
use ballpod::identify::lsq::{DEFAULT_RANK_TOL, GivensLsq, LsqError};

/// Independent oracle: solve (AᵀA) x = Aᵀb by Gauss–Jordan with partial pivoting (f64).
fn normal_equations<const N: usize>(rows: &[([f64; N], f64)]) -> ([f64; N], [[f64; N]; N]) {
    let mut m = [[0.0; N]; N];
    let mut v = [0.0; N];
    for (a, b) in rows {
        for i in 0..N {
            v[i] += a[i] * b;
            for j in 0..N {
                m[i][j] += a[i] * a[j];
            }
        }
    }
    // invert m
    let mut inv = [[0.0; N]; N];
    for i in 0..N {
        inv[i][i] = 1.0;
    }
    let mut a = m;
    for c in 0..N {
        let p = (c..N)
            .max_by(|&x, &y| a[x][c].abs().total_cmp(&a[y][c].abs()))
            .unwrap();
        a.swap(c, p);
        inv.swap(c, p);
        let d = a[c][c];
        for j in 0..N {
            a[c][j] /= d;
            inv[c][j] /= d;
        }
        for r in 0..N {
            if r != c {
                let f = a[r][c];
                for j in 0..N {
                    a[r][j] -= f * a[c][j];
                    inv[r][j] -= f * inv[c][j];
                }
            }
        }
    }
    let mut x = [0.0; N];
    for i in 0..N {
        x[i] = (0..N).map(|j| inv[i][j] * v[j]).sum();
    }
    (x, inv)
}

fn rows_cubic(n: usize, noise: impl Fn(usize) -> f64) -> Vec<([f64; 4], f64)> {
    (0..n)
        .map(|k| {
            let t = -1.0 + 2.0 * k as f64 / (n - 1) as f64;
            let a = [1.0, t, t * t, t * t * t];
            (a, 0.5 - 2.0 * t + 0.25 * t * t + 3.0 * t * t * t + noise(k))
        })
        .collect()
}

#[test]
fn exact_cubic_is_recovered() {
    let mut l = GivensLsq::<4>::new();
    for (a, b) in rows_cubic(50, |_| 0.0) {
        l.add_row(&a, b, 1.0).unwrap();
    }
    let s = l.solve_full_rank(DEFAULT_RANK_TOL).unwrap();
    for (x, t) in s.x.iter().zip([0.5, -2.0, 0.25, 3.0]) {
        assert!((x - t).abs() < 1e-12, "{x} vs {t}");
    }
    assert!(s.residual_rms < 1e-12);
    assert_eq!(s.rank, 4);
}

/// x, u and the correlation of every pair of unknowns against the normal equations' oracle.
#[test]
fn noisy_fit_matches_normal_equation_oracle_with_uncertainties() {
    // deterministic pseudo-noise
    let noise = |k: usize| ((k as f64 * 12.9898).sin() * 43758.5453).fract() * 0.01;
    let rows = rows_cubic(200, noise);
    let mut l = GivensLsq::<4>::new();
    for (a, b) in &rows {
        l.add_row(a, *b, 1.0).unwrap();
    }
    let s = l.solve_full_rank(DEFAULT_RANK_TOL).unwrap();
    let (x_ref, inv) = normal_equations(&rows);
    let rss: f64 = rows
        .iter()
        .map(|(a, b)| {
            let p: f64 = a.iter().zip(x_ref.iter()).map(|(u, v)| u * v).sum();
            (b - p).powi(2)
        })
        .sum();
    let s2 = rss / (rows.len() - 4) as f64;
    for i in 0..4 {
        assert!((s.x[i] - x_ref[i]).abs() < 1e-12);
        let u_ref = (s2 * inv[i][i]).sqrt();
        assert!(
            (s.std_uncertainty[i] - u_ref).abs() < 1e-9 * u_ref.max(1e-12),
            "{i}"
        );
        // the correlations of the same (AᵀA)⁻¹ (the powers of a cubic's basis correlate
        // strongly: the check is not of zeros)
        for j in 0..4 {
            let r_ref = inv[i][j] / (inv[i][i] * inv[j][j]).sqrt();
            assert!((s.correlation(i, j) - r_ref).abs() < 1e-9, "{i} {j}");
        }
    }
    assert!(s.correlation(0, 2).abs() > 0.3);
    assert_eq!(s.correlation(0, 4), 0.0);
    assert!((s.residual_rms - (rss / rows.len() as f64).sqrt()).abs() < 1e-12);
}

#[test]
fn condition_number_of_a_diagonal_design_is_its_scale_ratio() {
    let mut l = GivensLsq::<3>::new();
    l.add_row(&[10.0, 0.0, 0.0], 1.0, 1.0).unwrap();
    l.add_row(&[0.0, 2.0, 0.0], 1.0, 1.0).unwrap();
    l.add_row(&[0.0, 0.0, 0.5], 1.0, 1.0).unwrap();
    let s = l.solve(DEFAULT_RANK_TOL).unwrap();
    assert!((s.condition - 20.0).abs() < 1e-12);
    assert_eq!(s.singular_values, [10.0, 2.0, 0.5]);
}

#[test]
fn rank_deficiency_names_the_inseparable_combination() {
    // x0 and x1 only ever appear as x0 + x1: the weakest combination is (1, -1, 0)/√2.
    let mut l = GivensLsq::<3>::new();
    for k in 0..10 {
        let t = k as f64;
        l.add_row(&[1.0, 1.0, t], 2.0 + 0.5 * t, 1.0).unwrap();
    }
    let e = l.solve_full_rank(DEFAULT_RANK_TOL).unwrap_err();
    assert!(matches!(
        e,
        LsqError::RankDeficient {
            rank: 2,
            weakest_param: 0 | 1
        }
    ));
    let s = l.solve(DEFAULT_RANK_TOL).unwrap();
    let w = s.right_singular_vectors[2];
    assert!(
        (w[0].abs() - 0.5f64.sqrt()).abs() < 1e-9
            && (w[0] + w[1]).abs() < 1e-9
            && w[2].abs() < 1e-9
    );
    // minimum-norm solution splits the sum equally
    assert!(
        (s.x[0] - 1.0).abs() < 1e-9 && (s.x[1] - 1.0).abs() < 1e-9 && (s.x[2] - 0.5).abs() < 1e-9
    );
}

#[test]
fn bad_input_is_rejected_and_changes_nothing() {
    let mut l = GivensLsq::<2>::new();
    l.add_row(&[1.0, 0.0], 1.0, 1.0).unwrap();
    let before = l;
    assert_eq!(
        l.add_row(&[f64::NAN, 0.0], 1.0, 1.0),
        Err(LsqError::NonFinite { row: 1 })
    );
    assert_eq!(
        l.add_row(&[1.0, 0.0], f64::INFINITY, 1.0),
        Err(LsqError::NonFinite { row: 1 })
    );
    assert_eq!(l, before);
    assert_eq!(
        l.solve(DEFAULT_RANK_TOL),
        Err(LsqError::TooFewRows {
            rows: 1,
            unknowns: 2
        })
    );
}

#[test]
fn rank_deficiency_with_rounding_noise_converges_and_is_reported() {
    // 13 unknowns, column 12 = 0.7·col3 − 1.3·col5 computed in floating point: the SVD must
    // converge and report rank 12 (a combination of 3, 5 and 12 is inseparable).
    let mut rng = ballpod_host::rng::Rng::new(5);
    let mut l = GivensLsq::<13>::new();
    for _ in 0..60 {
        let mut a = [0.0f64; 13];
        for v in a.iter_mut().take(12) {
            *v = rng.range(-1.0, 1.0) * 1e3;
        }
        a[12] = 0.7 * a[3] - 1.3 * a[5];
        let b: f64 = a.iter().sum();
        l.add_row(&a, b, 1.0).unwrap();
    }
    let s = l.solve(DEFAULT_RANK_TOL).unwrap();
    assert_eq!(s.rank, 12);
    let w = s.right_singular_vectors[12];
    let n = (0.7f64 * 0.7 + 1.3 * 1.3 + 1.0).sqrt();
    assert!(
        (w[3].abs() - 0.7 / n).abs() < 1e-9
            && (w[5].abs() - 1.3 / n).abs() < 1e-9
            && (w[12].abs() - 1.0 / n).abs() < 1e-9
    );
    assert!(matches!(
        l.solve_full_rank(DEFAULT_RANK_TOL),
        Err(LsqError::RankDeficient {
            rank: 12,
            weakest_param: 5
        })
    ));
}

#[test]
fn a_column_of_pure_rounding_noise_converges() {
    // Column 12 is (a3 + a5) − a3 − a5: zero but for rounding, ~1e-13 of the others.
    let mut rng = ballpod_host::rng::Rng::new(9);
    let mut l = GivensLsq::<13>::new();
    for _ in 0..60 {
        let mut a = [0.0f64; 13];
        for v in a.iter_mut().take(12) {
            *v = rng.range(-1.0, 1.0) * 1e3;
        }
        a[12] = (a[3] + a[5]) - a[3] - a[5];
        let b: f64 = a.iter().take(12).sum();
        l.add_row(&a, b, 1.0).unwrap();
    }
    let s = l.solve(DEFAULT_RANK_TOL).unwrap();
    assert_eq!(s.rank, 12);
    for (i, x) in s.x.iter().enumerate().take(12) {
        assert!((x - 1.0).abs() < 1e-9, "x[{i}] = {x}");
    }
}

#[test]
fn repeated_identical_rows_of_a_rank_deficient_design_converge() {
    // Ten copies of the same three rows (rank 3 of 5): R is exact up to rounding noise in its
    // null directions; the SVD must converge and report rank 3.
    let rows = [
        [1.0, 2.0, 0.5, -1.0, 3.0],
        [0.0, 1.0, -2.0, 4.0, 1.0],
        [2.5, 0.0, 1.0, 1.0, -1.0],
    ];
    let mut l = GivensLsq::<5>::new();
    for _ in 0..10 {
        for r in &rows {
            l.add_row(r, r.iter().sum(), 1.0).unwrap();
        }
    }
    let s = l.solve(DEFAULT_RANK_TOL).unwrap();
    assert_eq!(s.rank, 3);
    assert!(s.residual_rms < 1e-12);
}

#[test]
fn r_test_gain_rows_repeated_converge_with_their_rank() {
    // Reported by the R-test work: ten copies of the three rows of the seed 003 reduced gains at
    // A = C = 0 (rank 3 of 11) made the Jacobi SVD stop without converging.
    use ballpod_host::methods::rtest::{RtestGeometry, reduced_gains};
    let h = reduced_gains(&RtestGeometry::SEED003_TABLE3, 0.0, 0.0);
    let mut l = GivensLsq::<11>::new();
    for _ in 0..10 {
        for r in &h {
            l.add_row(r, 1.0, 1.0).unwrap();
        }
    }
    let s = l.solve(DEFAULT_RANK_TOL).unwrap();
    assert_eq!(s.rank, 3);
}
