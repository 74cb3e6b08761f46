//! `cargo ncgen -- circle SETUP [options]` / `cargo ncgen -- pattern PATTERN SETUP [options]` /
//! `cargo ncgen -- sphere --centre X Y Z [options]`: the part program of a test, for LinuxCNC or
//! an ISO/Fanuc control: the ISO 230-4 circle from the pod's set-up (a TOML / JSON file with a
//! `[setup]` table of configuration fields, as replay's session files: `circle_plane`,
//! `circle_centre_*`, `circle_radius`, `circle_feed`), a seed 002 procedure pattern from its
//! `s002_*` fields, a touch-probe sphere measurement, or an SSM station set from its `ssm_*`
//! fields (`cargo ncgen -- ssm SETUP --target X Y Z`), seed 000's two-step procedure from its
//! `ts_*` fields (`cargo ncgen -- two-step SETUP`); `cargo ncgen -- correct PROGRAM SETUP
//! RESULTS` rewrites a program for the identified deviations (seed 002 chapter 3), and
//! `cargo ncgen -- correct-centrelines PROGRAM CENTRELINES` for estimated rotary-axis
//! centrelines (seed 004 eq 9); `cargo ncgen -- kins xyzac-trt RESULTS` writes an R-test's
//! identified axis lines into LinuxCNC's trt kinematics (`kins xyzbc-trt CENTRELINES.toml`
//! seed 004's; HAL `setp` lines, or the generic table with `--format csv`), `kins sinumerik-p`
//! the same into a SINUMERIK swivel table's record and `kins sinumerik-m RESULTS` seed 002's
//! deviations into a SINUMERIK mixed record (`$TC_CARR` assignments). Prints the
//! program, or writes it with `--out`. A set-up the machine cannot run is refused with the field
//! named — a program beyond the set-up file's `[travel]` too —; nothing is written.

use std::path::PathBuf;

use clap::{Parser, Subcommand, ValueEnum};

use ballpod::app::Direction;
use ballpod::config::{CirclePlane, Config, RunTrigger};
use ballpod_host::ncgen::{
    CircleOptions, CircleRun, Dialect, PatternTest, Session, SphereTest, SsmTest, TwoStepTest,
    centrelines_from_toml, check_travel, correct_program, correct_program_centrelines,
    deviations_from_results, session_scripts, setup_file,
};
use ballpod_host::session_file::{read_text, setup_config, setup_travel};

/// The control the program is for.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum DialectArg {
    /// LinuxCNC (RS274/NGC).
    Linuxcnc,
    /// ISO / Fanuc style.
    Fanuc,
}

/// Which runs, in order.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum Directions {
    /// CCW then CW.
    Both,
    /// CCW only.
    Ccw,
    /// CW only.
    Cw,
}

/// Part programs for the pod's tests.
#[derive(Parser, Debug)]
#[command(name = "cargo ncgen", version)]
struct Args {
    /// Control dialect.
    #[arg(long, value_enum, default_value = "linuxcnc", global = true)]
    dialect: DialectArg,
    /// Output file (default: standard output).
    #[arg(long, global = true)]
    out: Option<PathBuf>,
    #[command(subcommand)]
    test: Test,
}

/// The test to program.
#[derive(Subcommand, Debug)]
enum Test {
    /// An ISO 230-4 circle from the pod's set-up file.
    Circle(CircleArgs),
    /// The three-plane test from the pod's set-up file (every circle_centre coordinate set):
    /// an XY full circle, YZ and ZX arcs (default 220° from −20°), CCW then CW each, as
    /// `DIR/XY.ngc`, `DIR/YZ.ngc`, `DIR/ZX.ngc` with each plane's set-up
    /// (`DIR/ballpod-setup-<n>.toml`, n = --setup-number, +1, +2) to write to the pod before it.
    ThreePlanes(ThreePlanesArgs),
    /// A seed 002 procedure pattern (BX, BY, CR, CA, CR2) from the pod's set-up file.
    Pattern(PatternArgs),
    /// A touch-probe sphere measurement (pattern PROBE): nine touches along the normals.
    Sphere(SphereArgs),
    /// A single-socket-method station set (pattern SSM) from the pod's set-up file.
    Ssm(SsmArgs),
    /// Seed 000's two-step procedure (pattern SSM twice: after the translation and after the
    /// rotation) from the pod's set-up file (`ts_*` fields; RRTTT, TTTRR, RTTTR_SPINDLE or RTTTR_TABLE).
    TwoStep(TwoStepArgs),
    /// A program's G0/G1 points corrected for the identified deviations (seed 002 ch. 3; the
    /// program keeps its dialect).
    Correct(CorrectArgs),
    /// A program's G0/G1 points (X Y Z A B, no TCPM) corrected for estimated rotary-axis
    /// centrelines (seed 004 eq 9 and 4.3; the program keeps its dialect).
    CorrectCentrelines(CentrelinesArgs),
    /// Identified rotary-axis lines (an R-test's results, seed 004's centrelines) as the pins
    /// of LinuxCNC's table-tilting kinematics (HAL `setp` lines with the dispersion before and
    /// after and what the kinematics cannot take) or a SINUMERIK swivel data record of type P
    /// (`$TC_CARR` assignments), or the generic table (`--format csv`).
    Kins(KinsArgs),
    /// The LinuxCNC user M-code scripts of a program's session (`--session`): `DIR/M150` …
    /// `M155`, the python module they call and the pod's EDS; put DIR in the INI's
    /// `[RS274NGC] USER_M_PATH`.
    MCodes(MCodesArgs),
}

