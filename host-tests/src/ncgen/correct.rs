//! Compensation out, in the controller's terms: an NC program rewritten point by point so that
//! the tool reaches the ideal workpiece points — for the seed 002 deviations
//! (`cargo ncgen -- correct PROGRAM SETUP RESULTS`, [`correct_program`]) and for seed 004's
//! estimated rotary-axis centrelines (`cargo ncgen -- correct-centrelines PROGRAM CENTRELINES`,
//! [`correct_program_centrelines`]). Both rewrite the program the same way
//! ([`rewrite_points`]); only the corrected point differs. With the deviations' covariance
//! (`seed002_covariance` of the results) or the centrelines' standard uncertainties
//! (`[uncertainty]`), each corrected block also states u and U of its X, Y, Z.
//!
//! Seed 002:
//! Every `G0`/`G1` block's X, Y, Z become the core's corrected command
//! ([`ballpod::identify::mill_turn::compensation::compensate`], applied once: `A·x_c = P`,
//! eqs 3.4–3.10; compensation = −error) in the model frame (the block's position less the
//! set-up's `s002_origin`), B and C stay as programmed, and a trailing comment says what moved
//! and by how much (µm). The deviations are the pod's model-mode results by name (`dx_BT` …
//! `beta_CZ`, µm and arc-seconds, as `results.json` of the simulator and replay lists them);
//! all ten are applied, α_BT too (it moves the tool point; the thesis leaves it out because
//! the spindle's angle is not controlled — here only the point is corrected). Arcs (`G2`/`G3`)
//! are refused: a corrected arc is not an arc; program the path as `G1` points.

use std::fmt::Write as _;

use crate::methods::centreline::{AxisLine, RotationSense, TableAxes, nc_command_correction};
use ballpod::identify::mill_turn::compensation::{CompensationMode, compensate};
use ballpod::identify::mill_turn::patterns::NcBlock;
use ballpod::identify::mill_turn::{Deviations, Parameter, arcsec_to_urad};

use super::{NcError, WORD_RESOLUTION_MM, num};

/// The squareness deviations the ball-bar procedure does not identify (the pod's results
/// table has no entry for them): left 0.
const NOT_IDENTIFIED: [Parameter; 3] = [Parameter::GammaXy, Parameter::AlphaYz, Parameter::BetaYz];

/// What `ncgen correct` takes from a results file: the identified deviations and, when the
/// file has one, their covariance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IdentifiedDeviations {
    /// The model mode's deviations (µm, µrad; [`NOT_IDENTIFIED`] 0).
    pub deviations: Deviations,
    /// Their covariance (µm², µm·µrad, µrad²; [`Parameter::ALL`] order), from the file's
    /// `seed002_covariance`.
    pub covariance: Option<[[f64; 13]; 13]>,
}

impl From<Deviations> for IdentifiedDeviations {
    fn from(deviations: Deviations) -> Self {
        Self {
            deviations,
            covariance: None,
        }
    }
}

