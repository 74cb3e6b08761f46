//! A part program's commanded path as LinuxCNC's own interpreter gives it: `rs274 -g` prints
//! the canonical commands (`STRAIGHT_FEED`, `ARC_FEED`, `SET_FEED_RATE`, `SELECT_PLANE`,
//! `COMMENT`), which this module reads, splits into the program's data runs and samples at the
//! pod's rate — the virtual machine's motion source for `cargo sim -- --nc DIR` (NC program →
//! interpreter → virtual machine → pod → results).
//!
//! **Runs.** The generated programs (`cargo ncgen`) mark each data run with comments:
//! `(CCW run start)` … `(CCW run end)` for the seed 002 patterns, `(CCW data arc start)` …
//! `(CCW data arc end, overshoot)` for the circles; the moves between a start and its end are
//! the run.
//!
//! **Time.** As LinuxCNC plans a block in units-per-minute mode (`G94`, feed reference XYZ): a
//! move that changes X, Y or Z lasts its X Y Z path length over the feed (the rotary axes keep
//! in step: joint-space interpolation, no tool-centre-point control), a rotary-only move its
//! largest angle over the feed (degrees per minute). Samples are taken every `1/rate` s from the
//! run's first point, through the block boundaries, up to its last point; acceleration is not
//! modelled (the blocks' corners are passed at the feed).

use ballpod::app::Direction;

/// Axes of a canonical position: X, Y, Z (mm), A, B, C (degrees).
pub(crate) type Axes6 = [f64; 6];

/// The selected plane of an arc: (first, second, normal) axis indices of X Y Z.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ArcPlane([usize; 3]);

/// One feed move of a run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Move {
    /// Straight, every axis linear in time.
    Line { from: Axes6, to: Axes6, feed: f64 },
    /// Arc (helix) in `plane` about `centre` (first, second axis), `turns` the signed angle
    /// swept, rad; the normal axis and the rotary axes linear in time.
    Arc {
        from: Axes6,
        to: Axes6,
        plane: ArcPlane,
        centre: [f64; 2],
        turns: f64,
        feed: f64,
    },
}

impl Move {
    /// Where it ends.
    pub(crate) fn end(&self) -> Axes6 {
        match self {
            Move::Line { to, .. } | Move::Arc { to, .. } => *to,
        }
    }

    /// The sense of rotation in the arc's plane: +1 CCW, −1 CW, 0 for a straight move.
    pub(crate) fn sense(&self) -> f64 {
        match self {
            Move::Line { .. } => 0.0,
            Move::Arc { turns, .. } => turns.signum(),
        }
    }

    /// Duration, s.
    pub(crate) fn seconds(&self) -> f64 {
        let per_s = |feed: f64| feed / 60.0;
        match *self {
            Move::Line { from, to, feed } => {
                let d = |k: usize| to[k] - from[k];
                let xyz = (d(0).powi(2) + d(1).powi(2) + d(2).powi(2)).sqrt();
                let len = if xyz > 1e-9 {
                    xyz
                } else {
                    d(3).abs().max(d(4).abs()).max(d(5).abs())
                };
                len / per_s(feed)
            }
            Move::Arc {
                from,
                to,
                plane: ArcPlane([a, b, n]),
                centre,
                turns,
                feed,
            } => {
                let r = (from[a] - centre[0]).hypot(from[b] - centre[1]);
                ((r * turns).powi(2) + (to[n] - from[n]).powi(2)).sqrt() / per_s(feed)
            }
        }
    }

    /// The position a fraction `f` (0…1) of the move's time in.
    pub(crate) fn at(&self, f: f64) -> Axes6 {
        let lerp = |from: &Axes6, to: &Axes6| -> Axes6 {
            std::array::from_fn(|k| from[k] + (to[k] - from[k]) * f)
        };
        match self {
            Move::Line { from, to, .. } => lerp(from, to),
            Move::Arc {
                from,
                to,
                plane: ArcPlane([a, b, _]),
                centre,
                turns,
                ..
            } => {
                let mut p = lerp(from, to);
                let (u0, v0) = (from[*a] - centre[0], from[*b] - centre[1]);
                let (u1, v1) = (to[*a] - centre[0], to[*b] - centre[1]);
                let r = u0.hypot(v0) + (u1.hypot(v1) - u0.hypot(v0)) * f;
                let th = v0.atan2(u0) + turns * f;
                p[*a] = centre[0] + r * th.cos();
                p[*b] = centre[1] + r * th.sin();
                p
            }
        }
    }
}

