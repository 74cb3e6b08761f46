//! Corrections a control takes: the rotary-axis lines a test identified on a table-tilting
//! machine, written into the control's kinematics — LinuxCNC's `xyzac-trt-kins` (A tilts the
//! table about X, C turns it about Z) and `xyzbc-trt-kins` (B about Y, C about Z)
//! (`cargo ncgen -- kins`).
//!
//! A trt kinematics turns the work point about two lines (LinuxCNC `trtfuncs.c`): the table
//! axis C through (`x-rot-point`, `y-rot-point`) along Z, then the tilt axis — A through
//! (`y-rot-point + y-offset`, `z-rot-point + z-offset + tool-offset`) along X, or B through
//! (`x-rot-point + x-offset`, `z-rot-point + z-offset + tool-offset`) along Y. So it takes
//! where each line is, never which way it points: each line is placed where the measured one
//! crosses the work (C at the work point's height, A at its X, B at its Y), `z-rot-point` and
//! `tool-offset` stay, and the lines' tilts are reported as what the control cannot express,
//! with the tool-centre error they leave ([`Dispersion`]: before, with the control's present
//! values, and after, with the corrected ones — computed, as cycle 451's log states them
//! measured).
//!
//! The lines come as deviations from the control's own ([`LineDeviations`]): what a test
//! measures is the machine against the model the control commanded it with. From the R-test
//! ([`rtest_deviations`]): seed 003's location errors through `methods::rtest::axis_lines`.
//! A correction that would move a pin by more than the guard is refused with both numbers
//! (KinematicsOpt's maximum correction).

use crate::methods::centreline::AxisLine;
use crate::methods::rtest::{ARCSEC_RAD, LocationErrors, RtestGeometry, RtestParam, axis_lines};
use nalgebra::{Rotation3, Unit, Vector3};

use super::NcError;

/// A LinuxCNC table-rotary-tilting kinematics.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TrtKins {
    /// `xyzac-trt-kins`: A tilts the table about X, C turns it about Z.
    Xyzac,
    /// `xyzbc-trt-kins`: B tilts the table about Y, C turns it about Z.
    Xyzbc,
}

/// One HAL pin of a trt kinematics (the index into [`TrtPins`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pin {
    /// `x-rot-point`, mm.
    XRotPoint,
    /// `y-rot-point`, mm.
    YRotPoint,
    /// `z-rot-point`, mm.
    ZRotPoint,
    /// `x-offset`, mm (xyzbc).
    XOffset,
    /// `y-offset`, mm (xyzac).
    YOffset,
    /// `z-offset`, mm.
    ZOffset,
    /// `tool-offset`, mm (the tool's length; the control's, never corrected here).
    ToolOffset,
}

impl Pin {
    /// Every pin, in [`TrtPins`] order.
    pub const ALL: [Self; 7] = [
        Self::XRotPoint,
        Self::YRotPoint,
        Self::ZRotPoint,
        Self::XOffset,
        Self::YOffset,
        Self::ZOffset,
        Self::ToolOffset,
    ];

    /// The pin's name after the kinematics' prefix.
    pub fn name(self) -> &'static str {
        match self {
            Self::XRotPoint => "x-rot-point",
            Self::YRotPoint => "y-rot-point",
            Self::ZRotPoint => "z-rot-point",
            Self::XOffset => "x-offset",
            Self::YOffset => "y-offset",
            Self::ZOffset => "z-offset",
            Self::ToolOffset => "tool-offset",
        }
    }

    /// The pin of `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == name)
    }
}

/// The pins' values, mm, in [`Pin::ALL`] order.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TrtPins(pub [f64; 7]);

impl TrtPins {
    /// The value of `pin`, mm.
    pub fn get(&self, pin: Pin) -> f64 {
        self.0[pin as usize]
    }

    fn set(&mut self, pin: Pin, v: f64) {
        self.0[pin as usize] = v;
    }
}

impl TrtKins {
    /// The kinematics' module name (and its HAL pins' prefix).
    pub fn name(self) -> &'static str {
        match self {
            Self::Xyzac => "xyzac-trt-kins",
            Self::Xyzbc => "xyzbc-trt-kins",
        }
    }

    /// The tilt axis's letter.
    pub fn tilt_letter(self) -> char {
        match self {
            Self::Xyzac => 'A',
            Self::Xyzbc => 'B',
        }
    }

    /// The pins that take `feeds`, as the generic table says it.
    fn parameter(self, feeds: Feeds) -> String {
        let t = self.tilt_letter();
        match feeds {
            Feeds::SetUp => "none: the ball's place on the table, not the machine".into(),
            Feeds::TiltPoint(2) => format!("{t} axis Z: z-rot-point + z-offset + tool-offset"),
            Feeds::TiltPoint(k) if k == self.tilt_along() => {
                format!("none: along the {t} axis itself")
            }
            Feeds::TiltPoint(k) => {
                let x = axis_letter(k).to_ascii_lowercase();
                format!("{t} axis {}: {x}-rot-point + {x}-offset", axis_letter(k))
            }
            Feeds::TablePoint(k) => format!(
                "C axis {}: {}-rot-point",
                axis_letter(k),
                axis_letter(k).to_ascii_lowercase()
            ),
            Feeds::TiltDirection | Feeds::TableDirection => "not expressible (a direction)".into(),
        }
    }

    /// The machine axis the tilt axis runs along (0 = X, 1 = Y).
    fn tilt_along(self) -> usize {
        match self {
            Self::Xyzac => 0,
            Self::Xyzbc => 1,
        }
    }

    /// The pins this kinematics reads (the other offset is not a pin of it).
    pub fn pins(self) -> [Pin; 6] {
        let offset = match self {
            Self::Xyzac => Pin::YOffset,
            Self::Xyzbc => Pin::XOffset,
        };
        [
            Pin::XRotPoint,
            Pin::YRotPoint,
            Pin::ZRotPoint,
            offset,
            Pin::ZOffset,
            Pin::ToolOffset,
        ]
    }

    /// The two lines the kinematics turns the work about, at tilt = table = 0: the tilt axis
    /// and the table axis (mm, unit directions).
    pub fn lines(self, p: &TrtPins) -> TableLines {
        let (xr, yr, zr) = (
            p.get(Pin::XRotPoint),
            p.get(Pin::YRotPoint),
            p.get(Pin::ZRotPoint),
        );
        let z_tilt = zr + p.get(Pin::ZOffset) + p.get(Pin::ToolOffset);
        let tilt = match self {
            Self::Xyzac => AxisLine {
                direction: [1.0, 0.0, 0.0],
                point_mm: [xr, yr + p.get(Pin::YOffset), z_tilt],
            },
            Self::Xyzbc => AxisLine {
                direction: [0.0, 1.0, 0.0],
                point_mm: [xr + p.get(Pin::XOffset), yr, z_tilt],
            },
        };
        TableLines {
            tilt,
            table: AxisLine {
                direction: [0.0, 0.0, 1.0],
                point_mm: [xr, yr, z_tilt],
            },
        }
    }
}

