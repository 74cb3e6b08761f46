//! Independent forward model of seed 002 (Yao 2022 thesis), written from the spec's equations
//! with plain `[[f64; 4]; 4]` products (no nalgebra, no core code): the literal HTM chain
//! (eqs 2.1–2.21), the ball-bar reading (2.17), the commanded patterns (Tables 2.2/2.3), the
//! §3.5 eccentricity fit by 3×3 normal equations solved by Cramer's rule, and the thesis's own
//! chapter-4 relations (eqs 4.2–4.9).
//!
//! Deviation order (µm / µrad): [δx_BT, δz_BT, α_BT, α_XB, β_XB, γ_XB, γ_XY, α_YZ, β_YZ,
//! δx_CZ, δy_CZ, α_CZ, β_CZ].

/// 4×4 homogeneous matrix.
pub type M4 = [[f64; 4]; 4];

/// Matrix product.
pub fn mul(a: &M4, b: &M4) -> M4 {
    let mut c = [[0.0; 4]; 4];
    for i in 0..4 {
        for j in 0..4 {
            for k in 0..4 {
                c[i][j] += a[i][k] * b[k][j];
            }
        }
    }
    c
}

/// Matrix × point (homogeneous w = 1).
pub fn apply(a: &M4, p: [f64; 3]) -> [f64; 3] {
    let v = [p[0], p[1], p[2], 1.0];
    let mut o = [0.0; 3];
    for i in 0..3 {
        for k in 0..4 {
            o[i] += a[i][k] * v[k];
        }
    }
    o
}

fn h(r: [[f64; 3]; 3], t: [f64; 3]) -> M4 {
    [
        [r[0][0], r[0][1], r[0][2], t[0]],
        [r[1][0], r[1][1], r[1][2], t[1]],
        [r[2][0], r[2][1], r[2][2], t[2]],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

/// Pure translation.
pub fn tr(x: f64, y: f64, z: f64) -> M4 {
    h(
        [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        [x, y, z],
    )
}

/// E_B (2.4).
pub fn eb(p: f64) -> M4 {
    let (s, c) = p.sin_cos();
    h([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]], [0.0; 3])
}

/// E_C (2.12).
pub fn ec(t: f64) -> M4 {
    let (s, c) = t.sin_cos();
    h([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]], [0.0; 3])
}

/// Deviation HTMs (mm, rad) from a deviation vector (µm, µrad):
/// (M_BT, M_XB, M_YZ, M_XY, M_CZ, M_CZ⁻¹ first order).
pub fn mats(d: &[f64; 13]) -> (M4, M4, M4, M4, M4, M4) {
    let um = 1e-3;
    let ur = 1e-6;
    let (dxbt, dzbt, abt, axb, bxb, gxb) = (
        d[0] * um,
        d[1] * um,
        d[2] * ur,
        d[3] * ur,
        d[4] * ur,
        d[5] * ur,
    );
    let (gxy, ayz, byz, dxcz, dycz, acz, bcz) = (
        d[6] * ur,
        d[7] * ur,
        d[8] * ur,
        d[9] * um,
        d[10] * um,
        d[11] * ur,
        d[12] * ur,
    );
    (
        h(
            [[1.0, 0.0, 0.0], [0.0, 1.0, -abt], [0.0, abt, 1.0]],
            [dxbt, 0.0, dzbt],
        ),
        h(
            [[1.0, -gxb, bxb], [gxb, 1.0, -axb], [-bxb, axb, 1.0]],
            [0.0; 3],
        ),
        h(
            [[1.0, 0.0, byz], [0.0, 1.0, -ayz], [-byz, ayz, 1.0]],
            [0.0; 3],
        ),
        h(
            [[1.0, -gxy, 0.0], [gxy, 1.0, 0.0], [0.0, 0.0, 1.0]],
            [0.0; 3],
        ),
        h(
            [[1.0, 0.0, bcz], [0.0, 1.0, -acz], [-bcz, acz, 1.0]],
            [dxcz, dycz, 0.0],
        ),
        h(
            [[1.0, 0.0, -bcz], [0.0, 1.0, acz], [bcz, -acz, 1.0]],
            [-dxcz, -dycz, 0.0],
        ),
    )
}

/// T-ball (2.10, 2.20), mm; `tofs` in µm (spindle frame).
pub fn t_ball(
    d: &[f64; 13],
    x: f64,
    y: f64,
    z: f64,
    phi: f64,
    rb: f64,
    tofs: [f64; 3],
) -> [f64; 3] {
    let (mbt, mxb, myz, mxy, _, _) = mats(d);
    let mut m = tr(0.0, 0.0, z);
    for f in [
        myz,
        tr(0.0, y, 0.0),
        mxy,
        tr(x, 0.0, 0.0),
        mxb,
        eb(phi),
        mbt,
    ] {
        m = mul(&m, &f);
    }
    apply(&m, [tofs[0] * 1e-3, tofs[1] * 1e-3, tofs[2] * 1e-3 - rb])
}

/// W-ball (2.13–2.16, 2.21), mm; `wofs` in µm (C frame); `xw` = mounting X (0 or R_C).
pub fn w_ball(d: &[f64; 13], theta: f64, zc: f64, rb: f64, xw: f64, wofs: [f64; 3]) -> [f64; 3] {
    let (_, _, _, _, mcz, mczi) = mats(d);
    let wp = t_ball(d, xw, 0.0, zc + rb, 0.0, rb, [0.0; 3]);
    let mut wc = apply(&mczi, wp);
    for i in 0..3 {
        wc[i] += wofs[i] * 1e-3;
    }
    apply(&mul(&mcz, &ec(theta)), wc)
}

/// Patterns simulated here.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pat {
    /// BX
    Bx,
    /// BY
    By,
    /// BR
    Br,
    /// CR
    Cr,
    /// CA
    Ca,
    /// CX
    Cx,
}

