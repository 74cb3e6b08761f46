//! Part programs for the pod's tests (`cargo ncgen`): the machine moves through the test the
//! pod measures. Today: the ISO 230-4 circle (full or partial arc) in XY, YZ or ZX, CCW and CW,
//! from the pod's own set-up (`circle_*` fields), the seed 002 procedure's patterns BX, BY, CR,
//! CA, CR2 ([`PatternTest`], `s002_*` fields), the touch-probe sphere measurement
//! ([`SphereTest`]), the single-socket-method station set ([`SsmTest`], `ssm_*` fields) and
//! seed 000's two-step procedure ([`TwoStepTest`], `ts_*` fields), in two dialects ([`Dialect`]: LinuxCNC and ISO/Fanuc), every dialect
//! difference in `dialect.rs`; and a program corrected for the identified deviations
//! ([`correct_program`], seed 002 chapter 3) or for estimated rotary-axis centrelines
//! ([`correct_program_centrelines`], seed 004 eq 9 and §4.3).
//!
//! A circle test per direction, as ball-bar users know it: rapid to the **feed-in** point (the
//! start angle, `feed_in_mm` outside the radius: the bar extended), a radial feed move onto the
//! circle, the **data arc** (`arc_deg` from `start_deg`, measured from the plane's first axis
//! towards its second, the pod's convention), the **overshoot** arc (`overshoot_deg` further,
//! so that the data arc is not cut by the reversal of the start and stop), and a radial
//! **feed-out**; the next run returns to its feed-in point along the path just run, at the
//! feed-in radius (a straight move would cut the circle and crush the bar). The machine is at
//! the first feed-in point when the bar is mounted. The pod's run covers the data arc (armed before, started on it or by the CNC,
//! stopped at its end); comments mark where it begins and ends.

pub mod carr;
pub mod carr_mixed;
mod correct;
mod dialect;
pub mod kins;
mod pattern;
mod session;
mod sphere;
mod ssm;
mod travel;
mod two_step;

pub use correct::{
    CentrelinePair, CentrelineUncertainty, CentrelinesFile, IdentifiedDeviations, PointUncertainty,
    Senses, centrelines_from_toml, correct_program, correct_program_centrelines,
    deviations_from_results, rewrite_points,
};
pub use dialect::Dialect;
pub use pattern::PatternTest;
pub use session::{
    DEFAULT_M_BASE, STEPS as SESSION_STEPS, Session, SessionStep, SetupField, StepInfo,
    scripts as session_scripts, setup_file,
};
pub use sphere::SphereTest;
pub use ssm::SsmTest;
pub use travel::{Extents, Travel, check as check_travel, extents};
pub use two_step::TwoStepTest;

use std::fmt::Write as _;

use ballpod::app::Direction;
use ballpod::config::{CirclePlane, Config, RunTrigger};

/// The LVDT's stroke either side of the bar's length, mm (the bars the pod reads).
pub const BAR_STROKE_MM: f64 = 1.1;

/// Why a test cannot be programmed (the set-up field or option named).
#[derive(Clone, Debug, PartialEq)]
pub struct NcError {
    /// The configuration field or command-line option.
    pub field: &'static str,
    /// What is wrong with it.
    pub what: String,
}

impl std::fmt::Display for NcError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.field, self.what)
    }
}

/// How the circle is run (the command line's options; the geometry is the set-up's).
#[derive(Clone, Debug, PartialEq)]
pub struct CircleOptions {
    /// Start of the data arc, degrees from the plane's first axis towards its second.
    pub start_deg: f64,
    /// Span of the data arc, degrees (0 < span ≤ 360).
    pub arc_deg: f64,
    /// Arc run past the data arc's end before feeding out, degrees (0 … 180).
    pub overshoot_deg: f64,
    /// Radial feed-in and feed-out distance, mm (0.1 … 10; the bar's stroke is ±1.1 mm at
    /// the LVDT, so a feed-in beyond it moves a magnetic-socket bar, not the LVDT).
    pub feed_in_mm: f64,
    /// The runs, in order.
    pub directions: Vec<Direction>,
    /// Who starts and stops the runs: the header's `run_trigger` and the M-codes written.
    pub trigger: RunTrigger,
}

impl Default for CircleOptions {
    /// A full circle from 0°, 45° overshoot, 1 mm feed-in, CCW then CW, started by command.
    fn default() -> Self {
        Self {
            start_deg: 0.0,
            arc_deg: 360.0,
            overshoot_deg: 45.0,
            feed_in_mm: 1.0,
            directions: vec![Direction::Ccw, Direction::Cw],
            trigger: RunTrigger::Command,
        }
    }
}