/// The identified deviations of a results file (`{"results": [{"name", "value", …}]}`: µm and
/// arc-seconds); every one the procedure identifies (all but [`NOT_IDENTIFIED`]) must be there
/// and finite. With `seed002_covariance` (`names`, `units`, `matrix`, as `cargo sim` and
/// `cargo replay` write it) their covariance too: square, symmetric, finite, a non-negative
/// diagonal, every name a deviation.
pub fn deviations_from_results(json: &str) -> Result<IdentifiedDeviations, NcError> {
    #[derive(serde::Deserialize)]
    struct Entry {
        name: String,
        value: Option<f64>,
    }
    #[derive(serde::Deserialize)]
    struct Covariance {
        names: Vec<String>,
        matrix: Vec<Vec<f64>>,
    }
    #[derive(serde::Deserialize)]
    struct File {
        results: Vec<Entry>,
        #[serde(default)]
        seed002_covariance: Option<Covariance>,
    }
    let bad = |what: String| NcError {
        field: "RESULTS",
        what,
    };
    let file: File = serde_json::from_str(json).map_err(|e| bad(e.to_string()))?;
    // a value in the results' unit (µm or arc-seconds) in the model's (µm or µrad)
    let model_unit = |p: Parameter, v: f64| {
        if p.is_positional() {
            v
        } else {
            arcsec_to_urad(v)
        }
    };
    let mut a = [0.0; 13];
    for p in Parameter::ALL {
        if NOT_IDENTIFIED.contains(&p) {
            continue;
        }
        let v = file
            .results
            .iter()
            .find(|e| e.name == p.name())
            .and_then(|e| e.value)
            .filter(|v| v.is_finite())
            .ok_or_else(|| bad(format!("{} not identified", p.name())))?;
        if let Some(slot) = a.get_mut(p.index()) {
            *slot = model_unit(p, v);
        }
    }
    let covariance = match file.seed002_covariance {
        None => None,
        Some(c) => {
            let bad_cov = |what: &str| bad(format!("seed002_covariance: {what}"));
            let params = c
                .names
                .iter()
                .map(|n| {
                    Parameter::ALL
                        .into_iter()
                        .find(|p| p.name() == n && !NOT_IDENTIFIED.contains(p))
                        .ok_or_else(|| bad_cov(&format!("{n} is not an identified deviation")))
                })
                .collect::<Result<Vec<_>, _>>()?;
            let n = params.len();
            if c.matrix.len() != n || c.matrix.iter().any(|r| r.len() != n) {
                return Err(bad_cov("the matrix is not square over the names"));
            }
            let mut cov = [[0.0f64; 13]; 13];
            for (i, (p, row)) in params.iter().zip(&c.matrix).enumerate() {
                for (j, (q, v)) in params.iter().zip(row).enumerate() {
                    let w = c.matrix[j][i];
                    if !v.is_finite() || (v - w).abs() > 1e-9 * (v.abs() + w.abs()) {
                        return Err(bad_cov("not finite or not symmetric"));
                    }
                    if i == j && *v < 0.0 {
                        return Err(bad_cov("a negative variance"));
                    }
                    cov[p.index()][q.index()] = model_unit(*q, model_unit(*p, *v));
                }
            }
            Some(cov)
        }
    };
    Ok(IdentifiedDeviations {
        deviations: Deviations::from_array(&a),
        covariance,
    })
}

/// The words of a block: letter and number, in order; a parenthesised comment kept aside.
pub(super) fn words(code: &str) -> Result<Vec<(char, String)>, String> {
    let mut out = Vec::new();
    let mut chars = code.chars().peekable();
    while let Some(c) = chars.next() {
        if c.is_whitespace() {
            continue;
        }
        if !c.is_ascii_alphabetic() {
            return Err(format!("unexpected {c:?}"));
        }
        let mut n = String::new();
        while let Some(&d) = chars.peek() {
            if d.is_ascii_digit() || d == '.' || d == '-' || d == '+' {
                n.push(d);
                chars.next();
            } else {
                break;
            }
        }
        out.push((c.to_ascii_uppercase(), n));
    }
    Ok(out)
}

/// `program` with every linear block corrected for `dev`, the model frame's origin at
/// `origin_mm` (machine coordinates); `source` names the results in the header comment. With
/// the deviations' covariance, every block states u and U = 2u of its X, Y, Z: each deviation's
/// sensitivity by a secant of its own u, `u² = J C Jᵀ` (GUM 5.2.2), plus the word's rounding.
pub fn correct_program(
    program: &str,
    origin_mm: [f64; 3],
    dev: &IdentifiedDeviations,
    source: &str,
) -> Result<String, NcError> {
    let mut header = vec![
        format!(
            "corrected by ballpod ncgen for the deviations of {source}: seed 002 ch. 3, applied once"
        ),
        "each block's X Y Z moved by the compensation, minus the error; B and C as programmed"
            .into(),
    ];
    if dev.covariance.is_some() {
        header.push(
            "u: standard uncertainty from the deviations' covariance; U: 2u, as the pod's results"
                .into(),
        );
    }
    let command = |d: &Deviations, [x, y, z, b_deg, c_deg]: [f64; 5]| {
        let block = NcBlock {
            x_mm: x - origin_mm[0],
            y_mm: y - origin_mm[1],
            z_mm: z - origin_mm[2],
            b_deg,
            c_deg,
        };
        let c = compensate(&block, d, CompensationMode::Once)
            .map_err(|e| format!("not compensated: {e:?}"))?;
        Ok::<_, String>([
            c.x_mm + origin_mm[0],
            c.y_mm + origin_mm[1],
            c.z_mm + origin_mm[2],
        ])
    };
    let correct = |point: [f64; 5]| {
        let corrected = command(&dev.deviations, point)?;
        let Some(cov) = &dev.covariance else {
            return Ok((corrected, None));
        };
        // J: the corrected point's change per unit of each deviation (mm per µm or µrad)
        let x = dev.deviations.to_array();
        let mut jac = [[0.0f64; 13]; 3];
        for (j, row) in cov.iter().enumerate() {
            let h = row.get(j).copied().unwrap_or(0.0).sqrt();
            if h.is_nan() || h <= 0.0 {
                continue;
            }
            let mut moved = x;
            moved[j] += h;
            let p = command(&Deviations::from_array(&moved), point)?;
            for ((jk, a), b) in jac.iter_mut().zip(p).zip(corrected) {
                jk[j] = (a - b) / h;
            }
        }
        let rounding = (WORD_RESOLUTION_MM * 1e3).powi(2) / 12.0;
        let u = jac.map(|jk| {
            let mut v = rounding;
            for (ji, row) in jk.iter().zip(cov) {
                for (jj, c) in jk.iter().zip(row) {
                    v += ji * c * jj * 1e6;
                }
            }
            PointUncertainty::of(&[(v, None)])
        });
        Ok((corrected, Some(u)))
    };
    rewrite_points(program, ['B', 'C'], &header, &correct)
}

