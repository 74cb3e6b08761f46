//! The machine's travel: a set-up file's optional `[travel]` table gives each axis's range, and
//! a program that would take an axis beyond it is refused with the axis named — nothing is
//! written. The check reads the program ncgen wrote (any of its tests, and the corrected
//! programs): the end point of every move, and for an arc (`G2`/`G3` in `G17`/`G18`/`G19`) its
//! exact extent (the ends and every axis extreme the arc passes).
//!
//! ```toml
//! [travel]             # mm and degrees, machine coordinates; an axis not listed is not checked
//! x_mm = [-300.0, 300.0]
//! z_mm = [-400.0, 0.0]
//! b_deg = [-5.0, 95.0]
//! ```

use serde::Deserialize;

use super::NcError;
use super::correct::words;

/// `[travel]`: each axis's [min, max].
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Travel {
    /// X, mm.
    pub x_mm: Option<[f64; 2]>,
    /// Y, mm.
    pub y_mm: Option<[f64; 2]>,
    /// Z, mm.
    pub z_mm: Option<[f64; 2]>,
    /// A, degrees.
    pub a_deg: Option<[f64; 2]>,
    /// B, degrees.
    pub b_deg: Option<[f64; 2]>,
    /// C, degrees.
    pub c_deg: Option<[f64; 2]>,
}

/// Axis letters in [`Extents`] order, with their `[travel]` field names.
const AXES: [(char, &str); 6] = [
    ('X', "travel.x_mm"),
    ('Y', "travel.y_mm"),
    ('Z', "travel.z_mm"),
    ('A', "travel.a_deg"),
    ('B', "travel.b_deg"),
    ('C', "travel.c_deg"),
];

/// Per axis (X Y Z A B C) the smallest and largest position a program reaches (`None`: never
/// programmed).
pub type Extents = [Option<(f64, f64)>; 6];

/// The extents of `program` (ncgen's own output: one block a line, comments in parentheses).
pub fn extents(program: &str) -> Result<Extents, NcError> {
    let bad = |line: usize, what: String| NcError {
        field: "PROGRAM",
        what: format!("line {}: {what}", line + 1),
    };
    let mut ext: Extents = [None; 6];
    let mut reach = |k: usize, v: f64| {
        let e = ext[k].get_or_insert((v, v));
        *e = (e.0.min(v), e.1.max(v));
    };
    let (mut pos, mut motion, mut plane) = ([f64::NAN; 6], 0u32, 17u32);
    for (i, line) in program.lines().enumerate() {
        let code = line.split(['(', ';']).next().unwrap_or("").trim();
        if code.is_empty() || code == "%" || code.starts_with('O') {
            continue;
        }
        let w = words(code).map_err(|e| bad(i, e))?;
        let num = |n: &str| {
            n.parse::<f64>()
                .map_err(|_| bad(i, format!("{n}: not a number")))
        };
        let mut g_codes = Vec::new();
        for (c, n) in &w {
            if *c == 'G' {
                g_codes.push(num(n)? as u32);
            }
        }
        if g_codes.contains(&4) {
            continue; // a dwell's X is its time on an ISO/Fanuc control
        }
        for g in &g_codes {
            match g {
                0..=3 | 31 | 38 => motion = *g,
                17..=19 => plane = *g,
                _ => {}
            }
        }
        let start = pos;
        let mut ijk = [0.0f64; 3];
        let mut moved = false;
        for (c, n) in &w {
            if let Some(k) = AXES.iter().position(|(a, _)| a == c) {
                pos[k] = num(n)?;
                moved = true;
            } else if let Some(k) = "IJK".find(*c) {
                ijk[k] = num(n)?;
            }
        }
        if !moved {
            continue;
        }
        for (k, v) in pos.iter().enumerate() {
            if v.is_finite() {
                reach(k, *v);
            }
        }
        if matches!(motion, 2 | 3) {
            // the arc's plane axes (first, second) and their centre offsets
            let (a, b) = match plane {
                17 => (0, 1),
                18 => (2, 0),
                _ => (1, 2),
            };
            let (oa, ob) = (ijk[a], ijk[b]);
            let centre = [start[a] + oa, start[b] + ob];
            let r = oa.hypot(ob);
            let angle = |p: [f64; 6]| (p[b] - centre[1]).atan2(p[a] - centre[0]);
            let (t0, t1) = (angle(start), angle(pos));
            let ccw = motion == 3;
            let tau = std::f64::consts::TAU;
            // the swept range from t0 in the arc's direction (a full turn if the ends coincide)
            let mut sweep = if ccw { t1 - t0 } else { t0 - t1 };
            sweep = sweep.rem_euclid(tau);
            if sweep < 1e-12 {
                sweep = tau;
            }
            for q in 0..4 {
                let extreme = q as f64 * std::f64::consts::FRAC_PI_2;
                let from_start = if ccw { extreme - t0 } else { t0 - extreme }.rem_euclid(tau);
                if from_start <= sweep {
                    reach(a, centre[0] + r * extreme.cos());
                    reach(b, centre[1] + r * extreme.sin());
                }
            }
        }
    }
    Ok(ext)
}

/// Refuses `program` if it takes an axis beyond `travel`, naming the `[travel]` field.
pub fn check(program: &str, travel: &Travel) -> Result<(), NcError> {
    let ranges = [
        travel.x_mm,
        travel.y_mm,
        travel.z_mm,
        travel.a_deg,
        travel.b_deg,
        travel.c_deg,
    ];
    for ((_, field), range) in AXES.iter().zip(ranges) {
        if let Some([lo, hi]) = range
            && !(lo.is_finite() && hi.is_finite() && lo < hi)
        {
            return Err(NcError {
                field,
                what: format!("[{lo}, {hi}]: not a range (finite, min below max)"),
            });
        }
    }
    for ((axis, field), (range, ext)) in AXES.iter().zip(ranges.into_iter().zip(extents(program)?))
    {
        if let (Some([lo, hi]), Some((min, max))) = (range, ext) {
            // the words' 0.1 µm / 0.0001° resolution is not beyond the travel
            if min < lo - 5e-5 || max > hi + 5e-5 {
                return Err(NcError {
                    field,
                    what: format!(
                        "the program takes {axis} from {min:.4} to {max:.4}, beyond the travel [{lo}, {hi}]"
                    ),
                });
            }
        }
    }
    Ok(())
}
