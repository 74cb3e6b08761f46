//! Corrections a SINUMERIK takes: the rotary-axis lines a test identified on a table-tilting
//! machine, written into an orientable toolholder of kinematic type P (`$TC_CARR23 = "P"`, a
//! swivel table; `cargo ncgen -- kins sinumerik-p`).
//!
//! The swivel data record turns the part about two lines (Siemens W1, "Toolholder with
//! orientation capability"; the chain in `forward_siemens_carr`): rotary axis 1 through l2
//! (`$TC_CARR4…6`) along v1 (`$TC_CARR7…9`) — the tilt axis, fixed in the machine — and
//! rotary axis 2 through l2 + l3 (`$TC_CARR15…17`) along v2 (`$TC_CARR10…12`) — the table,
//! carried by axis 1 — with l4 (`$TC_CARR18…20`) = −(l2 + l3) closing the chain. Unlike a
//! LinuxCNC trt kinematics it takes both where each line is and which way it points, so every
//! location error an R-test or a centreline measurement identifies goes into it: nothing is
//! left unexpressed, and the dispersion after is the measurement's own u.
//!
//! Each pivot goes to the point of its measured line nearest the present one (the smallest
//! change of l2 and l3), each vector to the measured direction with the present vector's
//! sense (the sense a positive angle turns the part, which a test of the lines does not see;
//! Siemens' commissioning lists enter a table axis's vector against its ISO direction, so a
//! record may hold (0, 0, −1) for C: that stays). The values go into the base parameters, as
//! a kinematics measuring cycle that writes the vectors does; the fine offsets
//! (`$TC_CARR41…60`) are left as they are and must be 0 for the base values to be the whole
//! truth (said in the output).

use crate::methods::centreline::AxisLine;
use crate::methods::rtest::{ARCSEC_RAD, RtestGeometry};

use super::NcError;
use super::kins::{
    DeviationRow, Dispersion, DispersionGrid, Feeds, MeasuredLines, TableLines, TrtKins,
    axis_letter, nearest, rows_as_comments, rows_csv, rtest_nominal_pins, unit,
};

/// The swivel data record's values the correction writes (type P): l2, v1, v2, l3, l4 —
/// [`PARAMETERS`] order; mm, the vectors unit length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SwivelTable(pub [f64; 15]);

/// The record's parameters the correction writes, in [`SwivelTable`] order: the `$TC_CARR`
/// number and what it is.
pub const PARAMETERS: [(u8, &str); 15] = [
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
];

/// Where each vector starts in [`SwivelTable`].
const L2: usize = 0;
const V1: usize = 3;
const V2: usize = 6;
const L3: usize = 9;
const L4: usize = 12;

/// What a swivel data record's value is: its unit, how it is printed and guarded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// A length, mm (to the nm; changes in µm, guarded by `--max-change-um`).
    Length,
    /// A direction component, unitless (to 1e-9; changes in µrad, the vector's turn guarded
    /// by `--max-turn-urad`).
    Direction,
    /// An angle, degrees (to 1e-9°; changes in arc-seconds, guarded by `--max-turn-urad`).
    Angle,
}

/// What the value at `k` of a [`SwivelTable`] is.
pub fn kind(k: usize) -> Kind {
    if (V1..L3).contains(&k) {
        Kind::Direction
    } else {
        Kind::Length
    }
}

/// The vector of a record's values starting at `at` (NaN past the end).
pub(super) fn vector_at(values: &[f64], at: usize) -> [f64; 3] {
    std::array::from_fn(|k| values.get(at + k).copied().unwrap_or(f64::NAN))
}

/// Sets the vector of a record's values starting at `at`.
pub(super) fn set_at(values: &mut [f64], at: usize, v: [f64; 3]) {
    for (k, x) in v.into_iter().enumerate() {
        if let Some(slot) = values.get_mut(at + k) {
            *slot = x;
        }
    }
}

/// How far `b` is turned from `a` (µrad; neither need be unit).
pub(super) fn turn_urad(a: [f64; 3], b: [f64; 3]) -> f64 {
    let (a, b) = (unit(a), unit(b));
    let cross = [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ];
    cross.iter().map(|c| c * c).sum::<f64>().sqrt() * 1e6
}

/// Refused when one of `turns` (µrad, and what turns) is beyond `max_turn_urad`.
pub(super) fn check_turns(turns: &[(f64, &str)], max_turn_urad: f64) -> Result<(), NcError> {
    for &(turn_urad, which) in turns {
        if turn_urad > max_turn_urad {
            return Err(NcError {
                field: "--max-turn-urad",
                what: format!(
                    "{which} would turn by {turn_urad:.1} µrad ({:.1}″), beyond the guard of \
                     {max_turn_urad} µrad",
                    turn_urad * 1e-6 / ARCSEC_RAD
                ),
            });
        }
    }
    Ok(())
}