/// One data run of a program: its direction and its moves.
#[derive(Clone, Debug, PartialEq)]
pub struct NcRun {
    /// The direction the program's comment names.
    pub direction: Direction,
    moves: Vec<Move>,
}

impl NcRun {
    /// The commanded axes every `1/rate_hz` s from the run's first point (X, Y, Z mm; B, C
    /// degrees: the pod's five inputs; A is not one of them).
    pub fn samples(&self, rate_hz: f64) -> Vec<[f64; 5]> {
        let total: f64 = self.moves.iter().map(Move::seconds).sum();
        let n = (total * rate_hz).floor() as usize;
        let mut out = Vec::with_capacity(n + 1);
        let (mut k, mut t0) = (0usize, 0.0);
        for m in &self.moves {
            let dur = m.seconds();
            while k <= n {
                let t = k as f64 / rate_hz - t0;
                if t > dur && dur > 0.0 {
                    break;
                }
                let f = if dur > 0.0 { (t / dur).min(1.0) } else { 1.0 };
                let p = m.at(f);
                out.push([p[0], p[1], p[2], p[4], p[5]]);
                k += 1;
            }
            t0 += dur;
        }
        out
    }
}

/// Runs `rs274 -g` (Debian package `linuxcnc-uspace`) on `program` and returns its canonical
/// commands, or why not.
pub fn interpret(program: &std::path::Path) -> Result<String, String> {
    let out = std::process::Command::new("rs274")
        .arg("-g")
        .arg(program)
        .output()
        .map_err(|e| {
            format!("rs274 (LinuxCNC's interpreter, Debian package linuxcnc-uspace): {e}")
        })?;
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    if !out.status.success() {
        return Err(format!(
            "rs274 -g {}: {}{}",
            program.display(),
            text,
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    Ok(text)
}

/// One canonical command: its name and arguments (`  12 N..... NAME(a, b, …)`).
fn command(line: &str) -> Option<(&str, Vec<&str>)> {
    let rest = line.split_once("N..... ")?.1;
    let (name, args) = rest.split_once('(')?;
    let args = args.strip_suffix(')')?;
    let args = if args.is_empty() {
        Vec::new()
    } else if name == "COMMENT" || name == "MESSAGE" {
        vec![args.trim_matches('"')]
    } else {
        args.split(',').map(str::trim).collect()
    };
    Some((name, args))
}

/// The direction and whether a comment starts (`true`) or ends a run, if it marks one.
fn marker(comment: &str) -> Option<(Direction, bool)> {
    let (dir, rest) = comment.split_once(' ')?;
    let direction = match dir {
        "CCW" => Direction::Ccw,
        "CW" => Direction::Cw,
        _ => return None,
    };
    if rest == "run start" || rest == "data arc start" {
        Some((direction, true))
    } else if rest.starts_with("run end") || rest.starts_with("data arc end") {
        // the circles' end comment goes on: `(CCW data arc end, overshoot)`
        Some((direction, false))
    } else {
        None
    }
}

/// One canonical command the motion follows, in program order.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum CanonStep {
    /// A feed move (`STRAIGHT_FEED`, `ARC_FEED`).
    Feed(Move),
    /// A rapid (`STRAIGHT_TRAVERSE`) from one point to another.
    Traverse { from: Axes6, to: Axes6 },
    /// A comment's text.
    Comment(String),
    /// A message's text (`(MSG, …)`).
    Message(String),
}

/// The moves, comments and messages of a program's canonical commands (`rs274 -g` output), in
/// program order: the one reading of the canonical commands ([`runs`], [`super::nc_program`]).
pub(crate) fn canon_steps(canon: &str) -> Result<Vec<CanonStep>, String> {
    let num = |s: &str| {
        s.parse::<f64>()
            .map_err(|_| format!("not a number in the canonical commands: {s}"))
    };
    let axes = |a: &[&str]| -> Result<Axes6, String> {
        let mut p = [0.0; 6];
        for (k, v) in p.iter_mut().enumerate() {
            *v = num(a.get(k).ok_or("a move with fewer than six axes")?)?;
        }
        Ok(p)
    };
    let (mut pos, mut feed, mut plane) = ([0.0; 6], 0.0, ArcPlane([0, 1, 2]));
    let mut out = Vec::new();
    for line in canon.lines() {
        let Some((name, a)) = command(line) else {
            continue;
        };
        let mv = match name {
            "SET_FEED_RATE" => {
                feed = num(a.first().ok_or("SET_FEED_RATE without a rate")?)?;
                None
            }
            "SELECT_PLANE" => {
                plane = match a.first().copied() {
                    Some("CANON_PLANE_XY") => ArcPlane([0, 1, 2]),
                    Some("CANON_PLANE_YZ") => ArcPlane([1, 2, 0]),
                    Some("CANON_PLANE_XZ") => ArcPlane([2, 0, 1]),
                    p => return Err(format!("unknown plane {p:?}")),
                };
                None
            }
            "STRAIGHT_TRAVERSE" => {
                let to = axes(&a)?;
                out.push(CanonStep::Traverse { from: pos, to });
                pos = to;
                None
            }
            "STRAIGHT_FEED" => {
                let to = axes(&a)?;
                Some(Move::Line {
                    from: pos,
                    to,
                    feed,
                })
            }
            "ARC_FEED" => {
                // first end, second end, first centre, second centre, rotation, normal end, A, B, C
                let v = |k: usize| num(a.get(k).ok_or("ARC_FEED with too few arguments")?);
                let ArcPlane([f, s, n]) = plane;
                let mut to = pos;
                to[f] = v(0)?;
                to[s] = v(1)?;
                to[n] = v(5)?;
                to[3] = v(6)?;
                to[4] = v(7)?;
                to[5] = v(8)?;
                let centre = [v(2)?, v(3)?];
                let rotation = v(4)?;
                let ang = |p: &Axes6| (p[s] - centre[1]).atan2(p[f] - centre[0]);
                let tau = std::f64::consts::TAU;
                let sweep = (ang(&to) - ang(&pos)).rem_euclid(tau);
                // LinuxCNC: rotation > 0 CCW, < 0 CW, |rotation| − 1 extra full turns; ends
                // that coincide make a full turn
                let extra = (rotation.abs() - 1.0).max(0.0) * tau;
                let turns = if rotation > 0.0 {
                    (if sweep < 1e-12 { tau } else { sweep }) + extra
                } else {
                    -((if tau - sweep < 1e-12 || sweep < 1e-12 {
                        tau
                    } else {
                        tau - sweep
                    }) + extra)
                };
                Some(Move::Arc {
                    from: pos,
                    to,
                    plane,
                    centre,
                    turns,
                    feed,
                })
            }
            "COMMENT" | "MESSAGE" => {
                let text = a.first().copied().unwrap_or("").trim().to_string();
                out.push(if name == "COMMENT" {
                    CanonStep::Comment(text)
                } else {
                    CanonStep::Message(text)
                });
                None
            }
            _ => None,
        };
        if let Some(m) = mv {
            if feed <= 0.0 {
                return Err(format!("a feed move without a feed rate: {line}"));
            }
            pos = m.end();
            out.push(CanonStep::Feed(m));
        }
    }
    Ok(out)
}

/// The data runs of a program's canonical commands (`rs274 -g` output), in program order.
pub fn runs(canon: &str) -> Result<Vec<NcRun>, String> {
    let (mut out, mut open): (Vec<NcRun>, Option<NcRun>) = (Vec::new(), None);
    for step in canon_steps(canon)? {
        match step {
            CanonStep::Comment(c) => {
                if let Some((direction, start)) = marker(&c) {
                    match (start, open.take()) {
                        (true, None) => {
                            open = Some(NcRun {
                                direction,
                                moves: Vec::new(),
                            })
                        }
                        (false, Some(run)) if run.direction == direction => out.push(run),
                        _ => return Err(format!("run markers out of order at: ({c})")),
                    }
                }
            }
            CanonStep::Feed(m) => {
                if let Some(run) = open.as_mut() {
                    run.moves.push(m);
                }
            }
            CanonStep::Traverse { .. } | CanonStep::Message(_) => {}
        }
    }
    if open.is_some() {
        return Err("a run starts but never ends".into());
    }
    Ok(out)
}