/// A table-tilting machine's two rotary-axis lines at tilt = table = 0, in the control's
/// coordinates (mm; the tool tip over the table, machine axes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TableLines {
    /// The tilt axis (A or B), fixed in the machine.
    pub tilt: AxisLine,
    /// The table axis (C), carried by the tilt axis.
    pub table: AxisLine,
}

/// The point of `line` nearest `p` (mm).
pub(super) fn nearest(line: &AxisLine, p: [f64; 3]) -> [f64; 3] {
    let d = unit(line.direction);
    let o = line.point_mm;
    let s: f64 = (0..3).map(|k| (p[k] - o[k]) * d[k]).sum();
    std::array::from_fn(|k| o[k] + s * d[k])
}

impl TableLines {
    /// The same lines given at the points [`LineDeviations`] are taken at: the tilt axis where
    /// it passes nearest the table axis's point, the table axis nearest that (for LinuxCNC's
    /// lines, the points they already have).
    pub fn at_reference(&self) -> Self {
        let tilt = nearest(&self.tilt, self.table.point_mm);
        Self {
            tilt: AxisLine {
                direction: self.tilt.direction,
                point_mm: tilt,
            },
            table: AxisLine {
                direction: self.table.direction,
                point_mm: nearest(&self.table, tilt),
            },
        }
    }
}

/// Where the work point `work_mm` (the table at tilt = table = 0) is at `tilt_deg`,
/// `table_deg`: turned about the table line, then about the tilt line, right-handed about
/// each line's direction (exact rotations).
pub fn turned(lines: &TableLines, work_mm: [f64; 3], tilt_deg: f64, table_deg: f64) -> [f64; 3] {
    let about = |l: &AxisLine, deg: f64, p: Vector3<f64>| {
        let axis = Unit::new_normalize(Vector3::from(l.direction));
        let o = Vector3::from(l.point_mm);
        Rotation3::from_axis_angle(&axis, deg.to_radians()) * (p - o) + o
    };
    let p = about(&lines.table, table_deg, Vector3::from(work_mm));
    about(&lines.tilt, tilt_deg, p).into()
}

/// How the measured lines differ from the control's: each line's point moved (mm, at the
/// control line's point: for [`TrtKins::lines`] the tilt axis where it passes under the table
/// axis, the table axis at the tilt axis's height) and its direction turned (the measured unit
/// direction less the nominal axis's, rad to first order). A test measures the machine against
/// the kinematics the control commanded it with, so both are the control's errors, whatever
/// its lines are — axis-parallel (LinuxCNC's) or tilted by an earlier correction (a Siemens
/// swivel data record's vectors).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineDeviations {
    /// The tilt axis: point shift (mm), direction change.
    pub tilt: ([f64; 3], [f64; 3]),
    /// The table axis at tilt = 0: point shift (mm), direction change.
    pub table: ([f64; 3], [f64; 3]),
}

impl LineDeviations {
    /// The measured lines in the control's coordinates: the control's lines moved and turned.
    pub fn actual(&self, control: &TableLines) -> TableLines {
        let moved = |l: &AxisLine, (d, turn): ([f64; 3], [f64; 3])| AxisLine {
            direction: unit(std::array::from_fn(|k| l.direction[k] + turn[k])),
            point_mm: [
                l.point_mm[0] + d[0],
                l.point_mm[1] + d[1],
                l.point_mm[2] + d[2],
            ],
        };
        TableLines {
            tilt: moved(&control.tilt, self.tilt),
            table: moved(&control.table, self.table),
        }
    }
}

/// `d` scaled to unit length.
pub(super) fn unit(d: [f64; 3]) -> [f64; 3] {
    let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    d.map(|v| v / n)
}

/// `d` less the unit axis `k` (a direction's change from the nominal axis).
fn less_axis(d: [f64; 3], k: usize) -> [f64; 3] {
    std::array::from_fn(|i| d[i] - f64::from(u8::from(i == k)))
}