/// A record's values as a correction holds them: the parameters (`$TC_CARR` number, what),
/// each one's kind, and the present and corrected values with the corrected ones' u.
pub(super) struct Values<'a> {
    /// The record's number (`$TC_CARR…[n]`).
    pub record: u16,
    /// The parameters, in the values' order.
    pub parameters: &'a [(u8, &'static str)],
    /// What each value is.
    pub kind: fn(usize) -> Kind,
    /// The control's present values.
    pub current: &'a [f64],
    /// The corrected values.
    pub corrected: &'a [f64],
    /// Their standard uncertainties.
    pub u: &'a [f64],
}

impl Values<'_> {
    /// Refused when a length would change by more than `max_change_um`.
    pub fn check_lengths(&self, max_change_um: f64) -> Result<(), NcError> {
        for (k, &(n, what)) in self.parameters.iter().enumerate() {
            if (self.kind)(k) != Kind::Length {
                continue;
            }
            let change_um = (self.corrected[k] - self.current[k]) * 1e3;
            if change_um.abs() > max_change_um {
                return Err(NcError {
                    field: "--max-change-um",
                    what: format!(
                        "$TC_CARR{n}[{}] ({what}) would change by {change_um:+.1} µm, beyond \
                         the guard of {max_change_um} µm",
                        self.record
                    ),
                });
            }
        }
        Ok(())
    }

    /// The values as part-program assignments (`$TC_CARRn[record]=…`, a SINUMERIK takes them
    /// in an MPF or from MDA), each with its present value, change and u as a comment.
    pub fn write_assignments(&self, s: &mut String) {
        use std::fmt::Write as _;
        for (k, &(p, what)) in self.parameters.iter().enumerate() {
            let kind = (self.kind)(k);
            let (was, now) = (self.current[k], self.corrected[k]);
            let (d, unit) = change(kind, now - was);
            let (u, _) = change(kind, self.u[k]);
            let _ = writeln!(
                s,
                "$TC_CARR{p}[{}]={} ; {what}, was {}: {d:+.1} {unit} (u {u:.1} {unit})",
                self.record,
                value(kind, now),
                value(kind, was)
            );
        }
    }

    /// The values as CSV rows (`carr:N`, the parameter, the corrected value, its u, the unit,
    /// the present value).
    pub fn write_csv(&self, s: &mut String) {
        use std::fmt::Write as _;
        for (k, &(p, what)) in self.parameters.iter().enumerate() {
            let _ = writeln!(
                s,
                "carr:{p},$TC_CARR{p}[{}] ({what}),{:?},{:?},{},\"was {:?}\"",
                self.record,
                self.corrected[k],
                self.u[k],
                match (self.kind)(k) {
                    Kind::Length => "mm",
                    Kind::Direction => "1",
                    Kind::Angle => "deg",
                },
                self.current[k]
            );
        }
    }
}

/// A value with its kind's digits (mm to the nm, a vector component or degrees to 1e-9); one
/// that rounds to 0 is 0, not −0.
fn value(kind: Kind, v: f64) -> String {
    let s = match kind {
        Kind::Length => format!("{v:.6}"),
        Kind::Direction | Kind::Angle => format!("{v:.9}"),
    };
    match s.strip_prefix('-') {
        Some(digits) if digits.chars().all(|c| c == '0' || c == '.') => digits.to_string(),
        _ => s,
    }
}

/// A change in its kind's unit for the comments (to 0.1): µm, µrad for a vector component,
/// arc-seconds for an angle; one that rounds to 0 is 0 (not −0.0).
fn change(kind: Kind, d: f64) -> (f64, &'static str) {
    let (v, unit) = match kind {
        Kind::Length => (d * 1e3, "µm"),
        Kind::Direction => (d * 1e6, "µrad"),
        Kind::Angle => (d.to_radians() / ARCSEC_RAD, "arcsec"),
    };
    (if (v * 10.0).round() == 0.0 { 0.0 } else { v }, unit)
}

impl SwivelTable {
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

    /// The record of l2, l3, v1, v2 with l4 = −(l2 + l3).
    pub fn closed(l2: [f64; 3], l3: [f64; 3], v1: [f64; 3], v2: [f64; 3]) -> Self {
        let mut t = Self([0.0; 15]);
        t.set(L2, l2);
        t.set(L3, l3);
        // (0 − x, not −x: a 0 prints as 0, not −0)
        t.set(L4, std::array::from_fn(|k| 0.0 - (l2[k] + l3[k])));
        t.set(V1, v1);
        t.set(V2, v2);
        t
    }