/// The centrelines of seed 004's table-swivel machine for [`correct_program_centrelines`]: a
/// TOML file with `[actual]` (the estimated centrelines, seed 004 Tables 1 and 2), optional
/// `[nominal]` (as set in the NC; default A ∥ Z and B ∥ Y through the origin) and optional
/// `[sense]` (how a commanded angle turns the table: `primed`, the default — ISO 841's table
/// axes turn the work opposite to the tool's relative motion — or `right_handed`).
#[derive(Clone, Debug, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CentrelinesFile {
    /// The estimated centrelines.
    pub actual: CentrelinePair,
    /// The centrelines set in the NC.
    #[serde(default)]
    pub nominal: Option<CentrelinePair>,
    /// Rotation sense of A and B.
    #[serde(default)]
    pub sense: Option<Senses>,
    /// Standard uncertainties of `actual`.
    #[serde(default)]
    pub uncertainty: Option<CentrelineUncertainty>,
}

/// `[uncertainty]`: the standard uncertainties of the estimated centrelines and their
/// correlations, as the core's identification states them (`AxisDirection`:
/// `tilt_uncertainty_urad`, `tilt_correlation`; `CentreBudget` of `axis_centre_budget` or
/// replay's `[vertex]`: `u_um`, `correlation`, `degrees_of_freedom`), in the core's component
/// order. The four pairs are taken as
/// independent of each other (the directions come from face normals, the points from
/// vertices: separate readings).
#[derive(Clone, Copy, Debug, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CentrelineUncertainty {
    /// A's direction (nominally ∥ Z): its tilt towards X and towards Y, µrad.
    pub a_tilt_urad: [f64; 2],
    /// Correlation of A's two tilt components (default 0).
    #[serde(default)]
    pub a_tilt_correlation: f64,
    /// Degrees of freedom of `a_tilt_*` (the core's `tilt_degrees_of_freedom`; default:
    /// infinite, a u from a stated noise).
    #[serde(default)]
    pub a_tilt_dof: Option<u32>,
    /// A's point across the axis: X and Y, µm.
    pub a_point_um: [f64; 2],
    /// Correlation of A's two point components (default 0).
    #[serde(default)]
    pub a_point_correlation: f64,
    /// Degrees of freedom of `a_point_*` (the core's `centre_degrees_of_freedom`; default:
    /// infinite, a u from a stated noise).
    #[serde(default)]
    pub a_point_dof: Option<u32>,
    /// B's direction (nominally ∥ Y): its tilt towards X and towards −Z, µrad.
    pub b_tilt_urad: [f64; 2],
    /// Correlation of B's two tilt components (default 0).
    #[serde(default)]
    pub b_tilt_correlation: f64,
    /// Degrees of freedom of `b_tilt_*` (the core's `tilt_degrees_of_freedom`; default:
    /// infinite, a u from a stated noise).
    #[serde(default)]
    pub b_tilt_dof: Option<u32>,
    /// B's point across the axis: X and Z, µm.
    pub b_point_um: [f64; 2],
    /// Correlation of B's two point components (default 0).
    #[serde(default)]
    pub b_point_correlation: f64,
    /// Degrees of freedom of `b_point_*` (the core's `centre_degrees_of_freedom`; default:
    /// infinite, a u from a stated noise).
    #[serde(default)]
    pub b_point_dof: Option<u32>,
}