/// Where `line` crosses the plane `coordinate[axis] = at` (mm); `None` when it runs in it.
fn crossing(line: &AxisLine, axis: usize, at: f64) -> Option<[f64; 3]> {
    let d = line.direction;
    let p = line.point_mm;
    let da = *d.get(axis)?;
    if da.abs() < 1e-9 {
        return None;
    }
    let s = (at - p.get(axis)?) / da;
    Some([p[0] + s * d[0], p[1] + s * d[1], p[2] + s * d[2]])
}

/// The pins that put the control's lines where `actual`'s cross the work at `work_mm`: the
/// table axis at the work point's height, the tilt axis at its X (A) or Y (B);
/// `z-rot-point`, `tool-offset` and the pin the kinematics does not read stay as in `current`.
pub fn placed_pins(
    kins: TrtKins,
    current: &TrtPins,
    actual: &TableLines,
    work_mm: [f64; 3],
) -> Option<TrtPins> {
    let c = crossing(&actual.table, 2, work_mm[2])?;
    let along = kins.tilt_along();
    let t = crossing(&actual.tilt, along, *work_mm.get(along)?)?;
    let mut p = *current;
    p.set(Pin::XRotPoint, c[0]);
    p.set(Pin::YRotPoint, c[1]);
    match kins {
        TrtKins::Xyzac => p.set(Pin::YOffset, t[1] - c[1]),
        TrtKins::Xyzbc => p.set(Pin::XOffset, t[0] - c[0]),
    }
    p.set(
        Pin::ZOffset,
        t[2] - current.get(Pin::ZRotPoint) - current.get(Pin::ToolOffset),
    );
    Some(p)
}

/// The tool-centre error a kinematics leaves (µm): the tool where the control puts it less
/// where the work point is, over [`DispersionGrid`]'s poses and points.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Dispersion {
    /// Largest length of the error vector, µm.
    pub max_um: f64,
    /// Root mean square of its length, µm.
    pub rms_um: f64,
}

impl Dispersion {
    /// The largest and the rms of error lengths (µm).
    pub(super) fn of(errors_um: impl IntoIterator<Item = f64>) -> Self {
        let (mut max, mut sum, mut n) = (0.0f64, 0.0, 0usize);
        for e in errors_um {
            max = max.max(e);
            sum += e * e;
            n += 1;
        }
        Self {
            max_um: max,
            rms_um: (sum / n.max(1) as f64).sqrt(),
        }
    }
}

/// The angles every 15° (or fewer, evenly) from `lo` to `hi` inclusive, degrees.
pub(super) fn every_15_deg((lo, hi): (f64, f64)) -> impl Iterator<Item = f64> {
    let steps = ((hi - lo) / 15.0).ceil().max(1.0) as usize;
    (0..=steps).map(move |i| lo + (hi - lo) * i as f64 / steps as f64)
}

/// `work_mm` and the eight corners of a cube of half side `half_side_mm` about it (the work
/// point alone when that is 0), mm.
pub(super) fn cube_about(work_mm: [f64; 3], half_side_mm: f64) -> Vec<[f64; 3]> {
    let h = half_side_mm;
    let mut points = vec![work_mm];
    if h > 0.0 {
        for k in 0..8 {
            let s = |bit: usize| if k & bit == 0 { -h } else { h };
            points.push([work_mm[0] + s(1), work_mm[1] + s(2), work_mm[2] + s(4)]);
        }
    }
    points
}

/// Where the dispersion is taken: every 15° of the tilt over its range and of the table over
/// a turn, at the work point and the eight corners of a cube about it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DispersionGrid {
    /// The tilt's range, degrees (low, high).
    pub tilt_range_deg: (f64, f64),
    /// Half the cube's side, mm (0: the work point only).
    pub half_side_mm: f64,
}

impl DispersionGrid {
    /// The dispersion of the control's model `control` against the machine's `actual` lines.
    pub fn dispersion(
        &self,
        control: &TableLines,
        actual: &TableLines,
        work_mm: [f64; 3],
    ) -> Dispersion {
        let points = cube_about(work_mm, self.half_side_mm);
        let mut errors = Vec::new();
        for tilt in every_15_deg(self.tilt_range_deg) {
            for j in 0..24 {
                let table = 15.0 * j as f64;
                for &w in &points {
                    let c = turned(control, w, tilt, table);
                    let a = turned(actual, w, tilt, table);
                    let e = ((c[0] - a[0]).powi(2) + (c[1] - a[1]).powi(2) + (c[2] - a[2]).powi(2))
                        .sqrt()
                        * 1e3;
                    errors.push(e);
                }
            }
        }
        Dispersion::of(errors)
    }
}

/// A direction the kinematics cannot take: a line's tilt from its nominal axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Unexpressed {
    /// What it is ("C axis tilt about Y").
    pub what: &'static str,
    /// ISO 230-1's symbol of the location error it stands for.
    pub iso: &'static str,
    /// Its value, arc-seconds.
    pub value_arcsec: f64,
    /// Its standard uncertainty, arc-seconds.
    pub u_arcsec: f64,
}

/// The four tilts of `lines` from their nominal axes (rad): the tilt axis's two, then the
/// table axis's about X and Y.
fn tilts(kins: TrtKins, lines: &TableLines) -> [(&'static str, &'static str, f64); 4] {
    let t = lines.tilt.direction;
    let c = lines.table.direction;
    let tilt = match kins {
        // A along X: about Y = −z/x, about Z = y/x
        TrtKins::Xyzac => [
            ("A axis tilt about Y", "E_B0A", -t[2] / t[0]),
            ("A axis tilt about Z", "E_C0A", t[1] / t[0]),
        ],
        // B along Y: about X = z/y, about Z = −x/y
        TrtKins::Xyzbc => [
            ("B axis tilt about X", "E_A0B", t[2] / t[1]),
            ("B axis tilt about Z", "E_C0B", -t[0] / t[1]),
        ],
    };
    [
        tilt[0],
        tilt[1],
        ("C axis tilt about X", "E_A0C", -c[1] / c[2]),
        ("C axis tilt about Y", "E_B0C", c[0] / c[2]),
    ]
}

