//! Independent forward model of seed 000 (two-step method): literal 4×4 homogeneous transforms
//! (eqs 2, 4, 8, 13, 14) multiplied out in f64, to generate ΔV1/ΔV2 for the identification tests.
//! Angles in radians, lengths in mm. Error = actual − nominal.

/// A 4×4 homogeneous transform.
pub type Htm = [[f64; 4]; 4];

/// Matrix product a·b.
pub fn mul(a: &Htm, b: &Htm) -> Htm {
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

/// Pure translation.
pub fn trans(x: f64, y: f64, z: f64) -> Htm {
    [
        [1.0, 0.0, 0.0, x],
        [0.0, 1.0, 0.0, y],
        [0.0, 0.0, 1.0, z],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

/// Right-handed rotation about x.
pub fn rx(a: f64) -> Htm {
    let (s, c) = a.sin_cos();
    [
        [1.0, 0.0, 0.0, 0.0],
        [0.0, c, -s, 0.0],
        [0.0, s, c, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

/// Right-handed rotation about y.
pub fn ry(b: f64) -> Htm {
    let (s, c) = b.sin_cos();
    [
        [c, 0.0, s, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [-s, 0.0, c, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

/// Right-handed rotation about z.
pub fn rz(g: f64) -> Htm {
    let (s, c) = g.sin_cos();
    [
        [c, -s, 0.0, 0.0],
        [s, c, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

/// Applies a transform to a point.
pub fn apply(t: &Htm, p: [f64; 3]) -> [f64; 3] {
    let mut o = [0.0; 3];
    for i in 0..3 {
        o[i] = t[i][0] * p[0] + t[i][1] * p[1] + t[i][2] * p[2] + t[i][3];
    }
    o
}

/// RRTTT tip (eqs 2/4): Trans(p + e) · Rx(α) · Ry(β) · (0, 0, z_r).
pub fn rrttt_tip(p: [f64; 3], e: [f64; 3], alpha: f64, beta: f64, z_r: f64) -> [f64; 3] {
    let t = mul(
        &mul(&trans(p[0] + e[0], p[1] + e[1], p[2] + e[2]), &rx(alpha)),
        &ry(beta),
    );
    apply(&t, [0.0, 0.0, z_r])
}

/// TTTRR point (eq 8): Trans(p + e) · Rx(α) · Trans(0, 0, z_αγ) · Rz(γ) · r.
pub fn tttrr_point(
    p: [f64; 3],
    e: [f64; 3],
    alpha: f64,
    gamma: f64,
    z_ag: f64,
    r: [f64; 3],
) -> [f64; 3] {
    let t = mul(
        &mul(
            &mul(&trans(p[0] + e[0], p[1] + e[1], p[2] + e[2]), &rx(alpha)),
            &trans(0.0, 0.0, z_ag),
        ),
        &rz(gamma),
    );
    apply(&t, r)
}

/// RTTTR spindle tip (eqs 13/15): Trans(p + e) · Ry(β) · (0, 0, z_r).
pub fn rtttr_tip(p: [f64; 3], e: [f64; 3], beta: f64, z_r: f64) -> [f64; 3] {
    apply(
        &mul(&trans(p[0] + e[0], p[1] + e[1], p[2] + e[2]), &ry(beta)),
        [0.0, 0.0, z_r],
    )
}

/// RTTTR table point (eqs 14/16): Trans(p + e) · Rx(α) · r_t.
pub fn rtttr_table_point(p: [f64; 3], e: [f64; 3], alpha: f64, r: [f64; 3]) -> [f64; 3] {
    apply(
        &mul(&trans(p[0] + e[0], p[1] + e[1], p[2] + e[2]), &rx(alpha)),
        r,
    )
}

/// actual − nominal, in µm, from two positions in mm.
pub fn diff_um(actual: [f64; 3], nominal: [f64; 3]) -> [f64; 3] {
    [
        (actual[0] - nominal[0]) * 1e3,
        (actual[1] - nominal[1]) * 1e3,
        (actual[2] - nominal[2]) * 1e3,
    ]
}

/// Small deterministic PRNG (xorshift64*), uniform in [lo, hi).
pub struct Rng(pub u64);

impl Rng {
    /// Next uniform sample in [lo, hi).
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let v = self.0.wrapping_mul(0x2545_F491_4F6C_DD1D);
        lo + (hi - lo) * ((v >> 11) as f64 / (1u64 << 53) as f64)
    }
}