    /// l2, `$TC_CARR4…6`, mm.
    pub fn l2(&self) -> [f64; 3] {
        self.vector(L2)
    }
    /// l3, `$TC_CARR15…17`, mm.
    pub fn l3(&self) -> [f64; 3] {
        self.vector(L3)
    }
    /// l4, `$TC_CARR18…20`, mm.
    pub fn l4(&self) -> [f64; 3] {
        self.vector(L4)
    }
    /// v1, `$TC_CARR7…9`.
    pub fn v1(&self) -> [f64; 3] {
        self.vector(V1)
    }
    /// v2, `$TC_CARR10…12`.
    pub fn v2(&self) -> [f64; 3] {
        self.vector(V2)
    }

    /// How far l4 is from closing the chain, −(l2 + l3), mm (0 for a fixed swivel table).
    pub fn closure_gap_mm(&self) -> f64 {
        let (l2, l3, l4) = (self.l2(), self.l3(), self.l4());
        (0..3)
            .map(|k| (l4[k] + l2[k] + l3[k]).powi(2))
            .sum::<f64>()
            .sqrt()
    }

    /// The two lines the record turns the part about, at both angles 0: axis 1 through l2
    /// along v1, axis 2 through l2 + l3 along v2 (unit directions).
    pub fn lines(&self) -> TableLines {
        let (l2, l3) = (self.l2(), self.l3());
        TableLines {
            tilt: AxisLine {
                direction: unit(self.v1()),
                point_mm: l2,
            },
            table: AxisLine {
                direction: unit(self.v2()),
                point_mm: std::array::from_fn(|k| l2[k] + l3[k]),
            },
        }
    }

    /// The record whose lines are `actual`: each pivot the point of its line nearest this
    /// record's, each vector the line's unit direction with this record's sense, l4 closing.
    pub fn placed(&self, actual: &TableLines) -> Self {
        let present = self.lines();
        let p1 = nearest(&actual.tilt, present.tilt.point_mm);
        let p2 = nearest(&actual.table, present.table.point_mm);
        let sensed = |d: [f64; 3], like: [f64; 3]| {
            let d = unit(d);
            if (0..3).map(|k| d[k] * like[k]).sum::<f64>() < 0.0 {
                d.map(|v| -v)
            } else {
                d
            }
        };
        Self::closed(
            p1,
            std::array::from_fn(|k| p2[k] - p1[k]),
            sensed(actual.tilt.direction, self.v1()),
            sensed(actual.table.direction, self.v2()),
        )
    }

    /// The closed record whose lines are `lines`: l2 at the tilt axis's point, l3 from there
    /// to the table axis's, the vectors their directions.
    pub fn through(lines: &TableLines) -> Self {
        let (p1, p2) = (lines.tilt.point_mm, lines.table.point_mm);
        Self::closed(
            p1,
            std::array::from_fn(|k| p2[k] - p1[k]),
            lines.tilt.direction,
            lines.table.direction,
        )
    }

    /// The record a control set from the R-test frame's drawing holds: the lines of
    /// [`rtest_nominal_pins`] (axis 1, A, along +X under the C axis; axis 2, C, through
    /// (X_c, Y_c, 0) along +Z).
    pub fn rtest_nominal(g: &RtestGeometry) -> Self {
        Self::through(&TrtKins::Xyzac.lines(&rtest_nominal_pins(g)).at_reference())
    }
}

/// What `cargo ncgen -- kins sinumerik-p` writes: the corrected record, the u of each value,
/// the dispersion before and after, and the generic table.
#[derive(Clone, Debug, PartialEq)]
pub struct CarrCorrection {
    /// The record's number (`$TC_CARR…[n]`).
    pub record: u16,
    /// The control's present values.
    pub current: SwivelTable,
    /// The corrected values.
    pub corrected: SwivelTable,
    /// Standard uncertainty of each corrected value (mm; unitless for the vectors).
    pub u: [f64; 15],
    /// The tool-centre error with the present values (computed from the measured lines).
    pub before: Dispersion,
    /// The tool-centre error left with the corrected values (≈ 0: nothing is unexpressed).
    pub after: Dispersion,
    /// The generic table.
    pub rows: Vec<DeviationRow>,
    /// What the u leave out ([`MeasuredLines::u_note`]).
    pub u_note: Option<&'static str>,
}

/// The parameters that take `feeds`, as the generic table says it.
fn parameter(feeds: Feeds) -> String {
    match feeds {
        Feeds::SetUp => "none: the ball's place on the table, not the machine".into(),
        Feeds::TiltPoint(k) => format!(
            "axis 1's pivot {}: l2 $TC_CARR{} (l3, l4 follow)",
            axis_letter(k),
            4 + k
        ),
        Feeds::TablePoint(k) => format!(
            "axis 2's pivot {}: l3 $TC_CARR{} (l4 follows)",
            axis_letter(k),
            15 + k
        ),
        Feeds::TiltDirection => "axis 1's direction: v1 $TC_CARR7…9".into(),
        Feeds::TableDirection => "axis 2's direction: v2 $TC_CARR10…12".into(),
    }
}