/// One input pair of [`CentrelineUncertainty`].
pub(super) struct UncertainPair {
    /// The file's key of the standard uncertainties.
    pub(super) key: &'static str,
    /// The file's key of the correlation.
    pub(super) correlation_key: &'static str,
    /// The line (A: the table).
    pub(super) line: Line,
    /// The machine directions the two components move along (signed unit vectors).
    pub(super) along: [[f64; 3]; 2],
    /// Their standard uncertainties, µrad (a tilt) or µm (a point).
    pub(super) u: [f64; 2],
    /// Their correlation coefficient.
    pub(super) correlation: f64,
    /// Their degrees of freedom (`None`: infinite).
    pub(super) dof: Option<u32>,
    /// Whether it tilts the direction (else it moves the point).
    pub(super) tilt: bool,
}

impl CentrelineUncertainty {
    /// The four input pairs.
    pub(super) fn pairs(&self) -> [UncertainPair; 4] {
        const X: [f64; 3] = [1.0, 0.0, 0.0];
        const Y: [f64; 3] = [0.0, 1.0, 0.0];
        const Z: [f64; 3] = [0.0, 0.0, 1.0];
        const MINUS_Z: [f64; 3] = [0.0, 0.0, -1.0];
        let pair = |key, correlation_key, line, along, u, (correlation, dof), tilt| UncertainPair {
            key,
            correlation_key,
            line,
            along,
            u,
            correlation,
            dof,
            tilt,
        };
        [
            pair(
                "uncertainty.a_tilt_urad",
                "uncertainty.a_tilt_correlation",
                Line::A,
                [X, Y],
                self.a_tilt_urad,
                (self.a_tilt_correlation, self.a_tilt_dof),
                true,
            ),
            pair(
                "uncertainty.a_point_um",
                "uncertainty.a_point_correlation",
                Line::A,
                [X, Y],
                self.a_point_um,
                (self.a_point_correlation, self.a_point_dof),
                false,
            ),
            pair(
                "uncertainty.b_tilt_urad",
                "uncertainty.b_tilt_correlation",
                Line::B,
                [X, MINUS_Z],
                self.b_tilt_urad,
                (self.b_tilt_correlation, self.b_tilt_dof),
                true,
            ),
            pair(
                "uncertainty.b_point_um",
                "uncertainty.b_point_correlation",
                Line::B,
                [X, Z],
                self.b_point_um,
                (self.b_point_correlation, self.b_point_dof),
                false,
            ),
        ]
    }
}

/// One of the two centrelines.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Line {
    /// The rotary table A.
    A,
    /// The tilting axis B.
    B,
}

impl Line {
    fn of(self, axes: &mut TableAxes) -> &mut AxisLine {
        match self {
            Self::A => &mut axes.table,
            Self::B => &mut axes.tilt,
        }
    }
}

/// The two axis lines, machine coordinates: directions of any length, points in mm.
#[derive(Clone, Copy, Debug, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CentrelinePair {
    /// Rotary table A (nominally ∥ Z): direction.
    pub a_direction: [f64; 3],
    /// A point on A, mm.
    pub a_point_mm: [f64; 3],
    /// Tilting axis B (nominally ∥ Y) that carries A: direction.
    pub b_direction: [f64; 3],
    /// A point on B, mm.
    pub b_point_mm: [f64; 3],
}

impl CentrelinePair {
    /// Seed 004's NC-set default: A ∥ Z, B ∥ Y, both through the origin.
    pub const NOMINAL: Self = Self {
        a_direction: [0.0, 0.0, 1.0],
        a_point_mm: [0.0; 3],
        b_direction: [0.0, 1.0, 0.0],
        b_point_mm: [0.0; 3],
    };

    fn axes(&self) -> TableAxes {
        TableAxes {
            table: AxisLine {
                direction: self.a_direction,
                point_mm: self.a_point_mm,
            },
            tilt: AxisLine {
                direction: self.b_direction,
                point_mm: self.b_point_mm,
            },
        }
    }
}

/// `[sense]`: `a` and `b`, each `primed` or `right_handed`.
#[derive(Clone, Debug, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Senses {
    /// The rotary table A.
    #[serde(default)]
    pub a: Option<String>,
    /// The tilting axis B.
    #[serde(default)]
    pub b: Option<String>,
}

