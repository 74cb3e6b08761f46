//! Seed 001 in replay (host only): laser diagonal readings in, figures and controller
//! compensation tables out.
//!
//! - `[vector]`: the vector (sequential-step) body-diagonal method (§8.3.2.2, spec A.6). The
//!   readings are the laser's deviation at each stop, in the order the machine made them; the
//!   core's [`identify_vector_method`] turns the re-indexed step readings into the 9 error
//!   curves and the 3 squareness values, and this module writes the curves and the tables of
//!   §8.4 (compensation = −error, mm).
//! - `[body_diagonals]`: body-diagonal displacement errors → Ed, ESd (eqs 8.130–8.133).
//!
//! **The curves the tables carry.** Only the three crossed sums of straightness slopes are
//! observable (spec A.6: a diagonal's readings do not change under a rigid rotation of the
//! frame); the single slopes depend on how the beams were aligned. So, as eqs 8.58–8.60 fold
//! squareness, D_y(x), D_z(x) and D_z(y) are levelled (their least-squares slope removed) and
//! D_x(y), D_x(z), D_y(z) are levelled and then carry S_xy·(y − y₀), S_zx·(z − z₀),
//! S_yz·(z − z₀); pitch curves are kept as measured. Every curve is zero at the start corner
//! (x₀, y₀, z₀), where the laser was zeroed.
//!
//! **Uncertainty.** The method is linear in the readings, so each output's sensitivity to each
//! stop's reading is exact by a unit perturbation through the core; the readings' standard
//! deviation is Type A, pooled from the redundant fourth diagonal of every step (a step reading
//! is the difference of two stops, so σ_stop = σ_step/√2). Angular errors the rigid-body
//! inversion cannot hold (Abbé terms that differ between diagonals) show in those residuals
//! and so in u. With three diagonals there is no redundancy: u is not evaluated (`null`) and
//! the report says so.

use std::path::Path;

use serde::Deserialize;

use crate::methods::volumetric::Squareness;
use crate::methods::volumetric::compensation::{
    Axis, Controller, TableKind, fill_compensation_table_from_curve_mm, table_point_count,
};
use crate::methods::volumetric::metrics::diagonal_figures;
use crate::methods::volumetric::vector::{identify_vector_method, invert_step};

use crate::recording::{CsvTable, LogError, excerpt};
use crate::replay::Figure;

/// `[vector]` of a session file: the vector (sequential-step) diagonal method.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VectorEntry {
    /// Readings file: `diagonal,axis,deviation_um` — per diagonal (`PPP`, `NPP`, `PNP`, `PPN`)
    /// its stops in the order made, the first at the start corner with `axis` empty, each
    /// further one naming the axis (`X`, `Y`, `Z`) just stepped; `deviation_um` = the laser's
    /// reading minus the nominal displacement along the beam, µm (any zero).
    pub readings: String,
    /// Step of each axis (a, b, c), mm, all > 0; also the diagonals' direction.
    pub step_mm: [f64; 3],
    /// Machine position of the low corner (x₀, y₀, z₀), mm (default 0, 0, 0).
    #[serde(default)]
    pub start_mm: Option<[f64; 3]>,
    /// Controllers to write tables for ([`CONTROLLERS`] names).
    #[serde(default)]
    pub tables: Vec<String>,
    /// Table spacing per axis, mm (default `step_mm`); must divide the measured travel.
    #[serde(default)]
    pub table_step_mm: Option<[f64; 3]>,
}

/// `[body_diagonals]` of a session file: body-diagonal displacement measurement.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodyDiagonalsEntry {
    /// Readings file: `diagonal,position_mm,deviation_um` for the four pairs `PPP`, `NPP`,
    /// `PNP`, `PPN` (each pair's two directions under one name), µm.
    pub readings: String,
}

/// Table targets by name: the controllers of §8.4 and `grid`, the 3D error grid of 8.101.
pub const CONTROLLERS: [(&str, Option<Controller>); 6] = [
    ("siemens_840d", Some(Controller::Siemens840D)),
    ("fanuc_30i", Some(Controller::Fanuc30i)),
    ("heidenhain", Some(Controller::Heidenhain)),
    ("fagor_8055", Some(Controller::Fagor8055)),
    ("mdsi_opencnc", Some(Controller::MdsiOpenCnc)),
    ("grid", None),
];

