//! Seed 003 (Hsu, NSC 99-2221-E-216-037): R-test identification of the rotary-axis location
//! errors of an A/C table-tilting 5-axis machine.
//!
//! Spec: `design/spec/seed-003-004.md` part A (A4 chain, A5 Table 1 corrected, A6 Table 2,
//! A7 identifiability, A8 least squares, C1–C10 test vectors).
//!
//! # Model (A4)
//! Workpiece branch `r → X → A → C → ball`, probe branch `r → Y → Z → spindle → R-test nest`:
//! ```text
//! rT_x = T(X_x,Y_x,Z_x)·S(0,0,COX)·S(EAX,EBX,ECX; X_m+EXX, EYX, EZX)
//! xT_a = T(X_a,Y_a,Z_a)·S(0,BOA,COA; 0,YOA,ZOA)·S(0,EBA,ECA; EXA,EYA,EZA)·Rx(A_m+EAA)
//! aT_c = T(X_c,Y_c,Z_c)·S(AOC,BOC,0; XOC,YOC,0)·S(EAC,EBC,0; EXC,EYC,EZC)·Rz(C_m+ECC)
//! cT_w = T(X_w+XOW, Y_w+YOW, Z_w+ZOW)
//! rT_y = S(EAY,EBY,ECY; EXY, Y_m+EYY, EZY)
//! yT_z = T(X_z,Y_z,Z_z)·S(AOZ,BOZ,0)·S(EAZ,EBZ,ECZ; EXZ,EYZ,Z_m+EZZ)
//! zT_h = T(X_h,Y_h,Z_h),  hT_p = T(0,0,Z_p)
//! ```
//! `S(a,b,c; x,y,z)` = small rotation (a about X, b about Y, c about Z) then translation;
//! `Rx`, `Rz` are exact right-handed rotations (A about +X, C about +Z).
//!
//! # Conventions
//! - **Reading sign**: ΔP = P_probe − P_ball (the sign that reproduces the paper's Table 1; the
//!   printed eq 7 says the opposite, spec A4 / D.1). Readings are in the probe frame, which has
//!   no nominal rotation, so to first order they are machine-axis components.
//! - Orientation columns ΔI, ΔJ, ΔK: change of the tool-side minus workpiece-side z axis,
//!   `O = (T − T_ideal)·[0,0,1,0]` (A4).
//! - First order in every error (the exact chain differs by ≤ 2.64 nm at Table-4 sizes, C4).
//! - Units at the interface: readings and translational errors in µm, angular errors in
//!   arc-seconds, lengths in mm, axis angles in degrees. Gains in SI form are mm per mm and mm
//!   per rad ([`table1_gains`], [`reduced_gains_si`]).
//! - The 11 reduced parameters are HTM frame translations and small rotations, **not** axis-line
//!   shifts: a C-axis line offset e appears as XOC, YOC = e with XOW, YOW = −e (A6). Both are
//!   reported; the mapping to ISO 230-7 / controller tables is the caller's (D.4);
//!   [`axis_lines`] gives the axis lines they imply, comparable with seed 004's centrelines.
//! - Axis angles A_m, C_m are the model's right-handed table rotations about +X and +Z; map NC
//!   commands with [`super::centreline::RotationSense`] where the machine's table axes are primed.

use nalgebra::{Matrix3, Rotation3, Vector3};

use super::centreline::AxisLine;
use ballpod::identify::lsq::{GivensLsq, LsqError};

/// One arc-second in radians (π / 648 000).
pub const ARCSEC_RAD: f64 = core::f64::consts::PI / 648_000.0;

/// The 44 errors of Table 1 (41 ISO 230 geometric errors of the 5-axis machine + 3 ball
/// position errors), in the paper's row order. Linear-axis errors: E(dir)(axis); location
/// errors: (dir)O(axis) (ISO 230-1 writes E_(dir)0(axis)).
#[allow(missing_docs)] // the variant names are the paper's symbols, explained above
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorTerm {
    EXX,
    EYX,
    EZX,
    EAX,
    EBX,
    ECX,
    EXY,
    EYY,
    EZY,
    EAY,
    EBY,
    ECY,
    EXZ,
    EYZ,
    EZZ,
    EAZ,
    EBZ,
    ECZ,
    COX,
    AOZ,
    BOZ,
    XOW,
    YOW,
    ZOW,
    EXA,
    EYA,
    EZA,
    EAA,
    EBA,
    ECA,
    YOA,
    ZOA,
    BOA,
    COA,
    EXC,
    EYC,
    EZC,
    EAC,
    EBC,
    ECC,
    XOC,
    YOC,
    AOC,
    BOC,
}

impl ErrorTerm {
    /// All 44 errors in Table 1 order.
    pub const ALL: [Self; 44] = {
        use ErrorTerm::*;
        [
            EXX, EYX, EZX, EAX, EBX, ECX, EXY, EYY, EZY, EAY, EBY, ECY, EXZ, EYZ, EZZ, EAZ, EBZ,
            ECZ, COX, AOZ, BOZ, XOW, YOW, ZOW, EXA, EYA, EZA, EAA, EBA, ECA, YOA, ZOA, BOA, COA,
            EXC, EYC, EZC, EAC, EBC, ECC, XOC, YOC, AOC, BOC,
        ]
    };
}

/// Where an error sits in the chain (first-order bookkeeping of A4).
#[derive(Clone, Copy)]
enum Link {
    /// X slide component errors: rotations act about the x-frame origin on the point `p_x`.
    XComp,
    /// COX: acts before the X_m translation, lever `(X_m,0,0) + p_x`.
    XLoc,
    /// A-axis location/component errors and EAA: lever `q_a = Rx(A)·((X_c,Y_c,Z_c) + q_c)`.
    A,
    /// C-axis location/component errors and ECC: frame orientation Rx(A), lever `q_c = Rz(C)·w`.
    C,
    /// Ball position errors: translation in the c frame (orientation Rx(A)·Rz(C)).
    Ball,
    /// Y slide errors: lever `p_y = (X_z,Y_z,Z_z) + (0,0,Z_m) + p_h`.
    Y,
    /// Z slide component errors: lever `p_h = (X_h, Y_h, Z_h + Z_p)`.
    ZComp,
    /// AOZ, BOZ: act before the Z_m translation, lever `(0,0,Z_m) + p_h`.
    ZLoc,
}

/// Translation (unit direction index) or small rotation (axis index) error.
#[derive(Clone, Copy)]
enum Kind {
    Trans(usize),
    Rot(usize),
}

