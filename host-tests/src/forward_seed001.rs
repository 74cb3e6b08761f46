//! Independent forward model of seed 001: the matrix forms 8.55–8.66 of the four
//! configurations, literally, with R(u) of eq 8.62 and RI = Rᵀ (the first-order inverse), in
//! f64 SI-like units: positions mm, D in mm, A in rad. Used to check the first-order formulas
//! 8.68–8.82 of `methods::volumetric` and to generate diagonal readings.

/// 3×3 matrix.
pub type M3 = [[f64; 3]; 3];

fn matmul(a: &M3, b: &M3) -> M3 {
    let mut c = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            for k in 0..3 {
                c[i][j] += a[i][k] * b[k][j];
            }
        }
    }
    c
}

fn matvec(a: &M3, v: [f64; 3]) -> [f64; 3] {
    let mut o = [0.0; 3];
    for i in 0..3 {
        for k in 0..3 {
            o[i] += a[i][k] * v[k];
        }
    }
    o
}

fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// Eq 8.62 transposed: RI(u) = R(u)ᵀ, R = [[1, Az, −Ay], [−Az, 1, Ax], [Ay, −Ax, 1]].
pub fn ri(a: [f64; 3]) -> M3 {
    let (ax, ay, az) = (a[0], a[1], a[2]);
    let r = [[1.0, az, -ay], [-az, 1.0, ax], [ay, -ax, 1.0]];
    [
        [r[0][0], r[1][0], r[2][0]],
        [r[0][1], r[1][1], r[2][1]],
        [r[0][2], r[1][2], r[2][2]],
    ]
}

/// Errors in model units: `d[u][i]` = D_i(u) in mm, `a[u][i]` = A_i(u) in rad (u = 0,1,2 for
/// the x, y, z axes), squareness (S_xy, S_yz, S_zx) in rad.
#[derive(Clone, Copy, Debug, Default)]
pub struct Errors {
    /// D_i(u), mm.
    pub d: [[f64; 3]; 3],
    /// A_i(u), rad.
    pub a: [[f64; 3]; 3],
    /// (S_xy, S_yz, S_zx), rad.
    pub s: [f64; 3],
}

/// Configuration index: 0 FXYZ, 1 XFYZ, 2 XYFZ, 3 XYZF.
pub fn actual_position(cfg: usize, p: [f64; 3], e: &Errors, t: [f64; 3]) -> [f64; 3] {
    let (x, y, z) = (p[0], p[1], p[2]);
    // squareness folded into straightness, 8.58–8.60
    let mut d = e.d;
    d[1][0] += e.s[0] * y;
    d[2][0] += e.s[2] * z;
    d[2][1] += e.s[1] * z;
    // stage vectors 8.55–8.57
    let xs = [x + d[0][0], d[0][1], d[0][2]];
    let ys = [d[1][0], y + d[1][1], d[1][2]];
    let zs = [d[2][0], d[2][1], z + d[2][2]];
    let (rx, ry, rz) = (ri(e.a[0]), ri(e.a[1]), ri(e.a[2]));
    let tool = matvec(&matmul(&matmul(&rx, &ry), &rz), t);
    let pos = match cfg {
        0 => add(add(xs, matvec(&rx, ys)), matvec(&matmul(&rx, &ry), zs)), // 8.63
        1 => add(
            add(matvec(&rx, xs), matvec(&rx, ys)),
            matvec(&matmul(&rx, &ry), zs),
        ), // 8.64
        2 => add(
            add(matvec(&matmul(&ry, &rx), xs), matvec(&ry, ys)),
            matvec(&matmul(&ry, &rx), zs),
        ), // 8.65
        _ => add(
            add(
                matvec(&matmul(&matmul(&rz, &ry), &rx), xs),
                matvec(&matmul(&rz, &ry), ys),
            ),
            matvec(&rz, zs),
        ), // 8.66
    };
    add(pos, tool)
}
