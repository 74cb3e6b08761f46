//! Independent forward model of seed 003's A/C table-tilting machine with an R-test (virtual
//! machine tool side): the literal 4×4 HTM chain of spec A4 with all 44 errors, exact
//! rotations, multiplied out in f64 index by index (the core uses first-order lever-arm
//! bookkeeping with nalgebra instead).
//!
//! Error vector order = Table 1 order (see [`NAMES`]); translations in mm, rotations in rad.

/// 4×4 homogeneous matrix.
pub type M4 = [[f64; 4]; 4];

/// The 44 error names in Table 1 order (index into the error vector).
pub const NAMES: [&str; 44] = [
    "EXX", "EYX", "EZX", "EAX", "EBX", "ECX", "EXY", "EYY", "EZY", "EAY", "EBY", "ECY", "EXZ",
    "EYZ", "EZZ", "EAZ", "EBZ", "ECZ", "COX", "AOZ", "BOZ", "XOW", "YOW", "ZOW", "EXA", "EYA",
    "EZA", "EAA", "EBA", "ECA", "YOA", "ZOA", "BOA", "COA", "EXC", "EYC", "EZC", "EAC", "EBC",
    "ECC", "XOC", "YOC", "AOC", "BOC",
];

/// Index of a named error.
pub fn idx(name: &str) -> usize {
    NAMES.iter().position(|n| *n == name).expect("error name")
}

/// Kinematic offsets of the chain, mm.
#[derive(Clone, Copy, Debug, Default)]
pub struct Kin {
    pub x_x: f64,
    pub y_x: f64,
    pub z_x: f64,
    pub x_a: f64,
    pub y_a: f64,
    pub z_a: f64,
    pub x_c: f64,
    pub y_c: f64,
    pub z_c: f64,
    pub x_w: f64,
    pub y_w: f64,
    pub z_w: f64,
    pub x_z: f64,
    pub y_z: f64,
    pub z_z: f64,
    pub x_h: f64,
    pub y_h: f64,
    pub z_h: f64,
    pub z_p: f64,
}