impl ErrorTerm {
    fn link_kind(self) -> (Link, Kind) {
        use ErrorTerm::*;
        use Kind::{Rot, Trans};
        match self {
            EXX => (Link::XComp, Trans(0)),
            EYX => (Link::XComp, Trans(1)),
            EZX => (Link::XComp, Trans(2)),
            EAX => (Link::XComp, Rot(0)),
            EBX => (Link::XComp, Rot(1)),
            ECX => (Link::XComp, Rot(2)),
            COX => (Link::XLoc, Rot(2)),
            EXY => (Link::Y, Trans(0)),
            EYY => (Link::Y, Trans(1)),
            EZY => (Link::Y, Trans(2)),
            EAY => (Link::Y, Rot(0)),
            EBY => (Link::Y, Rot(1)),
            ECY => (Link::Y, Rot(2)),
            EXZ => (Link::ZComp, Trans(0)),
            EYZ => (Link::ZComp, Trans(1)),
            EZZ => (Link::ZComp, Trans(2)),
            EAZ => (Link::ZComp, Rot(0)),
            EBZ => (Link::ZComp, Rot(1)),
            ECZ => (Link::ZComp, Rot(2)),
            AOZ => (Link::ZLoc, Rot(0)),
            BOZ => (Link::ZLoc, Rot(1)),
            XOW => (Link::Ball, Trans(0)),
            YOW => (Link::Ball, Trans(1)),
            ZOW => (Link::Ball, Trans(2)),
            EXA => (Link::A, Trans(0)),
            EYA | YOA => (Link::A, Trans(1)),
            EZA | ZOA => (Link::A, Trans(2)),
            EAA => (Link::A, Rot(0)),
            EBA | BOA => (Link::A, Rot(1)),
            ECA | COA => (Link::A, Rot(2)),
            EXC | XOC => (Link::C, Trans(0)),
            EYC | YOC => (Link::C, Trans(1)),
            EZC => (Link::C, Trans(2)),
            EAC | AOC => (Link::C, Rot(0)),
            EBC | BOC => (Link::C, Rot(1)),
            ECC => (Link::C, Rot(2)),
        }
    }

    /// True for a small rotation (gain per rad), false for a translation (gain per mm).
    pub fn is_angular(self) -> bool {
        matches!(self.link_kind().1, Kind::Rot(_))
    }
}

/// Kinematic offsets of the full chain (A4), mm. `X_x, Y_x, Z_x` do not enter any gain.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ChainGeometry {
    /// A-frame origin in the x frame, X (mm).
    pub x_a_mm: f64,
    /// A-frame origin in the x frame, Y (mm).
    pub y_a_mm: f64,
    /// A-frame origin in the x frame, Z (mm).
    pub z_a_mm: f64,
    /// c-frame origin in the a frame, X (mm); 0 when the C axis intersects the A axis.
    pub x_c_mm: f64,
    /// c-frame origin in the a frame, Y (mm); 0 when the C axis intersects the A axis.
    pub y_c_mm: f64,
    /// c-frame origin above the A axis, Z (mm) (Table 3: 29.794).
    pub z_c_mm: f64,
    /// Ball centre in the c frame, X (mm) (Table 3: −217.504).
    pub x_w_mm: f64,
    /// Ball centre in the c frame, Y (mm) (Table 3: −0.279).
    pub y_w_mm: f64,
    /// Ball centre in the c frame, Z (mm) (Table 3: 211.537).
    pub z_w_mm: f64,
    /// z-frame origin in the y frame, X (mm).
    pub x_z_mm: f64,
    /// z-frame origin in the y frame, Y (mm).
    pub y_z_mm: f64,
    /// z-frame origin in the y frame, Z (mm).
    pub z_z_mm: f64,
    /// Spindle (holder) offset in the z frame, X (mm).
    pub x_h_mm: f64,
    /// Spindle (holder) offset in the z frame, Y (mm) (the paper's table assumes 0).
    pub y_h_mm: f64,
    /// Spindle (holder) offset in the z frame, Z (mm).
    pub z_h_mm: f64,
    /// Probe (R-test nest) length along Z (mm) (Table 3: 184.670).
    pub z_p_mm: f64,
}

/// Axis settings of one pose for the full Table 1 (Y_m enters no gain).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ChainPose {
    /// A-axis angle, degrees (right-handed about +X).
    pub a_deg: f64,
    /// C-axis angle, degrees (right-handed about +Z).
    pub c_deg: f64,
    /// X servo position, mm.
    pub x_m_mm: f64,
    /// Z servo position, mm.
    pub z_m_mm: f64,
}

fn axis(i: usize) -> Vector3<f64> {
    match i {
        0 => Vector3::x(),
        1 => Vector3::y(),
        _ => Vector3::z(),
    }
}

/// First-order gains of one error (seed 003 Table 1, corrected per spec A5):
/// `[ΔX_p, ΔY_p, ΔZ_p, ΔI, ΔJ, ΔK]` per unit error, positions in mm per mm (translations) or
/// mm per rad (rotations), orientations per rad. ΔP = P_probe − P_ball.
///
/// Computed from the chain of A4 by the first-order rule: a translation t of a frame with
/// orientation R moves its points by R·t; a small rotation ω about a frame's pivot moves a
/// point at lever L (frame coordinates) by R·(ω × L) and the end z axis by R·(ω × Rᵀ·k_end).
/// Workpiece-side moves enter with −, probe-side with +. This reproduces 42 of the 44 printed
/// rows; the printed ECX and COX ΔX rows carry a sign typo on `Ca·Sc·X_w + Ca·Cc·Y_w` (A5).
/// Unlike the printed table, X_c, Y_c and Y_h need not be 0.
pub fn table1_gains(err: ErrorTerm, g: &ChainGeometry, pose: &ChainPose) -> [f64; 6] {
    Levers::new(g, pose).gains(err)
}

/// The pose-dependent part of [`table1_gains`], computed once per pose (two rotations).
struct Levers {
    /// Rx(A): orientation of the a frame.
    ra: Rotation3<f64>,
    /// Rx(A)·Rz(C): orientation of the c frame (ball).
    rac: Rotation3<f64>,
    /// Lever of the C-level errors: Rz(C)·w (a-frame axes).
    q_c: Vector3<f64>,
    /// Lever of the A-level errors: Rx(A)·((X_c,Y_c,Z_c) + q_c).
    q_a: Vector3<f64>,
    /// Lever of the X component errors: (X_a,Y_a,Z_a) + q_a.
    p_x: Vector3<f64>,
    /// Lever of COX: (X_m,0,0) + p_x.
    p_xloc: Vector3<f64>,
    /// Lever of the Z component errors: (X_h, Y_h, Z_h + Z_p).
    p_h: Vector3<f64>,
    /// Lever of AOZ, BOZ: (0,0,Z_m) + p_h.
    p_zloc: Vector3<f64>,
    /// Lever of the Y errors: (X_z,Y_z,Z_z) + p_zloc.
    p_y: Vector3<f64>,
}