/// One row of the generic table: a deviation, what ISO 230-1 calls it, its value and u, and
/// the control parameter it goes to.
#[derive(Clone, Debug, PartialEq)]
pub struct DeviationRow {
    /// The test's name for it (`XOC`).
    pub name: &'static str,
    /// ISO 230-1's symbol (`E_X0C`), or what it is when not a machine error.
    pub iso: &'static str,
    /// Value (µm or arc-seconds).
    pub value: f64,
    /// Standard uncertainty (same unit).
    pub u: f64,
    /// `um` or `arcsec`.
    pub unit: &'static str,
    /// The control parameter it goes to, or why none.
    pub control: String,
}

/// What `cargo ncgen -- kins` writes: the corrected pins, their u, what the kinematics cannot
/// take, the dispersion before and after, and the generic table.
#[derive(Clone, Debug, PartialEq)]
pub struct KinsCorrection {
    /// The kinematics.
    pub kins: TrtKins,
    /// The control's present values.
    pub current: TrtPins,
    /// The corrected values.
    pub corrected: TrtPins,
    /// Standard uncertainty of each corrected value, mm (0 where not changed).
    pub u_mm: [f64; 7],
    /// The lines' tilts the kinematics cannot take.
    pub unexpressed: [Unexpressed; 4],
    /// The tool-centre error with the present values (computed from the measured lines).
    pub before: Dispersion,
    /// The tool-centre error left with the corrected values: the unexpressed tilts' share.
    pub after: Dispersion,
    /// The generic table.
    pub rows: Vec<DeviationRow>,
    /// What the u leave out ([`MeasuredLines::u_note`]).
    pub u_note: Option<&'static str>,
}

/// The deviations of a test, with what moving each by its u does to the lines: the source
/// side of [`correct`].
pub struct MeasuredLines {
    /// The lines' deviations at the estimate.
    pub deviations: LineDeviations,
    /// The lines' deviations with each measured quantity moved by its standard uncertainty.
    pub moved_by_u: Vec<LineDeviations>,
    /// The correlated pairs among them: indices into `moved_by_u` and the correlation
    /// coefficient (the others are taken as uncorrelated).
    pub correlated: Vec<(usize, usize, f64)>,
    /// What the u leave out, said with the output (`None`: nothing known).
    pub u_note: Option<&'static str>,
    /// The generic table's rows, each with what it moves (its `control` column is filled by
    /// the target: [`correct`], [`super::carr::correct`]).
    pub rows: Vec<(DeviationRow, Feeds)>,
}

/// What of the lines a deviation moves: each target names the parameter that takes it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Feeds {
    /// The test's set-up (the ball's place on the table), not the machine.
    SetUp,
    /// The tilt axis's point, along machine axis 0 (X), 1 (Y) or 2 (Z).
    TiltPoint(usize),
    /// The table axis's point, along machine axis 0 (X) or 1 (Y).
    TablePoint(usize),
    /// The tilt axis's direction.
    TiltDirection,
    /// The table axis's direction.
    TableDirection,
}

/// A machine axis's letter (0 = X).
pub(super) fn axis_letter(k: usize) -> char {
    ['X', 'Y', 'Z'].get(k).copied().unwrap_or('?')
}

/// The correction of `current` for `measured`: the pins placed at the work point
/// ([`placed_pins`]), their u, the unexpressed tilts and the dispersion before and after;
/// refused when a pin would move by more than `max_change_um`.
pub fn correct(
    kins: TrtKins,
    current: &TrtPins,
    measured: &MeasuredLines,
    work_mm: [f64; 3],
    grid: &DispersionGrid,
    max_change_um: f64,
) -> Result<KinsCorrection, NcError> {
    let bad = |field: &'static str, what: String| NcError { field, what };
    let control = kins.lines(current);
    let place = |d: &LineDeviations| {
        placed_pins(kins, current, &d.actual(&control), work_mm).ok_or_else(|| {
            bad(
                "RESULTS",
                "a measured axis runs across its nominal one: not a table-tilting machine's".into(),
            )
        })
    };
    let actual = measured.deviations.actual(&control);
    let corrected = place(&measured.deviations)?;
    for pin in kins.pins() {
        let change_um = (corrected.get(pin) - current.get(pin)) * 1e3;
        if change_um.abs() > max_change_um {
            return Err(bad(
                "--max-change-um",
                format!(
                    "{}.{} would change by {change_um:+.1} µm, beyond the guard of {max_change_um} µm",
                    kins.name(),
                    pin.name()
                ),
            ));
        }
    }
    // each input moved by its u: the pins' and the tilts' changes, then
    // u² = Σ cᵢ² + 2 Σ r·cᵢ·cⱼ over the correlated pairs
    let base_tilts = tilts(kins, &actual);
    let mut changes = Vec::new();
    for d in &measured.moved_by_u {
        let p = place(d)?;
        let t = tilts(kins, &d.actual(&control));
        let pins: [f64; 7] = std::array::from_fn(|k| p.0[k] - corrected.0[k]);
        let tilt: [f64; 4] = std::array::from_fn(|k| t[k].2 - base_tilts[k].2);
        changes.push((pins, tilt));
    }
    let mut var = [0.0f64; 7];
    let mut tilt_var = [0.0f64; 4];
    for (p, t) in &changes {
        var.iter_mut().zip(p).for_each(|(v, c)| *v += c * c);
        tilt_var.iter_mut().zip(t).for_each(|(v, c)| *v += c * c);
    }
    for &(i, j, r) in &measured.correlated {
        if let (Some((pi, ti)), Some((pj, tj))) = (changes.get(i), changes.get(j)) {
            for k in 0..7 {
                var[k] += 2.0 * r * pi[k] * pj[k];
            }
            for k in 0..4 {
                tilt_var[k] += 2.0 * r * ti[k] * tj[k];
            }
        }
    }
    let unexpressed = std::array::from_fn(|k| Unexpressed {
        what: base_tilts[k].0,
        iso: base_tilts[k].1,
        value_arcsec: base_tilts[k].2 / ARCSEC_RAD,
        u_arcsec: tilt_var[k].sqrt() / ARCSEC_RAD,
    });
    let rows = measured
        .rows
        .iter()
        .map(|(r, feeds)| DeviationRow {
            control: kins.parameter(*feeds),
            ..r.clone()
        })
        .collect();
    Ok(KinsCorrection {
        kins,
        current: *current,
        corrected,
        u_mm: var.map(f64::sqrt),
        unexpressed,
        before: grid.dispersion(&control, &actual, work_mm),
        after: grid.dispersion(&kins.lines(&corrected), &actual, work_mm),
        rows,
        u_note: measured.u_note,
    })
}

