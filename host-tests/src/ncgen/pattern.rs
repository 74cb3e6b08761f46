//! The seed 002 procedure's pattern programs (steps BX, BY, CR, CA, CR2) from the pod's own
//! set-up (`s002_*` fields): the core's Table 2.2 / 2.3 commands
//! ([`ballpod::identify::mill_turn::patterns::PatternProgram`], the model frame moved by
//! `s002_origin`) as simultaneous G1 blocks of X Y Z B C.
//!
//! A B pattern turns B over a quarter (0° → 90° is CW in the pod's XZ plane, 90° → 0° CCW: the
//! pod's convention, θ from +X towards +Z), a C pattern turns C a full revolution
//! (0° → 360° CCW, back CW). The second run starts where the first ended, so the bar stays
//! mounted between runs with no move of its own; the machine is at the first block when the bar
//! is mounted. Feed: G94 mm/min, which the controls apply to the linear axes' path (the rotary
//! axis follows in the same block).

use std::fmt::Write as _;

use ballpod::app::bc_ballbar::{Setup, model_pattern};
use ballpod::app::{Direction, Pattern};
use ballpod::config::{Config, TestSetup};
use ballpod::identify::mill_turn::patterns::PatternProgram;

use super::{Dialect, NcError, Session, SessionStep, SetupField, field_lines, num, session_line};

/// The largest bar-length change between blocks the default block count allows, µm (a tenth
/// of a good ball bar's uncertainty: the thesis's 0.2778° blocks leave 1 µm on the B patterns).
pub const MAX_INTERPOLATION_ERROR_UM: f64 = 0.05;

/// A pattern program ready to be written: the set-up's geometry and the options checked.
#[derive(Clone, Debug, PartialEq)]
pub struct PatternTest {
    /// The procedure's step.
    pub step: Pattern,
    /// The set-up (lengths and the model frame's origin in machine coordinates).
    pub setup: Setup,
    /// Blocks per run (a B quarter or a C revolution).
    pub steps: usize,
    /// Feed, mm/min.
    pub feed_mm_per_min: f64,
    /// The runs, in order.
    pub directions: Vec<Direction>,
    /// The configuration fields the pod needs for the runs: the set `s002_*` geometry (not its
    /// uncertainties, which have defaults) and `bar_length` = L_B.
    pub setup_fields: Vec<SetupField>,
}

impl PatternTest {
    /// The program of `step` (BX, BY, CR, CA or CR2) for the set-up in `cfg`: every length the
    /// step needs set and positive, the origin set; `steps` in 4 … 100 000, the feed positive.
    pub fn from_config(
        cfg: &Config,
        step: Pattern,
        steps: usize,
        feed_mm_per_min: f64,
        directions: Vec<Direction>,
    ) -> Result<Self, NcError> {
        if step.seed002_step().is_none() {
            return Err(NcError {
                field: "PATTERN",
                what: format!("{}: not a seed 002 step (BX, BY, CR, CA, CR2)", step.name()),
            });
        }
        let setup = setup_of(&cfg.setup)?;
        if !(4..=100_000).contains(&steps) {
            return Err(NcError {
                field: "--steps",
                what: format!("{steps} outside [4, 100000]"),
            });
        }
        if !(feed_mm_per_min.is_finite() && feed_mm_per_min > 0.0) {
            return Err(NcError {
                field: "--feed",
                what: format!("{feed_mm_per_min} mm/min: must be > 0"),
            });
        }
        if directions.is_empty() {
            return Err(NcError {
                field: "--direction",
                what: "no direction".into(),
            });
        }
        let test = Self {
            step,
            setup,
            steps,
            feed_mm_per_min,
            directions,
            setup_fields: s002_fields(cfg),
        };
        // the core validates the geometry (e.g. CR with R_C = L_B puts the T-ball on the axis)
        test.run(Direction::Ccw).map_err(|e| NcError {
            field: "s002_*",
            what: format!("{e:?}"),
        })?;
        Ok(test)
    }