/// Diagonal names in the core's order (`vector::DIAGONAL_SIGNS`).
const DIAGONALS: [&str; 4] = ["PPP", "NPP", "PNP", "PPN"];
const AXES: [Axis; 3] = [Axis::X, Axis::Y, Axis::Z];
const AXIS_NAMES: [&str; 3] = ["X", "Y", "Z"];

/// What replay writes for the seed 001 methods: figures and files (name, text).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Output {
    /// Figures for `results.json`'s `host[]`.
    pub figures: Vec<Figure>,
    /// Files for the output directory.
    pub files: Vec<(String, String)>,
}

fn fault(file: &Path, line: u64, field: Option<&str>, what: String) -> LogError {
    LogError {
        file: file.to_path_buf(),
        line: line as usize,
        field: field.map(str::to_string),
        what,
    }
}

/// One stop of a diagonal: the axis stepped to reach it (`None` at the start corner) and the
/// deviation read there (µm).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Stop {
    axis: Option<usize>,
    deviation_um: f64,
}

/// The stops of each diagonal (empty where a diagonal was not measured).
type Stops = [Vec<Stop>; 4];

/// The rows of a readings file: each row's line and its cells of `columns`, in that order.
fn read_rows(file: &Path, columns: &[&str]) -> Result<Vec<(u64, Vec<String>)>, LogError> {
    let text = crate::session_file::read_text(file)?;
    let CsvTable {
        mut reader,
        header,
        header_line,
    } = CsvTable::read(file, &text)?;
    let cols = columns
        .iter()
        .map(|n| {
            let missing = || fault(file, header_line, Some(n), "required column missing".into());
            header.iter().position(|f| f == *n).ok_or_else(missing)
        })
        .collect::<Result<Vec<_>, _>>()?;
    let mut rows = Vec::new();
    for record in reader.records() {
        let record = record.map_err(|e| CsvTable::error(file, &e))?;
        let line = record.position().map_or(0, |p| p.line());
        let cells = cols
            .iter()
            .map(|&c| record.get(c).unwrap_or("").to_string())
            .collect();
        rows.push((line, cells));
    }
    Ok(rows)
}

/// A `diagonal` cell: its index in [`DIAGONALS`].
fn diagonal_of(file: &Path, line: u64, cell: &str) -> Result<usize, LogError> {
    DIAGONALS
        .iter()
        .position(|n| n.eq_ignore_ascii_case(cell))
        .ok_or_else(|| {
            let what = format!("{} (PPP, NPP, PNP or PPN)", excerpt(cell));
            fault(file, line, Some("diagonal"), what)
        })
}

/// A `deviation_um` cell: a finite number.
fn deviation_of(file: &Path, line: u64, cell: &str) -> Result<f64, LogError> {
    cell.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| {
            let what = format!("bad number {}", excerpt(cell));
            fault(file, line, Some("deviation_um"), what)
        })
}

fn read_stops(file: &Path) -> Result<Stops, LogError> {
    let mut stops: Stops = Default::default();
    for (line, cells) in read_rows(file, &["diagonal", "axis", "deviation_um"])? {
        let d = diagonal_of(file, line, &cells[0])?;
        let axis = match cells[1].as_str() {
            "" => None,
            a => Some(
                AXIS_NAMES
                    .iter()
                    .position(|n| n.eq_ignore_ascii_case(a))
                    .ok_or_else(|| {
                        let what = format!("{} (X, Y, Z, or empty at the start)", excerpt(a));
                        fault(file, line, Some("axis"), what)
                    })?,
            ),
        };
        let deviation_um = deviation_of(file, line, &cells[2])?;
        let list = &mut stops[d];
        match (list.is_empty(), axis) {
            (true, Some(_)) => {
                let what = "a diagonal's first stop is its start corner: leave axis empty".into();
                return Err(fault(file, line, Some("axis"), what));
            }
            (false, None) => {
                let what = "a stop after the start names the axis stepped to reach it".into();
                return Err(fault(file, line, Some("axis"), what));
            }
            _ => {}
        }
        list.push(Stop { axis, deviation_um });
    }
    Ok(stops)
}