/// Reads a centrelines file (TOML); a fault names the key.
pub fn centrelines_from_toml(text: &str) -> Result<CentrelinesFile, NcError> {
    let f: CentrelinesFile = toml::from_str(text).map_err(|e| NcError {
        field: "CENTRELINES",
        what: e.message().to_string(),
    })?;
    let pairs = [Some(f.actual), f.nominal];
    for p in pairs.iter().flatten() {
        let all = [p.a_direction, p.a_point_mm, p.b_direction, p.b_point_mm];
        if all.iter().flatten().any(|v| !v.is_finite())
            || [p.a_direction, p.b_direction]
                .iter()
                .any(|d| d.iter().map(|v| v * v).sum::<f64>() < 1e-12)
        {
            return Err(NcError {
                field: "CENTRELINES",
                what: "a direction is zero or a value not finite".into(),
            });
        }
    }
    for p in f.uncertainty.iter().flat_map(CentrelineUncertainty::pairs) {
        let bad = |what: String| NcError {
            field: "CENTRELINES",
            what,
        };
        if !p.u.iter().all(|v| v.is_finite() && *v >= 0.0) {
            return Err(bad(format!(
                "{}: a standard uncertainty is ≥ 0 and finite",
                p.key
            )));
        }
        if !(-1.0..=1.0).contains(&p.correlation) {
            return Err(bad(format!("{}: within −1 … 1", p.correlation_key)));
        }
        if p.dof == Some(0) {
            return Err(bad(format!(
                "{}: 0 degrees of freedom (no redundancy): its u is not evaluated",
                p.key
            )));
        }
    }
    Ok(f)
}

fn sense(name: &Option<String>, field: &'static str) -> Result<RotationSense, NcError> {
    match name.as_deref() {
        None | Some("primed") => Ok(RotationSense::Primed),
        Some("right_handed") => Ok(RotationSense::RightHanded),
        Some(s) => Err(NcError {
            field,
            what: format!("{s:?}: primed or right_handed"),
        }),
    }
}

/// `program` (X Y Z A B, machine coordinates without TCPM, computed with the NC-set
/// centrelines) with every linear block's X Y Z moved to seed 004 §4.3's corrected point
/// ([`nc_command_correction`]: the work point recovered with the NC-set centrelines and
/// rotated about the estimated ones); A and B as programmed; `source` names the file in the
/// header. Only the tool-centre position is corrected, not the orientation: exact for a ball
/// end mill (spec B6).
pub fn correct_program_centrelines(
    program: &str,
    lines: &CentrelinesFile,
    source: &str,
) -> Result<String, NcError> {
    let actual = lines.actual.axes();
    let nominal = lines.nominal.unwrap_or(CentrelinePair::NOMINAL).axes();
    let senses = lines.sense.clone().unwrap_or(Senses { a: None, b: None });
    let (sa, sb) = (sense(&senses.a, "sense.a")?, sense(&senses.b, "sense.b")?);
    let header = [
        format!("corrected by ballpod ncgen for the centrelines of {source}: seed 004 eq 9, 4.3"),
        "each block's X Y Z moved to the work point turned about the estimated centrelines; A and B as programmed"
            .into(),
    ];
    let stated = [
        "u: standard uncertainty from the centrelines' u; U: k times u for 95.45 percent, k from Student's t at the Welch-Satterthwaite degrees of freedom, GUM G.4"
            .to_string(),
    ];
    let header = if lines.uncertainty.is_some() {
        [header.as_slice(), &stated].concat()
    } else {
        header.to_vec()
    };
    let correct = |[x, y, z, a_deg, b_deg]: [f64; 5]| {
        let at = |actual: &TableAxes| {
            nc_command_correction(
                actual,
                &nominal,
                [x, y, z],
                sa.physical_deg(a_deg),
                sb.physical_deg(b_deg),
            )
            .map(|c| c.corrected_command_mm)
            .map_err(|e| format!("not corrected: {e:?}"))
        };
        let point = at(&actual)?;
        let Some(budget) = &lines.uncertainty else {
            return Ok((point, None));
        };
        // each input moved by its u (a secant: the correction is linear in them far beyond
        // their size); the corrected point's changes c₁, c₂ of a pair with correlation r add
        // c₁² + c₂² + 2r·c₁c₂ to its variance (GUM 5.2.2)
        // the four pairs, then the written word's rounding: uniform over one resolution step,
        // (step)²/12, known exactly (GUM F.2.2.1)
        let rounding = (WORD_RESOLUTION_MM * 1e3).powi(2) / 12.0;
        let mut var_um2 = [[
            (0.0f64, None),
            (0.0, None),
            (0.0, None),
            (0.0, None),
            (rounding, None),
        ]; 3];
        for (i, pair) in budget.pairs().into_iter().enumerate() {
            let mut change = [[0.0f64; 3]; 2];
            for ((c, dir), u) in change.iter_mut().zip(pair.along).zip(pair.u) {
                let mut moved = actual;
                let line = pair.line.of(&mut moved);
                let (v, step) = if pair.tilt {
                    let step = u * 1e-6 * norm(line.direction);
                    (&mut line.direction, step)
                } else {
                    (&mut line.point_mm, u * 1e-3)
                };
                v.iter_mut().zip(dir).for_each(|(v, d)| *v += step * d);
                let p = at(&moved)?;
                for ((c, a), b) in c.iter_mut().zip(p).zip(point) {
                    *c = (a - b) * 1e3;
                }
            }
            let [c1, c2] = change;
            for ((v, a), b) in var_um2.iter_mut().zip(c1).zip(c2) {
                if let Some(v) = v.get_mut(i) {
                    *v = (a * a + b * b + 2.0 * pair.correlation * a * b, pair.dof);
                }
            }
        }
        Ok((point, Some(var_um2.map(|v| PointUncertainty::of(&v)))))
    };
    rewrite_points(program, ['A', 'B'], &header, &correct)
}