    /// The blocks of one run.
    fn run(
        &self,
        d: Direction,
    ) -> Result<PatternProgram, ballpod::identify::mill_turn::patterns::PatternError> {
        let span = if model_pattern(self.step).is_b() {
            90.0
        } else {
            360.0
        };
        // B: 0 → 90° turns CW in the pod's XZ plane; C: 0 → 360° turns CCW
        let increasing = model_pattern(self.step).is_b() == (d == Direction::Cw);
        let (from, to) = if increasing { (0.0, span) } else { (span, 0.0) };
        PatternProgram::new(
            model_pattern(self.step),
            self.setup.geometry(self.step),
            self.setup.offset,
            from,
            to,
            self.steps,
        )
    }

    /// The largest change of the bar's length between two consecutive blocks, µm, on a perfect
    /// machine. The controls interpolate a block in joint space (every axis linear, no
    /// tool-centre-point control), so between blocks the balls leave the pattern: by the
    /// sagitta R·Δ²/8 of a pivot circle of radius R turned Δ per block, the bar's share of it
    /// (its mean over a block, ⅔ of the peak, acts on the fit like a ball offset).
    pub fn interpolation_error_um(&self) -> f64 {
        let machine = crate::vmt::machine::Machine002::perfect();
        let Ok(blocks) = self.run(Direction::Ccw) else {
            return f64::NAN;
        };
        let axes = |b: &ballpod::identify::mill_turn::patterns::NcBlock| {
            [b.x_mm, b.y_mm, b.z_mm, b.b_deg, b.c_deg]
        };
        let blocks: Vec<[f64; 5]> = blocks.map(|b| axes(&b)).collect();
        blocks
            .windows(2)
            .map(|w| {
                let mid: [f64; 5] = std::array::from_fn(|k| 0.5 * (w[0][k] + w[1][k]));
                machine.delta_l_um(&self.setup, self.step, &mid).abs()
            })
            .fold(0.0, f64::max)
    }

    /// The default blocks per run: the thesis's step (0.2778°: 324 per B quarter, 1296 per C
    /// revolution), doubled until the interpolation error between blocks is at most
    /// [`MAX_INTERPOLATION_ERROR_UM`] (or 100 000 blocks).
    pub fn default_steps(
        cfg: &Config,
        step: Pattern,
        feed_mm_per_min: f64,
    ) -> Result<usize, NcError> {
        let mut steps = if model_pattern(step).is_b() {
            324
        } else {
            1296
        };
        loop {
            let t = Self::from_config(cfg, step, steps, feed_mm_per_min, vec![Direction::Ccw])?;
            if steps * 2 > 100_000 || t.interpolation_error_um() <= MAX_INTERPOLATION_ERROR_UM {
                return Ok(steps);
            }
            steps *= 2;
        }
    }

    /// The part program in `dialect`; the pod is driven by its client (no M-codes).
    pub fn program(&self, dialect: Dialect) -> String {
        self.program_with(dialect, None)
    }