/// A circle test ready to be written: the set-up's geometry checked, the options checked.
#[derive(Clone, Debug, PartialEq)]
pub struct CircleRun {
    /// Plane of the circle.
    pub plane: CirclePlane,
    /// Centre (the socket), mm; the out-of-plane coordinate may be unknown (not moved).
    pub centre_mm: [Option<f64>; 3],
    /// Radius, mm.
    pub radius_mm: f64,
    /// The bar's calibrated length, mm (the set-up's `bar_length`).
    pub bar_length_mm: f64,
    /// Feed, mm/min.
    pub feed_mm_per_min: f64,
    /// The options.
    pub options: CircleOptions,
}

/// Axis indices (0 X, 1 Y, 2 Z) of a plane's first and second axis and its normal.
pub fn plane_axes(plane: CirclePlane) -> (usize, usize, usize) {
    match plane {
        CirclePlane::XY => (0, 1, 2),
        CirclePlane::YZ => (1, 2, 0),
        CirclePlane::ZX => (2, 0, 1),
    }
}

impl CircleRun {
    /// The test of the set-up in `cfg` with `options`: the circle's radius, feed and in-plane
    /// centre must be set and positive (finite); the options in their ranges.
    pub fn from_config(cfg: &Config, options: CircleOptions) -> Result<Self, NcError> {
        let t = &cfg.setup;
        let (u, v, _) = plane_axes(t.circle_plane);
        let set = |x: f32| Some(f64::from(x)).filter(|x| x.is_finite());
        // the normal's coordinate may stay unknown (that axis is not moved); u and v may not
        let centre_mm = t.circle_centre_mm.map(set);
        for k in [u, v] {
            if centre_mm[k].is_none() {
                return Err(NcError {
                    field: "circle_centre",
                    what: format!("circle_centre_{} not set", ["x", "y", "z"][k]),
                });
            }
        }
        let positive = |x: f32, field: &'static str| match set(x) {
            Some(x) if x > 0.0 => Ok(x),
            _ => Err(NcError {
                field,
                what: format!("{x} mm: must be set and > 0"),
            }),
        };
        let radius_mm = positive(t.circle_radius_mm, "circle_radius")?;
        // the bar is the radius: on the circle the LVDT must stay within its stroke
        let bar_length_mm = f64::from(cfg.bar_length_mm);
        if (radius_mm - bar_length_mm).abs() > BAR_STROKE_MM {
            return Err(NcError {
                field: "circle_radius",
                what: format!(
                    "{radius_mm} mm: the bar (bar_length {bar_length_mm} mm) reaches only ±{BAR_STROKE_MM} mm beyond its length"
                ),
            });
        }
        let feed_mm_per_min = positive(t.circle_feed_mm_per_min, "circle_feed")?;
        let range = |x: f64, lo: f64, hi: f64, open_lo: bool, field: &'static str| {
            let ok = x.is_finite() && (if open_lo { x > lo } else { x >= lo }) && x <= hi;
            if ok {
                Ok(())
            } else {
                let l = if open_lo { "(" } else { "[" };
                Err(NcError {
                    field,
                    what: format!("{x} outside {l}{lo}, {hi}]"),
                })
            }
        };
        let o = &options;
        range(o.start_deg, -360.0, 360.0, false, "--start-deg")?;
        range(o.arc_deg, 0.0, 360.0, true, "--arc-deg")?;
        range(o.overshoot_deg, 0.0, 180.0, false, "--overshoot-deg")?;
        range(o.feed_in_mm, 0.1, 10.0, false, "--feed-in-mm")?;
        if o.directions.is_empty() {
            return Err(NcError {
                field: "--direction",
                what: "no direction".into(),
            });
        }
        Ok(Self {
            plane: t.circle_plane,
            centre_mm,
            radius_mm,
            bar_length_mm,
            feed_mm_per_min,
            options,
        })
    }

    /// Every configuration field the pod needs for this program's runs, as the header names
    /// them and `M150` applies them.
    pub fn setup_fields(&self) -> Vec<SetupField> {
        let mut f: Vec<SetupField> = vec![("circle_plane", f64::from(self.plane as u8))];
        for (name, c) in ["circle_centre_x", "circle_centre_y", "circle_centre_z"]
            .into_iter()
            .zip(self.centre_mm)
        {
            if let Some(c) = c {
                f.push((name, c));
            }
        }
        let arc_deg = self.options.arc_deg;
        f.extend([
            ("circle_radius", self.radius_mm),
            ("bar_length", self.bar_length_mm),
            ("circle_feed", self.feed_mm_per_min),
            ("circle_arc", arc_deg),
        ]);
        if arc_deg < 360.0 {
            // a partial arc: the pod's minimum (default 300°) would refuse it
            f.push(("circle_min_arc", arc_deg));
        }
        f.push(("run_trigger", f64::from(self.options.trigger as u8)));
        f
    }

    /// The point at angle `deg` and distance `r_mm` from the centre, in the plane, mm (the
    /// out-of-plane coordinate is the centre's, if known).
    pub fn point(&self, deg: f64, r_mm: f64) -> [Option<f64>; 3] {
        let (u, v, _) = plane_axes(self.plane);
        let mut p = self.centre_mm;
        let (s, c) = deg.to_radians().sin_cos();
        p[u] = p[u].map(|x| x + r_mm * c);
        p[v] = p[v].map(|x| x + r_mm * s);
        p
    }

    /// The part program in `dialect`; the pod is driven by its client (no M-codes).
    pub fn program(&self, dialect: Dialect) -> String {
        self.program_with(dialect, None)
    }

    /// The part program in `dialect`, with `session`'s M-codes when given: `M150 P<n>` applies
    /// the set-up, then per direction: arm before the feed-in (or before the return to it),
    /// start at the data arc's start and stop at its end (run_trigger COMMAND), wait for the
    /// results after the feed-out.
    pub fn program_with(&self, dialect: Dialect, session: Option<&Session>) -> String {
        let o = &self.options;
        let mut out = String::new();
        let names: Vec<&str> = o.directions.iter().map(|d| d.name()).collect();
        let axis = ["X", "Y", "Z"];
        let centre: Vec<String> = self
            .centre_mm
            .iter()
            .zip(axis)
            .map(|(c, a)| match c {
                Some(c) => format!("{a} {}", num(*c)),
                None => format!("{a} as set"),
            })
            .collect();
        let header = [
            format!(
                "ballpod ISO 230-4 circle test, plane {}, {}",
                CirclePlane::NAMES[self.plane as usize],
                names.join(" then ")
            ),
            format!(
                "radius {} mm, centre {}, feed {} mm/min",
                num(self.radius_mm),
                centre.join(" "),
                num(self.feed_mm_per_min)
            ),
            format!(
                "data arc {} deg from {} deg, overshoot {} deg, feed-in {} mm",
                num(o.arc_deg),
                num(o.start_deg),
                num(o.overshoot_deg),
                num(o.feed_in_mm)
            ),
            "pod set-up, pattern CIRCLE, the fields:".into(),
            match session {
                None => "the pod runs one test per direction: arm it before each feed-in; with run_trigger FEED_IN the feed-in starts it, the data arc's end stops it"
                    .into(),
                Some(s) => session_line(s),
            },
        ];
        let at = header.len() - 1;
        let mut header = header.to_vec();
        let fields = self.setup_fields();
        header.splice(at..at, field_lines(&fields));
        dialect.begin(&mut out, &header);
        let _ = writeln!(out, "{}", dialect.modal(self.plane));
        let step = |out: &mut String, st: SessionStep| {
            if let Some(s) = session {
                let commanded = matches!(st, SessionStep::Start | SessionStep::Stop);
                if s.commanded() || !commanded {
                    let _ = writeln!(out, "{}", s.block(st));
                }
            }
        };
        step(&mut out, SessionStep::SetUp);
        let (_, _, w) = plane_axes(self.plane);
        if let Some(z) = self.centre_mm[w] {
            let _ = writeln!(out, "G0 {}{}", axis[w], num(z));
        }
        let r = self.radius_mm;
        let out_r = r + o.feed_in_mm;
        // where the previous run fed out: its direction and angle
        let mut previous: Option<(Direction, f64)> = None;
        for d in &o.directions {
            let sign = match d {
                Direction::Ccw => 1.0,
                Direction::Cw => -1.0,
            };
            let data_end = o.start_deg + sign * o.arc_deg;
            let over_end = data_end + sign * o.overshoot_deg;
            step(
                &mut out,
                match d {
                    Direction::Ccw => SessionStep::ArmCcw,
                    Direction::Cw => SessionStep::ArmCw,
                },
            );
            match previous {
                None => {
                    dialect.comment(
                        &mut out,
                        &format!(
                            "{} run: feed-in; mount the bar at this point before the start",
                            d.name()
                        ),
                    );
                    let _ = writeln!(out, "G0 {}", self.words(o.start_deg, out_r));
                }
                Some((back, at)) => {
                    // back to the start along the path just run, at the feed-in radius: the
                    // bar stays within its stroke (a straight move would cut the circle)
                    dialect.comment(&mut out, &format!("{} run: back to the feed-in", d.name()));
                    let back = match back {
                        Direction::Ccw => Direction::Cw,
                        Direction::Cw => Direction::Ccw,
                    };
                    if (o.arc_deg + o.overshoot_deg) % 360.0 != 0.0 {
                        self.arc_at(&mut out, back, at, o.start_deg, out_r);
                    }
                }
            }
            let _ = writeln!(
                out,
                "G1 {} F{}",
                self.words(o.start_deg, r),
                num(self.feed_mm_per_min)
            );
            dialect.comment(&mut out, &format!("{} data arc start", d.name()));
            step(&mut out, SessionStep::Start);
            self.arc(&mut out, *d, o.start_deg, data_end);
            dialect.comment(&mut out, &format!("{} data arc end, overshoot", d.name()));
            step(&mut out, SessionStep::Stop);
            if o.overshoot_deg > 0.0 {
                self.arc(&mut out, *d, data_end, over_end);
            }
            dialect.comment(&mut out, &format!("{} feed-out", d.name()));
            let _ = writeln!(out, "G1 {}", self.words(over_end, out_r));
            step(&mut out, SessionStep::Results);
            previous = Some((*d, over_end));
        }
        dialect.end(&mut out);
        out
    }

    /// The in-plane axes in the order words are written: XY and YZ in axis order, ZX as X
    /// then Z (the usual order).
    fn word_axes(&self) -> [usize; 2] {
        let (u, v, _) = plane_axes(self.plane);
        [u.min(v), u.max(v)]
    }

    /// The address words of the in-plane axes at angle `deg`, radius `r_mm`.
    fn words(&self, deg: f64, r_mm: f64) -> String {
        let p = self.point(deg, r_mm);
        let axis = ["X", "Y", "Z"];
        self.word_axes()
            .iter()
            .map(|&k| format!("{}{}", axis[k], num(p[k].unwrap_or(0.0))))
            .collect::<Vec<_>>()
            .join(" ")
    }

    /// One arc block on the circle from `from_deg` to `to_deg` (|span| ≤ 360°: equal ends is
    /// a full circle) with the centre as incremental offsets from the start point.
    fn arc(&self, out: &mut String, d: Direction, from_deg: f64, to_deg: f64) {
        self.arc_at(out, d, from_deg, to_deg, self.radius_mm);
    }

    /// The same at radius `r_mm`.
    fn arc_at(&self, out: &mut String, d: Direction, from_deg: f64, to_deg: f64, r_mm: f64) {
        let g = match d {
            Direction::Ccw => "G3",
            Direction::Cw => "G2",
        };
        let start = self.point(from_deg, r_mm);
        let offset = ["I", "J", "K"];
        let centre: Vec<String> = self
            .word_axes()
            .iter()
            .map(|&k| {
                let o = self.centre_mm[k].unwrap_or(0.0) - start[k].unwrap_or(0.0);
                format!("{}{}", offset[k], num(o))
            })
            .collect();
        let _ = writeln!(out, "{g} {} {}", self.words(to_deg, r_mm), centre.join(" "));
    }
}