impl Levers {
    fn new(g: &ChainGeometry, pose: &ChainPose) -> Self {
        let ra = Rotation3::from_axis_angle(&Vector3::x_axis(), pose.a_deg.to_radians());
        let rc = Rotation3::from_axis_angle(&Vector3::z_axis(), pose.c_deg.to_radians());
        let q_c = rc * Vector3::new(g.x_w_mm, g.y_w_mm, g.z_w_mm);
        let q_a = ra * (Vector3::new(g.x_c_mm, g.y_c_mm, g.z_c_mm) + q_c);
        let p_x = Vector3::new(g.x_a_mm, g.y_a_mm, g.z_a_mm) + q_a;
        let p_h = Vector3::new(g.x_h_mm, g.y_h_mm, g.z_h_mm + g.z_p_mm);
        let p_zloc = Vector3::new(0.0, 0.0, pose.z_m_mm) + p_h;
        Self {
            ra,
            rac: ra * rc,
            q_c,
            q_a,
            p_x,
            p_xloc: Vector3::new(pose.x_m_mm, 0.0, 0.0) + p_x,
            p_h,
            p_zloc,
            p_y: Vector3::new(g.x_z_mm, g.y_z_mm, g.z_z_mm) + p_zloc,
        }
    }

    fn gains(&self, err: ErrorTerm) -> [f64; 6] {
        let ident = Rotation3::identity();
        let (link, kind) = err.link_kind();
        // (sign: − workpiece side, + probe side; frame orientation; lever in frame axes)
        let (sign, frame, lever) = match link {
            Link::XComp => (-1.0, ident, self.p_x),
            Link::XLoc => (-1.0, ident, self.p_xloc),
            Link::A => (-1.0, ident, self.q_a),
            Link::C => (-1.0, self.ra, self.q_c),
            Link::Ball => (-1.0, self.rac, Vector3::zeros()),
            Link::Y => (1.0, ident, self.p_y),
            Link::ZComp => (1.0, ident, self.p_h),
            Link::ZLoc => (1.0, ident, self.p_zloc),
        };
        // End-frame z axis of the branch, in the reference frame (probe side: no rotation).
        let k_end = if sign < 0.0 {
            self.rac * Vector3::z()
        } else {
            Vector3::z()
        };
        let (dp, dk) = match kind {
            Kind::Trans(i) => (frame * axis(i), Vector3::zeros()),
            Kind::Rot(i) => {
                let om = axis(i);
                (
                    frame * om.cross(&lever),
                    frame * om.cross(&(frame.inverse() * k_end)),
                )
            }
        };
        let (dp, dk) = (dp * sign, dk * sign);
        [dp.x, dp.y, dp.z, dk.x, dk.y, dk.z]
    }
}

/// The 11 parameters of the reduced model (Table 2), in the paper's order a1…a11.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RtestParam {
    /// a1: ball position error along the c-frame X, µm.
    Xow,
    /// a2: ball position error along the c-frame Y, µm.
    Yow,
    /// a3: ball position error along the c-frame Z, µm.
    Zow,
    /// a4: A-axis location error, offset in Y, µm.
    Yoa,
    /// a5: A-axis location error, offset in Z, µm.
    Zoa,
    /// a6: A-axis location error, tilt about Y, arc-seconds (A direction ≈ (1, COA, −BOA)).
    Boa,
    /// a7: A-axis location error, tilt about Z, arc-seconds.
    Coa,
    /// a8: C-axis location error, offset in X, µm.
    Xoc,
    /// a9: C-axis location error, offset in Y, µm.
    Yoc,
    /// a10: C-axis location error, tilt about X, arc-seconds (C direction ≈ (BOC, −AOC, 1)).
    Aoc,
    /// a11: C-axis location error, tilt about Y, arc-seconds.
    Boc,
}

impl RtestParam {
    /// All 11 in the paper's order (the index into every `[f64; 11]` of this module).
    pub const ALL: [Self; 11] = [
        Self::Xow,
        Self::Yow,
        Self::Zow,
        Self::Yoa,
        Self::Zoa,
        Self::Boa,
        Self::Coa,
        Self::Xoc,
        Self::Yoc,
        Self::Aoc,
        Self::Boc,
    ];

    /// Index a1…a11 − 1.
    pub fn index(self) -> usize {
        self as usize
    }

    /// The paper's symbol (`XOC`), as results name it (`rtest_XOC`).
    pub fn name(self) -> &'static str {
        match self {
            Self::Xow => "XOW",
            Self::Yow => "YOW",
            Self::Zow => "ZOW",
            Self::Yoa => "YOA",
            Self::Zoa => "ZOA",
            Self::Boa => "BOA",
            Self::Coa => "COA",
            Self::Xoc => "XOC",
            Self::Yoc => "YOC",
            Self::Aoc => "AOC",
            Self::Boc => "BOC",
        }
    }

    /// The full-model error this parameter is.
    pub fn iso(self) -> ErrorTerm {
        match self {
            Self::Xow => ErrorTerm::XOW,
            Self::Yow => ErrorTerm::YOW,
            Self::Zow => ErrorTerm::ZOW,
            Self::Yoa => ErrorTerm::YOA,
            Self::Zoa => ErrorTerm::ZOA,
            Self::Boa => ErrorTerm::BOA,
            Self::Coa => ErrorTerm::COA,
            Self::Xoc => ErrorTerm::XOC,
            Self::Yoc => ErrorTerm::YOC,
            Self::Aoc => ErrorTerm::AOC,
            Self::Boc => ErrorTerm::BOC,
        }
    }

    /// True for the four tilts (unit arc-second), false for the seven offsets (unit µm).
    pub fn is_angular(self) -> bool {
        matches!(self, Self::Boa | Self::Coa | Self::Aoc | Self::Boc)
    }

    /// Size in mm or rad of one interface unit (1 µm = 1e-3 mm, 1″ = π/648000 rad).
    fn si_per_unit(self) -> f64 {
        if self.is_angular() { ARCSEC_RAD } else { 1e-3 }
    }
}

/// The 11 identified quantities, by name (translations µm, tilts arc-seconds).
#[allow(missing_docs)] // each field is the RtestParam of the same name, with its unit
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LocationErrors {
    pub xow_um: f64,
    pub yow_um: f64,
    pub zow_um: f64,
    pub yoa_um: f64,
    pub zoa_um: f64,
    pub boa_arcsec: f64,
    pub coa_arcsec: f64,
    pub xoc_um: f64,
    pub yoc_um: f64,
    pub aoc_arcsec: f64,
    pub boc_arcsec: f64,
}

impl LocationErrors {
    /// As an array in [`RtestParam::ALL`] order (µm / arc-seconds).
    pub fn to_array(&self) -> [f64; 11] {
        [
            self.xow_um,
            self.yow_um,
            self.zow_um,
            self.yoa_um,
            self.zoa_um,
            self.boa_arcsec,
            self.coa_arcsec,
            self.xoc_um,
            self.yoc_um,
            self.aoc_arcsec,
            self.boc_arcsec,
        ]
    }