/// Steps of each axis, the same on every measured diagonal and for every axis (≥ 2).
fn step_counts(file: &Path, stops: &Stops) -> Result<[usize; 3], LogError> {
    let mut counts: Option<([usize; 3], usize)> = None;
    for (d, s) in stops.iter().enumerate().filter(|(_, s)| !s.is_empty()) {
        let mut n = [0usize; 3];
        for a in s.iter().filter_map(|st| st.axis) {
            n[a] += 1;
        }
        match counts {
            None => counts = Some((n, d)),
            Some((m, first)) if m != n => {
                let what = format!(
                    "diagonal {} steps X, Y, Z {:?} times, {} {:?}: every diagonal covers the same grid",
                    DIAGONALS[d], n, DIAGONALS[first], m
                );
                return Err(fault(file, 0, Some("axis"), what));
            }
            _ => {}
        }
    }
    let (n, _) = counts.ok_or_else(|| fault(file, 0, None, "no readings".into()))?;
    // the beam lies along (a, b, c): the machine follows it only if every axis steps as often
    if n[0] < 2 || n.iter().any(|&k| k != n[0]) {
        let what = format!(
            "X, Y, Z stepped {n:?} times: along a diagonal every axis steps equally often, at least twice"
        );
        return Err(fault(file, 0, Some("axis"), what));
    }
    Ok(n)
}

/// The step readings re-indexed by position (spec A.6): the k-th step of axis u on a diagonal
/// that runs in −u covers forward interval N_u − 1 − k and reads minus the forward increment.
fn step_readings(stops: &Stops, n: [usize; 3]) -> [Vec<[Option<f64>; 4]>; 3] {
    let mut out = n.map(|k| vec![[None; 4]; k]);
    let signs = crate::methods::volumetric::vector::DIAGONAL_SIGNS;
    for (d, (s, sign)) in stops.iter().zip(signs).enumerate() {
        let mut k = [0usize; 3];
        for w in s.windows(2) {
            let [before, after] = [w[0], w[1]];
            let Some(a) = after.axis else { continue };
            let m = after.deviation_um - before.deviation_um;
            let forward = sign[a] > 0.0;
            let q = if forward { k[a] } else { n[a] - 1 - k[a] };
            k[a] += 1;
            if let Some(slot) = out[a].get_mut(q).and_then(|r| r.get_mut(d)) {
                *slot = Some(if forward { m } else { -m });
            }
        }
    }
    out
}

/// The identified curves at the measured positions, in the tables' convention (module doc):
/// `curves[u][k]` = (D_x(u), D_y(u), D_z(u)) at position k of axis u, µm, and the squareness.
#[derive(Clone, Debug, PartialEq)]
struct Curves {
    curves_um: [Vec<[f64; 3]>; 3],
    squareness: Squareness,
}

impl Curves {
    /// Every output as one vector (curves, then S_xy, S_yz, S_zx): what the perturbation
    /// differentiates.
    fn flat(&self) -> Vec<f64> {
        let mut v: Vec<f64> = self.curves_um.iter().flatten().flatten().copied().collect();
        let s = &self.squareness;
        v.extend([s.xy_urad, s.yz_urad, s.zx_urad]);
        v
    }
}

fn solve(stops: &Stops, n: [usize; 3], step_mm: [f64; 3]) -> Result<Curves, String> {
    let steps = step_readings(stops, n);
    let mut curves_um = n.map(|k| vec![[0.0f64; 3]; k + 1]);
    let [cx, cy, cz] = &mut curves_um;
    let summary = identify_vector_method(
        step_mm,
        [&steps[0], &steps[1], &steps[2]],
        [cx.as_mut_slice(), cy.as_mut_slice(), cz.as_mut_slice()],
    )
    .map_err(|e| format!("vector method: {e:?}"))?;
    // level every straightness curve, then fold the squareness as eqs 8.58–8.60
    let sq = summary.squareness;
    for (u, curve) in curves_um.iter_mut().enumerate() {
        for (k, point) in curve.iter_mut().enumerate() {
            let pos_mm = k as f64 * step_mm[u];
            for (i, d) in point.iter_mut().enumerate() {
                if i == u {
                    continue;
                }
                let fold_urad = match (u, i) {
                    (1, 0) => sq.xy_urad,
                    (2, 0) => sq.zx_urad,
                    (2, 1) => sq.yz_urad,
                    _ => 0.0,
                };
                *d += (fold_urad - summary.slopes_urad[u][i]) * pos_mm * 1e-3;
            }
        }
    }
    Ok(Curves {
        curves_um,
        squareness: sq,
    })
}