/// The R-test's set-up in the control's coordinates: where the ball (the work point) is.
/// The seed 003 geometry puts the ball at (X_w, Y_w, Z_w) from the C-frame origin, which is
/// Z_c above the A axis on the C axis: so the ball is at (x-rot-point + X_w, y-rot-point +
/// Y_w, A's height + Z_c + Z_w).
pub fn rtest_work_point(g: &RtestGeometry, current: &TrtPins) -> [f64; 3] {
    rtest_ball(g, &TrtKins::Xyzac.lines(current))
}

/// The R-test's ball for a control whose lines are `lines` (at their reference points,
/// [`TableLines::at_reference`]): (X_w, Y_w, Z_w) from the C-frame origin, which is on the C
/// axis Z_c above the A axis (seed 003's chain: on a tilted C axis, where it has risen Z_c).
pub fn rtest_ball(g: &RtestGeometry, lines: &TableLines) -> [f64; 3] {
    let z = lines.tilt.point_mm[2] + g.z_c_mm;
    let o = crossing(&lines.table, 2, z).unwrap_or([
        lines.table.point_mm[0],
        lines.table.point_mm[1],
        z,
    ]);
    [o[0] + g.x_w_mm, o[1] + g.y_w_mm, o[2] + g.z_w_mm]
}

/// The R-test's location errors as line deviations (`methods::rtest::axis_lines`, each
/// against the nominal line of `g`), with each moved by its u and their correlations
/// (`correlation`, [`RtestParam::ALL`] order; `None`: taken as uncorrelated, and said so), and
/// the generic table's rows.
pub fn rtest_deviations(
    g: &RtestGeometry,
    errors: &LocationErrors,
    u: &LocationErrors,
    correlation: Option<&[[f64; 11]; 11]>,
) -> Result<MeasuredLines, NcError> {
    let lines = |e: &LocationErrors| -> Result<LineDeviations, NcError> {
        let (a, c) = axis_lines(g, e).map_err(|x| NcError {
            field: "RESULTS",
            what: format!("the R-test's axis lines: {x:?}"),
        })?;
        // each deviation at the point the control's line is given by (`TrtKins::lines`):
        // the A axis where it passes under the C axis (X = X_c), the C axis at the A axis's
        // height (Z = 0); the R-test frame has the nominal A axis through its origin
        let at = |l: &AxisLine, axis: usize, v: f64, nominal: [f64; 3]| {
            crossing(l, axis, v)
                .map(|p| std::array::from_fn(|k| p[k] - nominal[k]))
                .ok_or_else(|| NcError {
                    field: "RESULTS",
                    what: "an R-test axis line runs across its nominal one".into(),
                })
        };
        Ok(LineDeviations {
            tilt: (
                at(&a, 0, g.x_c_mm, [g.x_c_mm, 0.0, 0.0])?,
                less_axis(unit(a.direction), 0),
            ),
            table: (
                at(&c, 2, 0.0, [g.x_c_mm, g.y_c_mm, 0.0])?,
                less_axis(unit(c.direction), 2),
            ),
        })
    };
    let (v, uv) = (errors.to_array(), u.to_array());
    let mut moved_by_u = Vec::new();
    for k in 0..11 {
        let mut m = v;
        m[k] += uv[k];
        moved_by_u.push(lines(&LocationErrors::from_array(m))?);
    }
    let rows = RtestParam::ALL
        .iter()
        .map(|&p| {
            let (iso, feeds) = match p {
                RtestParam::Xow => ("ball position X (set-up)", Feeds::SetUp),
                RtestParam::Yow => ("ball position Y (set-up)", Feeds::SetUp),
                RtestParam::Zow => ("ball position Z (set-up)", Feeds::SetUp),
                RtestParam::Yoa => ("E_Y0A", Feeds::TiltPoint(1)),
                RtestParam::Zoa => ("E_Z0A", Feeds::TiltPoint(2)),
                RtestParam::Boa => ("E_B0A", Feeds::TiltDirection),
                RtestParam::Coa => ("E_C0A", Feeds::TiltDirection),
                RtestParam::Xoc => ("E_X0C", Feeds::TablePoint(0)),
                RtestParam::Yoc => ("E_Y0C", Feeds::TablePoint(1)),
                RtestParam::Aoc => ("E_A0C", Feeds::TableDirection),
                RtestParam::Boc => ("E_B0C", Feeds::TableDirection),
            };
            let name = p.name();
            let unit = if p.is_angular() { "arcsec" } else { "um" };
            (
                DeviationRow {
                    name,
                    iso,
                    value: v[p.index()],
                    u: uv[p.index()],
                    unit,
                    control: String::new(),
                },
                feeds,
            )
        })
        .collect();
    let mut correlated = Vec::new();
    if let Some(r) = correlation {
        for (i, row) in r.iter().enumerate() {
            for (j, &rij) in row.iter().enumerate().skip(i + 1) {
                if rij != 0.0 {
                    correlated.push((i, j, rij));
                }
            }
        }
    }
    Ok(MeasuredLines {
        deviations: lines(errors)?,
        moved_by_u,
        correlated,
        u_note: correlation.is_none().then_some(
            "the figures taken as uncorrelated (the results file has no rtest_covariance): the \
             corrected values' u are not their own",
        ),
        rows,
    })
}

