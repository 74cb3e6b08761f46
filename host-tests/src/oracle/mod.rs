//! Independent f64 oracles for the metrology tests: batch least squares by Householder QR on the
//! full design matrix (never the normal equations the core accumulates), a seeded normal random
//! generator, forward models of the ball bar, and a bit-by-bit CRC-32.

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

/// Peak-to-valley of the residuals of `y` about its least-squares fit on `rows` ([`lstsq`]):
/// with rows [1, cos θ, sin θ], G about the least-squares circle (ISO 230-4).
pub fn peak_to_valley_about_lstsq(rows: &[Vec<f64>], y: &[f64]) -> f64 {
    let (x, _) = lstsq(rows, y);
    let res: Vec<f64> = rows
        .iter()
        .zip(y)
        .map(|(g, y)| y - g.iter().zip(&x).map(|(g, x)| g * x).sum::<f64>())
        .collect();
    res.iter().cloned().fold(f64::MIN, f64::max) - res.iter().cloned().fold(f64::MAX, f64::min)
}

/// The seeded generator of the host tests (SplitMix64 + Box–Muller).
pub use crate::rng::Rng;

/// CRC-32/ISO-HDLC (the zlib CRC) bit by bit, reflected polynomial 0xEDB8_8320: independent of
/// the `crc` crate the core uses.
pub fn crc32_bitwise(bytes: &[u8]) -> u32 {
    let mut crc = 0xFFFF_FFFFu32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}