    /// From an array in [`RtestParam::ALL`] order (µm / arc-seconds).
    pub fn from_array(a: [f64; 11]) -> Self {
        let [
            xow_um,
            yow_um,
            zow_um,
            yoa_um,
            zoa_um,
            boa_arcsec,
            coa_arcsec,
            xoc_um,
            yoc_um,
            aoc_arcsec,
            boc_arcsec,
        ] = a;
        Self {
            xow_um,
            yow_um,
            zow_um,
            yoa_um,
            zoa_um,
            boa_arcsec,
            coa_arcsec,
            xoc_um,
            yoc_um,
            aoc_arcsec,
            boc_arcsec,
        }
    }
}

/// The kinematic inputs of the reduced model (Table 3), mm. `X_c = Y_c = 0` in the paper
/// (C axis intersecting the A axis); non-zero values add the A-side terms of spec A5.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RtestGeometry {
    /// Ball centre in the c frame, X (mm).
    pub x_w_mm: f64,
    /// Ball centre in the c frame, Y (mm).
    pub y_w_mm: f64,
    /// Ball centre in the c frame, Z (mm).
    pub z_w_mm: f64,
    /// c-frame origin relative to the A axis, X (mm).
    pub x_c_mm: f64,
    /// c-frame origin relative to the A axis, Y (mm).
    pub y_c_mm: f64,
    /// c-frame origin above the A axis, Z (mm).
    pub z_c_mm: f64,
}

impl RtestGeometry {
    /// Seed 003 Table 3: X_w = −217.504, Y_w = −0.279, Z_w = 211.537, Z_c = 29.794 mm
    /// (Z_p = 184.670 is not used by the reduced model).
    pub const SEED003_TABLE3: Self = Self {
        x_w_mm: -217.504,
        y_w_mm: -0.279,
        z_w_mm: 211.537,
        x_c_mm: 0.0,
        y_c_mm: 0.0,
        z_c_mm: 29.794,
    };

    /// From the six lengths as a session file's `[rtest] geometry_mm` lists them: ball X_w,
    /// Y_w, Z_w, then the C-frame origin X_c, Y_c, Z_c (mm).
    pub fn from_array([x_w_mm, y_w_mm, z_w_mm, x_c_mm, y_c_mm, z_c_mm]: [f64; 6]) -> Self {
        Self {
            x_w_mm,
            y_w_mm,
            z_w_mm,
            x_c_mm,
            y_c_mm,
            z_c_mm,
        }
    }

    fn chain(&self) -> ChainGeometry {
        ChainGeometry {
            x_c_mm: self.x_c_mm,
            y_c_mm: self.y_c_mm,
            z_c_mm: self.z_c_mm,
            x_w_mm: self.x_w_mm,
            y_w_mm: self.y_w_mm,
            z_w_mm: self.z_w_mm,
            ..ChainGeometry::default()
        }
    }

    fn is_finite(&self) -> bool {
        [
            self.x_w_mm,
            self.y_w_mm,
            self.z_w_mm,
            self.x_c_mm,
            self.y_c_mm,
            self.z_c_mm,
        ]
        .iter()
        .all(|v| v.is_finite())
    }
}

/// Table 2 gains at one pose in SI form: rows ΔX_p, ΔY_p, ΔZ_p; columns a1…a11 in mm per mm
/// (offsets) and mm per rad (tilts). Same numbers as [`table1_gains`] for those 11 rows.
pub fn reduced_gains_si(g: &RtestGeometry, a_deg: f64, c_deg: f64) -> [[f64; 11]; 3] {
    let pose = ChainPose {
        a_deg,
        c_deg,
        ..ChainPose::default()
    };
    let levers = Levers::new(&g.chain(), &pose);
    let mut h = [[0.0; 11]; 3];
    for p in RtestParam::ALL {
        let col = levers.gains(p.iso());
        for (row, &v) in h.iter_mut().zip(col.iter()) {
            if let Some(x) = row.get_mut(p.index()) {
                *x = v;
            }
        }
    }
    h
}

/// Table 2 gains in interface units: µm of reading per µm (offsets) or per arc-second (tilts).
/// (Model tables: finite inputs give finite gains; the fallible entry points validate.)
pub fn reduced_gains(g: &RtestGeometry, a_deg: f64, c_deg: f64) -> [[f64; 11]; 3] {
    let mut h = reduced_gains_si(g, a_deg, c_deg);
    for row in h.iter_mut() {
        for (x, p) in row.iter_mut().zip(RtestParam::ALL.iter()) {
            // reading in µm = gain[mm/unit_SI] · value[unit] · si_per_unit · 1e3
            *x *= p.si_per_unit() * 1e3;
        }
    }
    h
}

/// Predicted R-test reading (ΔX_p, ΔY_p, ΔZ_p), µm, of the reduced model at one pose.
pub fn predict_um(
    g: &RtestGeometry,
    e: &LocationErrors,
    a_deg: f64,
    c_deg: f64,
) -> Result<[f64; 3], RtestError> {
    let x = e.to_array();
    if !(g.is_finite() && ballpod::num::all_finite(&x) && a_deg.is_finite() && c_deg.is_finite()) {
        return Err(RtestError::BadParameter);
    }
    let h = reduced_gains(g, a_deg, c_deg);
    Ok(h.map(|row| row.iter().zip(x.iter()).map(|(a, b)| a * b).sum()))
}

/// One R-test reading with the axis setting it was taken at (p_j of seed 003).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RtestSample {
    /// A-axis angle, degrees.
    pub a_deg: f64,
    /// C-axis angle, degrees.
    pub c_deg: f64,
    /// Ball-centre displacement ΔX_p, ΔY_p, ΔZ_p, µm (probe − ball, probe frame).
    pub reading_um: [f64; 3],
}

/// What the sensor zero of the readings is (D.3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReadingZero {
    /// Absolute readings: zero when the ball is exactly at the nominal nest point (calibrated
    /// nest zero and known ball position). A constant sensor-zero error is indistinguishable
    /// from the constant columns XOC, YOA, ZOA (−X, −Y, −Z): it ends up in them.
    Absolute,
    /// Readings zeroed at the first sample (usual R-test practice), or with any unknown sensor
    /// zero: the zero is a nuisance offset per axis, fitted rather than differenced — the rows
    /// are centred on the path's mean, `q_j − q̄ = (H_j − H̄)·a`, which is the least-squares
    /// estimate with the offsets as unknowns and a covariance-correct u (differencing against
    /// the first pose made every row share that reading's noise, and u came out 3–10× too
    /// small). The constant columns XOC, YOA, ZOA vanish and are fixed.
    FirstPose,
}

/// What to do when the path cannot separate all 11 parameters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RankPolicy {
    /// Fix the inseparable parameters at `RtestConfig::fixed_values` (0 by default), chosen
    /// greedily in `estimation_order`, and report them in `RtestIdentification::fixed`.
    FixUnidentifiable,
    /// Refuse with [`RtestError::NotIdentifiable`] naming them.
    Refuse,
}

