//! Independent f64 oracles for the metrology tests: batch least squares by Householder QR on the
//! full design matrix (never the normal equations the core accumulates), a seeded normal random
//! generator, and forward models of the ball bar.

/// Batch linear least squares min ‖A x − y‖ by Householder QR, f64. `rows` are the design rows.
/// Returns (x, residual sum of squares). Panics on rank deficiency (a test oracle).
pub fn lstsq(rows: &[Vec<f64>], y: &[f64]) -> (Vec<f64>, f64) {
    let m = rows.len();
    let k = rows[0].len();
    assert!(m >= k, "underdetermined");
    // column-major copy
    let mut a: Vec<Vec<f64>> = (0..k)
        .map(|j| rows.iter().map(|r| r[j]).collect())
        .collect();
    let mut b = y.to_vec();
    for j in 0..k {
        let norm = a[j][j..].iter().map(|v| v * v).sum::<f64>().sqrt();
        assert!(norm > 0.0, "rank deficient");
        let alpha = if a[j][j] > 0.0 { -norm } else { norm };
        let mut v: Vec<f64> = a[j][j..].to_vec();
        v[0] -= alpha;
        let vn2: f64 = v.iter().map(|x| x * x).sum();
        if vn2 == 0.0 {
            continue;
        }
        for col in a.iter_mut().skip(j) {
            let d: f64 = v.iter().zip(&col[j..]).map(|(p, q)| p * q).sum();
            let f = 2.0 * d / vn2;
            for (c, vi) in col[j..].iter_mut().zip(&v) {
                *c -= f * vi;
            }
        }
        let d: f64 = v.iter().zip(&b[j..]).map(|(p, q)| p * q).sum();
        let f = 2.0 * d / vn2;
        for (c, vi) in b[j..].iter_mut().zip(&v) {
            *c -= f * vi;
        }
    }
    let mut x = vec![0.0; k];
    for i in (0..k).rev() {
        let mut s = b[i];
        for (jj, xj) in x.iter().enumerate().skip(i + 1) {
            s -= a[jj][i] * xj;
        }
        assert!(a[i][i].abs() > 1e-300, "rank deficient");
        x[i] = s / a[i][i];
    }
    let rss = b[k..].iter().map(|v| v * v).sum();
    (x, rss)
}

/// Seeded SplitMix64 generator with Box–Muller normals (no external dependency, reproducible).
pub struct Rng(u64);

impl Rng {
    /// A generator with `seed`.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }
    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in (0, 1).
    pub fn uniform(&mut self) -> f64 {
        ((self.next_u64() >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }
    /// Standard normal (Box–Muller).
    pub fn normal(&mut self) -> f64 {
        let u1 = self.uniform();
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}