/// The correction of the record `current` (number `record`) for `measured`: the pivots and
/// vectors placed on the measured lines ([`SwivelTable::placed`]), their u and the dispersion
/// before and after; refused when a length would change by more than `max_change_um` or a
/// vector turn by more than `max_turn_urad`, or when l4 does not close the chain.
pub fn correct(
    record: u16,
    current: &SwivelTable,
    measured: &MeasuredLines,
    work_mm: [f64; 3],
    grid: &DispersionGrid,
    max_change_um: f64,
    max_turn_urad: f64,
) -> Result<CarrCorrection, NcError> {
    let bad = |field: &'static str, what: String| NcError { field, what };
    let gap = current.closure_gap_mm();
    if gap.is_nan() || gap > 1e-6 {
        return Err(bad(
            "--carr",
            format!(
                "l4 ($TC_CARR18…20) is {:.4} mm from −(l2 + l3): not a fixed swivel table's \
                 closed chain (W1), which the correction keeps",
                gap
            ),
        ));
    }
    let control = current.lines().at_reference();
    let actual = measured.deviations.actual(&control);
    let corrected = current.placed(&actual);
    SwivelTable::values(record, current, &corrected, &[]).check_lengths(max_change_um)?;
    check_turns(
        &[
            (turn_urad(current.v1(), corrected.v1()), "v1 ($TC_CARR7…9)"),
            (
                turn_urad(current.v2(), corrected.v2()),
                "v2 ($TC_CARR10…12)",
            ),
        ],
        max_turn_urad,
    )?;
    // each input moved by its u: the values' changes, then u² = Σ cᵢ² + 2 Σ r·cᵢ·cⱼ
    let changes: Vec<[f64; 15]> = measured
        .moved_by_u
        .iter()
        .map(|d| {
            let p = current.placed(&d.actual(&control));
            std::array::from_fn(|k| p.0[k] - corrected.0[k])
        })
        .collect();
    let mut var = [0.0f64; 15];
    for c in &changes {
        var.iter_mut().zip(c).for_each(|(v, c)| *v += c * c);
    }
    for &(i, j, r) in &measured.correlated {
        if let (Some(ci), Some(cj)) = (changes.get(i), changes.get(j)) {
            for k in 0..15 {
                var[k] += 2.0 * r * ci[k] * cj[k];
            }
        }
    }
    let rows = measured
        .rows
        .iter()
        .map(|(r, feeds)| DeviationRow {
            control: parameter(*feeds),
            ..r.clone()
        })
        .collect();
    Ok(CarrCorrection {
        record,
        current: *current,
        corrected,
        u: var.map(|v| v.max(0.0).sqrt()),
        before: grid.dispersion(&control, &actual, work_mm),
        after: grid.dispersion(&corrected.lines(), &actual, work_mm),
        rows,
        u_note: measured.u_note,
    })
}

/// The correction as part-program assignments (`$TC_CARRn[record]=…`, a SINUMERIK takes them
/// in an MPF or from MDA), with the dispersion and the generic table as comments.
pub fn carr_lines(c: &CarrCorrection, source: &str) -> String {
    use std::fmt::Write as _;
    let n = c.record;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "; swivel data record {n} ($TC_CARR23[{n}]=\"P\") corrected from {source} (cargo ncgen -- kins)"
    );
    let _ = writeln!(
        s,
        "; tool-centre error over the grid: before max {:.2} µm rms {:.2} µm; after max {:.2} µm rms {:.2} µm",
        c.before.max_um, c.before.rms_um, c.after.max_um, c.after.rms_um
    );
    let _ = writeln!(
        s,
        "; base values: the fine offsets $TC_CARR41…60[{n}] must be 0 (or subtract them)"
    );
    if let Some(note) = c.u_note {
        let _ = writeln!(s, "; u: {note}");
    }
    SwivelTable::values(n, &c.current, &c.corrected, &c.u).write_assignments(&mut s);
    rows_as_comments(&mut s, ";", &c.rows);
    s
}

/// The generic table as CSV (deviation, ISO 230-1 name, value, u, unit, control parameter),
/// then the record's values (`carr:N`, the corrected value, its u, the present value).
pub fn carr_csv(c: &CarrCorrection) -> String {
    let mut s = rows_csv(&c.rows);
    SwivelTable::values(c.record, &c.current, &c.corrected, &c.u).write_csv(&mut s);
    s
}
