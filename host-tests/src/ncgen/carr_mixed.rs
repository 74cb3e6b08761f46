//! Corrections a SINUMERIK takes from seed 002: the deviations of a B-head / C-table machine
//! written into an orientable toolholder of kinematic type M (`$TC_CARR23 = "M"`, mixed: the
//! tool turns about axis 1, the part about axis 2; `cargo ncgen -- kins sinumerik-m`).
//!
//! The record (Siemens W1; the chain in `forward_siemens_carr`) turns the tool about axis 1
//! through the end of l2 (`$TC_CARR4…6`, from the tool adapter) along v1 (`$TC_CARR7…9`), l1
//! (`$TC_CARR1…3`) = −l2 closing the tool's chain, with axis 1 counted from its offset
//! (`$TC_CARR24`, degrees); and the part about axis 2 through the end of l3 (`$TC_CARR15…17`,
//! from the machine reference) along v2 (`$TC_CARR10…12`), l4 (`$TC_CARR18…20`) = −l3. Seed
//! 002's model (thesis eqs 2.2–2.21) maps onto it term by term, to first order:
//!
//! - δx_BT, δz_BT (the spindle's offset from the B axis) move the B pivot against the adapter,
//!   l2 by −(δx_BT, 0, δz_BT), while l1 stays: the tool chain opens by the spindle's offset,
//!   l1 + l2 = −(δx_BT, 0, δz_BT), the tip at rest that far from where the chain had it;
//! - α_XB, γ_XB (B's tilt about X and Z) turn v1 to M_XB·Y = (−γ_XB, 1, α_XB);
//! - β_XB (B turned about itself: its zero) goes into the offset, o1 − β_XB for a v1 along +Y;
//! - δx_CZ, δy_CZ (C's position at the table face, the model frame's z = 0) move l3, l4
//!   following, and α_CZ, β_CZ turn v2 to M_CZ·Z = (β_CZ, −α_CZ, 1).
//!
//! What the record cannot take: M_XB·M_BT also tilts the spindle about X at B = 0 by
//! α_BT + α_XB, and a type M record holds the tool along Z at rest — reported with the error it
//! leaves. (The linear axes' squareness γ_XY, α_YZ, β_YZ belongs to the control's squareness
//! compensation, not to a swivel data record; the ball-bar procedure does not identify it.)
//! The part's chain stays closed (l4 = −l3: at C = 0 the part is where it was); the tool's
//! tip moves at B = 0 by the spindle's offset, so a part zero probed with the old record is
//! probed again (as after any kinematics measurement).
//!
//! The deviations are the machine's against the model the control commanded it with (the
//! present record), so a record corrected once and measured again takes the second run's
//! deviations on top of the first's.

use crate::methods::centreline::AxisLine;
use ballpod::identify::mill_turn::{Deviations, Parameter, urad_to_arcsec};
use nalgebra::{Rotation3, Unit, Vector3};

use super::NcError;
use super::carr::{Kind, Values, check_turns, set_at, turn_urad, vector_at};
use super::kins::{
    DeviationRow, Dispersion, Figures, cube_about, every_15_deg, nearest, rows_as_comments,
    rows_csv, unit,
};

/// The type-M record's values the correction writes: l1, l2, v1, v2, l3, l4 (mm, the vectors
/// unit length) and axis 1's offset (degrees) — [`PARAMETERS`] order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MixedRecord(pub [f64; 19]);

/// The record's parameters, in [`MixedRecord`] order: the `$TC_CARR` number and what it is.
pub const PARAMETERS: [(u8, &str); 19] = [
    (1, "l1 x"),
    (2, "l1 y"),
    (3, "l1 z"),
    (4, "l2 x"),
    (5, "l2 y"),
    (6, "l2 z"),
    (7, "v1 x"),
    (8, "v1 y"),
    (9, "v1 z"),
    (10, "v2 x"),
    (11, "v2 y"),
    (12, "v2 z"),
    (15, "l3 x"),
    (16, "l3 y"),
    (17, "l3 z"),
    (18, "l4 x"),
    (19, "l4 y"),
    (20, "l4 z"),
    (24, "axis 1 offset, degrees"),
];