/// Configuration of [`identify`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RtestConfig {
    /// Sensor zero of the readings.
    pub zero: ReadingZero,
    /// Rank policy.
    pub policy: RankPolicy,
    /// Preference order: a parameter is estimated if it adds rank to those before it,
    /// otherwise fixed. Default: tilts (AOC, BOC, BOA, COA), axis offsets (YOC, XOC, YOA,
    /// ZOA), ball offsets last (XOW, YOW, ZOW) — the ball position is a set-up quantity that
    /// the axis offsets can stand in for (A6). Must be a permutation of all 11.
    pub estimation_order: [RtestParam; 11],
    /// Values of fixed parameters (µm / arc-seconds).
    pub fixed_values: LocationErrors,
    /// Relative singular-value tolerance of the rank check, with columns in µm and arc-seconds
    /// (spec C6: 1e-9).
    pub rank_tol: f64,
    /// The head's calibration (Type B): relative standard uncertainty of each axis's reading
    /// scale (ΔX_p, ΔY_p, ΔZ_p independent), 1 = 100 %. Default [`U_READING_SCALE`].
    pub u_reading_scale: f64,
    /// Take the gains again at the ball and the C-frame origin where the readings put them
    /// ([`identify`]; default true). False: the paper's one linear pass with the gains of the
    /// geometry as entered, which reproduces readings made with those gains (seed 003 Table 2)
    /// exactly.
    pub refine_ball: bool,
}

/// Default [`RtestConfig::u_reading_scale`]: 0.5 % of the reading. Seed 003 says nothing of
/// the head's calibration (spec A10); a nest calibrated by moving a reference sphere through
/// ±0.2 mm against a 1 µm reference leaves about 1/200 of the reading per axis.
pub const U_READING_SCALE: f64 = 0.005;

impl Default for RtestConfig {
    fn default() -> Self {
        use RtestParam::*;
        Self {
            zero: ReadingZero::Absolute,
            policy: RankPolicy::FixUnidentifiable,
            estimation_order: [Aoc, Boc, Boa, Coa, Yoc, Xoc, Yoa, Zoa, Xow, Yow, Zow],
            fixed_values: LocationErrors::default(),
            rank_tol: 1e-9,
            u_reading_scale: U_READING_SCALE,
            refine_ball: true,
        }
    }
}

/// A set of the 11 parameters (indexed by [`RtestParam::index`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ParamSet(pub [bool; 11]);

impl ParamSet {
    /// Whether `p` is in the set.
    pub fn contains(&self, p: RtestParam) -> bool {
        self.0.get(p.index()).copied().unwrap_or(false)
    }
    /// Number of members.
    pub fn count(&self) -> usize {
        self.0.iter().filter(|&&b| b).count()
    }
    fn set(&mut self, p: RtestParam, v: bool) {
        if let Some(b) = self.0.get_mut(p.index()) {
            *b = v;
        }
    }
}

/// Why an R-test identification or verification failed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RtestError {
    /// A sample (index given) held a NaN or infinity.
    NonFiniteSample {
        /// Zero-based index of the sample.
        sample: usize,
    },
    /// The geometry, the configuration (rank tolerance ≤ 0, fixed values, a reading scale's u
    /// below 0) or the given errors held a NaN, an infinity or an out-of-range value.
    BadParameter,
    /// Not enough samples: the reduced model needs at least 4 poses (12 equations ≥ 11).
    TooFewSamples {
        /// Samples given.
        given: usize,
        /// Samples needed.
        needed: usize,
    },
    /// `estimation_order` is not a permutation of the 11 parameters.
    BadEstimationOrder,
    /// The path cannot separate all parameters (policy `Refuse`): `rank` of 11, and the
    /// parameters that would have to be fixed.
    NotIdentifiable {
        /// Numerical rank of the 11-column problem.
        rank: usize,
        /// Parameters the path cannot separate from the others (greedy in the estimation
        /// order).
        inseparable: ParamSet,
    },
    /// The least-squares solver failed.
    Lsq(LsqError),
}

impl From<LsqError> for RtestError {
    fn from(e: LsqError) -> Self {
        Self::Lsq(e)
    }
}

/// Result of an R-test identification.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RtestIdentification {
    /// Estimated location and ball errors (µm / arc-seconds); NaN where the path does not
    /// determine the parameter: the fixed ones and those in [`Self::combined`].
    pub errors: LocationErrors,
    /// Standard uncertainty of each estimate (µm / arc-seconds): the root sum of squares of
    /// [`Self::u_type_a`] and [`Self::u_reading_scale`]; NaN where `errors` is NaN.
    pub std_uncertainty: LocationErrors,
    /// Its Type A share, from the residual variance (µm / arc-seconds).
    pub u_type_a: LocationErrors,
    /// The estimates' covariance (µm², µm·″, ″²; [`RtestParam::ALL`] order): the Type A part
    /// s²·(HᵀH)⁻¹ plus the head's calibration, each axis's response moved by its u, outer
    /// products summed; its diagonal is [`Self::std_uncertainty`] squared. NaN rows and
    /// columns where `errors` is NaN.
    pub covariance: [[f64; 11]; 11],
    /// Its share from the head's calibration, [`RtestConfig::u_reading_scale`]: each axis's
    /// readings scaled by 1 + u through the same least squares (µm / arc-seconds).
    pub u_reading_scale: LocationErrors,
    /// Parameters fixed because the path cannot separate them (empty when rank = 11).
    pub fixed: ParamSet,
    /// Free parameters whose estimate moves with the fixed values: the path sees them only in
    /// a combination with fixed ones (on K1, BOA − BOC = Z_c·XOC), so their own value is not
    /// determined (K1 with XOC fixed at 0 read BOA as 262″ for a true −9.4″).
    pub combined: ParamSet,
    /// The solution the path's readings determine: fixed parameters at their fixed values and
    /// the combined ones absorbing them. It predicts this path's readings (for [`verify`] on
    /// the same kind of path), not the machine's parameters.
    pub path_model: LocationErrors,
    /// Numerical rank of the 11-column problem before fixing (= 11 − number fixed).
    pub rank: usize,
    /// Condition number of the 11-column problem (columns in µm / arc-seconds); infinite when
    /// rank-deficient.
    pub condition: f64,
    /// Fit residuals (measured − predicted) on the identification path, with the gains of
    /// [`Self::gains_geometry`].
    pub residuals: Residuals,
    /// The geometry the gains were taken at: the one entered, or with
    /// [`RtestConfig::refine_ball`] the ball and the C-frame origin moved by the first pass's
    /// XOW, YOW, ZOW, XOC, YOC ([`identify`]). [`verify`] and [`predict_um`] with
    /// [`Self::path_model`] take it.
    pub gains_geometry: RtestGeometry,
}