/// The kinematics to correct.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum KinsArg {
    /// `xyzac-trt-kins`: A tilts the table about X, C turns it about Z.
    XyzacTrt,
    /// `xyzbc-trt-kins`: B tilts the table about Y, C turns it about Z.
    XyzbcTrt,
    /// A SINUMERIK orientable toolholder of kinematic type P (a swivel table,
    /// `$TC_CARR23="P"`): rotary axis 1 tilts, axis 2 is the table it carries.
    SinumerikP,
    /// A SINUMERIK orientable toolholder of kinematic type M (mixed, `$TC_CARR23="M"`):
    /// rotary axis 1 turns the tool (seed 002's B head), axis 2 the part (its C table).
    SinumerikM,
}

/// What `kins` writes.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum KinsFormat {
    /// The control's own lines: HAL `setp` lines (LinuxCNC) or `$TC_CARR` assignments
    /// (SINUMERIK), the rest as comments.
    Hal,
    /// The generic table: deviation, ISO 230-1 name, value, u, unit, control parameter.
    Csv,
}

/// The correction's inputs.
#[derive(clap::Args, Debug)]
struct KinsArgs {
    /// The control's kinematics.
    #[arg(value_enum)]
    kins: KinsArg,
    /// Where the lines come from: an R-test's results (`results.json` of `cargo replay`,
    /// xyzac-trt, sinumerik-p), seed 004's centrelines file (`.toml`, as `correct-centrelines`
    /// takes it, with `[uncertainty]`; xyzbc-trt, sinumerik-p) or seed 002's results
    /// (`results.json` of `cargo sim` or `cargo replay`; sinumerik-m).
    source: PathBuf,
    /// The R-test's geometry as its session file gives it (`[rtest] geometry_mm`): ball X_w
    /// Y_w Z_w from the C-frame origin, C-frame origin X_c Y_c Z_c from the A axis, mm
    /// (default: seed 003 Table 3).
    #[arg(long, num_args = 6, allow_negative_numbers = true, value_names = ["X_W", "Y_W", "Z_W", "X_C", "Y_C", "Z_C"])]
    geometry_mm: Option<Vec<f64>>,
    /// A pin's present value in the control, `NAME=MM` (e.g. `x-rot-point=12.5`): every pin
    /// the kinematics reads (`tool-offset` may be left at 0), or none — then the values are in
    /// the R-test's frame (the nominal A axis through the origin, C at X_c, Y_c).
    #[arg(long = "pin", value_name = "NAME=MM")]
    pins: Vec<String>,
    /// A SINUMERIK record's present value, `N=VALUE` with N the `$TC_CARR` number (4…12,
    /// 15…20; e.g. `4=250.0`; type M also 1…3 and 24): every one of l2, v1, v2, l3 (l1, 1…3,
    /// and l4, 18…20, may be left out: they close the chains; 24, axis 1's offset, defaults to
    /// 0), or none — then the values are the source's frame's nominal ones.
    #[arg(long = "carr", value_name = "N=VALUE")]
    carr: Vec<String>,
    /// The SINUMERIK swivel data record's number (`$TC_CARR…[N]`).
    #[arg(long, default_value_t = 1)]
    record: u16,
    /// The largest change a pin or a record's length may take, µm (a larger one is refused).
    #[arg(long, default_value_t = 200.0)]
    max_change_um: f64,
    /// The largest turn a SINUMERIK record's vector may take, µrad (a larger one is refused).
    #[arg(long, default_value_t = 500.0)]
    max_turn_urad: f64,
    /// The tilt axis's range for the dispersion, degrees (default −90 … 0 for A, 0 … 90 for
    /// seed 002's B).
    #[arg(long, num_args = 2, allow_negative_numbers = true, value_names = ["LOW", "HIGH"])]
    tilt_range_deg: Option<Vec<f64>>,
    /// sinumerik-m: the table face's height in the record's machine coordinates, mm — where
    /// seed 002 states C's position (its model frame's z = 0, from which Z_C is measured).
    /// Required with --carr; without, the model frame's 0.
    #[arg(long, allow_negative_numbers = true)]
    table_face_z_mm: Option<f64>,
    /// sinumerik-m: the tool tip's distance below the B pivot for the dispersion, mm (default
    /// R_B of the thesis's Table 4.3).
    #[arg(long)]
    tool_mm: Option<f64>,
    /// sinumerik-m: take the touch probe's figures (`probe_*`, thesis chapter 5) even when the
    /// file has the model mode's (without them they are taken anyway).
    #[arg(long)]
    probe: bool,
    /// The work point the lines are placed at (C at its height, A at its X, B at its Y) and
    /// the dispersion is taken about, in the pins' frame, mm. Default: the R-test's ball, or
    /// for centrelines the table axis at the tilt axis's height.
    #[arg(long, num_args = 3, allow_negative_numbers = true, value_names = ["X", "Y", "Z"])]
    work_point_mm: Option<Vec<f64>>,
    /// Half the side of the cube about the work point the dispersion covers, mm (0: the
    /// work point only).
    #[arg(long, default_value_t = 50.0)]
    half_side_mm: f64,
    /// What to write.
    #[arg(long, value_enum, default_value = "hal")]
    format: KinsFormat,
}