/// Where l1 starts in [`MixedRecord`] (each vector's three components follow).
pub const L1: usize = 0;
/// Where l2 starts.
pub const L2: usize = 3;
/// Where v1 starts.
pub const V1: usize = 6;
/// Where v2 starts.
pub const V2: usize = 9;
/// Where l3 starts.
pub const L3: usize = 12;
/// Where l4 starts.
pub const L4: usize = 15;
/// Axis 1's offset in [`MixedRecord`].
pub const OFFSET1: usize = 18;

/// What the value at `k` of a [`MixedRecord`] is.
pub fn kind(k: usize) -> Kind {
    match k {
        OFFSET1 => Kind::Angle,
        k if (V1..L3).contains(&k) => Kind::Direction,
        _ => Kind::Length,
    }
}

/// `a · b`.
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

impl MixedRecord {
    /// The vector starting at `at`.
    fn vector(&self, at: usize) -> [f64; 3] {
        vector_at(&self.0, at)
    }

    fn set(&mut self, at: usize, v: [f64; 3]) {
        set_at(&mut self.0, at, v);
    }

    /// The values with their parameters, for the guards and the output.
    fn values<'a>(record: u16, current: &'a Self, corrected: &'a Self, u: &'a [f64]) -> Values<'a> {
        Values {
            record,
            parameters: &PARAMETERS,
            kind,
            current: &current.0,
            corrected: &corrected.0,
            u,
        }
    }

    /// The closed record of l2, v1, l3, v2 and axis 1's offset (degrees): l1 = −l2, l4 = −l3.
    pub fn closed(
        l2: [f64; 3],
        v1: [f64; 3],
        l3: [f64; 3],
        v2: [f64; 3],
        offset1_deg: f64,
    ) -> Self {
        let mut r = Self([0.0; 19]);
        r.set(L2, l2);
        // (0 − x, not −x: a 0 prints as 0, not −0)
        r.set(L1, l2.map(|v| 0.0 - v));
        r.set(V1, v1);
        r.set(L3, l3);
        r.set(L4, l3.map(|v| 0.0 - v));
        r.set(V2, v2);
        r.0[OFFSET1] = offset1_deg;
        r
    }

    /// Seed 002's model frame as a record: B through the carrier reference along +Y, C through
    /// the machine reference (the table face's centre) along +Z, no offset.
    pub fn model_frame() -> Self {
        Self::closed([0.0; 3], [0.0, 1.0, 0.0], [0.0; 3], [0.0, 0.0, 1.0], 0.0)
    }

    /// l1, `$TC_CARR1…3`, mm.
    pub fn l1(&self) -> [f64; 3] {
        self.vector(L1)
    }
    /// l2, `$TC_CARR4…6`, mm.
    pub fn l2(&self) -> [f64; 3] {
        self.vector(L2)
    }
    /// v1, `$TC_CARR7…9`.
    pub fn v1(&self) -> [f64; 3] {
        self.vector(V1)
    }
    /// v2, `$TC_CARR10…12`.
    pub fn v2(&self) -> [f64; 3] {
        self.vector(V2)
    }
    /// l3, `$TC_CARR15…17`, mm.
    pub fn l3(&self) -> [f64; 3] {
        self.vector(L3)
    }
    /// l4, `$TC_CARR18…20`, mm.
    pub fn l4(&self) -> [f64; 3] {
        self.vector(L4)
    }
    /// Axis 1's offset, `$TC_CARR24`, degrees.
    pub fn offset1_deg(&self) -> f64 {
        self.0[OFFSET1]
    }

    /// How far the part's chain is from closing, |l3 + l4|, mm (0 for a fixed table).
    pub fn part_gap_mm(&self) -> f64 {
        let (l3, l4) = (self.l3(), self.l4());
        (0..3).map(|k| (l3[k] + l4[k]).powi(2)).sum::<f64>().sqrt()
    }

    /// Where the tool's chain puts the tip at rest from where a closed one would: −(l1 + l2),
    /// mm (the spindle's offset from the B pivot a correction wrote; 0 for a closed chain).
    pub fn tool_shift_mm(&self) -> [f64; 3] {
        let (l1, l2) = (self.l1(), self.l2());
        std::array::from_fn(|k| 0.0 - (l1[k] + l2[k]))
    }

    /// The tool's axis (B) at rest in the carrier's frame (the carrier reference at the
    /// origin), and the table's (C) in the machine's (mm, unit directions).
    pub fn lines(&self) -> (AxisLine, AxisLine) {
        (
            AxisLine {
                direction: unit(self.v1()),
                point_mm: self.l2(),
            },
            AxisLine {
                direction: unit(self.v2()),
                point_mm: self.l3(),
            },
        )
    }

    /// Seed 002's B pivot in the carrier's frame: the point of the tool's axis nearest the
    /// spindle's (Z through the carrier reference), where the thesis's B frame has its origin.
    pub fn b_pivot(&self) -> [f64; 3] {
        let (b, _) = self.lines();
        // the lines p + s·d and t·Z: s where p + s·d is nearest the Z axis
        let (p, d) = (b.point_mm, b.direction);
        let den = d[0] * d[0] + d[1] * d[1];
        let s = if den > 0.0 {
            -(p[0] * d[0] + p[1] * d[1]) / den
        } else {
            0.0
        };
        std::array::from_fn(|k| p[k] + s * d[k])
    }

    /// Where the table's axis crosses the height `z_mm` (the machine's Z; its l3 point when it
    /// runs in the plane), mm.
    pub fn table_at(&self, z_mm: f64) -> [f64; 3] {
        let (_, c) = self.lines();
        let (p, d) = (c.point_mm, c.direction);
        if d[2].abs() < 1e-9 {
            return p;
        }
        let s = (z_mm - p[2]) / d[2];
        std::array::from_fn(|k| p[k] + s * d[k])
    }

    /// The record for seed 002's deviations `d` (µm, µrad) against this one, C's position
    /// taken at the table face `face_z_mm`: each pivot on its moved line nearest the present
    /// one, each vector turned with its present sense, axis 1's offset less B's zero error,
    /// the tool's tip at rest moved by the spindle's offset (l1 + l2 = its negative).
    pub fn corrected(&self, d: &Deviations, face_z_mm: f64) -> Self {
        let (um, urad) = (1e-3, 1e-6);
        let s1 = dot(self.v1(), [0.0, 1.0, 0.0]).signum();
        let s2 = dot(self.v2(), [0.0, 0.0, 1.0]).signum();
        let v1 = unit(self.v1());
        let v1 = unit([
            v1[0] - s1 * d.gamma_xb_urad * urad,
            v1[1],
            v1[2] + s1 * d.alpha_xb_urad * urad,
        ]);
        let b0 = self.b_pivot();
        let pivot = [b0[0] - d.dx_bt_um * um, b0[1], b0[2] - d.dz_bt_um * um];
        let l2 = nearest(
            &AxisLine {
                direction: v1,
                point_mm: pivot,
            },
            self.l2(),
        );
        let c0 = self.table_at(face_z_mm);
        let v2 = unit(self.v2());
        let v2 = unit([
            v2[0] + s2 * d.beta_cz_urad * urad,
            v2[1] - s2 * d.alpha_cz_urad * urad,
            v2[2],
        ]);
        let l3 = nearest(
            &AxisLine {
                direction: v2,
                point_mm: [c0[0] + d.dx_cz_um * um, c0[1] + d.dy_cz_um * um, c0[2]],
            },
            self.l3(),
        );
        let offset = self.offset1_deg() - (s1 * d.beta_xb_urad * urad).to_degrees();
        let mut r = Self::closed(l2, v1, l3, v2, offset);
        let shift = self.tool_shift_mm();
        let moved = [
            shift[0] + d.dx_bt_um * um,
            shift[1],
            shift[2] + d.dz_bt_um * um,
        ];
        r.set(L1, std::array::from_fn(|k| 0.0 - (moved[k] + l2[k])));
        r
    }
}