/// Measured − predicted statistics over a path (µm).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Residuals {
    /// RMS per axis (ΔX_p, ΔY_p, ΔZ_p), µm.
    pub rms_um: [f64; 3],
    /// Largest |residual| per axis, µm.
    pub max_abs_um: [f64; 3],
    /// RMS over all three axes, µm.
    pub rms_total_um: f64,
    /// Samples used (for `FirstPose`, the first one is the reference and counts too).
    pub samples: usize,
}

/// Rows of one sample in the chosen zero convention: (gains 3×11 in µm per unit, readings µm).
/// `mean` = mean gains and reading of the path (subtracted for `FirstPose`).
fn sample_rows(
    g: &RtestGeometry,
    s: &RtestSample,
    mean: &([[f64; 11]; 3], [f64; 3]),
    zero: ReadingZero,
) -> ([[f64; 11]; 3], [f64; 3]) {
    let h = reduced_gains(g, s.a_deg, s.c_deg);
    match zero {
        ReadingZero::Absolute => (h, s.reading_um),
        ReadingZero::FirstPose => {
            let (h0, q0) = mean;
            let mut d = h;
            for (r, r0) in d.iter_mut().zip(h0.iter()) {
                for (x, x0) in r.iter_mut().zip(r0.iter()) {
                    *x -= x0;
                }
            }
            let q = s.reading_um;
            (d, [q[0] - q0[0], q[1] - q0[1], q[2] - q0[2]])
        }
    }
}

/// Mean gains and reading over the path (the `FirstPose` centre); `None` without samples.
fn mean_rows(g: &RtestGeometry, samples: &[RtestSample]) -> Option<([[f64; 11]; 3], [f64; 3])> {
    if samples.is_empty() {
        return None;
    }
    let k = 1.0 / samples.len() as f64;
    let mut h = [[0.0f64; 11]; 3];
    let mut q = [0.0f64; 3];
    for s in samples {
        let hs = reduced_gains(g, s.a_deg, s.c_deg);
        for ((row, rs), (qm, qs)) in h
            .iter_mut()
            .zip(hs.iter())
            .zip(q.iter_mut().zip(s.reading_um))
        {
            for (x, xs) in row.iter_mut().zip(rs.iter()) {
                *x += xs * k;
            }
            *qm += qs * k;
        }
    }
    Some((h, q))
}

fn check_inputs(g: &RtestGeometry, samples: &[RtestSample]) -> Result<(), RtestError> {
    if !g.is_finite() {
        return Err(RtestError::BadParameter);
    }
    for (i, s) in samples.iter().enumerate() {
        if !(s.a_deg.is_finite() && s.c_deg.is_finite() && ballpod::num::all_finite(&s.reading_um))
        {
            return Err(RtestError::NonFiniteSample { sample: i });
        }
    }
    Ok(())
}

/// Builds the least-squares problem over the samples, with equality rows `x_j = v_j` (heavy
/// weight) for the parameters in `fixed`.
fn build(
    g: &RtestGeometry,
    samples: &[RtestSample],
    zero: ReadingZero,
    fixed: &ParamSet,
    fixed_values: &[f64; 11],
) -> Result<GivensLsq<11>, RtestError> {
    build_scaled(g, samples, zero, fixed, fixed_values, [1.0; 3])
}

/// [`build`] with each axis's readings multiplied by `scale` (ΔX_p, ΔY_p, ΔZ_p; for
/// `FirstPose` their mean too, so the centred readings scale alike).
fn build_scaled(
    g: &RtestGeometry,
    samples: &[RtestSample],
    zero: ReadingZero,
    fixed: &ParamSet,
    fixed_values: &[f64; 11],
    scale: [f64; 3],
) -> Result<GivensLsq<11>, RtestError> {
    let mut lsq = GivensLsq::<11>::new();
    let Some(mean) = mean_rows(g, samples) else {
        return Ok(lsq);
    };
    for s in samples {
        let (h, q) = sample_rows(g, s, &mean, zero);
        for ((row, &b), k) in h.iter().zip(q.iter()).zip(scale) {
            lsq.add_row(row, b * k, 1.0)?;
        }
    }
    // A fixed parameter's column lies in the span of the free ones, so the data do not care
    // about its value and the constraint row holds exactly; the weight only has to dominate
    // the data scale (1e6·rows) so it does not leak into the free parameters' uncertainty.
    let w = 1e6 * (samples.len().max(1) as f64);
    for p in RtestParam::ALL {
        if fixed.contains(p) {
            let mut row = [0.0; 11];
            if let Some(x) = row.get_mut(p.index()) {
                *x = 1.0;
            }
            lsq.add_row(&row, fixed_values.get(p.index()).copied().unwrap_or(0.0), w)?;
        }
    }
    Ok(lsq)
}

/// How far (µm or arc-seconds per unit of a fixed value) a free estimate may move with a fixed
/// value and still count as determined: rounding of the 11-column solve is ~1e-9.
const COMBINED_TOL: f64 = 1e-6;

/// Identifies the 11 reduced-model parameters from R-test readings by least squares
/// (seed 003 §3, `q = H·a + e`, A8), with a rank check (C6) that fixes — or, with
/// [`RankPolicy::Refuse`], refuses on — the parameters the path cannot separate.
///
/// The ball's and the C axis's positions as entered are not budgeted but estimated (issue
/// 14): the gains are the lever arms of the ball and the C-frame origin as entered, and their
/// errors XOW, YOW, ZOW and XOC, YOC are identified with them. The identification is then
/// taken again with the gains where the readings put them (the angular columns' lever arms at
/// the first estimate; the readings still hold the whole offsets, so the second pass reads
/// them against the geometry as entered again, and
/// [`RtestIdentification::gains_geometry`] says where the gains were taken). With the ball up
/// to 0.5 mm and the C axis up to 0.3 mm off and the other errors up to 3× seed 003's Table 4,
/// the first pass erred by up to 0.23 (µm or ″) on the exact chain and the second by 0.009
/// (`identify_rtest.rs`), against a u of 0.06–0.23 at 0.3 µm of noise. An offset the path does
/// not determine moves nothing.
///
/// Unweighted (every reading 1 µm σ), Givens QR (not the normal equations). Which parameters
/// are fixed is decided greedily in `cfg.estimation_order`: each parameter is estimated if its
/// column adds rank to those already kept. Examples (spec A7): K4-type paths with absolute
/// readings: rank 11, nothing fixed; readings zeroed at the first pose: XOC, YOA, ZOA fixed
/// (they are indistinguishable from the sensor zero); K1 alone (A = 0): four fixed.
pub fn identify(
    g: &RtestGeometry,
    samples: &[RtestSample],
    cfg: &RtestConfig,
) -> Result<RtestIdentification, RtestError> {
    let first = identify_about(g, samples, cfg)?;
    if !cfg.refine_ball {
        return Ok(first);
    }
    let e = &first.errors;
    let mm = |v: f64| if v.is_finite() { v * 1e-3 } else { 0.0 };
    let at = RtestGeometry {
        x_w_mm: g.x_w_mm + mm(e.xow_um),
        y_w_mm: g.y_w_mm + mm(e.yow_um),
        z_w_mm: g.z_w_mm + mm(e.zow_um),
        x_c_mm: g.x_c_mm + mm(e.xoc_um),
        y_c_mm: g.y_c_mm + mm(e.yoc_um),
        z_c_mm: g.z_c_mm,
    };
    if !at.is_finite() {
        return Ok(first);
    }
    // the readings still hold the whole offsets (the head follows the ball as entered), so the
    // second pass reads them against the geometry as entered again, with the angular errors'
    // lever arms taken where the ball and the C axis are
    identify_about(&at, samples, cfg)
}