    /// The part program in `dialect`, with `session`'s M-codes when given (a commanded
    /// session: the seed 002 runs start and stop on the client's or the program's command):
    /// `M150 P<n>` applies the set-up, then per run: arm before it, start at `(… run start)`,
    /// stop at `(… run end)`, wait for its results.
    pub fn program_with(&self, dialect: Dialect, session: Option<&Session>) -> String {
        let s = &self.setup;
        let g = s.geometry(self.step);
        let names: Vec<&str> = self.directions.iter().map(|d| d.name()).collect();
        let mut out = String::new();
        let header = [
            format!(
                "ballpod seed 002 pattern {}, {}",
                self.step.name(),
                names.join(" then ")
            ),
            format!(
                "L_B {} R_B {} R_C {} Z_C {} mm, model origin at X {} Y {} Z {}",
                num(g.l_b_mm),
                num(g.r_b_mm),
                num(g.r_c_mm),
                num(g.z_c_mm),
                num(s.offset.x_mm),
                num(s.offset.y_mm),
                num(s.offset.z_mm)
            ),
            format!(
                "{} blocks per run, feed {} mm/min on the linear axes",
                self.steps,
                num(self.feed_mm_per_min)
            ),
            format!(
                "joint-space interpolation: the bar leaves the pattern by up to {} um between blocks",
                num(self.interpolation_error_um())
            ),
            format!("pod set-up, pattern {}, the fields:", self.step.name()),
            match session {
                None => "the pod runs one test per direction: arm it before each run".into(),
                Some(se) => session_line(se),
            },
        ];
        let at = header.len() - 1;
        let mut header = header.to_vec();
        header.splice(at..at, field_lines(&self.setup_fields));
        dialect.begin(&mut out, &header);
        let _ = writeln!(out, "G21 G90 G94");
        let step = |out: &mut String, st: SessionStep| {
            if let Some(se) = session {
                let _ = writeln!(out, "{}", se.block(st));
            }
        };
        step(&mut out, SessionStep::SetUp);
        let mut first = true;
        for d in &self.directions {
            // from_config checked the geometry: a run always builds
            let Ok(mut blocks) = self.run(*d) else {
                continue;
            };
            let Some(start) = blocks.next() else {
                continue;
            };
            let words = |b: &ballpod::identify::mill_turn::patterns::NcBlock| {
                format!(
                    "X{} Y{} Z{} B{} C{}",
                    num(b.x_mm),
                    num(b.y_mm),
                    num(b.z_mm),
                    num(b.b_deg),
                    num(b.c_deg)
                )
            };
            step(
                &mut out,
                match d {
                    Direction::Ccw => SessionStep::ArmCcw,
                    Direction::Cw => SessionStep::ArmCw,
                },
            );
            if first {
                dialect.comment(
                    &mut out,
                    &format!(
                        "{} run: mount the bar at this point before the start",
                        d.name()
                    ),
                );
                let _ = writeln!(out, "G0 {}", words(&start));
                first = false;
            }
            // the run starts where the machine is (the mounting point, or the previous run's
            // end): its first block is the next one
            dialect.comment(&mut out, &format!("{} run start", d.name()));
            step(&mut out, SessionStep::Start);
            for (i, b) in blocks.enumerate() {
                if i == 0 {
                    let _ = writeln!(out, "G1 {} F{}", words(&b), num(self.feed_mm_per_min));
                } else {
                    let _ = writeln!(out, "G1 {}", words(&b));
                }
            }
            dialect.comment(&mut out, &format!("{} run end", d.name()));
            step(&mut out, SessionStep::Stop);
            step(&mut out, SessionStep::Results);
        }
        dialect.end(&mut out);
        out
    }
}

/// The fields a seed 002 run needs: every set `s002_*` geometry field (their uncertainties have
/// defaults), then `bar_length` — the procedure's bar, L_B (`s002_l_b`).
fn s002_fields(cfg: &Config) -> Vec<SetupField> {
    let mut out: Vec<SetupField> = ballpod::config::FIELDS
        .iter()
        .flat_map(|row| row.fields())
        .filter_map(|f| {
            let name = ballpod::app::field_name(f);
            let v = cfg.field_value(f)?;
            (name.starts_with("s002_") && !name.starts_with("s002_u_") && v.is_finite())
                .then_some((name, v))
        })
        .collect();
    out.push(("bar_length", f64::from(cfg.setup.s002_l_b_mm)));
    out
}

/// The seed 002 set-up of a configuration, or the first field it lacks, by name.
fn setup_of(t: &TestSetup) -> Result<Setup, NcError> {
    Setup::from_config(t).map_err(|f| NcError {
        field: Config::field_info(f).map_or("s002_*", |i| i.name),
        what: "not set".into(),
    })
}