/// The tool tip's place from the carrier reference with B at `b_deg` (mm): the tool `t` (tip
/// → adapter) hanging from the adapter, tilted by `tilt_rad` about X through the B pivot,
/// turned about the record's tool axis from its offset (exact rotations), and moved by the
/// chain's [`MixedRecord::tool_shift_mm`].
fn tool_tip(r: &MixedRecord, t: [f64; 3], tilt_rad: f64, b_deg: f64) -> Vector3<f64> {
    let (b, _) = r.lines();
    let pivot = Vector3::from(r.b_pivot());
    let tilted = Rotation3::from_axis_angle(&Vector3::x_axis(), tilt_rad)
        * (-Vector3::from(t) - pivot)
        + pivot;
    let o = Vector3::from(b.point_mm);
    let axis = Unit::new_normalize(Vector3::from(b.direction));
    Rotation3::from_axis_angle(&axis, (b_deg - r.offset1_deg()).to_radians()) * (tilted - o)
        + o
        + Vector3::from(r.tool_shift_mm())
}

/// The part point `w` (mm, the table at 0) with C at `c_deg`: turned about the table's axis.
fn part_point(r: &MixedRecord, w: [f64; 3], c_deg: f64) -> Vector3<f64> {
    let (_, c) = r.lines();
    let o = Vector3::from(c.point_mm);
    let axis = Unit::new_normalize(Vector3::from(c.direction));
    Rotation3::from_axis_angle(&axis, c_deg.to_radians()) * (Vector3::from(w) - o) + o
}