/// Pooled standard deviation of one stop's reading, µm, from every step's redundant diagonal;
/// `None` without redundancy.
fn stop_std_um(stops: &Stops, n: [usize; 3], step_mm: [f64; 3]) -> Option<f64> {
    let (mut ssr, mut dof) = (0.0, 0usize);
    for s in step_readings(stops, n).iter().flatten() {
        let inc = invert_step(step_mm, *s).ok()?;
        ssr += inc.residual_rms_um * inc.residual_rms_um * f64::from(inc.readings);
        dof += (inc.readings as usize).saturating_sub(3);
    }
    // a step reading is the difference of two stops: var(step) = 2 var(stop)
    (dof > 0).then(|| (ssr / dof as f64 / 2.0).sqrt())
}

/// ∂output/∂stop for every output of [`Curves::flat`] (rows) and every stop (columns): exact,
/// the method being linear in the readings.
fn sensitivities(
    stops: &Stops,
    n: [usize; 3],
    step_mm: [f64; 3],
    base: &[f64],
) -> Result<Vec<Vec<f64>>, String> {
    let mut rows = vec![Vec::new(); base.len()];
    for d in 0..4 {
        for k in 0..stops[d].len() {
            let mut p = stops.clone();
            p[d][k].deviation_um += 1.0;
            let moved = solve(&p, n, step_mm)?.flat();
            for (row, (m, b)) in rows.iter_mut().zip(moved.iter().zip(base)) {
                row.push(m - b);
            }
        }
    }
    Ok(rows)
}

/// Each output's sensitivity to each stop and the stops' standard deviation: the u of any
/// linear combination of outputs.
struct Propagation {
    /// ∂output/∂stop, rows in [`Curves::flat`] order.
    j: Vec<Vec<f64>>,
    /// σ of one stop's reading, µm (`None`: no redundancy, u not evaluated).
    sigma: Option<f64>,
    /// Start of each axis's curve in the rows.
    offsets: [usize; 3],
}

impl Propagation {
    /// Row of the curve value of axis `u` at point `k`, component `i`.
    fn at(&self, u: usize, k: usize, i: usize) -> usize {
        self.offsets[u] + k * 3 + i
    }

    /// Row of S_xy (then S_yz, S_zx).
    fn squareness_row(&self) -> usize {
        self.j.len() - 3
    }

    /// Standard uncertainty of Σ w·output(row) over `terms` = (row, w).
    fn u(&self, terms: &[(usize, f64)]) -> Option<f64> {
        let cols = self.j.first().map_or(0, Vec::len);
        let ss: f64 = (0..cols)
            .map(|c| {
                let g: f64 = terms.iter().map(|&(r, w)| w * self.j[r][c]).sum();
                g * g
            })
            .sum();
        self.sigma.map(|s| s * ss.sqrt())
    }

    /// u of the curve of axis `u`, component `i`, interpolated at fraction `f` of the steps.
    fn u_between(&self, u: usize, i: usize, k: usize, t: f64) -> Option<f64> {
        self.u(&[(self.at(u, k, i), 1.0 - t), (self.at(u, k + 1, i), t)])
    }
}

/// A table point at `p` table steps from the start: the measured interval k it lies in and
/// its fraction t of that interval.
fn interval(p: usize, table_step_mm: f64, step_mm: f64, steps: usize) -> (usize, f64) {
    let f = p as f64 * table_step_mm / step_mm;
    let k = (f.floor() as usize).min(steps - 1);
    (k, f - k as f64)
}