/// Pure translation.
pub fn t(x: f64, y: f64, z: f64) -> M4 {
    [
        [1.0, 0.0, 0.0, x],
        [0.0, 1.0, 0.0, y],
        [0.0, 0.0, 1.0, z],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

/// Seed 003's small-rotation-plus-translation matrix S(a,b,c; x,y,z).
pub fn s(a: f64, b: f64, c: f64, x: f64, y: f64, z: f64) -> M4 {
    [
        [1.0, -c, b, x],
        [c, 1.0, -a, y],
        [-b, a, 1.0, z],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

/// Exact right-handed rotation about X.
pub fn rx(th: f64) -> M4 {
    let (sn, cs) = th.sin_cos();
    [
        [1.0, 0.0, 0.0, 0.0],
        [0.0, cs, -sn, 0.0],
        [0.0, sn, cs, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

/// Exact right-handed rotation about Z.
pub fn rz(th: f64) -> M4 {
    let (sn, cs) = th.sin_cos();
    [
        [cs, -sn, 0.0, 0.0],
        [sn, cs, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

/// Matrix product.
pub fn mm(a: &M4, b: &M4) -> M4 {
    let mut r = [[0.0; 4]; 4];
    for i in 0..4 {
        for j in 0..4 {
            for k in 0..4 {
                r[i][j] += a[i][k] * b[k][j];
            }
        }
    }
    r
}

/// Product of a list of matrices, left to right.
pub fn chain(ms: &[M4]) -> M4 {
    let mut r = ms[0];
    for m in &ms[1..] {
        r = mm(&r, m);
    }
    r
}

/// The two chains (rT_w, rT_p) for errors `e` (Table 1 order), axis angles in rad and servo
/// positions in mm.
pub fn chains(k: &Kin, e: &[f64; 44], a: f64, c: f64, xm: f64, ym: f64, zm: f64) -> (M4, M4) {
    let g = |n: &str| e[idx(n)];
    let r_tx = chain(&[
        t(k.x_x, k.y_x, k.z_x),
        s(0.0, 0.0, g("COX"), 0.0, 0.0, 0.0),
        s(
            g("EAX"),
            g("EBX"),
            g("ECX"),
            xm + g("EXX"),
            g("EYX"),
            g("EZX"),
        ),
    ]);
    let x_ta = chain(&[
        t(k.x_a, k.y_a, k.z_a),
        s(0.0, g("BOA"), g("COA"), 0.0, g("YOA"), g("ZOA")),
        s(0.0, g("EBA"), g("ECA"), g("EXA"), g("EYA"), g("EZA")),
        rx(a + g("EAA")),
    ]);
    let a_tc = chain(&[
        t(k.x_c, k.y_c, k.z_c),
        s(g("AOC"), g("BOC"), 0.0, g("XOC"), g("YOC"), 0.0),
        s(g("EAC"), g("EBC"), 0.0, g("EXC"), g("EYC"), g("EZC")),
        rz(c + g("ECC")),
    ]);
    let c_tw = t(k.x_w + g("XOW"), k.y_w + g("YOW"), k.z_w + g("ZOW"));
    let r_tw = chain(&[r_tx, x_ta, a_tc, c_tw]);
    let r_ty = s(
        g("EAY"),
        g("EBY"),
        g("ECY"),
        g("EXY"),
        ym + g("EYY"),
        g("EZY"),
    );
    let y_tz = chain(&[
        t(k.x_z, k.y_z, k.z_z),
        s(g("AOZ"), g("BOZ"), 0.0, 0.0, 0.0, 0.0),
        s(
            g("EAZ"),
            g("EBZ"),
            g("ECZ"),
            g("EXZ"),
            g("EYZ"),
            zm + g("EZZ"),
        ),
    ]);
    let r_tp = chain(&[r_ty, y_tz, t(k.x_h, k.y_h, k.z_h), t(0.0, 0.0, k.z_p)]);
    (r_tw, r_tp)
}

/// Servo positions (X_m, Y_m, Z_m) that put the nest on the ball in the error-free machine
/// (ideal TCP following), found by evaluating the chains at zero servo positions.
pub fn tcp_commands(k: &Kin, a: f64, c: f64) -> (f64, f64, f64) {
    let (w, p) = chains(k, &[0.0; 44], a, c, 0.0, 0.0, 0.0);
    // X_m moves the ball by +X_m; Y_m, Z_m move the probe by +Y_m, +Z_m.
    (p[0][3] - w[0][3], w[1][3] - p[1][3], w[2][3] - p[2][3])
}

fn inv3(m: &M4) -> [[f64; 3]; 3] {
    let a = |i: usize, j: usize| m[i][j];
    let det = a(0, 0) * (a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1))
        - a(0, 1) * (a(1, 0) * a(2, 2) - a(1, 2) * a(2, 0))
        + a(0, 2) * (a(1, 0) * a(2, 1) - a(1, 1) * a(2, 0));
    let mut r = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            let (r0, r1) = ((j + 1) % 3, (j + 2) % 3);
            let (c0, c1) = ((i + 1) % 3, (i + 2) % 3);
            r[i][j] = (a(r0, c0) * a(r1, c1) - a(r0, c1) * a(r1, c0)) / det;
        }
    }
    r
}

/// R-test reading and orientation deviation at one pose: returns
/// `[ΔX_p, ΔY_p, ΔZ_p, ΔI, ΔJ, ΔK]` (mm, probe frame: `(rT_p)⁻¹` applied to P_p − P_w;
/// orientation `O_t − O_w` with `O = (T − T_ideal)·[0,0,1,0]`).
pub fn reading(k: &Kin, e: &[f64; 44], a: f64, c: f64, xm: f64, ym: f64, zm: f64) -> [f64; 6] {
    let (w, p) = chains(k, e, a, c, xm, ym, zm);
    let (w0, p0) = chains(k, &[0.0; 44], a, c, xm, ym, zm);
    let d = [p[0][3] - w[0][3], p[1][3] - w[1][3], p[2][3] - w[2][3]];
    let ri = inv3(&p);
    let mut out = [0.0; 6];
    for i in 0..3 {
        out[i] = ri[i][0] * d[0] + ri[i][1] * d[1] + ri[i][2] * d[2];
        out[3 + i] = (p[i][2] - p0[i][2]) - (w[i][2] - w0[i][2]);
    }
    out
}

/// Central-difference first-order gains of every error at one pose (step `h`).
pub fn numeric_gains(k: &Kin, a: f64, c: f64, xm: f64, ym: f64, zm: f64, h: f64) -> [[f64; 6]; 44] {
    let mut g = [[0.0; 6]; 44];
    for n in 0..44 {
        let mut ep = [0.0; 44];
        let mut en = [0.0; 44];
        ep[n] = h;
        en[n] = -h;
        let (rp, rn) = (
            reading(k, &ep, a, c, xm, ym, zm),
            reading(k, &en, a, c, xm, ym, zm),
        );
        for i in 0..6 {
            g[n][i] = (rp[i] - rn[i]) / (2.0 * h);
        }
    }
    g
}

/// Exact R-test reading (µm) of the machine with only the 11 reduced-model errors, following
/// the ideal TCP commands. `p` = [XOW, YOW, ZOW, YOA, ZOA, BOA, COA, XOC, YOC, AOC, BOC] in
/// mm / rad.
pub fn exact_reduced_reading_um(k: &Kin, p: &[f64; 11], a: f64, c: f64) -> [f64; 3] {
    let e = reduced_errors(p);
    let (xm, ym, zm) = tcp_commands(k, a, c);
    let r = reading(k, &e, a, c, xm, ym, zm);
    [r[0] * 1e3, r[1] * 1e3, r[2] * 1e3]
}

/// The 44-error vector (Table 1 order) with only the 11 reduced-model errors `p` =
/// [XOW, YOW, ZOW, YOA, ZOA, BOA, COA, XOC, YOC, AOC, BOC] set (mm / rad).
pub fn reduced_errors(p: &[f64; 11]) -> [f64; 44] {
    const MAP: [&str; 11] = [
        "XOW", "YOW", "ZOW", "YOA", "ZOA", "BOA", "COA", "XOC", "YOC", "AOC", "BOC",
    ];
    let mut e = [0.0; 44];
    for (v, n) in p.iter().zip(MAP) {
        e[idx(n)] = *v;
    }
    e
}