/// |d| of a direction (the file's directions may have any length).
fn norm(d: [f64; 3]) -> f64 {
    d.iter().map(|v| v * v).sum::<f64>().sqrt()
}

/// The uncertainty of one coordinate of a corrected point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointUncertainty {
    /// Standard uncertainty, µm.
    pub u_um: f64,
    /// Expanded uncertainty for 95.45 %, µm: k from Student's t at the Welch–Satterthwaite
    /// degrees of freedom (k = 2 when every input's are infinite).
    pub expanded_um: f64,
}

impl PointUncertainty {
    /// From its variance contributions (µm²) and their degrees of freedom.
    fn of(contributions: &[(f64, Option<u32>)]) -> Self {
        let u_um = contributions.iter().map(|(v, _)| v).sum::<f64>().sqrt();
        // every ν ≥ 1 (refused otherwise), so ν_eff ≥ 1 and k exists
        let k = crate::gum::coverage_factor(crate::gum::effective_dof(contributions));
        Self {
            u_um,
            expanded_um: k.map_or(f64::NAN, |k| k * u_um),
        }
    }
}

/// The corrected X Y Z (mm) of a point X Y Z (mm) R1 R2 (deg, the machine's two rotary axes),
/// with the uncertainty of each when the corrections state one.
type Corrector<'a> =
    dyn Fn([f64; 5]) -> Result<([f64; 3], Option<[PointUncertainty; 3]>), String> + 'a;