/// Where the dispersion is taken: every 15° of B over its range and of C over a turn, the tool
/// tip `tool_below_pivot_mm` under the B pivot, at the work point and the eight corners of a
/// cube about it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MixedGrid {
    /// B's range, degrees (low, high).
    pub b_range_deg: (f64, f64),
    /// The tool tip's distance below the B pivot along the spindle, mm.
    pub tool_below_pivot_mm: f64,
    /// The work point (mm, the machine's; the table at C = 0).
    pub work_mm: [f64; 3],
    /// Half the cube's side, mm (0: the work point only).
    pub half_side_mm: f64,
}

impl MixedGrid {
    /// The tool-centre error of a control holding `control` on a machine that is `actual`
    /// with its spindle tilted by `tilt_rad` about X at B = 0: the tool where the control's
    /// record puts it for each part point less where the part point is.
    pub fn dispersion(
        &self,
        control: &MixedRecord,
        actual: &MixedRecord,
        tilt_rad: f64,
    ) -> Dispersion {
        let points = cube_about(self.work_mm, self.half_side_mm);
        // one tool, whichever record the control holds: its tip on the spindle (the Z axis
        // through the adapter) `tool_below_pivot_mm` under the control's B pivot
        let t = [0.0, 0.0, self.tool_below_pivot_mm - control.b_pivot()[2]];
        let mut errors = Vec::new();
        for b in every_15_deg(self.b_range_deg) {
            let tool = tool_tip(actual, t, tilt_rad, b) - tool_tip(control, t, 0.0, b);
            for j in 0..24 {
                let c = 15.0 * j as f64;
                for &w in &points {
                    let part = part_point(actual, w, c) - part_point(control, w, c);
                    errors.push((tool - part).norm() * 1e3);
                }
            }
        }
        Dispersion::of(errors)
    }
}

/// Which of seed 002's figures the deviations come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    /// The ball-bar procedure's model mode (`dx_BT` … `beta_CZ`): all ten.
    Model,
    /// The touch-probe method (`probe_*`, thesis chapter 5): the C axis's four when it was
    /// probed; the B axis's δx_BT, δz_BT, β_XB and α_BT + α_XB when it was — B's tilt (α_XB,
    /// γ_XB) is not separable from the spindle's with B = 0/90°, so v1 stays.
    Probe {
        /// The B axis was probed.
        b_axis: bool,
        /// The C axis was probed.
        c_axis: bool,
    },
}

/// Seed 002's identified deviations with their covariance, as a results file gives them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Seed002Deviations {
    /// The deviations (µm, µrad; the squareness ones 0: not identified; from the touch probe,
    /// α_BT holds α_BT + α_XB and α_XB, γ_XB are 0, as are an axis's not probed).
    pub deviations: Deviations,
    /// Their covariance (µm², µm·µrad, µrad²; [`Parameter::ALL`] order).
    pub covariance: [[f64; 13]; 13],
    /// What the u leave out, said with the output (`None`: nothing known).
    pub u_note: Option<&'static str>,
    /// Which figures they are.
    pub source: Source,
}