/// Geometry (mm).
#[derive(Clone, Copy, Debug)]
pub struct Geo {
    /// L_B
    pub lb: f64,
    /// Z_C
    pub zc: f64,
    /// R_B
    pub rb: f64,
    /// R_C
    pub rc: f64,
}

/// A commanded point `x` (mm, the NC's X, Y, Z) at B = `phi`, C = `th` (rad) on a machine
/// with deviations `d` (µm / µrad): where it lands in the C (work) frame,
/// E_C⁻¹·M_CZ⁻¹·M_XB·E_B·M_BT·x, and where it should land, E_C⁻¹·E_B·x (mm).
pub fn actual_and_ideal(d: &[f64; 13], x: [f64; 3], phi: f64, th: f64) -> ([f64; 3], [f64; 3]) {
    let (mbt, mxb, _, _, _, mczi) = mats(d);
    let ideal = apply(&mul(&ec(-th), &eb(phi)), x);
    let mut a = ec(-th);
    for m in [mczi, mxb, eb(phi), mbt] {
        a = mul(&a, &m);
    }
    (apply(&a, x), ideal)
}

/// Eccentricity (e1, e2) in µm of pattern `p` over `n` samples (B: 0..=90°, C: 2πi/n).
pub fn ecc(p: Pat, d: &[f64; 13], g: &Geo, n: usize, tofs: [f64; 3], wofs: [f64; 3]) -> (f64, f64) {
    let b = matches!(p, Pat::Bx | Pat::By | Pat::Br);
    let mut ata = [[0.0; 3]; 3];
    let mut atb = [0.0; 3];
    for i in 0..n {
        let a = if b {
            std::f64::consts::FRAC_PI_2 * i as f64 / (n - 1) as f64
        } else {
            2.0 * std::f64::consts::PI * i as f64 / n as f64
        };
        let (s, c) = a.sin_cos();
        let (x, y, z, phi, th, n1, n2) = match p {
            Pat::Bx => (g.lb + g.rb * s, 0.0, g.zc + g.rb * c, a, 0.0, s, c),
            Pat::By => (g.rb * s, g.lb, g.zc + g.rb * c, a, 0.0, s, c),
            Pat::Br => (
                (g.lb + g.rb) * s,
                0.0,
                g.zc + (g.lb + g.rb) * c,
                a,
                0.0,
                s,
                c,
            ),
            Pat::Cr => {
                let sg = (g.rc - g.lb).signum();
                (
                    (g.rc - g.lb) * c,
                    (g.rc - g.lb) * s,
                    g.zc + g.rb,
                    0.0,
                    a,
                    sg * c,
                    sg * s,
                )
            }
            Pat::Ca => (g.rc * c, g.rc * s, g.zc + g.lb + g.rb, 0.0, a, c, s),
            Pat::Cx => (g.lb + g.rc * c, g.rc * s, g.zc + g.rb, 0.0, a, c, s),
        };
        let t = t_ball(d, x, y, z, phi, g.rb, tofs);
        let w = w_ball(d, th, g.zc, g.rb, if b { 0.0 } else { g.rc }, wofs);
        let dl = (((t[0] - w[0]).powi(2) + (t[1] - w[1]).powi(2) + (t[2] - w[2]).powi(2)).sqrt()
            - g.lb)
            * 1e3;
        let r = [1.0, n1, n2];
        for i in 0..3 {
            atb[i] += r[i] * dl;
            for j in 0..3 {
                ata[i][j] += r[i] * r[j];
            }
        }
    }
    let sol = cramer3(&ata, &atb);
    (sol[1], sol[2])
}