/// The seed 001 vector method of `[vector]`.
pub fn vector(path: &Path, e: &VectorEntry) -> Result<Output, LogError> {
    let file = path.parent().unwrap_or(Path::new(".")).join(&e.readings);
    let bad = |field: &str, what: String| fault(path, 0, Some(field), what);
    if e.step_mm.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
        return Err(bad("vector.step_mm", "every step must be > 0 mm".into()));
    }
    let start = e.start_mm.unwrap_or([0.0; 3]);
    if start.iter().any(|s| !s.is_finite()) {
        return Err(bad("vector.start_mm", "not a finite position".into()));
    }
    let targets = e
        .tables
        .iter()
        .map(|t| {
            CONTROLLERS
                .iter()
                .find(|(name, _)| name.eq_ignore_ascii_case(t))
                .copied()
                .ok_or_else(|| {
                    let known: Vec<&str> = CONTROLLERS.iter().map(|c| c.0).collect();
                    bad(
                        "vector.tables",
                        format!("{} (known: {})", excerpt(t), known.join(", ")),
                    )
                })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let stops = read_stops(&file)?;
    let n = step_counts(&file, &stops)?;
    let table_step = e.table_step_mm.unwrap_or(e.step_mm);
    for (u, (&ts, &k)) in table_step.iter().zip(n.iter()).enumerate() {
        let travel = k as f64 * e.step_mm[u];
        table_point_count(0.0, travel, ts).map_err(|x| {
            let what = format!(
                "{} mm does not divide the measured {} travel of {travel} mm ({x:?})",
                ts, AXIS_NAMES[u]
            );
            bad("vector.table_step_mm", what)
        })?;
    }
    let whole = |what: String| fault(&file, 0, None, what);
    let curves = solve(&stops, n, e.step_mm).map_err(whole)?;
    let base = curves.flat();
    let prop = Propagation {
        j: sensitivities(&stops, n, e.step_mm, &base).map_err(whole)?,
        sigma: stop_std_um(&stops, n, e.step_mm),
        offsets: [0, 3 * (n[0] + 1), 3 * (n[0] + n[1] + 2)],
    };

    let mut out = Output::default();
    let s = curves.squareness;
    for (k, (name, v)) in [
        ("S_xy", s.xy_urad),
        ("S_yz", s.yz_urad),
        ("S_zx", s.zx_urad),
    ]
    .into_iter()
    .enumerate()
    {
        out.figures.push(Figure {
            name: format!("vector_{name}"),
            value: v as f32,
            u: prop
                .u(&[(prop.squareness_row() + k, 1.0)])
                .map(|u| u as f32),
            dof: None,
            unit: "urad".into(),
            contributors: Vec::new(),
        });
    }
    out.figures.push(Figure {
        name: "vector_reading_std".into(),
        value: prop.sigma.unwrap_or(f64::NAN) as f32,
        u: None,
        dof: None,
        unit: "um".into(),
        contributors: Vec::new(),
    });
    out.figures.retain(|f| f.value.is_finite());

    // the curves as identified (tables' convention), with u
    let mut csv = String::from(
        "# seed 001 vector method: error curves (µm), zero at the start corner; straightness \
         levelled, squareness folded into D_x(y), D_x(z), D_y(z) (eqs 8.58-8.60); u = standard \
         uncertainty (empty: not evaluated, no redundant diagonal)\n\
         axis,position_mm,dx_um,dy_um,dz_um,u_dx_um,u_dy_um,u_dz_um\n",
    );
    for (u, c) in curves.curves_um.iter().enumerate() {
        for (k, p) in c.iter().enumerate() {
            let us = [0, 1, 2].map(|i| prop.u(&[(prop.at(u, k, i), 1.0)]));
            let cell = |x: Option<f64>| x.map_or(String::new(), |v| format!("{v:.4}"));
            csv += &format!(
                "{},{},{:.4},{:.4},{:.4},{},{},{}\n",
                AXIS_NAMES[u],
                start[u] + k as f64 * e.step_mm[u],
                p[0],
                p[1],
                p[2],
                cell(us[0]),
                cell(us[1]),
                cell(us[2])
            );
        }
    }
    out.files.push(("vector_curves.csv".into(), csv));

    // tables: table point x lies between measured points k and k + 1 with weight t
    let table = |u: usize, i: usize| -> Result<Vec<(f64, f64, Option<f64>)>, String> {
        let positions: Vec<f64> = (0..=n[u])
            .map(|k| start[u] + k as f64 * e.step_mm[u])
            .collect();
        let errors: Vec<f64> = curves.curves_um[u].iter().map(|p| p[i]).collect();
        let (lo, hi) = (start[u], start[u] + n[u] as f64 * e.step_mm[u]);
        let count = table_point_count(lo, hi, table_step[u]).map_err(|x| format!("{x:?}"))?;
        let mut vals = vec![0.0; count];
        fill_compensation_table_from_curve_mm(
            lo,
            hi,
            table_step[u],
            &positions,
            &errors,
            &mut vals,
        )
        .map_err(|x| format!("{x:?}"))?;
        Ok(vals
            .iter()
            .enumerate()
            .map(|(p, &v)| {
                let (k, t) = interval(p, table_step[u], e.step_mm[u], n[u]);
                let u_mm = prop.u_between(u, i, k, t).map(|x| x * 1e-3);
                (lo + p as f64 * table_step[u], v, u_mm)
            })
            .collect())
    };
    for (name, controller) in &targets {
        match controller {
            Some(c) => {
                let mut tables = Vec::new();
                for (u, moving) in AXES.iter().enumerate() {
                    for (i, comp) in AXES.iter().enumerate() {
                        let kind = TableKind {
                            moving: *moving,
                            comp: *comp,
                        };
                        if c.supports(kind) {
                            tables.push((kind, u, i, table(u, i).map_err(whole)?));
                        }
                    }
                }
                out.files
                    .push((format!("comp_{name}.csv"), tables_csv(name, &tables)));
                if *c == Controller::Siemens840D {
                    out.files.push((
                        "comp_siemens_840d.ini".into(),
                        siemens_ini(&tables, table_step),
                    ));
                }
            }
            None => out.files.push((
                "comp_grid.csv".into(),
                grid_csv(&curves, n, e.step_mm, table_step, start, &prop),
            )),
        }
    }
    Ok(out)
}

/// One table: its kind, moving axis index, comp axis index and its (position mm,
/// compensation mm, u mm) points.
type Table = (TableKind, usize, usize, Vec<(f64, f64, Option<f64>)>);

/// A controller's tables as CSV, one row per point, with u.
fn tables_csv(controller: &str, tables: &[Table]) -> String {
    let mut s = format!(
        "# seed 001 compensation tables for {controller}: compensation = -error, mm; u = its \
         standard uncertainty, mm (k = 1; empty: not evaluated)\n\
         table,moving_axis,comp_axis,position_mm,compensation_mm,u_mm\n"
    );
    for (kind, u, i, points) in tables {
        for (x, v, uu) in points {
            s += &format!(
                "{},{},{},{x},{:.7},{}\n",
                kind.fanuc_name(),
                AXIS_NAMES[*u],
                AXIS_NAMES[*i],
                v + 0.0, // −0 (compensation of a zero error) reads 0
                uu.map_or(String::new(), |x| format!("{x:.7}"))
            );
        }
    }
    s
}

/// Siemens 840D CEC tables as seed 001 Table 8.3 prints them: one table per moving/comp pair
/// (numbered in the order X→X, X→Y, X→Z, Y→X, …), both travel directions
/// (`$AN_CEC_DIRECTION` 0: the vector method measures one), values in mm to 0.1 µm.
fn siemens_ini(tables: &[Table], step_mm: [f64; 3]) -> String {
    let mut s = String::from("%_N_NC_CEC_INI\nCHANDATA(1)\n");
    for (t, (_, u, i, points)) in tables.iter().enumerate() {
        for (p, (_, v, _)) in points.iter().enumerate() {
            // rounded first so that a value below 0.05 µm reads +0.0000, never -0.0000
            let v = (v * 1e4).round() / 1e4 + 0.0;
            s += &format!("$AN_CEC[{t},{p}]={v:+.4}\n");
        }
        let (min, max) = (
            points.first().map_or(0.0, |p| p.0),
            points.last().map_or(0.0, |p| p.0),
        );
        s += &format!(
            "$AN_CEC_INPUT_AXIS[{t}]=(AX{})\n$AN_CEC_OUTPUT_AXIS[{t}]=(AX{})\n\
             $AN_CEC_STEP[{t}]={:+.4}\n$AN_CEC_MIN[{t}]={min:+.4}\n$AN_CEC_MAX[{t}]={max:+.4}\n\
             $AN_CEC_DIRECTION[{t}]=0\n$AN_CEC_MULT_BY_TABLE[{t}]=0\n$AN_CEC_IS_MODULO[{t}]=0\n",
            u + 1,
            i + 1,
            step_mm[*u]
        );
    }
    s + "M17\n"
}

/// The 3D grid (eq 8.101's nodes) at the table spacing: compensation = −(D(x) + D(y) + D(z))
/// per direction (the rigid-body sum without angular terms, which the vector method does not
/// identify), mm, with u.
fn grid_csv(
    curves: &Curves,
    n: [usize; 3],
    step_mm: [f64; 3],
    table_step: [f64; 3],
    start: [f64; 3],
    prop: &Propagation,
) -> String {
    let mut s = String::from(
        "# seed 001 3D compensation grid: compensation = -error, mm; error = D(x) + D(y) + D(z) \
         of the vector method's curves (no angular terms); u = standard uncertainty, mm\n\
         x_mm,y_mm,z_mm,comp_x_mm,comp_y_mm,comp_z_mm,u_x_mm,u_y_mm,u_z_mm\n",
    );
    // each axis's table points as (position, measured point k, weight t)
    let nodes = |u: usize| -> Vec<(f64, usize, f64)> {
        let count = (n[u] as f64 * step_mm[u] / table_step[u]).round() as usize;
        (0..=count)
            .map(|p| {
                let (k, t) = interval(p, table_step[u], step_mm[u], n[u]);
                (start[u] + p as f64 * table_step[u], k, t)
            })
            .collect()
    };
    let (nx, ny, nz) = (nodes(0), nodes(1), nodes(2));
    for &(z, kz, tz) in &nz {
        for &(y, ky, ty) in &ny {
            for &(x, kx, tx) in &nx {
                let mut comp = [0.0; 3];
                let mut us = [None; 3];
                for (i, (c, uu)) in comp.iter_mut().zip(us.iter_mut()).enumerate() {
                    let mut terms = Vec::new();
                    for (u, (k, t)) in [(kx, tx), (ky, ty), (kz, tz)].into_iter().enumerate() {
                        let c0 = curves.curves_um[u][k][i];
                        let c1 = curves.curves_um[u][k + 1][i];
                        *c -= (c0 + t * (c1 - c0)) * 1e-3;
                        terms.push((prop.at(u, k, i), 1.0 - t));
                        terms.push((prop.at(u, k + 1, i), t));
                    }
                    *uu = prop.u(&terms).map(|v| v * 1e-3);
                }
                let cell = |x: Option<f64>| x.map_or(String::new(), |v| format!("{v:.7}"));
                s += &format!(
                    "{x},{y},{z},{:.7},{:.7},{:.7},{},{},{}\n",
                    comp[0] + 0.0,
                    comp[1] + 0.0,
                    comp[2] + 0.0,
                    cell(us[0]),
                    cell(us[1]),
                    cell(us[2])
                );
            }
        }
    }
    s
}

/// The body-diagonal figures of `[body_diagonals]`: the range per diagonal pair, Ed, ESd.
/// Ranges are extreme statistics of the readings: u is not evaluated (as for ISO 230-4's G).
pub fn body_diagonals(path: &Path, e: &BodyDiagonalsEntry) -> Result<Output, LogError> {
    let file = path.parent().unwrap_or(Path::new(".")).join(&e.readings);
    let mut data: [Vec<f64>; 4] = Default::default();
    for (line, cells) in read_rows(&file, &["diagonal", "position_mm", "deviation_um"])? {
        data[diagonal_of(&file, line, &cells[0])?].push(deviation_of(&file, line, &cells[2])?);
    }
    if let Some(d) = data.iter().position(Vec::is_empty) {
        let what = format!(
            "no readings of diagonal {}: Ed and ESd need all four",
            DIAGONALS[d]
        );
        return Err(fault(&file, 0, Some("diagonal"), what));
    }
    let f = diagonal_figures([&data[0], &data[1], &data[2], &data[3]])
        .map_err(|x| fault(&file, 0, None, format!("{x:?}")))?;
    let figure = |name: String, value: f64| Figure {
        name,
        value: value as f32,
        u: None,
        dof: None,
        unit: "um".into(),
        contributors: Vec::new(),
    };
    let mut figures: Vec<Figure> = DIAGONALS
        .iter()
        .zip(f.ranges_um)
        .map(|(d, r)| figure(format!("body_diagonal_range_{d}"), r))
        .collect();
    figures.push(figure("body_diagonal_Ed".into(), f.ed_um));
    figures.push(figure("body_diagonal_ESd".into(), f.esd_um));
    Ok(Output {
        figures,
        files: Vec::new(),
    })
}