/// The touch-probe figures of each axis and the deviation each stands for (α_BT + α_XB in
/// α_BT's place).
const PROBE_B: [(&str, Parameter); 4] = [
    ("probe_dx_BT", Parameter::DxBt),
    ("probe_dz_BT", Parameter::DzBt),
    ("probe_beta_XB", Parameter::BetaXb),
    ("probe_alpha_BT_plus_alpha_XB", Parameter::AlphaBt),
];
const PROBE_C: [(&str, Parameter); 4] = [
    ("probe_alpha_CZ", Parameter::AlphaCz),
    ("probe_beta_CZ", Parameter::BetaCz),
    ("probe_dx_CZ", Parameter::DxCz),
    ("probe_dy_CZ", Parameter::DyCz),
];

/// The touch-probe figures of `file` as deviations, each axis probed or not (refused when
/// an axis has some of its figures, or neither has any).
fn probe_deviations(file: &Figures) -> Result<Seed002Deviations, NcError> {
    let bad = |what: String| NcError {
        field: "RESULTS",
        what,
    };
    let mut d = [0.0; 13];
    let mut covariance = [[0.0f64; 13]; 13];
    let mut probed = [false; 2];
    for (axis, figures) in [PROBE_B, PROBE_C].iter().enumerate() {
        let found: Vec<_> = figures
            .iter()
            .map(|(name, p)| (name, p, file.results.iter().find(|e| e.name == *name)))
            .collect();
        if found.iter().all(|f| f.2.is_none()) {
            continue;
        }
        for &(name, &p, entry) in &found {
            let (v, u) = entry
                .and_then(|e| Some((e.value?, e.u?)))
                .filter(|(v, u)| v.is_finite() && u.is_finite() && *u >= 0.0)
                .ok_or_else(|| bad(format!("{name}: a finite value with a u ≥ 0")))?;
            let to_model = |x: f64| {
                if p.is_positional() {
                    x
                } else {
                    ballpod::identify::mill_turn::arcsec_to_urad(x)
                }
            };
            let i = p.index();
            d[i] = to_model(v);
            if let Some(c) = covariance.get_mut(i).and_then(|r| r.get_mut(i)) {
                *c = to_model(u).powi(2);
            }
        }
        probed[axis] = true;
    }
    let [b_axis, c_axis] = probed;
    if !(b_axis || c_axis) {
        return Err(bad(
            "no touch-probe results (probe_dx_BT …, probe_alpha_CZ …): probe the B or the C axis"
                .into(),
        ));
    }
    Ok(Seed002Deviations {
        deviations: Deviations::from_array(&d),
        covariance,
        u_note: Some(
            "the touch-probe figures taken as uncorrelated (the pod states no covariance for \
             them; δx_BT and β_XB come from the same equations): the corrected values' u are \
             not their own",
        ),
        source: Source::Probe { b_axis, c_axis },
    })
}

/// The deviations of a seed 002 results file (`results.json` of `cargo sim` or `cargo replay`):
/// the model mode's, with `seed002_covariance` their covariance, without it each result's own
/// `u` taken as uncorrelated (and the output says so); the touch probe's (`probe_*`) when
/// `probe` is asked or the file has no model-mode results. A file of another test is refused
/// with the reason.
pub fn seed002_from_results(json: &str, probe: bool) -> Result<Seed002Deviations, NcError> {
    let bad = |what: String| NcError {
        field: "RESULTS",
        what,
    };
    let file: Figures = serde_json::from_str(json).map_err(|e| bad(e.to_string()))?;
    let model = file.results.iter().any(|e| e.name == "dx_BT");
    let probed = file.results.iter().any(|e| e.name.starts_with("probe_"));
    if probe || (!model && probed) {
        return probe_deviations(&file);
    }
    if !model {
        return Err(bad(
            if file.host.iter().any(|e| e.name.starts_with("rtest_")) {
                "an R-test's results: its machine tilts the table (A) and turns it (C), a swivel \
                 table: sinumerik-p or xyzac-trt, not a mixed record"
                    .into()
            } else {
                "no seed 002 results (the model mode's dx_BT … beta_CZ or the touch probe's \
                 probe_*): run the seed 002 procedure (cargo sim, or cargo replay of its runs)"
                    .into()
            },
        ));
    }
    let identified = super::deviations_from_results(json)?;
    let (covariance, u_note) = match identified.covariance {
        Some(c) => (c, None),
        None => {
            let mut c = [[0.0f64; 13]; 13];
            for p in Parameter::ALL {
                let Some(e) = file.results.iter().find(|e| e.name == p.name()) else {
                    continue;
                };
                let u = e.u.filter(|u| u.is_finite() && *u >= 0.0).ok_or_else(|| {
                    bad(format!(
                        "{}: a finite u ≥ 0 (or seed002_covariance)",
                        p.name()
                    ))
                })?;
                let u = if p.is_positional() {
                    u
                } else {
                    ballpod::identify::mill_turn::arcsec_to_urad(u)
                };
                if let Some(v) = c.get_mut(p.index()).and_then(|r| r.get_mut(p.index())) {
                    *v = u * u;
                }
            }
            (
                c,
                Some(
                    "the deviations taken as uncorrelated (the results file has no \
                     seed002_covariance): the corrected values' u are not their own",
                ),
            )
        }
    };
    Ok(Seed002Deviations {
        deviations: identified.deviations,
        covariance,
        u_note,
        source: Source::Model,
    })
}

