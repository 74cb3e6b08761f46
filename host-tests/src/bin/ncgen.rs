//! `cargo ncgen -- SETUP [options]`: the part program of a test, from the pod's set-up (a
//! TOML / JSON file with a `[setup]` table of configuration fields, as replay's session files):
//! today the ISO 230-4 circle (`circle_plane`, `circle_centre_*`, `circle_radius`,
//! `circle_feed`), for LinuxCNC or an ISO/Fanuc control. Prints the program, or writes it with
//! `--out`. A set-up the machine cannot run is refused with the field named; nothing is written.

use std::path::PathBuf;

use clap::{Parser, ValueEnum};

use ballpod::app::Direction;
use ballpod_host::ncgen::{CircleOptions, CircleTest, Dialect};
use ballpod_host::session_file::{read_text, setup_config};

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

/// The part program of an ISO 230-4 circle test from the pod's set-up.
#[derive(Parser, Debug)]
#[command(name = "cargo ncgen", version)]
struct Args {
    /// Set-up file (.toml or .json) with a `[setup]` table of configuration fields.
    setup: PathBuf,
    /// Control dialect.
    #[arg(long, value_enum, default_value = "linuxcnc")]
    dialect: DialectArg,
    /// Runs, in order.
    #[arg(long, value_enum, default_value = "both")]
    direction: Directions,
    /// Start of the data arc, degrees from the plane's first axis towards its second.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    start_deg: f64,
    /// Span of the data arc, degrees (0 < span ≤ 360).
    #[arg(long, default_value_t = 360.0, allow_negative_numbers = true)]
    arc_deg: f64,
    /// Overshoot past the data arc, degrees (0 … 180).
    #[arg(long, default_value_t = 45.0, allow_negative_numbers = true)]
    overshoot_deg: f64,
    /// Radial feed-in / feed-out distance, mm (0.1 … 10).
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    feed_in_mm: f64,
    /// Output file (default: standard output).
    #[arg(long)]
    out: Option<PathBuf>,
}

fn main() {
    let mut raw: Vec<String> = std::env::args().collect();
    if raw.get(1).is_some_and(|a| a == "--") {
        raw.remove(1);
    }
    let args = Args::parse_from(raw);
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
    let text = read_text(&args.setup).map_err(|e| e.to_string())?;
    let cfg = setup_config(&args.setup, &text).map_err(|e| e.to_string())?;
    let directions = match args.direction {
        Directions::Both => vec![Direction::Ccw, Direction::Cw],
        Directions::Ccw => vec![Direction::Ccw],
        Directions::Cw => vec![Direction::Cw],
    };
    let options = CircleOptions {
        start_deg: args.start_deg,
        arc_deg: args.arc_deg,
        overshoot_deg: args.overshoot_deg,
        feed_in_mm: args.feed_in_mm,
        directions,
    };
    let test = CircleTest::from_config(&cfg, options)
        .map_err(|e| format!("{}: {e}", args.setup.display()))?;
    let dialect = match args.dialect {
        DialectArg::Linuxcnc => Dialect::LinuxCnc,
        DialectArg::Fanuc => Dialect::Fanuc,
    };
    Ok(test.program(dialect))
}