/// Where the M-code scripts go.
#[derive(clap::Args, Debug)]
struct MCodesArgs {
    /// The directory (created if missing).
    dir: PathBuf,
    /// The first of the six M-codes (100 … 194).
    #[arg(long, default_value_t = ballpod_host::ncgen::DEFAULT_M_BASE)]
    m_base: u16,
}

/// Who starts and stops a circle's runs.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum TriggerArg {
    /// The program's M-codes (start at the data arc, stop at its end).
    Command,
    /// The pod itself (run_trigger FEED_IN): the program only arms and waits.
    FeedIn,
}

/// Who starts a circle's runs: `--trigger` when given, else the set-up's `run_trigger`.
fn run_trigger(arg: Option<TriggerArg>, cfg: &Config) -> RunTrigger {
    match arg {
        Some(TriggerArg::Command) => RunTrigger::Command,
        Some(TriggerArg::FeedIn) => RunTrigger::FeedIn,
        None => cfg.setup.run_trigger,
    }
}

/// A program that drives the pod itself.
#[derive(clap::Args, Debug)]
struct SessionArgs {
    /// Write the pod's session into the program as M-codes (book: "Running a test from the
    /// CNC"), and the set-up they apply to `--setup-out`.
    #[arg(long)]
    session: bool,
    /// The first of the six M-codes (100 … 194).
    #[arg(long, default_value_t = ballpod_host::ncgen::DEFAULT_M_BASE)]
    m_base: u16,
    /// The set-up's number (`M150 P<n>` applies `ballpod-setup-<n>.toml`).
    #[arg(long, default_value_t = 1000)]
    setup_number: u32,
    /// Who starts and stops the runs (default: the set-up's `run_trigger`).
    #[arg(long, value_enum)]
    trigger: Option<TriggerArg>,
    /// Write the set-up the program needs here (TOML: `[session]` pattern, `[setup]` fields),
    /// e.g. `DIR/ballpod-setup-1000.toml` beside the M-code scripts.
    #[arg(long)]
    setup_out: Option<PathBuf>,
}

/// The program to correct and the centrelines file.
#[derive(clap::Args, Debug)]
struct CentrelinesArgs {
    /// The NC program (G0/G1 points of X Y Z A B, machine coordinates, computed with the
    /// NC-set centrelines).
    program: PathBuf,
    /// Centrelines file (TOML): `[actual]`, optional `[nominal]` and `[sense]` (book: "Part
    /// programs").
    centrelines: PathBuf,
}

/// The station set's place and layout (the socket, bar and dwell detection are the set-up's).
#[derive(clap::Args, Debug)]
struct SsmArgs {
    /// Set-up file (.toml or .json) with a `[setup]` table of configuration fields.
    setup: PathBuf,
    /// The point whose error is wanted: the first station is on the bar's sphere towards it.
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true, required = true)]
    target: Vec<f64>,
    #[command(flatten)]
    layout: StationArgs,
}

/// A station set's layout.
#[derive(clap::Args, Debug)]
struct StationArgs {
    /// Angle between the first station and its neighbours, degrees.
    #[arg(long, default_value_t = 10.0, allow_negative_numbers = true)]
    separation_deg: f64,
    /// Stations per set, the first included (3 … 8).
    #[arg(long, default_value_t = 4)]
    stations: usize,
    /// Feed between stations, mm/min.
    #[arg(long, default_value_t = 1000.0, allow_negative_numbers = true)]
    feed: f64,
}

/// The two-step's station sets (the geometry is the set-up's `ts_*` fields).
#[derive(clap::Args, Debug)]
struct TwoStepArgs {
    /// Set-up file (.toml or .json) with a `[setup]` table of configuration fields.
    setup: PathBuf,
    #[command(flatten)]
    layout: StationArgs,
}

/// The program to correct and where the deviations come from.
#[derive(clap::Args, Debug)]
struct CorrectArgs {
    /// The NC program (G0/G1 points of X Y Z B C, machine coordinates).
    program: PathBuf,
    /// Set-up file with the model frame's origin (`s002_origin_x/y/z`).
    setup: PathBuf,
    /// Results file with the identified deviations (`results.json` of sim or replay).
    results: PathBuf,
}

/// The circle's options (the geometry is the set-up's).
#[derive(clap::Args, Debug)]
struct CircleArgs {
    /// Set-up file (.toml or .json) with a `[setup]` table of configuration fields.
    setup: PathBuf,
    /// Runs, in order.
    #[arg(long, value_enum, default_value = "both")]
    direction: Directions,
    /// Start of the data arc, degrees from the plane's first axis towards its second.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    start_deg: f64,
    /// Span of the data arc, degrees (0 < span ≤ 360; default: the set-up's `circle_arc`, else
    /// 360).
    #[arg(long, allow_negative_numbers = true)]
    arc_deg: Option<f64>,
    /// Overshoot past the data arc, degrees (0 … 180).
    #[arg(long, default_value_t = 45.0, allow_negative_numbers = true)]
    overshoot_deg: f64,
    /// Radial feed-in / feed-out distance, mm (0.1 … 10).
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    feed_in_mm: f64,
    #[command(flatten)]
    session: SessionArgs,
}