/// The identified deviations in the generic table's order: the parameter, ISO 230-1's name for
/// it (the B axis's location against the spindle, C's against the machine) and the record's
/// parameter that takes it.
const ROWS: [(Parameter, &str, &str); 10] = [
    (
        Parameter::DxBt,
        "−E_X0B (the spindle's X from B)",
        "axis 1's pivot X: l2 $TC_CARR4 (l1 stays: the tip at rest moves)",
    ),
    (
        Parameter::DzBt,
        "−E_Z0B (the spindle's Z from B)",
        "axis 1's pivot Z: l2 $TC_CARR6 (l1 stays: the tip at rest moves)",
    ),
    (
        Parameter::AlphaBt,
        "the spindle's tilt about X in B",
        "not expressible (the tool is along Z at rest): the tilt alpha_BT + alpha_XB above",
    ),
    (
        Parameter::AlphaXb,
        "E_A0B",
        "axis 1's direction: v1 $TC_CARR9",
    ),
    (
        Parameter::BetaXb,
        "E_B0B (B's zero)",
        "axis 1's offset: $TC_CARR24",
    ),
    (
        Parameter::GammaXb,
        "E_C0B",
        "axis 1's direction: v1 $TC_CARR7",
    ),
    (
        Parameter::DxCz,
        "E_X0C (at the table face)",
        "axis 2's pivot X: l3 $TC_CARR15 (l4 follows)",
    ),
    (
        Parameter::DyCz,
        "E_Y0C (at the table face)",
        "axis 2's pivot Y: l3 $TC_CARR16 (l4 follows)",
    ),
    (
        Parameter::AlphaCz,
        "E_A0C",
        "axis 2's direction: v2 $TC_CARR11",
    ),
    (
        Parameter::BetaCz,
        "E_B0C",
        "axis 2's direction: v2 $TC_CARR10",
    ),
];

/// What `cargo ncgen -- kins sinumerik-m` writes.
#[derive(Clone, Debug, PartialEq)]
pub struct MixedCorrection {
    /// The record's number (`$TC_CARR…[n]`).
    pub record: u16,
    /// The control's present values.
    pub current: MixedRecord,
    /// The corrected values.
    pub corrected: MixedRecord,
    /// Standard uncertainty of each corrected value (mm, unitless, degrees).
    pub u: [f64; 19],
    /// The spindle's tilt about X at B = 0 the record cannot take, α_BT + α_XB, and its
    /// standard uncertainty (µrad).
    pub spindle_tilt_urad: (f64, f64),
    /// The height C's position is taken at (the table face), mm.
    pub face_z_mm: f64,
    /// The tool-centre error with the present values (computed from the deviations).
    pub before: Dispersion,
    /// The tool-centre error left with the corrected values: the spindle tilt's.
    pub after: Dispersion,
    /// The generic table.
    pub rows: Vec<DeviationRow>,
    /// What the u leave out.
    pub u_note: Option<&'static str>,
    /// Which figures the deviations came from.
    pub source: Source,
}