/// 3×3 solve by Cramer's rule.
pub fn cramer3(a: &[[f64; 3]; 3], b: &[f64; 3]) -> [f64; 3] {
    let det = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(a);
    let mut out = [0.0; 3];
    for k in 0..3 {
        let mut m = *a;
        for i in 0..3 {
            m[i][k] = b[i];
        }
        out[k] = det(&m) / d;
    }
    out
}

/// Thesis relations (eqs 4.1–4.9) as a forward map: deviations (µm, rad) → the ten
/// eccentricities [ex_BX, ez_BX, ex_BY, ez_BY, ex_CR, ey_CR, ex_CA, ey_CA, ex_CR', ey_CR'] (µm).
/// `t` = [α_CZ, β_CZ, α_XB, β_XB, γ_XB, α_BT] (rad), `dx` = δx_CZ − δx_BT (µm), `dy` = δy_CZ,
/// `dz` = δz_BT (µm); lengths (mm): R_B, R_C, Z_C, Z_T, Z'_T, X_T.
#[allow(clippy::too_many_arguments)]
pub fn thesis_forward(
    t: [f64; 6],
    dx: f64,
    dy: f64,
    dz: f64,
    rb: f64,
    rc: f64,
    zc: f64,
    zt: f64,
    zt2: f64,
    xt: f64,
) -> [f64; 10] {
    let [acz, bcz, axb, bxb, gxb, abt] = t;
    let k = 1e3; // mm·rad → µm
    [
        dz,
        rb * bxb * k,
        -rb * gxb * k,
        rb * axb * k,
        -dx - zt * bxb * k + zc * bcz * k,
        -dy + zt * (axb + abt) * k - zc * acz * k - xt * gxb * k,
        rc * bcz * k,
        -rc * acz * k,
        -dx - zt2 * bxb * k + zc * bcz * k,
        -dy + zt2 * (axb + abt) * k - zc * acz * k - xt * gxb * k,
    ]
}

/// Small deterministic PRNG (xorshift64) for the round-trip tests.
pub struct Rng(pub u64);

impl Rng {
    /// Uniform in [−1, 1).
    pub fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }

    /// Random deviations: positional ±30 µm, angular ±150 µrad (≈ ±31"), in the order of the
    /// module doc.
    pub fn deviations(&mut self) -> [f64; 13] {
        let mut d = [0.0; 13];
        for (i, v) in d.iter_mut().enumerate() {
            let positional = matches!(i, 0 | 1 | 9 | 10);
            *v = if positional { 30.0 } else { 150.0 } * self.uniform();
        }
        d
    }
}

/// The 21 touch points of seed 002 Fig 5.13 (X, Y, Z at B = C = 0), mm: the input of TV-13.
pub const FIG_5_13: [[f64; 3]; 21] = [
    [-390.0000, 0.0000, -464.5118],
    [-392.3406, 0.0, -464.7967],
    [-394.5199, 0.0, -465.7790],
    [-396.3313, 0.0, -467.4001],
    [-397.5836, 0.0, -469.5359],
    [-398.1191, 0.0, -472.0000],
    [-390.0, 2.3213, -464.8558],
    [-390.0, 4.4467, -465.8796],
    [-390.0, 6.1922, -467.5011],
    [-390.0, 7.3864, -469.5999],
    [-390.0, 7.8969, -472.0000],
    [-387.6988, 0.0, -464.9178],
    [-385.6247, 0.0, -465.9779],
    [-383.9443, 0.0, -467.6003],
    [-382.7995, 0.0, -469.6604],
    [-382.3193, 0.0, -472.0000],
    [-390.0, -2.3213, -464.8558],
    [-390.0, -4.4467, -465.8796],
    [-390.0, -6.1922, -467.5011],
    [-390.0, -7.3892, -469.5990],
    [-390.0, -7.8969, -472.0000],
];