/// The correction as HAL `setp` lines for the kinematics' pins, the dispersion, the
/// unexpressed tilts and the generic table as comments.
pub fn hal_lines(c: &KinsCorrection, source: &str) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let k = c.kins.name();
    let _ = writeln!(
        s,
        "# {k} pins corrected from {source} (cargo ncgen -- kins)"
    );
    let _ = writeln!(
        s,
        "# tool-centre error over the grid: before max {:.2} µm rms {:.2} µm; after (the unexpressed tilts) max {:.2} µm rms {:.2} µm",
        c.before.max_um, c.before.rms_um, c.after.max_um, c.after.rms_um
    );
    if let Some(note) = c.u_note {
        let _ = writeln!(s, "# u: {note}");
    }
    for u in &c.unexpressed {
        let _ = writeln!(
            s,
            "# not expressible in {k}: {} ({}) {:+.2}″ (u {:.2}″)",
            u.what, u.iso, u.value_arcsec, u.u_arcsec
        );
    }
    for pin in c.kins.pins() {
        let (was, now) = (c.current.get(pin), c.corrected.get(pin));
        if pin == Pin::ToolOffset {
            continue;
        }
        let _ = writeln!(
            s,
            "setp {k}.{} {now:.6}  # was {was:.6}: {:+.1} µm (u {:.1} µm)",
            pin.name(),
            (now - was) * 1e3,
            c.u_mm[pin as usize] * 1e3
        );
    }
    rows_as_comments(&mut s, "#", &c.rows);
    s
}

/// The generic table's rows as comment lines after `comment` (`#` in HAL, `;` in a part
/// program).
pub(super) fn rows_as_comments(s: &mut String, comment: &str, rows: &[DeviationRow]) {
    use std::fmt::Write as _;
    let _ = writeln!(
        s,
        "{comment} deviation | ISO 230-1 | value | u | unit | control parameter"
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{comment} {} | {} | {:+.3} | {:.3} | {} | {}",
            r.name, r.iso, r.value, r.u, r.unit, r.control
        );
    }
}

/// The generic table as CSV: its header and rows (deviation, ISO 230-1 name, value, u, unit,
/// control parameter).
pub(super) fn rows_csv(rows: &[DeviationRow]) -> String {
    use std::fmt::Write as _;
    let mut s = String::from("deviation,iso_230_1,value,u,unit,control\n");
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{:?},{:?},{},\"{}\"",
            r.name, r.iso, r.value, r.u, r.unit, r.control
        );
    }
    s
}

/// The generic table as CSV (deviation, ISO 230-1 name, value, u, unit, control parameter),
/// then the pins (`pin:NAME`, the corrected value, its u, mm, the present value).
pub fn table_csv(c: &KinsCorrection) -> String {
    use std::fmt::Write as _;
    let mut s = rows_csv(&c.rows);
    for u in &c.unexpressed {
        let _ = writeln!(
            s,
            "{},{},{:?},{:?},arcsec,\"not expressible in {}\"",
            u.what,
            u.iso,
            u.value_arcsec,
            u.u_arcsec,
            c.kins.name()
        );
    }
    for pin in c.kins.pins() {
        let _ = writeln!(
            s,
            "pin:{},{}.{},{:?},{:?},mm,\"was {:?}\"",
            pin.name(),
            c.kins.name(),
            pin.name(),
            c.corrected.get(pin),
            c.u_mm[pin as usize],
            c.current.get(pin)
        );
    }
    s
}

/// The R-test frame's nominal pins for `g` (the A axis through the origin, C at (X_c, Y_c)):
/// the values a control set from the machine's drawing would hold, `z-rot-point` on the A
/// axis.
pub fn rtest_nominal_pins(g: &RtestGeometry) -> TrtPins {
    let mut p = TrtPins::default();
    p.set(Pin::XRotPoint, g.x_c_mm);
    p.set(Pin::YRotPoint, g.y_c_mm);
    // (0 − y, not −y: a Y_c of 0 gives +0, which prints as 0, not −0)
    p.set(Pin::YOffset, 0.0 - g.y_c_mm);
    p
}

/// One figure of a results file (`results.json`): its name, value and u (either may be null).
#[derive(serde::Deserialize)]
pub(super) struct Figure {
    /// The figure's name (`dx_BT`, `rtest_XOW`).
    pub name: String,
    /// Its value, in its unit.
    #[serde(default)]
    pub value: Option<f64>,
    /// Its standard uncertainty.
    #[serde(default)]
    pub u: Option<f64>,
}