/// The correction of the type-M record `current` (number `record`) for seed 002's
/// deviations: [`MixedRecord::corrected`], each value's u through the covariance, the spindle
/// tilt it cannot take and the dispersion before and after; refused when the part's chain is
/// open, v1
/// does not run along Y or v2 along Z (seed 002's B and C), a length would change by more
/// than `max_change_um`, or a vector or the offset turn by more than `max_turn_urad`.
pub fn correct(
    record: u16,
    current: &MixedRecord,
    measured: &Seed002Deviations,
    face_z_mm: f64,
    grid: &MixedGrid,
    max_change_um: f64,
    max_turn_urad: f64,
) -> Result<MixedCorrection, NcError> {
    let bad = |field: &'static str, what: String| NcError { field, what };
    let gap = current.part_gap_mm();
    if gap.is_nan() || gap > 1e-6 {
        return Err(bad(
            "--carr",
            format!(
                "l4 ($TC_CARR18…20) is {gap:.4} mm from −l3: not a fixed table's closed chain \
                 (W1), which the correction keeps"
            ),
        ));
    }
    // seed 002's machine: B turns the tool about Y, C the table about Z (within 1°)
    let along = |v: [f64; 3], k: usize| {
        unit(v)
            .get(k)
            .is_some_and(|c| c.abs() > 1f64.to_radians().cos())
    };
    if !along(current.v1(), 1) || !along(current.v2(), 2) {
        return Err(bad(
            "--carr",
            "seed 002's machine turns the tool about Y (B) and the table about Z (C): v1 \
             ($TC_CARR7…9) must run along Y and v2 ($TC_CARR10…12) along Z"
                .into(),
        ));
    }
    let d = &measured.deviations;
    let corrected = current.corrected(d, face_z_mm);
    MixedRecord::values(record, current, &corrected, &[]).check_lengths(max_change_um)?;
    let offset_turn = (corrected.offset1_deg() - current.offset1_deg())
        .to_radians()
        .abs()
        * 1e6;
    check_turns(
        &[
            (turn_urad(current.v1(), corrected.v1()), "v1 ($TC_CARR7…9)"),
            (
                turn_urad(current.v2(), corrected.v2()),
                "v2 ($TC_CARR10…12)",
            ),
            (offset_turn, "axis 1's offset ($TC_CARR24)"),
        ],
        max_turn_urad,
    )?;
    // each deviation moved by its u: the values' changes, then u² = Σᵢⱼ cᵢ·cⱼ·rᵢⱼ
    let cov = &measured.covariance;
    let sigma: [f64; 13] = std::array::from_fn(|i| cov[i][i].max(0.0).sqrt());
    let changes: Vec<[f64; 19]> = (0..13)
        .map(|i| {
            let mut moved = d.to_array();
            moved[i] += sigma[i];
            let p = current.corrected(&Deviations::from_array(&moved), face_z_mm);
            std::array::from_fn(|k| p.0[k] - corrected.0[k])
        })
        .collect();
    let mut var = [0.0f64; 19];
    for (i, ci) in changes.iter().enumerate() {
        for (j, cj) in changes.iter().enumerate() {
            let (si, sj) = (sigma[i], sigma[j]);
            if si == 0.0 || sj == 0.0 {
                continue;
            }
            let r = cov[i][j] / (si * sj);
            for k in 0..19 {
                var[k] += r * ci[k] * cj[k];
            }
        }
    }
    let (a, b) = (Parameter::AlphaBt.index(), Parameter::AlphaXb.index());
    let tilt = d.alpha_bt_urad + d.alpha_xb_urad;
    let u_tilt = (cov[a][a] + cov[b][b] + 2.0 * cov[a][b]).max(0.0).sqrt();
    // the figures' names: the model mode's, or the touch probe's of the axes probed
    let named = |p: Parameter| match measured.source {
        Source::Model => Some(p.name()),
        Source::Probe { b_axis, c_axis } => [(PROBE_B, b_axis), (PROBE_C, c_axis)]
            .into_iter()
            .filter(|(_, probed)| *probed)
            .find_map(|(figures, _)| figures.iter().find(|(_, q)| *q == p).map(|(n, _)| *n)),
    };
    let rows = ROWS
        .iter()
        .filter_map(|&(p, iso, control)| {
            let name = named(p)?;
            let (value, u, unit) = if p.is_positional() {
                (d.get(p), sigma[p.index()], "um")
            } else {
                (
                    urad_to_arcsec(d.get(p)),
                    urad_to_arcsec(sigma[p.index()]),
                    "arcsec",
                )
            };
            Some(DeviationRow {
                name,
                iso,
                value,
                u,
                unit,
                control: control.into(),
            })
        })
        .collect();
    let actual = corrected;
    Ok(MixedCorrection {
        record,
        current: *current,
        corrected,
        u: var.map(|v| v.max(0.0).sqrt()),
        spindle_tilt_urad: (tilt, u_tilt),
        face_z_mm,
        before: grid.dispersion(current, &actual, tilt * 1e-6),
        after: grid.dispersion(&corrected, &actual, tilt * 1e-6),
        rows,
        u_note: measured.u_note,
        source: measured.source,
    })
}

