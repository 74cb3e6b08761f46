//! Independent model of a control's kinematics (virtual machine tool side): LinuxCNC's
//! table-rotary-tilting kinematics `xyzac-trt-kins` and `xyzbc-trt-kins` as their published
//! forward and inverse equations state them (LinuxCNC `src/emc/kinematics/trtfuncs.c`), term
//! by term in f64 — the HAL pins `x/y/z-rot-point`, `x/y/z-offset` and `tool-offset` (mm),
//! joint and axis angles in degrees. The correction side (`ncgen::kins`) derives the same
//! kinematics as rotations about two axis lines; the tests hold one against the other.

/// The HAL pins of a trt kinematics (mm).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pins {
    /// `x-rot-point`.
    pub x_rot_point: f64,
    /// `y-rot-point`.
    pub y_rot_point: f64,
    /// `z-rot-point`.
    pub z_rot_point: f64,
    /// `x-offset` (xyzbc only).
    pub x_offset: f64,
    /// `y-offset` (xyzac only).
    pub y_offset: f64,
    /// `z-offset`.
    pub z_offset: f64,
    /// `tool-offset` (added to `z-offset`).
    pub tool_offset: f64,
}

/// xyzac: joints X Y Z (mm), A, C (deg) → position X Y Z (mm).
pub fn xyzac_forward(p: &Pins, j: [f64; 3], a_deg: f64, c_deg: f64) -> [f64; 3] {
    let (a, c) = (a_deg.to_radians(), c_deg.to_radians());
    let (xr, yr, zr) = (p.x_rot_point, p.y_rot_point, p.z_rot_point);
    let dy = p.y_offset;
    let dz = p.z_offset + p.tool_offset;
    let x = c.cos() * (j[0] - xr)
        + c.sin() * a.cos() * (j[1] - dy - yr)
        + c.sin() * a.sin() * (j[2] - dz - zr)
        + c.sin() * dy
        + xr;
    let y = -c.sin() * (j[0] - xr)
        + c.cos() * a.cos() * (j[1] - dy - yr)
        + c.cos() * a.sin() * (j[2] - dz - zr)
        + c.cos() * dy
        + yr;
    let z = -a.sin() * (j[1] - dy - yr) + a.cos() * (j[2] - dz - zr) + dz + zr;
    [x, y, z]
}

/// xyzac: position X Y Z (mm), A, C (deg) → joints X Y Z (mm).
pub fn xyzac_inverse(p: &Pins, q: [f64; 3], a_deg: f64, c_deg: f64) -> [f64; 3] {
    let (a, c) = (a_deg.to_radians(), c_deg.to_radians());
    let (xr, yr, zr) = (p.x_rot_point, p.y_rot_point, p.z_rot_point);
    let dy = p.y_offset;
    let dz = p.z_offset + p.tool_offset;
    let x = c.cos() * (q[0] - xr) - c.sin() * (q[1] - yr) + xr;
    let y = c.sin() * a.cos() * (q[0] - xr) + c.cos() * a.cos() * (q[1] - yr)
        - a.sin() * (q[2] - zr)
        - a.cos() * dy
        + a.sin() * dz
        + dy
        + yr;
    let z =
        c.sin() * a.sin() * (q[0] - xr) + c.cos() * a.sin() * (q[1] - yr) + a.cos() * (q[2] - zr)
            - a.sin() * dy
            - a.cos() * dz
            + dz
            + zr;
    [x, y, z]
}

/// xyzbc: joints X Y Z (mm), B, C (deg) → position X Y Z (mm).
pub fn xyzbc_forward(p: &Pins, j: [f64; 3], b_deg: f64, c_deg: f64) -> [f64; 3] {
    let (b, c) = (b_deg.to_radians(), c_deg.to_radians());
    let (xr, yr, zr) = (p.x_rot_point, p.y_rot_point, p.z_rot_point);
    let dx = p.x_offset;
    let dz = p.z_offset + p.tool_offset;
    let x = c.cos() * b.cos() * (j[0] - dx - xr) + c.sin() * (j[1] - yr)
        - c.cos() * b.sin() * (j[2] - dz - zr)
        + c.cos() * dx
        + xr;
    let y = -c.sin() * b.cos() * (j[0] - dx - xr)
        + c.cos() * (j[1] - yr)
        + c.sin() * b.sin() * (j[2] - dz - zr)
        - c.sin() * dx
        + yr;
    let z = b.sin() * (j[0] - dx - xr) + b.cos() * (j[2] - dz - zr) + dz + zr;
    [x, y, z]
}

/// xyzbc: position X Y Z (mm), B, C (deg) → joints X Y Z (mm).
pub fn xyzbc_inverse(p: &Pins, q: [f64; 3], b_deg: f64, c_deg: f64) -> [f64; 3] {
    let (b, c) = (b_deg.to_radians(), c_deg.to_radians());
    let (xr, yr, zr) = (p.x_rot_point, p.y_rot_point, p.z_rot_point);
    let dx = p.x_offset;
    let dz = p.z_offset + p.tool_offset;
    let dpx = -b.cos() * dx - b.sin() * dz + dx;
    let dpz = b.sin() * dx - b.cos() * dz + dz;
    let x = c.cos() * b.cos() * (q[0] - xr) - c.sin() * b.cos() * (q[1] - yr)
        + b.sin() * (q[2] - zr)
        + dpx
        + xr;
    let y = c.sin() * (q[0] - xr) + c.cos() * (q[1] - yr) + yr;
    let z = -c.cos() * b.sin() * (q[0] - xr)
        + c.sin() * b.sin() * (q[1] - yr)
        + b.cos() * (q[2] - zr)
        + dpz
        + zr;
    [x, y, z]
}
