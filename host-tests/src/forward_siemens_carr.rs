//! Independent model of a control's kinematics (virtual machine tool side): a SINUMERIK
//! orientable toolholder of kinematic type P (`$TC_CARR23 = "P"`, a swivel table: only the
//! part turns), as Siemens' function manual W1 (tool offset, "Toolholder with orientation
//! capability") states its chain: the offset vector l2 (`$TC_CARR4…6`) from the machine
//! reference to a point on rotary axis 1 (direction v1, `$TC_CARR7…9`), l3 (`$TC_CARR15…17`)
//! from there to a point on rotary axis 2 (v2, `$TC_CARR10…12`), which axis 1 carries, and l4
//! (`$TC_CARR18…20`) closing the chain, l4 = −(l2 + l3) for a fixed table. A part point w
//! (mm, the table at both angles 0) is at l2 + R(v1, θ1)·(l3 + R(v2, θ2)·(l4 + w)), each R
//! a right-handed turn about its (normalised) vector — Rodrigues' formula term by term in
//! f64. The correction side (`ncgen::carr`) derives the same as turns about two axis lines;
//! the tests hold one against the other.
//!
//! Kinematic type M (`$TC_CARR23 = "M"`, mixed: the tool turns about axis 1, the part about
//! axis 2), as W1 and the commissioning manual state its vectors: l2 (`$TC_CARR4…6`) from the
//! tool adapter to a point on axis 1 (v1), l1 (`$TC_CARR1…3`) = −l2 closing the tool's chain;
//! l3 (`$TC_CARR15…17`) from the machine reference to a point on axis 2 (v2), l4
//! (`$TC_CARR18…20`) = −l3 closing the part's. The tool's length vector t (from its tip to
//! the adapter) becomes l1 + R(v1, θ1 − o1)·(l2 + t), so the tip is that far below the carrier
//! reference; a part point w is at l3 + R(v2, θ2)·(l4 + w). o1 (`$TC_CARR24`, degrees) is the
//! axis position at which the chain holds as written ("the initial state of the rotary axis is
//! the position specified by the parameter; all angle specifications then refer to the
//! coordinate system displaced by this value").

/// A type-P swivel data record's vectors (mm; v1, v2 need not be unit).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SwivelTable {
    /// l2, `$TC_CARR4…6`.
    pub l2: [f64; 3],
    /// l3, `$TC_CARR15…17`.
    pub l3: [f64; 3],
    /// l4, `$TC_CARR18…20`.
    pub l4: [f64; 3],
    /// v1, `$TC_CARR7…9`.
    pub v1: [f64; 3],
    /// v2, `$TC_CARR10…12`.
    pub v2: [f64; 3],
}

/// `p` turned by `deg` right-handed about the direction `v` through the origin (Rodrigues:
/// p cos θ + (k × p) sin θ + k (k·p)(1 − cos θ), k = v / |v|).
fn rodrigues(v: [f64; 3], deg: f64, p: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let k = [v[0] / n, v[1] / n, v[2] / n];
    let (s, c) = deg.to_radians().sin_cos();
    let kxp = [
        k[1] * p[2] - k[2] * p[1],
        k[2] * p[0] - k[0] * p[2],
        k[0] * p[1] - k[1] * p[0],
    ];
    let kp = k[0] * p[0] + k[1] * p[1] + k[2] * p[2];
    [
        p[0] * c + kxp[0] * s + k[0] * kp * (1.0 - c),
        p[1] * c + kxp[1] * s + k[1] * kp * (1.0 - c),
        p[2] * c + kxp[2] * s + k[2] * kp * (1.0 - c),
    ]
}

fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// Where the part point `w` (mm) is in the machine at rotary axis 1 at `deg1` and axis 2 at
/// `deg2`: l2 + R(v1)(l3 + R(v2)(l4 + w)) — where the control sends the tool for it.
pub fn part_point(t: &SwivelTable, w: [f64; 3], deg1: f64, deg2: f64) -> [f64; 3] {
    let inner = rodrigues(t.v2, deg2, add(t.l4, w));
    add(t.l2, rodrigues(t.v1, deg1, add(t.l3, inner)))
}

/// A type-M swivel data record's vectors (mm; v1, v2 need not be unit) and axis 1's offset.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MixedRecord {
    /// l1, `$TC_CARR1…3`.
    pub l1: [f64; 3],
    /// l2, `$TC_CARR4…6`.
    pub l2: [f64; 3],
    /// v1, `$TC_CARR7…9` (the tool's axis).
    pub v1: [f64; 3],
    /// v2, `$TC_CARR10…12` (the table's axis).
    pub v2: [f64; 3],
    /// l3, `$TC_CARR15…17`.
    pub l3: [f64; 3],
    /// l4, `$TC_CARR18…20`.
    pub l4: [f64; 3],
    /// Axis 1's offset, `$TC_CARR24`, degrees.
    pub offset1_deg: f64,
}

/// Where a type-M record puts the tool's tip from the carrier reference (mm) with axis 1 at
/// `deg1`: −(l1 + R(v1, deg1 − o1)·(l2 + t)), `t` the tool's length vector (tip → adapter).
pub fn mixed_tool_tip(r: &MixedRecord, t: [f64; 3], deg1: f64) -> [f64; 3] {
    let turned = rodrigues(r.v1, deg1 - r.offset1_deg, add(r.l2, t));
    let v = add(r.l1, turned);
    [-v[0], -v[1], -v[2]]
}

/// Where a type-M record has the part point `w` (mm, the table at angle 0) with axis 2 at
/// `deg2`: l3 + R(v2, deg2)·(l4 + w).
pub fn mixed_part_point(r: &MixedRecord, w: [f64; 3], deg2: f64) -> [f64; 3] {
    add(r.l3, rodrigues(r.v2, deg2, add(r.l4, w)))
}

/// Where a control with the record `r` puts its carrier reference (the linear axes, mm) for
/// the tool `t`'s tip to be on the part point `w` at `deg1`, `deg2`.
pub fn mixed_command(r: &MixedRecord, t: [f64; 3], w: [f64; 3], deg1: f64, deg2: f64) -> [f64; 3] {
    let p = mixed_part_point(r, w, deg2);
    let tip = mixed_tool_tip(r, t, deg1);
    [p[0] - tip[0], p[1] - tip[1], p[2] - tip[2]]
}