/// The correction as part-program assignments (`$TC_CARRn[record]=…`), with the dispersion,
/// what the record cannot take and the generic table as comments.
pub fn mixed_lines(c: &MixedCorrection, source: &str) -> String {
    use std::fmt::Write as _;
    let n = c.record;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "; swivel data record {n} ($TC_CARR23[{n}]=\"M\") corrected from {source} (cargo ncgen -- kins)"
    );
    let _ = writeln!(
        s,
        "; tool-centre error over the grid: before max {:.2} µm rms {:.2} µm; after (the spindle's tilt) max {:.2} µm rms {:.2} µm",
        c.before.max_um, c.before.rms_um, c.after.max_um, c.after.rms_um
    );
    let _ = writeln!(
        s,
        "; base values: the fine offsets $TC_CARR41…65[{n}] must be 0 (or subtract them)"
    );
    let _ = writeln!(
        s,
        "; C's position (dx_CZ, dy_CZ) taken at the table face, Z = {:.3} mm",
        c.face_z_mm
    );
    if let Some(note) = c.u_note {
        let _ = writeln!(s, "; u: {note}");
    }
    if let Source::Probe { b_axis, c_axis } = c.source {
        let _ = writeln!(
            s,
            "; from the touch-probe figures (probe_*): B's tilt (alpha_XB, gamma_XB) is not separable from the spindle's with B = 0/90°: v1 stays"
        );
        if !b_axis {
            let _ = writeln!(s, "; B axis not probed: l1, l2 and the offset stay");
        }
        if !c_axis {
            let _ = writeln!(s, "; C axis not probed: l3, l4 and v2 stay");
        }
    }
    let (tilt, u) = c.spindle_tilt_urad;
    let tilt = match c.source {
        Source::Probe { b_axis: false, .. } => "not measured (the B axis was not probed)".into(),
        _ => format!(
            "{:+.2}″ (u {:.2}″)",
            urad_to_arcsec(tilt),
            urad_to_arcsec(u)
        ),
    };
    let _ = writeln!(
        s,
        "; not expressible in a type M record: the spindle's tilt about X at B = 0 (alpha_BT + alpha_XB) {tilt}"
    );
    let _ = writeln!(
        s,
        "; not identified: the linear axes' squareness (gamma_XY, alpha_YZ, beta_YZ): the control's squareness compensation"
    );
    MixedRecord::values(n, &c.current, &c.corrected, &c.u).write_assignments(&mut s);
    rows_as_comments(&mut s, ";", &c.rows);
    s
}

/// The generic table as CSV, the spindle tilt, then the record's values (`carr:N`, the
/// corrected value, its u, the present value).
pub fn mixed_csv(c: &MixedCorrection) -> String {
    use std::fmt::Write as _;
    let mut s = rows_csv(&c.rows);
    let (tilt, u) = c.spindle_tilt_urad;
    let _ = writeln!(
        s,
        "alpha_BT + alpha_XB,the spindle's tilt about X at B = 0,{:?},{:?},arcsec,\"not expressible in a type M record\"",
        urad_to_arcsec(tilt),
        urad_to_arcsec(u)
    );
    MixedRecord::values(c.record, &c.current, &c.corrected, &c.u).write_csv(&mut s);
    s
}
