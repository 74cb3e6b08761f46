//! Compensation out, in the controller's terms: an NC program rewritten point by point so that
//! the tool reaches the ideal workpiece points — for the seed 002 deviations
//! (`cargo ncgen -- correct PROGRAM SETUP RESULTS`, [`correct_program`]) and for seed 004's
//! estimated rotary-axis centrelines (`cargo ncgen -- correct-centrelines PROGRAM CENTRELINES`,
//! [`correct_program_centrelines`]). Both rewrite the program the same way
//! ([`rewrite_points`]); only the corrected point differs.
//!
//! Seed 002:
//! Every `G0`/`G1` block's X, Y, Z become the core's corrected command
//! ([`ballpod::identify::multitasking::compensation::compensate`], applied once: `A·x_c = P`,
//! eqs 3.4–3.10; compensation = −error) in the model frame (the block's position less the
//! set-up's `s002_origin`), B and C stay as programmed, and a trailing comment says what moved
//! and by how much (µm). The deviations are the pod's model-mode results by name (`dx_BT` …
//! `beta_CZ`, µm and arc-seconds, as `results.json` of the simulator and replay lists them);
//! all ten are applied, α_BT too (it moves the tool point; the thesis leaves it out because
//! the spindle's angle is not controlled — here only the point is corrected). Arcs (`G2`/`G3`)
//! are refused: a corrected arc is not an arc; program the path as `G1` points.

use std::fmt::Write as _;

use ballpod::identify::centreline::{AxisLine, RotationSense, TableAxes, nc_command_correction};
use ballpod::identify::multitasking::compensation::{CompensationMode, compensate};
use ballpod::identify::multitasking::patterns::NcBlock;
use ballpod::identify::multitasking::{Deviations, Parameter, arcsec_to_urad};

use super::{NcError, num};

/// The squareness deviations the ball-bar procedure does not identify (the pod's results
/// table has no entry for them): left 0.
const NOT_IDENTIFIED: [Parameter; 3] = [Parameter::GammaXy, Parameter::AlphaYz, Parameter::BetaYz];

/// The identified deviations of a results file (`{"results": [{"name", "value", …}]}`: µm and
/// arc-seconds); every one the procedure identifies (all but [`NOT_IDENTIFIED`]) must be there
/// and finite.
pub fn deviations_from_results(json: &str) -> Result<Deviations, NcError> {
    #[derive(serde::Deserialize)]
    struct Entry {
        name: String,
        value: Option<f64>,
    }
    #[derive(serde::Deserialize)]
    struct File {
        results: Vec<Entry>,
    }
    let bad = |what: String| NcError {
        field: "RESULTS",
        what,
    };
    let file: File = serde_json::from_str(json).map_err(|e| bad(e.to_string()))?;
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
            *slot = if p.is_positional() {
                v
            } else {
                arcsec_to_urad(v)
            };
        }
    }
    Ok(Deviations::from_array(&a))
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
/// `origin_mm` (machine coordinates); `source` names the results in the header comment.
pub fn correct_program(
    program: &str,
    origin_mm: [f64; 3],
    dev: &Deviations,
    source: &str,
) -> Result<String, NcError> {
    let header = [
        format!(
            "corrected by ballpod ncgen for the deviations of {source}: seed 002 ch. 3, applied once"
        ),
        "each block's X Y Z moved by the compensation, minus the error; B and C as programmed"
            .into(),
    ];
    let correct = |[x, y, z, b_deg, c_deg]: [f64; 5]| {
        let block = NcBlock {
            x_mm: x - origin_mm[0],
            y_mm: y - origin_mm[1],
            z_mm: z - origin_mm[2],
            b_deg,
            c_deg,
        };
        let c = compensate(&block, dev, CompensationMode::Once)
            .map_err(|e| format!("not compensated: {e:?}"))?;
        Ok([
            c.x_mm + origin_mm[0],
            c.y_mm + origin_mm[1],
            c.z_mm + origin_mm[2],
        ])
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
    let correct = |[x, y, z, a_deg, b_deg]: [f64; 5]| {
        nc_command_correction(
            &actual,
            &nominal,
            [x, y, z],
            sa.physical_deg(a_deg),
            sb.physical_deg(b_deg),
        )
        .map(|c| c.corrected_command_mm)
        .map_err(|e| format!("not corrected: {e:?}"))
    };
    rewrite_points(program, ['A', 'B'], &header, &correct)
}

/// The corrected X Y Z (mm) of a point X Y Z (mm) R1 R2 (deg, the machine's two rotary axes).
type Corrector<'a> = dyn Fn([f64; 5]) -> Result<[f64; 3], String> + 'a;

/// `program` with every linear block's X Y Z replaced by `correct` of its point, the machine's
/// rotary axes being `rotary` (another rotary word is refused), `header` written as comments
/// before the first block. Every move must know all five axes (the first one programs all);
/// dwells (`G4`) pass unchanged; arcs, probing, reference returns, machine-coordinate moves and
/// offset settings (`G10`, `G28`, `G30`, `G52`, `G53`, `G92`) are refused by line.
pub fn rewrite_points(
    program: &str,
    rotary: [char; 2],
    header: &[String; 2],
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
        let xyz = correct(pos).map_err(|e| bad(i, e))?;
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
        let moved = note(format!(
            "moved X {} Y {} Z {} um",
            um(xyz[0] - x),
            um(xyz[1] - y),
            um(xyz[2] - z)
        ));
        let _ = writeln!(out, "{} ({moved}){}", text.trim_start(), comment);
    }
    Ok(out)
}