/// [`identify`] with the gains of the ball at `g`: one pass of the linear least squares, its
/// rank check and its u.
fn identify_about(
    g: &RtestGeometry,
    samples: &[RtestSample],
    cfg: &RtestConfig,
) -> Result<RtestIdentification, RtestError> {
    check_inputs(g, samples)?;
    if !(cfg.rank_tol.is_finite()
        && cfg.rank_tol > 0.0
        && ballpod::num::all_finite(&cfg.fixed_values.to_array())
        && cfg.u_reading_scale.is_finite()
        && cfg.u_reading_scale >= 0.0)
    {
        return Err(RtestError::BadParameter);
    }
    let mut seen = ParamSet::default();
    for p in cfg.estimation_order {
        if seen.contains(p) {
            return Err(RtestError::BadEstimationOrder);
        }
        seen.set(p, true);
    }
    let needed = 4 + usize::from(cfg.zero == ReadingZero::FirstPose);
    if samples.len() < needed {
        return Err(RtestError::TooFewSamples {
            given: samples.len(),
            needed,
        });
    }
    let fixed_values = cfg.fixed_values.to_array();
    let free_all = build(g, samples, cfg.zero, &ParamSet::default(), &fixed_values)?;
    // `lsq`'s Jacobi SVD can report `NoConvergence` on a rank-deficient problem whose null
    // singular values are rounding noise (their relative orthogonality cannot reach machine
    // epsilon); a full-rank problem of this size converges. So `NoConvergence` is treated as
    // "not full rank" here and in the greedy trials below, and the rank is the size of the
    // greedy independent set.
    let full = match free_all.solve(cfg.rank_tol) {
        Ok(s) => Some(s),
        Err(LsqError::NoConvergence) => None,
        Err(e) => return Err(e.into()),
    };
    let mut fixed = ParamSet::default();
    let (sol, rank, condition) = if let Some(full) = full.filter(|s| s.rank == 11) {
        (full, 11, full.condition)
    } else {
        // Greedy: keep parameter j if {kept ∪ j} has full column rank (tested with every other
        // parameter constrained).
        let mut kept = ParamSet::default();
        for p in cfg.estimation_order {
            let mut trial_fixed = ParamSet([true; 11]);
            for q in RtestParam::ALL {
                if kept.contains(q) || q == p {
                    trial_fixed.set(q, false);
                }
            }
            let trial = build(g, samples, cfg.zero, &trial_fixed, &fixed_values)?;
            let independent = match trial.solve(cfg.rank_tol) {
                Ok(s) => s.rank == 11,
                Err(LsqError::NoConvergence) => false,
                Err(e) => return Err(e.into()),
            };
            if independent {
                kept.set(p, true);
            }
        }
        for q in RtestParam::ALL {
            fixed.set(q, !kept.contains(q));
        }
        let rank = kept.count();
        if cfg.policy == RankPolicy::Refuse {
            return Err(RtestError::NotIdentifiable {
                rank,
                inseparable: fixed,
            });
        }
        let sol =
            build(g, samples, cfg.zero, &fixed, &fixed_values)?.solve_full_rank(cfg.rank_tol)?;
        (sol, rank, f64::INFINITY)
    };
    let mut x = sol.x;
    let mut u = sol.std_uncertainty;
    // Type A correlations from the SVD of the triangular factor: (HᵀH)⁻¹ = V·Σ⁻²·Vᵀ (s²
    // cancels in the correlation; the u above carry it)
    let inv = |i: usize, j: usize| -> f64 {
        sol.right_singular_vectors
            .iter()
            .zip(sol.singular_values)
            .filter(|(_, s)| *s > 0.0)
            .map(|(v, s)| {
                v.get(i).copied().unwrap_or(0.0) * v.get(j).copied().unwrap_or(0.0) / (s * s)
            })
            .sum()
    };
    let correlation_a: [[f64; 11]; 11] = core::array::from_fn(|i| {
        core::array::from_fn(|j| {
            let d = ballpod::num::sqrt(inv(i, i) * inv(j, j));
            if d > 0.0 { inv(i, j) / d } else { 0.0 }
        })
    });

    if cfg.zero == ReadingZero::FirstPose {
        // the centred rows also spent one degree of freedom per axis on the offsets, which the
        // solver's s² = RSS/(m − 11) does not know of
        let dof = f64::from(sol.rows) - 11.0;
        let scale = ballpod::num::sqrt(dof / (dof - 3.0));
        u.iter_mut().for_each(|v| *v *= scale);
    }
    // The head's calibration: each axis's readings scaled by 1 + u through the same least
    // squares (linear in the readings: the response is exact), the axes independent.
    let mut u_scale = [0.0f64; 11];
    let mut scale_shifts = [[0.0f64; 11]; 3];
    if cfg.u_reading_scale > 0.0 {
        for (axis, shift) in scale_shifts.iter_mut().enumerate() {
            let mut scale = [1.0; 3];
            if let Some(k) = scale.get_mut(axis) {
                *k += cfg.u_reading_scale;
            }
            let moved = build_scaled(g, samples, cfg.zero, &fixed, &fixed_values, scale)?
                .solve_full_rank(cfg.rank_tol)?;
            for (((v, d), a), b) in u_scale.iter_mut().zip(shift.iter_mut()).zip(moved.x).zip(x) {
                *d = a - b;
                *v += (a - b) * (a - b);
            }
        }
        u_scale.iter_mut().for_each(|v| *v = ballpod::num::sqrt(*v));
    }
    let mut u_type_a = u;
    for ((v, a), b) in u.iter_mut().zip(u_type_a).zip(u_scale) {
        *v = ballpod::num::sqrt(a * a + b * b);
    }
    let mut covariance = correlation_a;
    for ((row, ui), i) in covariance.iter_mut().zip(u_type_a).zip(0..) {
        for ((c, uj), j) in row.iter_mut().zip(u_type_a).zip(0..) {
            let scale: f64 = scale_shifts
                .iter()
                .map(|d: &[f64; 11]| {
                    d.get(i).copied().unwrap_or(0.0) * d.get(j).copied().unwrap_or(0.0)
                })
                .sum();
            *c = *c * ui * uj + scale;
        }
    }
    for p in RtestParam::ALL {
        if fixed.contains(p)
            && let Some(xi) = x.get_mut(p.index())
        {
            *xi = fixed_values.get(p.index()).copied().unwrap_or(0.0);
        }
    }
    let path_model = LocationErrors::from_array(x);
    let residuals = residuals(g, &path_model, samples, cfg.zero)?;
    // a free parameter is determined when its estimate does not move with any fixed value
    let mut combined = ParamSet::default();
    for q in RtestParam::ALL.into_iter().filter(|q| fixed.contains(*q)) {
        let mut moved = fixed_values;
        if let Some(v) = moved.get_mut(q.index()) {
            *v += 1.0;
        }
        let other = build(g, samples, cfg.zero, &fixed, &moved)?.solve_full_rank(cfg.rank_tol)?;
        for p in RtestParam::ALL.into_iter().filter(|p| !fixed.contains(*p)) {
            let (a, b) = (x.get(p.index()), other.x.get(p.index()));
            if let (Some(a), Some(b)) = (a, b)
                && libm::fabs(b - a) > COMBINED_TOL
            {
                combined.set(p, true);
            }
        }
    }
    for p in RtestParam::ALL {
        if fixed.contains(p) || combined.contains(p) {
            for v in [&mut x, &mut u, &mut u_type_a, &mut u_scale] {
                if let Some(v) = v.get_mut(p.index()) {
                    *v = f64::NAN;
                }
            }
            for (i, row) in covariance.iter_mut().enumerate() {
                for (j, c) in row.iter_mut().enumerate() {
                    if i == p.index() || j == p.index() {
                        *c = f64::NAN;
                    }
                }
            }
        }
    }
    Ok(RtestIdentification {
        errors: LocationErrors::from_array(x),
        std_uncertainty: LocationErrors::from_array(u),
        u_type_a: LocationErrors::from_array(u_type_a),
        covariance,
        u_reading_scale: LocationErrors::from_array(u_scale),
        fixed,
        combined,
        path_model,
        rank,
        condition,
        residuals,
        gains_geometry: *g,
    })
}