/// The three-plane test's options (the geometry is the set-up's).
#[derive(clap::Args, Debug)]
struct ThreePlanesArgs {
    /// Set-up file (.toml or .json) with a `[setup]` table of configuration fields.
    setup: PathBuf,
    /// Directory for the three programs and their set-up files.
    #[arg(long)]
    out_dir: PathBuf,
    /// Start of the YZ and ZX data arcs, degrees from the plane's first axis.
    #[arg(long, default_value_t = -20.0, allow_negative_numbers = true)]
    vertical_start_deg: f64,
    /// Span of the YZ and ZX data arcs, degrees (220 … 360: the summary needs every quadrant).
    #[arg(long, default_value_t = 220.0, allow_negative_numbers = true)]
    vertical_arc_deg: f64,
    /// Radial feed-in / feed-out distance, mm (0.1 … 10).
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    feed_in_mm: f64,
    #[command(flatten)]
    session: SessionArgs,
}

/// The pattern and its options (the geometry is the set-up's `s002_*` fields).
#[derive(clap::Args, Debug)]
struct PatternArgs {
    /// The procedure's step: BX, BY, CR, CA or CR2.
    pattern: String,
    /// Set-up file (.toml or .json) with a `[setup]` table of configuration fields.
    setup: PathBuf,
    /// Runs, in order.
    #[arg(long, value_enum, default_value = "both")]
    direction: Directions,
    /// Blocks per run (a B quarter turn or a C revolution). Default: the thesis's 0.2778° steps
    /// (324 per quarter, 1296 per revolution) doubled until the bar leaves the pattern by at
    /// most 0.05 µm between blocks (the controls interpolate in joint space).
    #[arg(long)]
    steps: Option<usize>,
    /// Feed of the linear axes, mm/min.
    #[arg(long, default_value_t = 1000.0, allow_negative_numbers = true)]
    feed: f64,
    #[command(flatten)]
    session: SessionArgs,
}

/// The sphere's place (as the stylus ball's centre) and size.
#[derive(clap::Args, Debug)]
struct SphereArgs {
    /// Sphere centre X, Y, Z (the stylus ball's centre on it), mm.
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true, required = true)]
    centre: Vec<f64>,
    /// Sphere radius plus stylus ball radius, mm.
    #[arg(long, default_value_t = 14.2, allow_negative_numbers = true)]
    contact_radius: f64,
    /// B during the measurement, degrees.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    b_deg: f64,
    /// C during the measurement, degrees.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    c_deg: f64,
}

fn main() {
    let args: Args = ballpod_host::cli::parse();
    match run(&args) {
        Ok(program) => match &args.out {
            Some(p) => {
                if let Err(e) = std::fs::write(p, program) {
                    eprintln!("ncgen: {}: {e}", p.display());
                    std::process::exit(1);
                }
            }
            None => print!("{program}"),
        },
        Err(e) => {
            eprintln!("ncgen: {e}");
            std::process::exit(1);
        }
    }
}