/// A results file's figures: the pod's (`results`) and the host's (`host`).
#[derive(serde::Deserialize)]
pub(super) struct Figures {
    /// The pod's results table.
    #[serde(default)]
    pub results: Vec<Figure>,
    /// The host's figures (the R-test's).
    #[serde(default)]
    pub host: Vec<Figure>,
}

/// The R-test's location errors and their u from a results file (`results.json` of `cargo
/// replay`: `host[]`'s `rtest_XOW` … `rtest_BOC`, µm and arc-seconds). A file of another test
/// is refused with the reason: seed 002's deviations belong to a machine that turns the tool
/// (B head) and the table (C), which no trt kinematics describes. With `rtest_covariance`
/// (as `cargo replay` writes it) the figures' correlations too ([`RtestParam::ALL`] order).
#[allow(clippy::type_complexity)] // (the three parts are named in the doc)
pub fn rtest_from_results(
    json: &str,
) -> Result<(LocationErrors, LocationErrors, Option<[[f64; 11]; 11]>), NcError> {
    #[derive(serde::Deserialize)]
    struct File {
        #[serde(flatten)]
        figures: Figures,
        #[serde(default)]
        rtest_covariance: Option<crate::replay::DeviationCovariance>,
    }
    let bad = |what: String| NcError {
        field: "RESULTS",
        what,
    };
    let file: File = serde_json::from_str(json).map_err(|e| bad(e.to_string()))?;
    if !file
        .figures
        .host
        .iter()
        .any(|e| e.name.starts_with("rtest_"))
    {
        return Err(bad(
            if file.figures.results.iter().any(|e| e.name == "dx_BT") {
                "seed 002's deviations: its machine turns the tool about B and the table about C, \
             which neither a table-tilting (trt) kinematics nor a swivel table (SINUMERIK type \
             P) describes: `kins sinumerik-m` writes them into a mixed record (type M), \
             `ncgen correct` rewrites the program for them"
                    .into()
            } else {
                "no R-test results (host[]: rtest_XOW … rtest_BOC): run `cargo replay` on the \
             R-test's session file"
                    .into()
            },
        ));
    }
    let mut v = [0.0; 11];
    let mut u = [0.0; 11];
    for p in RtestParam::ALL {
        let name = format!("rtest_{}", p.name());
        let e = file
            .figures
            .host
            .iter()
            .find(|e| e.name == name)
            .ok_or_else(|| {
                bad(format!(
                    "{name}: not identified (the path does not determine it)"
                ))
            })?;
        let (x, ux) = (e.value.unwrap_or(f64::NAN), e.u.unwrap_or(f64::NAN));
        if !(x.is_finite() && ux.is_finite() && ux >= 0.0) {
            return Err(bad(format!("{name}: a finite value with a u ≥ 0")));
        }
        v[p.index()] = x;
        u[p.index()] = ux;
    }
    let correlation = match file.rtest_covariance {
        None => None,
        Some(c) => {
            let bad_cov = |what: String| bad(format!("rtest_covariance: {what}"));
            let index = |n: &String| {
                RtestParam::ALL
                    .into_iter()
                    .find(|p| format!("rtest_{}", p.name()) == *n)
                    .map(RtestParam::index)
                    .ok_or_else(|| bad_cov(format!("{n} is not an R-test figure")))
            };
            let idx = c.names.iter().map(index).collect::<Result<Vec<_>, _>>()?;
            if idx.len() != 11 || c.matrix.len() != 11 || c.matrix.iter().any(|r| r.len() != 11) {
                return Err(bad_cov("11 × 11 over the eleven figures".into()));
            }
            let mut r = [[0.0f64; 11]; 11];
            for (row, &i) in c.matrix.iter().zip(&idx) {
                for (&cij, &j) in row.iter().zip(&idx) {
                    let (ui, uj) = (u[i], u[j]);
                    let rij = if i == j { 1.0 } else { cij / (ui * uj) };
                    if !rij.is_finite() || rij.abs() > 1.0 + 1e-6 {
                        return Err(bad_cov(format!(
                            "{} × {}: a correlation outside −1 … 1 with the figures' u",
                            RtestParam::ALL[i].name(),
                            RtestParam::ALL[j].name()
                        )));
                    }
                    r[i][j] = rij.clamp(-1.0, 1.0);
                }
            }
            Some(r)
        }
    };
    Ok((
        LocationErrors::from_array(v),
        LocationErrors::from_array(u),
        correlation,
    ))
}