fn residuals(
    g: &RtestGeometry,
    e: &LocationErrors,
    samples: &[RtestSample],
    zero: ReadingZero,
) -> Result<Residuals, RtestError> {
    let Some(mean) = mean_rows(g, samples) else {
        return Err(RtestError::TooFewSamples {
            given: 0,
            needed: 1,
        });
    };
    let a = e.to_array();
    let mut out = Residuals {
        samples: samples.len(),
        ..Residuals::default()
    };
    let mut ss = [0.0f64; 3];
    for s in samples {
        let (h, q) = sample_rows(g, s, &mean, zero);
        for (k, (row, &b)) in h.iter().zip(q.iter()).enumerate() {
            let pred: f64 = row.iter().zip(a.iter()).map(|(x, y)| x * y).sum();
            let r = b - pred;
            if let (Some(acc), Some(m)) = (ss.get_mut(k), out.max_abs_um.get_mut(k)) {
                *acc += r * r;
                *m = m.max(libm::fabs(r));
            }
        }
    }
    let n = samples.len() as f64;
    for (r, s) in out.rms_um.iter_mut().zip(ss.iter()) {
        *r = ballpod::num::sqrt(s / n);
    }
    out.rms_total_um = ballpod::num::sqrt(ss.iter().sum::<f64>() / (3.0 * n));
    Ok(out)
}

/// The rotary-axis lines implied by identified location errors (spec B7, the bridge to seed
/// 004's centrelines), in machine axes at A = 0 with the origin at the **nominal** point of the
/// A axis (the x-frame point (X_a, Y_a, Z_a)); mm, directions unit.
///
/// - A axis: `xT_a` rotates about the line through (0, YOA, ZOA) with direction
///   `S(0,BOA,COA)·e_x = (1, COA, −BOA)`.
/// - C axis (at A = 0): in the a frame the line through (X_c + XOC, Y_c + YOC, Z_c) with
///   direction (BOC, −AOC, 1), carried into machine axes by the A location matrix
///   `S(0,BOA,COA; 0,YOA,ZOA)`; so its machine-axis tilt about Y is BOC + BOA, not BOC alone —
///   a dial-gauge table-axis direction (seed 004) measures that sum.
///
/// First order in the errors, like the model (second-order terms ≈ 1e-6 mm at Table-4 sizes).
/// The ball-offset ambiguity of A6 applies: these lines are where the model's axes are, given
/// the identified ball offsets.
pub fn axis_lines(
    g: &RtestGeometry,
    e: &LocationErrors,
) -> Result<(AxisLine, AxisLine), RtestError> {
    if !(g.is_finite() && ballpod::num::all_finite(&e.to_array())) {
        return Err(RtestError::BadParameter);
    }
    let um = 1e-3;
    let (boa, coa) = (e.boa_arcsec * ARCSEC_RAD, e.coa_arcsec * ARCSEC_RAD);
    let (aoc, boc) = (e.aoc_arcsec * ARCSEC_RAD, e.boc_arcsec * ARCSEC_RAD);
    // S(0, BOA, COA; 0, YOA, ZOA) as a linear map plus translation.
    let s_a = Matrix3::new(1.0, -coa, boa, coa, 1.0, 0.0, -boa, 0.0, 1.0);
    let t_a = Vector3::new(0.0, e.yoa_um * um, e.zoa_um * um);
    let a_dir = Vector3::new(1.0, coa, -boa);
    let c_point_a = Vector3::new(g.x_c_mm + e.xoc_um * um, g.y_c_mm + e.yoc_um * um, g.z_c_mm);
    let c_dir = s_a * Vector3::new(boc, -aoc, 1.0);
    let c_point = s_a * c_point_a + t_a;
    let unit = |v: Vector3<f64>| {
        let n = ballpod::num::sqrt(v.dot(&v));
        [v.x / n, v.y / n, v.z / n]
    };
    Ok((
        AxisLine {
            direction: unit(a_dir),
            point_mm: [t_a.x, t_a.y, t_a.z],
        },
        AxisLine {
            direction: unit(c_dir),
            point_mm: [c_point.x, c_point.y, c_point.z],
        },
    ))
}

/// Verification on another path (seed 003: identify on K4, verify on K1/K2): measured −
/// predicted statistics of the reduced model with the given errors. The paper reports
/// ±12 µm on K4 and ±15 µm on K1/K2 for its machine (C9; realistic acceptance envelopes, not
/// exact tests).
pub fn verify(
    g: &RtestGeometry,
    errors: &LocationErrors,
    samples: &[RtestSample],
    zero: ReadingZero,
) -> Result<Residuals, RtestError> {
    check_inputs(g, samples)?;
    if !ballpod::num::all_finite(&errors.to_array()) {
        return Err(RtestError::BadParameter);
    }
    residuals(g, errors, samples, zero)
}