/// `program` with every linear block's X Y Z replaced by `correct` of its point, the machine's
/// rotary axes being `rotary` (another rotary word is refused), `header` written as comments
/// before the first block. Every move must know all five axes (the first one programs all);
/// dwells (`G4`) pass unchanged; arcs, probing, reference returns, machine-coordinate moves and
/// offset settings (`G10`, `G28`, `G30`, `G52`, `G53`, `G92`) are refused by line.
pub fn rewrite_points(
    program: &str,
    rotary: [char; 2],
    header: &[String],
    correct: &Corrector,
) -> Result<String, NcError> {
    let bad = |line: usize, what: String| NcError {
        field: "PROGRAM",
        what: format!("line {}: {what}", line + 1),
    };
    // modal state: motion mode and the position (machine coordinates: X Y Z mm, the rotary
    // axes deg) with the axes programmed so far (the others' positions are not known)
    let axes: String = ['X', 'Y', 'Z', rotary[0], rotary[1]].iter().collect();
    let (mut motion, mut pos, mut known) = (None::<u32>, [0.0f64; 5], [false; 5]);
    // an ISO/Fanuc program (ncgen's `%` dialect) takes upper-case comments
    let fanuc = program.trim_start().starts_with('%');
    let note = |s: String| if fanuc { s.to_uppercase() } else { s };
    let mut out = String::new();
    let mut header_done = false;
    for (i, line) in program.lines().enumerate() {
        let cut = line.find(['(', ';']).unwrap_or(line.len());
        let (code, comment) = line.split_at(cut);
        let trimmed = code.trim();
        if trimmed.is_empty() || trimmed == "%" || trimmed.starts_with('O') {
            out.push_str(line);
            out.push('\n');
            continue;
        }
        if !header_done {
            for h in header {
                let _ = writeln!(out, "({})", note(h.clone()));
            }
            header_done = true;
        }
        let w = words(code).map_err(|e| bad(i, e))?;
        let g_codes = w
            .iter()
            .filter(|(c, _)| *c == 'G')
            .map(|(_, n)| {
                n.parse::<f64>()
                    .map(|g| g as u32)
                    .map_err(|_| bad(i, format!("G{n}: not a number")))
            })
            .collect::<Result<Vec<u32>, NcError>>()?;
        // the motion group: G0 G1 (corrected), G2 G3 arcs, G31 / G38 probing
        if let Some(g) = g_codes.iter().rev().find(|g| matches!(g, 0..=3 | 31 | 38)) {
            motion = Some(*g);
        }
        // a dwell's X is its time on an ISO/Fanuc control: the block is not a move
        if g_codes.contains(&4) {
            out.push_str(line);
            out.push('\n');
            continue;
        }
        // reference returns, machine coordinates and offset settings take axis words that are
        // not a point of the path
        if let Some(g) = g_codes
            .iter()
            .find(|g| matches!(g, 10 | 28 | 30 | 52 | 53 | 92))
        {
            return Err(bad(
                i,
                format!("G{g}: not a point of the path; not corrected"),
            ));
        }
        let mut axis_word = false;
        for (c, n) in &w {
            let v = || {
                n.parse::<f64>()
                    .map_err(|_| bad(i, format!("{c}{n}: not a number")))
            };
            match c {
                _ if axes.contains(*c) => {
                    let k = axes.find(*c).unwrap_or(0);
                    pos[k] = v()?;
                    known[k] = true;
                    axis_word = true;
                }
                'A' | 'B' | 'C' | 'U' | 'V' | 'W' => {
                    return Err(bad(
                        i,
                        format!("{c}{n}: not an axis of this machine ({axes})"),
                    ));
                }
                'I' | 'J' | 'K' | 'R' => {
                    return Err(bad(i, "arc words: correct G1 points, not arcs".into()));
                }
                _ => {}
            }
        }
        if !axis_word {
            out.push_str(line);
            out.push('\n');
            continue;
        }
        match motion {
            Some(0 | 1) => {}
            Some(g) => {
                return Err(bad(
                    i,
                    format!("a G{g} move: only G0 / G1 points are corrected"),
                ));
            }
            None => return Err(bad(i, "a move before any G0/G1".into())),
        }
        if let Some(k) = known.iter().position(|k| !k) {
            let axis = axes.get(k..=k).unwrap_or("?");
            return Err(bad(
                i,
                format!("{axis} not programmed yet: its position is not known"),
            ));
        }
        let [x, y, z, _, _] = pos;
        let (xyz, u_um) = correct(pos).map_err(|e| bad(i, e))?;
        // the block again: its words before the first axis word, X Y Z corrected (all three:
        // a word the block left modal may move too), then its other words
        let xyz_words = format!(" X{} Y{} Z{}", num(xyz[0]), num(xyz[1]), num(xyz[2]));
        let mut text = String::new();
        let mut xyz_written = false;
        for (c, n) in &w {
            let axis = axes.contains(*c);
            if axis && !xyz_written {
                text.push_str(&xyz_words);
                xyz_written = true;
            }
            if !matches!(c, 'X' | 'Y' | 'Z') {
                let _ = write!(text, " {c}{n}");
            }
        }
        let um = |d: f64| format!("{:+.2}", d * 1e3);
        let mut moved = format!(
            "moved X {} Y {} Z {} um",
            um(xyz[0] - x),
            um(xyz[1] - y),
            um(xyz[2] - z)
        );
        if let Some([x, y, z]) = u_um {
            let _ = write!(
                moved,
                "; u X {:.2} Y {:.2} Z {:.2} um, U X {:.2} Y {:.2} Z {:.2} um",
                x.u_um, y.u_um, z.u_um, x.expanded_um, y.expanded_um, z.expanded_um
            );
        }
        let moved = note(moved);
        let _ = writeln!(out, "{} ({moved}){}", text.trim_start(), comment);
    }
    Ok(out)
}