/// A centrelines file's lines (seed 004: the rotary table A, nominally ∥ Z, carried by the
/// tilting axis B, nominally ∥ Y — LinuxCNC's C and B of `xyzbc-trt-kins`) as line
/// deviations from its `[nominal]` ones, each `[uncertainty]` component moved by its u (the
/// pairs with their correlation), the generic table's rows, and the pins the nominal lines are
/// (the file's frame: `z-rot-point` 0). Refused without `[uncertainty]` (a pin is not written
/// without its u) or when the nominal lines are not along Z and Y.
pub fn centreline_deviations(
    file: &super::CentrelinesFile,
) -> Result<(MeasuredLines, TrtPins), NcError> {
    use super::CentrelinePair;
    use super::correct::Line;
    let bad = |what: String| NcError {
        field: "CENTRELINES",
        what,
    };
    let nominal = file.nominal.unwrap_or(CentrelinePair::NOMINAL);
    let (na, nb) = (unit(nominal.a_direction), unit(nominal.b_direction));
    if na[2].abs() < 1.0 - 1e-12 || nb[1].abs() < 1.0 - 1e-12 {
        return Err(bad(
            "nominal: the NC-set lines are not along Z (a) and Y (b), as xyzbc-trt-kins's are"
                .into(),
        ));
    }
    let u = file.uncertainty.as_ref().ok_or_else(|| {
        bad("uncertainty: the lines' standard uncertainties are needed for the pins' u".into())
    })?;
    // the deviations where the control's lines are given: B where it passes the table axis
    // (Y of nominal A), the table axis at B's height (Z of nominal B)
    let (y0, z0) = (nominal.a_point_mm[1], nominal.b_point_mm[2]);
    let line = |d: [f64; 3], p: [f64; 3]| AxisLine {
        direction: d,
        point_mm: p,
    };
    let (nom_a, nom_b) = (
        line(nominal.a_direction, nominal.a_point_mm),
        line(nominal.b_direction, nominal.b_point_mm),
    );
    let deviations = |a: &AxisLine, b: &AxisLine| -> Result<LineDeviations, NcError> {
        let shift = |actual: &AxisLine, nom: &AxisLine, axis: usize, at: f64| match (
            crossing(actual, axis, at),
            crossing(nom, axis, at),
        ) {
            (Some(p), Some(q)) => Ok(std::array::from_fn(|k| p[k] - q[k])),
            _ => Err(bad("a line runs across its nominal one".into())),
        };
        // directions along +Y (B) and +Z (A), as the kinematics' lines run
        let along = |d: [f64; 3], k: usize| {
            let d = unit(d);
            if d[k] < 0.0 { d.map(|v| -v) } else { d }
        };
        Ok(LineDeviations {
            tilt: (
                shift(b, &nom_b, 1, y0)?,
                less_axis(along(b.direction, 1), 1),
            ),
            table: (
                shift(a, &nom_a, 2, z0)?,
                less_axis(along(a.direction, 2), 2),
            ),
        })
    };
    let actual = &file.actual;
    let (act_a, act_b) = (
        line(actual.a_direction, actual.a_point_mm),
        line(actual.b_direction, actual.b_point_mm),
    );
    let mut moved_by_u = Vec::new();
    let mut correlated = Vec::new();
    for pair in u.pairs() {
        for k in 0..2 {
            let (mut a, mut b) = (act_a, act_b);
            let l = match pair.line {
                Line::A => &mut a,
                Line::B => &mut b,
            };
            let along = pair.along[k];
            if pair.tilt {
                let d = unit(l.direction);
                l.direction = std::array::from_fn(|i| d[i] + pair.u[k] * 1e-6 * along[i]);
            } else {
                l.point_mm = std::array::from_fn(|i| l.point_mm[i] + pair.u[k] * 1e-3 * along[i]);
            }
            moved_by_u.push(deviations(&a, &b)?);
        }
        let n = moved_by_u.len();
        if pair.correlation != 0.0 {
            correlated.push((n - 2, n - 1, pair.correlation));
        }
    }
    let dev = deviations(&act_a, &act_b)?;
    let (a_dir, b_dir) = (unit(act_a.direction), unit(act_b.direction));
    let (a_dir, b_dir) = (
        if a_dir[2] < 0.0 {
            a_dir.map(|v| -v)
        } else {
            a_dir
        },
        if b_dir[1] < 0.0 {
            b_dir.map(|v| -v)
        } else {
            b_dir
        },
    );
    let row = |name, iso, value: f64, u: f64, unit, feeds| {
        (
            DeviationRow {
                name,
                iso,
                value,
                u,
                unit,
                control: String::new(),
            },
            feeds,
        )
    };
    let rows = vec![
        row(
            "table tilt X",
            "E_B0C",
            a_dir[0] / a_dir[2] * 1e6,
            u.a_tilt_urad[0],
            "urad",
            Feeds::TableDirection,
        ),
        row(
            "table tilt Y",
            "−E_A0C",
            a_dir[1] / a_dir[2] * 1e6,
            u.a_tilt_urad[1],
            "urad",
            Feeds::TableDirection,
        ),
        row(
            "table point X",
            "E_X0C",
            dev.table.0[0] * 1e3,
            u.a_point_um[0],
            "um",
            Feeds::TablePoint(0),
        ),
        row(
            "table point Y",
            "E_Y0C",
            dev.table.0[1] * 1e3,
            u.a_point_um[1],
            "um",
            Feeds::TablePoint(1),
        ),
        row(
            "tilt axis tilt X",
            "−E_C0B",
            b_dir[0] / b_dir[1] * 1e6,
            u.b_tilt_urad[0],
            "urad",
            Feeds::TiltDirection,
        ),
        row(
            "tilt axis tilt −Z",
            "−E_A0B",
            -b_dir[2] / b_dir[1] * 1e6,
            u.b_tilt_urad[1],
            "urad",
            Feeds::TiltDirection,
        ),
        row(
            "tilt axis point X",
            "E_X0B",
            dev.tilt.0[0] * 1e3,
            u.b_point_um[0],
            "um",
            Feeds::TiltPoint(0),
        ),
        row(
            "tilt axis point Z",
            "E_Z0B",
            dev.tilt.0[2] * 1e3,
            u.b_point_um[1],
            "um",
            Feeds::TiltPoint(2),
        ),
    ];
    let mut pins = TrtPins::default();
    pins.set(Pin::XRotPoint, nominal.a_point_mm[0]);
    pins.set(Pin::YRotPoint, y0);
    pins.set(Pin::XOffset, nominal.b_point_mm[0] - nominal.a_point_mm[0]);
    pins.set(Pin::ZOffset, z0);
    Ok((
        MeasuredLines {
            deviations: dev,
            moved_by_u,
            correlated,
            u_note: None,
            rows,
        },
        pins,
    ))
}