fn run(args: &Args) -> Result<String, String> {
    let dialect = match args.dialect {
        DialectArg::Linuxcnc => Dialect::LinuxCnc,
        DialectArg::Fanuc => Dialect::Fanuc,
    };
    match &args.test {
        Test::Circle(c) => {
            let text = read_text(&c.setup).map_err(|e| e.to_string())?;
            let cfg = setup_config(&c.setup, &text).map_err(|e| e.to_string())?;
            let a = &c.session;
            // the set-up file is the program's source; an option given overrides it, and the
            // header then names what the program was made for
            let file_arc = Some(f64::from(cfg.setup.circle_arc_deg)).filter(|x| x.is_finite());
            let trigger = run_trigger(a.trigger, &cfg);
            let options = CircleOptions {
                start_deg: c.start_deg,
                arc_deg: c.arc_deg.or(file_arc).unwrap_or(360.0),
                overshoot_deg: c.overshoot_deg,
                feed_in_mm: c.feed_in_mm,
                directions: directions(c.direction),
                trigger,
            };
            let test = CircleRun::from_config(&cfg, options)
                .map_err(|e| format!("{}: {e}", c.setup.display()))?;
            let session = if a.session {
                Some(Session::new(a.m_base, a.setup_number, trigger)?)
            } else {
                None
            };
            let program = within_travel(&c.setup, test.program_with(dialect, session.as_ref()))?;
            if let Some(path) = &a.setup_out {
                let text = setup_file(
                    "CIRCLE",
                    &test.setup_fields(),
                    &format!("ballpod set-up {} (ncgen circle)", a.setup_number),
                );
                std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))?;
            }
            Ok(program)
        }
        Test::ThreePlanes(t) => three_planes(t, dialect).map(|files| {
            let mut listing = String::new();
            for f in files {
                listing.push_str(&format!("{}\n", f.display()));
            }
            listing
        }),
        Test::MCodes(m) => {
            Session::new(m.m_base, 0, RunTrigger::Command)?;
            let d = &m.dir;
            std::fs::create_dir_all(d).map_err(|e| format!("{}: {e}", d.display()))?;
            let mut eds = String::new();
            ballpod::protocol::canopen::eds::write_eds(&mut eds).map_err(|e| e.to_string())?;
            let mut files = session_scripts(m.m_base);
            files.push(("ballpod.eds".into(), eds, false));
            for (name, text, executable) in files {
                let path = d.join(&name);
                std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))?;
                if executable {
                    use std::os::unix::fs::PermissionsExt;
                    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755))
                        .map_err(|e| format!("{}: {e}", path.display()))?;
                }
            }
            Ok(String::new())
        }
        Test::Pattern(p) => {
            let step = ballpod::app::Pattern::from_name(p.pattern.as_bytes())
                .ok_or_else(|| format!("PATTERN: {:?} is not BX, BY, CR, CA or CR2", p.pattern))?;
            let text = read_text(&p.setup).map_err(|e| e.to_string())?;
            let cfg = setup_config(&p.setup, &text).map_err(|e| e.to_string())?;
            let steps = match p.steps {
                Some(n) => n,
                None => PatternTest::default_steps(&cfg, step, p.feed)
                    .map_err(|e| format!("{}: {e}", p.setup.display()))?,
            };
            let test = PatternTest::from_config(&cfg, step, steps, p.feed, directions(p.direction))
                .map_err(|e| format!("{}: {e}", p.setup.display()))?;
            let a = &p.session;
            if matches!(a.trigger, Some(TriggerArg::FeedIn)) {
                return Err("--trigger feed-in: a seed 002 run starts and stops on command".into());
            }
            let session = if a.session {
                Some(Session::new(a.m_base, a.setup_number, RunTrigger::Command)?)
            } else {
                None
            };
            let program = within_travel(&p.setup, test.program_with(dialect, session.as_ref()))?;
            if let Some(path) = &a.setup_out {
                let text = setup_file(
                    step.name(),
                    &test.setup_fields,
                    &format!(
                        "ballpod set-up {} (ncgen pattern {})",
                        a.setup_number,
                        step.name()
                    ),
                );
                std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))?;
            }
            Ok(program)
        }
        Test::Ssm(a) => {
            let text = read_text(&a.setup).map_err(|e| e.to_string())?;
            let cfg = setup_config(&a.setup, &text).map_err(|e| e.to_string())?;
            let target = [0, 1, 2].map(|k| a.target.get(k).copied().unwrap_or(f64::NAN));
            let l = &a.layout;
            let test = SsmTest::from_config(&cfg, target, l.separation_deg, l.stations, l.feed)
                .map_err(|e| format!("{}: {e}", a.setup.display()))?;
            within_travel(&a.setup, test.program(dialect))
        }
        Test::Correct(c) => {
            let read = |p: &PathBuf| {
                std::fs::read_to_string(p).map_err(|e| format!("{}: {e}", p.display()))
            };
            let program = read(&c.program)?;
            let text = read_text(&c.setup).map_err(|e| e.to_string())?;
            let cfg = setup_config(&c.setup, &text).map_err(|e| e.to_string())?;
            let origin = cfg.setup.s002_origin_mm.map(f64::from);
            if origin.iter().any(|v| v.is_nan()) {
                return Err(format!("{}: s002_origin_x/y/z: not set", c.setup.display()));
            }
            let dev = deviations_from_results(&read(&c.results)?)
                .map_err(|e| format!("{}: {e}", c.results.display()))?;
            let name = c.results.file_name().map_or_else(
                || c.results.display().to_string(),
                |n| n.to_string_lossy().into_owned(),
            );
            let corrected = correct_program(&program, origin, &dev, &name)
                .map_err(|e| format!("{}: {e}", c.program.display()))?;
            within_travel(&c.setup, corrected)
        }
        Test::TwoStep(t) => {
            let text = read_text(&t.setup).map_err(|e| e.to_string())?;
            let cfg = setup_config(&t.setup, &text).map_err(|e| e.to_string())?;
            let l = &t.layout;
            let test = TwoStepTest::from_config(&cfg, l.separation_deg, l.stations, l.feed)
                .map_err(|e| e.to_string())?;
            within_travel(&t.setup, test.program(dialect))
        }
        Test::CorrectCentrelines(c) => {
            let read = |p: &PathBuf| {
                std::fs::read_to_string(p).map_err(|e| format!("{}: {e}", p.display()))
            };
            let program = read(&c.program)?;
            let lines = centrelines_from_toml(&read(&c.centrelines)?)
                .map_err(|e| format!("{}: {e}", c.centrelines.display()))?;
            let name = c.centrelines.file_name().map_or_else(
                || c.centrelines.display().to_string(),
                |n| n.to_string_lossy().into_owned(),
            );
            correct_program_centrelines(&program, &lines, &name)
                .map_err(|e| format!("{}: {e}", c.program.display()))
        }
        Test::Kins(k) => kins(k),
        Test::Sphere(s) => {
            let centre = [0, 1, 2].map(|k| s.centre.get(k).copied().unwrap_or(f64::NAN));
            let test = SphereTest::new(centre, s.contact_radius, [s.b_deg, s.c_deg])
                .map_err(|e| e.to_string())?;
            Ok(test.program(dialect))
        }
    }
}

/// `text` as a finite number.
fn finite(text: &str) -> Option<f64> {
    text.trim().parse().ok().filter(|v: &f64| v.is_finite())
}

