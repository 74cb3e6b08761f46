//! Compensation out, in the controller's terms (seed 002 chapter 3): an NC program rewritten
//! point by point with the machine's identified deviations, so that the tool reaches the ideal
//! workpiece points — `cargo ncgen -- correct PROGRAM SETUP RESULTS`.
//!
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
fn words(code: &str) -> Result<Vec<(char, String)>, String> {
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
/// `origin_mm` (machine coordinates); `source` names the results in the header comment. Every
/// move must know all five axes (the first one programs X Y Z B C); dwells (`G4`) pass
/// unchanged; reference returns, machine-coordinate moves and offset settings (`G10`, `G28`,
/// `G30`, `G52`, `G53`, `G92`) are refused.
pub fn correct_program(
    program: &str,
    origin_mm: [f64; 3],
    dev: &Deviations,
    source: &str,
) -> Result<String, NcError> {
    let bad = |line: usize, what: String| NcError {
        field: "PROGRAM",
        what: format!("line {}: {what}", line + 1),
    };
    // modal state: motion mode and the position (machine coordinates: X Y Z mm, B C deg) with
    // the axes programmed so far (the others' positions are not known)
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
            for h in [
                format!(
                    "corrected by ballpod ncgen for the deviations of {source}: seed 002 ch. 3, applied once"
                ),
                "each block's X Y Z moved by the compensation, minus the error; B and C as programmed"
                    .into(),
            ] {
                let _ = writeln!(out, "({})", note(h));
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
                'X' | 'Y' | 'Z' | 'B' | 'C' => {
                    let k = "XYZBC".find(*c).unwrap_or(0);
                    pos[k] = v()?;
                    known[k] = true;
                    axis_word = true;
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
            let axis = "XYZBC".get(k..=k).unwrap_or("?");
            return Err(bad(
                i,
                format!("{axis} not programmed yet: its position is not known"),
            ));
        }
        let [x, y, z, b_deg, c_deg] = pos;
        let block = NcBlock {
            x_mm: x - origin_mm[0],
            y_mm: y - origin_mm[1],
            z_mm: z - origin_mm[2],
            b_deg,
            c_deg,
        };
        let c = compensate(&block, dev, CompensationMode::Once)
            .map_err(|e| bad(i, format!("not compensated: {e:?}")))?;
        let xyz = [
            c.x_mm + origin_mm[0],
            c.y_mm + origin_mm[1],
            c.z_mm + origin_mm[2],
        ];
        // the block again: its words before the first axis word, X Y Z corrected (all three:
        // a word the block left modal may move too), then its other words
        let xyz_words = format!(" X{} Y{} Z{}", num(xyz[0]), num(xyz[1]), num(xyz[2]));
        let mut text = String::new();
        let mut xyz_written = false;
        for (c, n) in &w {
            let axis = matches!(c, 'X' | 'Y' | 'Z' | 'B' | 'C');
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