/// The header line of a program with its session.
fn session_line(s: &Session) -> String {
    format!(
        "the M-codes M{}-M{} drive the pod: set-up {}, arm, start, stop, results; book: Running a test from the CNC",
        s.m_base,
        s.m_base + SESSION_STEPS.len() as u16 - 1,
        s.setup_number
    )
}

/// The set-up fields as header comment lines, a few to a line (controls limit a block's
/// length: LinuxCNC 255 characters).
fn field_lines(fields: &[SetupField]) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    for w in fields.iter().map(|(name, v)| setup_word(name, *v)) {
        match lines.last_mut() {
            Some(l) if l.len() + w.len() < 64 => {
                l.push_str(", ");
                l.push_str(&w);
            }
            _ => lines.push(format!("  {w}")),
        }
    }
    lines
}

/// A set-up field as the header names it: `circle_plane XY`, `run_trigger COMMAND`, numbers
/// with the programs' 4 decimals.
fn setup_word(name: &str, v: f64) -> String {
    let choice = |names: &[&str]| names.get(v as usize).map(|n| n.to_string());
    let value = match name {
        "circle_plane" => choice(&CirclePlane::NAMES),
        "run_trigger" => choice(&RunTrigger::NAMES),
        _ => None,
    };
    format!("{name} {}", value.unwrap_or_else(|| num(v)))
}

/// The resolution of the coordinates the programs write ([`num`]), mm.
pub const WORD_RESOLUTION_MM: f64 = 1e-4;

/// A coordinate as the programs write it: 4 decimals (0.1 µm), `-0` as `0`.
pub fn num(x: f64) -> String {
    let s = format!("{x:.4}");
    if s == "-0.0000" { "0.0000".into() } else { s }
}