/// `ncgen kins`: an R-test's or seed 004's lines into the kinematics' pins or record.
fn kins(k: &KinsArgs) -> Result<String, String> {
    use ballpod_host::methods::rtest::RtestGeometry;
    use ballpod_host::ncgen::carr::{self, SwivelTable};
    use ballpod_host::ncgen::kins::{
        DispersionGrid, Pin, TrtKins, centreline_deviations, correct, hal_lines, rtest_ball,
        rtest_deviations, rtest_from_results, rtest_nominal_pins, table_csv,
    };
    if matches!(k.kins, KinsArg::SinumerikM) {
        return kins_mixed(k);
    }
    if k.table_face_z_mm.is_some() || k.tool_mm.is_some() || k.probe {
        return Err("--table-face-z-mm, --tool-mm, --probe: sinumerik-m's (seed 002)".into());
    }
    // the trt kinematics, or (SINUMERIK type P) the one whose lines the source's frame gives
    let siemens = matches!(k.kins, KinsArg::SinumerikP);
    let src = &k.source;
    let at = |e: String| format!("{}: {e}", src.display());
    let text = std::fs::read_to_string(src).map_err(|e| at(e.to_string()))?;
    let centrelines = src.extension().is_some_and(|x| x == "toml");
    let kins = match k.kins {
        KinsArg::XyzacTrt => TrtKins::Xyzac,
        KinsArg::XyzbcTrt => TrtKins::Xyzbc,
        KinsArg::SinumerikP if centrelines => TrtKins::Xyzbc,
        // (type M went to `kins_mixed`)
        KinsArg::SinumerikP | KinsArg::SinumerikM => TrtKins::Xyzac,
    };
    // the source's lines, the pins its frame has, and where the R-test's ball is
    let (measured, drawing, geometry) = if centrelines {
        if kins != TrtKins::Xyzbc {
            return Err(at(format!(
                "seed 004's centrelines are a rotary table on a B tilting axis: xyzbc-trt or \
                 sinumerik-p, not {}",
                kins.name()
            )));
        }
        if k.geometry_mm.is_some() {
            return Err("--geometry-mm: an R-test's; a centrelines file has its lines".into());
        }
        let file = centrelines_from_toml(&text).map_err(|e| at(e.to_string()))?;
        let (m, pins) = centreline_deviations(&file).map_err(|e| at(e.to_string()))?;
        (m, pins, None)
    } else {
        let (errors, u, correlation) = rtest_from_results(&text).map_err(|e| at(e.to_string()))?;
        if kins != TrtKins::Xyzac {
            return Err(at(format!(
                "the R-test identifies an A/C table-tilting machine (seed 003): xyzac-trt or \
                 sinumerik-p, not {}",
                kins.name()
            )));
        }
        let g = match k.geometry_mm.as_deref() {
            None => RtestGeometry::SEED003_TABLE3,
            Some(&[x_w, y_w, z_w, x_c, y_c, z_c]) => {
                RtestGeometry::from_array([x_w, y_w, z_w, x_c, y_c, z_c])
            }
            Some(_) => return Err("--geometry-mm: six values".into()),
        };
        if ![g.x_w_mm, g.y_w_mm, g.z_w_mm, g.x_c_mm, g.y_c_mm, g.z_c_mm]
            .iter()
            .all(|v| v.is_finite())
        {
            return Err("--geometry-mm: finite values".into());
        }
        let m =
            rtest_deviations(&g, &errors, &u, correlation.as_ref()).map_err(|e| e.to_string())?;
        (m, rtest_nominal_pins(&g), Some(g))
    };
    // the control's present values: the pins, or the record (its lines at their reference)
    let (current, record) = if siemens {
        if !k.pins.is_empty() {
            return Err("--pin: LinuxCNC's; a SINUMERIK record's values are --carr N=VALUE".into());
        }
        let mut rec = SwivelTable::through(&kins.lines(&drawing).at_reference());
        let given = carr_given(
            &k.carr,
            &carr::PARAMETERS,
            "4…12 or 15…20 ($TC_CARR l2 v1 v2 l3 l4)",
            0..12,
            &mut rec.0,
        )?;
        if !given.iter().any(|&i| i >= 12) {
            // l4 left out: it closes the chain
            rec = SwivelTable::closed(rec.l2(), rec.l3(), rec.v1(), rec.v2());
        }
        for (v, name) in [
            (rec.v1(), "v1 ($TC_CARR7…9)"),
            (rec.v2(), "v2 ($TC_CARR10…12)"),
        ] {
            if v.iter().map(|c| c * c).sum::<f64>().sqrt() < 1e-9 {
                return Err(format!("--carr: {name} is the zero vector"));
            }
        }
        (drawing, Some(rec))
    } else {
        if !k.carr.is_empty() {
            return Err("--carr: a SINUMERIK record's; LinuxCNC's pins are --pin NAME=MM".into());
        }
        let mut current = drawing;
        let mut given = Vec::new();
        for p in &k.pins {
            let (name, value) = p
                .split_once('=')
                .ok_or_else(|| format!("--pin {p}: NAME=MM"))?;
            let pin = Pin::from_name(name.trim())
                .filter(|pin| kins.pins().contains(pin))
                .ok_or_else(|| {
                    let names: Vec<_> = kins.pins().iter().map(|p| p.name()).collect();
                    format!(
                        "--pin {p}: {name} is not a pin of {} ({})",
                        kins.name(),
                        names.join(", ")
                    )
                })?;
            let v =
                finite(value).ok_or_else(|| format!("--pin {p}: {value} is not a length in mm"))?;
            current.0[pin as usize] = v;
            given.push(pin);
        }
        // the pins hold one frame: the control's (all given) or the source's (none given)
        let missing: Vec<_> = kins
            .pins()
            .into_iter()
            .filter(|p| *p != Pin::ToolOffset && !given.contains(p))
            .map(Pin::name)
            .collect();
        if !given.is_empty() && !missing.is_empty() {
            return Err(format!(
                "--pin: give every pin of {} or none (missing: {})",
                kins.name(),
                missing.join(", ")
            ));
        }
        (current, None)
    };
    let lines = match &record {
        Some(r) => r.lines().at_reference(),
        None => kins.lines(&current),
    };
    let work = match (k.work_point_mm.as_deref(), &geometry) {
        (Some(&[x, y, z]), _) if [x, y, z].iter().all(|v| v.is_finite()) => [x, y, z],
        (Some(_), _) => return Err("--work-point-mm: three finite values".into()),
        (None, Some(g)) => rtest_ball(g, &lines),
        (None, None) => lines.table.point_mm,
    };
    let grid = DispersionGrid {
        tilt_range_deg: grid_limits(k, (-90.0, 0.0))?,
        half_side_mm: k.half_side_mm,
    };
    let name = src.file_name().map_or_else(
        || src.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    if let Some(rec) = record {
        let c = carr::correct(
            k.record,
            &rec,
            &measured,
            work,
            &grid,
            k.max_change_um,
            k.max_turn_urad,
        )
        .map_err(|e| e.to_string())?;
        return Ok(match k.format {
            KinsFormat::Hal => carr::carr_lines(&c, &name),
            KinsFormat::Csv => carr::carr_csv(&c),
        });
    }
    let c = correct(kins, &current, &measured, work, &grid, k.max_change_um)
        .map_err(|e| e.to_string())?;
    Ok(match k.format {
        KinsFormat::Hal => hal_lines(&c, &name),
        KinsFormat::Csv => table_csv(&c),
    })
}

/// The tilt range (`default` when not given), after the grid's and the guards' options are
/// checked.
fn grid_limits(k: &KinsArgs, default: (f64, f64)) -> Result<(f64, f64), String> {
    let (lo, hi) = match k.tilt_range_deg.as_deref() {
        None => default,
        Some(&[lo, hi]) => (lo, hi),
        Some(_) => return Err("--tilt-range-deg: LOW HIGH".into()),
    };
    if !(lo.is_finite() && hi.is_finite() && lo < hi && hi - lo <= 360.0) {
        return Err("--tilt-range-deg: LOW < HIGH, at most 360° apart".into());
    }
    if !(k.half_side_mm.is_finite() && (0.0..=2000.0).contains(&k.half_side_mm)) {
        return Err("--half-side-mm: 0 … 2000".into());
    }
    if !(k.max_change_um.is_finite() && k.max_change_um > 0.0) {
        return Err("--max-change-um: a length > 0".into());
    }
    if !(k.max_turn_urad.is_finite() && k.max_turn_urad > 0.0) {
        return Err("--max-turn-urad: an angle > 0".into());
    }
    Ok((lo, hi))
}

/// The record's values `--carr N=VALUE` gives, each at N's place in `parameters` (`numbers`
/// says which N there are): the places given — every one of `needed` (l2, v1, v2, l3:
/// `$TC_CARR4…12` and 15…17) or none.
fn carr_given(
    carr: &[String],
    parameters: &[(u8, &str)],
    numbers: &str,
    needed: std::ops::Range<usize>,
    values: &mut [f64],
) -> Result<Vec<usize>, String> {
    let mut given = Vec::new();
    for c in carr {
        let (n, value) = c
            .split_once('=')
            .ok_or_else(|| format!("--carr {c}: N=VALUE"))?;
        let index = n
            .trim()
            .parse::<u8>()
            .ok()
            .and_then(|n| parameters.iter().position(|p| p.0 == n))
            .filter(|&i| i < values.len())
            .ok_or_else(|| format!("--carr {c}: {n} is not {numbers}"))?;
        let v = finite(value).ok_or_else(|| format!("--carr {c}: {value} is not a number"))?;
        values[index] = v;
        given.push(index);
    }
    let missing: Vec<_> = needed
        .filter(|i| !given.contains(i))
        .filter_map(|i| parameters.get(i).map(|p| p.0.to_string()))
        .collect();
    if !given.is_empty() && !missing.is_empty() {
        return Err(format!(
            "--carr: give every one of $TC_CARR4…12 and 15…17 or none (missing: {})",
            missing.join(", ")
        ));
    }
    Ok(given)
}

/// `ncgen kins sinumerik-m`: seed 002's deviations into a type-M record.
fn kins_mixed(k: &KinsArgs) -> Result<String, String> {
    use ballpod::app::bc_ballbar::Setup;
    use ballpod_host::ncgen::carr_mixed::{self, MixedGrid, MixedRecord};
    let src = &k.source;
    let at = |e: String| format!("{}: {e}", src.display());
    if src.extension().is_some_and(|x| x == "toml") {
        return Err(at(
            "seed 004's centrelines are a rotary table on a tilting axis (a swivel table): \
             sinumerik-p or xyzbc-trt, not a mixed record"
                .into(),
        ));
    }
    if !k.pins.is_empty() {
        return Err("--pin: LinuxCNC's; a SINUMERIK record's values are --carr N=VALUE".into());
    }
    if k.geometry_mm.is_some() {
        return Err("--geometry-mm: an R-test's, not seed 002's".into());
    }
    let text = std::fs::read_to_string(src).map_err(|e| at(e.to_string()))?;
    let measured =
        carr_mixed::seed002_from_results(&text, k.probe).map_err(|e| at(e.to_string()))?;
    let mut rec = MixedRecord::model_frame();
    let given = carr_given(
        &k.carr,
        &carr_mixed::PARAMETERS,
        "1…12, 15…20 or 24 ($TC_CARR l1 l2 v1 v2 l3 l4, axis 1's offset)",
        carr_mixed::L2..carr_mixed::L4,
        &mut rec.0,
    )?;
    use carr_mixed::{L1, L2, L3, L4, OFFSET1};
    // l1 and l4 left out close their chains (l1 = −l2, l4 = −l3)
    for (closing, of) in [(L1..L2, L2), (L4..OFFSET1, L3)] {
        if !given.iter().any(|i| closing.contains(i)) {
            for (k, i) in closing.enumerate() {
                rec.0[i] = 0.0 - rec.0[of + k];
            }
        }
    }
    for (v, name) in [
        (rec.v1(), "v1 ($TC_CARR7…9)"),
        (rec.v2(), "v2 ($TC_CARR10…12)"),
    ] {
        if v.iter().map(|c| c * c).sum::<f64>().sqrt() < 1e-9 {
            return Err(format!("--carr: {name} is the zero vector"));
        }
    }
    let face_z_mm = match (k.table_face_z_mm, given.is_empty()) {
        (Some(z), _) if z.is_finite() => z,
        (Some(_), _) => return Err("--table-face-z-mm: a finite height".into()),
        (None, true) => 0.0,
        (None, false) => {
            return Err(
                "--table-face-z-mm: the table face's height in the record's coordinates (where \
                 seed 002 states C's position) is needed with --carr"
                    .into(),
            );
        }
    };
    let tool = k.tool_mm.unwrap_or(Setup::thesis_table_4_3().r_b_mm);
    if !(tool.is_finite() && tool >= 0.0) {
        return Err("--tool-mm: a length ≥ 0".into());
    }
    // the work point: C at the table face (model frame: the origin)
    let work = match k.work_point_mm.as_deref() {
        Some(&[x, y, z]) if [x, y, z].iter().all(|v| v.is_finite()) => [x, y, z],
        Some(_) => return Err("--work-point-mm: three finite values".into()),
        None => rec.table_at(face_z_mm),
    };
    let grid = MixedGrid {
        b_range_deg: grid_limits(k, (0.0, 90.0))?,
        tool_below_pivot_mm: tool,
        work_mm: work,
        half_side_mm: k.half_side_mm,
    };
    let c = carr_mixed::correct(
        k.record,
        &rec,
        &measured,
        face_z_mm,
        &grid,
        k.max_change_um,
        k.max_turn_urad,
    )
    .map_err(|e| e.to_string())?;
    let name = src.file_name().map_or_else(
        || src.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    Ok(match k.format {
        KinsFormat::Hal => carr_mixed::mixed_lines(&c, &name),
        KinsFormat::Csv => carr_mixed::mixed_csv(&c),
    })
}

/// `program` if it stays within the travel the set-up file gives (`[travel]`), else the
/// refusal naming the axis: nothing is written.
/// Writes the three-plane test's programs and set-up files ([`ThreePlanesArgs`]); returns the
/// files written. Nothing is written unless every plane's program is valid.
fn three_planes(t: &ThreePlanesArgs, dialect: Dialect) -> Result<Vec<PathBuf>, String> {
    if !(220.0..=360.0).contains(&t.vertical_arc_deg) {
        return Err(format!(
            "--vertical-arc-deg: {} outside [220, 360] (the summary needs every quadrant)",
            t.vertical_arc_deg
        ));
    }
    let text = read_text(&t.setup).map_err(|e| e.to_string())?;
    let cfg = setup_config(&t.setup, &text).map_err(|e| e.to_string())?;
    let a = &t.session;
    let trigger = run_trigger(a.trigger, &cfg);
    let mut files = Vec::new();
    for (k, plane) in [CirclePlane::XY, CirclePlane::YZ, CirclePlane::ZX]
        .into_iter()
        .enumerate()
    {
        let mut c = cfg;
        c.setup.circle_plane = plane;
        let (start_deg, arc_deg) = match plane {
            CirclePlane::XY => (0.0, 360.0),
            _ => (t.vertical_start_deg, t.vertical_arc_deg),
        };
        let options = CircleOptions {
            start_deg,
            arc_deg,
            feed_in_mm: t.feed_in_mm,
            trigger,
            ..CircleOptions::default()
        };
        let name = CirclePlane::NAMES[plane as usize];
        let test = CircleRun::from_config(&c, options)
            .map_err(|e| format!("{} ({name}): {e}", t.setup.display()))?;
        let number = a.setup_number + k as u32;
        let session = if a.session {
            Some(Session::new(a.m_base, number, trigger)?)
        } else {
            None
        };
        let program = within_travel(&t.setup, test.program_with(dialect, session.as_ref()))?;
        let setup = setup_file(
            "CIRCLE",
            &test.setup_fields(),
            &format!("ballpod set-up {number} (ncgen three-planes, {name})"),
        );
        files.push((t.out_dir.join(format!("{name}.ngc")), program));
        files.push((
            t.out_dir.join(format!("ballpod-setup-{number}.toml")),
            setup,
        ));
    }
    std::fs::create_dir_all(&t.out_dir).map_err(|e| format!("{}: {e}", t.out_dir.display()))?;
    files
        .into_iter()
        .map(|(path, text)| {
            std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))?;
            Ok(path)
        })
        .collect()
}

fn within_travel(setup: &std::path::Path, program: String) -> Result<String, String> {
    let text = read_text(setup).map_err(|e| e.to_string())?;
    if let Some(t) = setup_travel(setup, &text).map_err(|e| e.to_string())? {
        check_travel(&program, &t).map_err(|e| format!("{}: {e}", setup.display()))?;
    }
    Ok(program)
}

/// The runs of a `--direction`, in order.
fn directions(d: Directions) -> Vec<Direction> {
    match d {
        Directions::Both => vec![Direction::Ccw, Direction::Cw],
        Directions::Ccw => vec![Direction::Ccw],
        Directions::Cw => vec![Direction::Cw],
    }
}
