//! `cargo sim`: the pod on a virtual machine tool — the seed 002 ball-bar procedure (BX, BY,
//! CR, CA, CR2, CW and CCW, repeated) on a machine whose deviations are the thesis's identified
//! values, and an ISO 230-4 circular test with typical linear-axis faults, each run armed,
//! started and stopped on the simulated pod and its results read from the pod's results
//! table. Prints truth vs identified ± uncertainty, writes `results.json`, `truth.json` and
//! SVG polar plots, and with `--write-logs` the recorded runs for `cargo replay`.
//!
//! `--serve`: instead, the simulated pod on loopback TCP for CANopen / SCPI clients (SLCAN, the
//! USB command port, the USB sample stream; see `ballpod_host::serve`).

use std::path::PathBuf;
use std::time::Instant;

use clap::Parser;

use ballpod::identify::mill_turn::{Parameter, urad_to_arcsec};
use ballpod_host::replay::Report;
use ballpod_host::report;
use ballpod_host::simulate::{SimOptions, simulate};
use ballpod_host::vmt::machine::MachineFile;
use ballpod_host::vmt::mounting;

/// The pod on a virtual machine tool: the seed 002 procedure and an ISO 230-4 circle test through
/// the pod's own application, truth vs measured (or `--serve` for CANopen / SCPI clients).
#[derive(Parser, Debug)]
#[command(name = "cargo sim", version)]
struct Args {
    /// Noise seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Bar noise σ, µm (default: the machine file's instrument, 0.2).
    #[arg(long, value_parser = non_negative)]
    noise: Option<f64>,
    /// Machine description (TOML or JSON; every key optional); with `--serve`, the served
    /// machine (its instrument section aside: `--noise`).
    #[arg(long)]
    machine: Option<PathBuf>,
    /// Output directory.
    #[arg(long, default_value = "sim-out")]
    out: PathBuf,
    /// Write the recorded runs (the pod's stream text, one file per run) and `session.toml` here.
    #[arg(long)]
    write_logs: Option<PathBuf>,
    /// The seed 002 steps from part programs in this directory (`BX.ngc` … `CR2.ngc`, as `cargo
    /// ncgen -- pattern` writes them) through LinuxCNC's interpreter (`rs274`, Debian package
    /// linuxcnc-uspace) instead of the built-in motion.
    #[arg(long, value_name = "DIR")]
    nc: Option<PathBuf>,
    /// A feed-rate sweep: the ISO 230-4 circle at each of these feeds too (mm/min, comma
    /// separated, e.g. 500,1000,2000,4000), before the three-plane test and the circle.
    #[arg(long, value_delimiter = ',', value_name = "F,F,…")]
    feed_sweep: Vec<f64>,
    /// Mount the seed 002 balls without offsets (by default the machine's W- and T-ball
    /// offsets are drawn, with `--seed`, as the default uncertainty budget assumes, unless
    /// the machine file states them).
    #[arg(long)]
    perfect_mounting: bool,
    /// Print the seed 002 thesis mode too (eqs 4.10–4.18 verbatim: the thesis's printed
    /// formulas, which read α_BT about 32″ for a true 9.63″).
    #[arg(long)]
    thesis: bool,
    /// Repeats of the seed 002 procedure.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u64).range(1..=ballpod::app::bc_ballbar::MAX_REPEATS as u64))]
    repeats: u64,
    /// Serve the simulated pod to CANopen / SCPI clients on loopback TCP instead.
    #[arg(long)]
    serve: bool,
    /// `--serve`: SLCAN port (0: any free port).
    #[arg(long, default_value_t = 0)]
    can_port: u16,
    /// `--serve`: SCPI (USB command) port (0: any free port).
    #[arg(long, default_value_t = 0)]
    usb_port: u16,
    /// `--serve`: sample stream port (0: any free port).
    #[arg(long, default_value_t = 0)]
    stream_port: u16,
    /// `--serve`: pace the running session at real time too.
    #[arg(long)]
    realtime: bool,
    /// `--serve`: virtual-time speed-up while a run runs.
    #[arg(long, default_value_t = 20.0)]
    speed: f64,
    /// `--serve`: stop after this many seconds of real time.
    #[arg(long, default_value_t = 600.0)]
    max_seconds: f64,
    /// `--serve`: a setting the pod boots with (repeatable; `NAME=VALUE`, NAME as in
    /// `CONFigure:LIST?`, VALUE a number or a choice's name), stored in its settings pages as on
    /// a pod configured and saved before: e.g. `--set can_node_id=255` for a pod without a
    /// node-ID (it waits for an LSS master).
    #[arg(long = "set", value_name = "NAME=VALUE")]
    set: Vec<String>,
    /// `--serve`: the served CNC runs this part program (LinuxCNC dialect, `ncgen circle` or
    /// `ncgen pattern` with `--session`) on the machine of the pod's pattern, its user M-codes
    /// from `--m-codes` in step with the motion, as LinuxCNC's task does; repeated, the programs
    /// run one after the other.
    #[arg(long, requires = "m_codes")]
    program: Vec<PathBuf>,
    /// `--serve --program`: the directory of the user M-codes' programs (`ncgen m-codes DIR`).
    #[arg(long, requires = "program")]
    m_codes: Option<PathBuf>,
    /// `--serve --program`: the M-codes reach the pod over the USB command port (SCPI) instead
    /// of CAN.
    #[arg(long, requires = "program")]
    m_codes_via_usb: bool,
    /// `--serve --program`: cycle start this many seconds after the server is up.
    #[arg(long, default_value_t = 1.0, requires = "program")]
    cycle_start_after: f64,
}

fn non_negative(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v >= 0.0 && v.is_finite() => Ok(v),
        _ => Err(format!("{s:?}: not a non-negative number")),
    }
}

fn main() {
    let args: Args = ballpod_host::cli::parse();
    let result = if args.serve { serve(&args) } else { run(&args) };
    if let Err(e) = result {
        eprintln!("sim: {e}");
        std::process::exit(1);
    }
}

fn serve(a: &Args) -> Result<(), String> {
    let d = ballpod_host::serve::ServeOptions::default();
    ballpod_host::serve::run(ballpod_host::serve::ServeOptions {
        can_port: a.can_port,
        usb_port: a.usb_port,
        stream_port: a.stream_port,
        realtime: a.realtime,
        speed: a.speed,
        seed: a.seed,
        bar_noise_um: a.noise.unwrap_or(d.bar_noise_um),
        max_seconds: a.max_seconds,
        settings: (!a.set.is_empty())
            .then(|| ballpod_host::cli::settings(&a.set))
            .transpose()?,
        program: a.m_codes.clone().map(|dir| (a.program.clone(), dir)),
        m_codes_via_usb: a.m_codes_via_usb,
        cycle_start_s: a.cycle_start_after,
        machine: a
            .machine
            .as_ref()
            .map(|p| MachineFile::read(p))
            .transpose()?,
    })
    .map_err(|e| format!("--serve: {e}"))
}

fn run(args: &Args) -> Result<(), String> {
    let t0 = Instant::now();
    let mut machine = match &args.machine {
        Some(p) => MachineFile::read(p)?,
        None => MachineFile::default(),
    };
    if let Some(n) = args.noise {
        machine.instrument.bar_noise_um = n;
    }
    // the balls as a technician mounts them (the budget's defaults assume these shifts), unless
    // the machine file states the offsets or --perfect-mounting asks for none
    let m2 = &mut machine.seed002;
    let drawn = !args.perfect_mounting
        && m2.t_offset_um == [0.0; 3]
        && m2.w_offset_um == [0.0; 3]
        && m2.t_offset_2_um.is_none()
        && m2.w_offset_c_um.is_none();
    if drawn {
        // the W-ball clamped on the C axis (BX, BY), then at R_C (CR, CA, CR2); the T-ball
        // mounted on each tool length (R_B, then R′_B for CR2)
        let mut rng = ballpod_host::rng::Rng::new(args.seed ^ 0x6d6f_756e_7469_6e67);
        m2.w_offset_um = mounting::clamping_shift(&mut rng);
        m2.w_offset_c_um = Some(mounting::clamping_shift(&mut rng));
        m2.t_offset_um = mounting::t_ball_offset(&mut rng);
        m2.t_offset_2_um = Some(mounting::t_ball_offset(&mut rng));
    }
    let opts = SimOptions {
        seed: args.seed,
        repeats: args.repeats as usize,
        nc_dir: args.nc.clone(),
        feed_sweep: args.feed_sweep.clone(),
        ..SimOptions::default()
    };
    // a progress bar on a terminal (indicatif draws nothing when stderr is not one)
    let bar = indicatif::ProgressBar::new(0).with_style(
        indicatif::ProgressStyle::with_template("sim: run {pos:>2}/{len} {msg:<24} {elapsed}")
            .map_err(|e| e.to_string())?,
    );
    let mut progress = |done: usize, total: usize, what: &str| {
        bar.set_length(total as u64);
        bar.set_position((done as u64 + 1).min(total as u64));
        bar.set_message(what.to_string());
    };
    let session = simulate(&machine, &opts, &mut progress)?;
    bar.finish_and_clear();
    eprintln!(
        "sim: {} runs in {:.1} s",
        session.runs.len(),
        t0.elapsed().as_secs_f64()
    );
    let report = &session.report;
    print_seed002(&machine, report, drawn, args.thesis);
    print_iso(&machine, report);
    print_planes(&machine, report);
    print_sweep(&machine, &session);
    std::fs::create_dir_all(&args.out).map_err(|e| format!("{}: {e}", args.out.display()))?;
    let write = |dir: &PathBuf, name: &str, text: &str| -> Result<(), String> {
        let p = dir.join(name);
        std::fs::write(&p, text).map_err(|e| format!("{}: {e}", p.display()))
    };
    write(&args.out, "results.json", &report.to_json()?)?;
    write(&args.out, "truth.json", &report::truth_json(&machine)?)?;
    for (name, svg) in report::plots(&session.runs, report) {
        write(&args.out, &name, &svg)?;
    }
    if let Some(dir) = &args.write_logs {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        let mut session_toml = String::from(
            "# The runs of `cargo sim`, as the pod's USB stream records them: `cargo replay` this file.\n",
        );
        for (name, run) in &session.runs {
            write(dir, name, &run.to_csv())?;
            session_toml.push_str(&format!("\n[[runs]]\nlog = \"{name}\"\n"));
        }
        write(dir, "session.toml", &session_toml)?;
        println!(
            "recorded runs and session.toml written to {}",
            dir.display()
        );
    }
    println!(
        "results written to {} ({:.1} s)",
        args.out.display(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}

/// Truth of each model-mode deviation in the report's units (µm / arc-seconds), as the
/// procedure identifies it (the T-ball's offset in δx_BT, δz_BT, δy_CZ).
fn truth_of(m: &MachineFile, p: Parameter) -> f64 {
    let v = m.seed002.as_identified().get(p);
    if p.is_positional() {
        v
    } else {
        urad_to_arcsec(v)
    }
}

/// The seed 002 procedure: the identified deviations against the truth first (model mode),
/// then each step's eccentricities, then (`thesis`) the thesis's formulas verbatim.
fn print_seed002(m: &MachineFile, r: &Report, drawn: bool, thesis: bool) {
    if r.result("alpha_CZ").is_none() {
        return;
    }
    let f = |v: [f64; 3]| format!("({:.1}, {:.1}, {:.1})", v[0], v[1], v[2]);
    let s = &m.seed002;
    println!(
        "\nseed 002 ball-bar procedure (BX, BY, CR, CA, CR2; CW+CCW each; thesis Table 4.3 set-up), B and C axes identified by the pod"
    );
    println!(
        "balls mounted {}: W-ball off by {} µm on the C axis, {} µm at R_C; T-ball by {} µm on R_B, {} µm on R′_B",
        if drawn {
            "as the default budget assumes (drawn with --seed; --perfect-mounting: none)"
        } else {
            "as the machine file states"
        },
        f(s.w_offset_um),
        f(s.w_offset_c_um.unwrap_or(s.w_offset_um)),
        f(s.t_offset_um),
        f(s.t_offset_2_um.unwrap_or(s.t_offset_um))
    );
    println!(
        "truth vs identified (literal HTM model, 10 deviations; δx_BT, δz_BT, δy_CZ with the T-ball's offset in them), u standard, U = 3u"
    );
    println!(
        "{:<10} {:>10} {:>12} {:>9} {:>9} {:>7}  check",
        "deviation", "truth", "identified", "u", "diff", "|d|/u"
    );
    let mut all_ok = true;
    for p in Parameter::ALL {
        let Some(v) = r.result(p.name()) else {
            continue;
        };
        let t = truth_of(m, p);
        let u = f64::from(v.u.unwrap_or(f32::NAN));
        let d = f64::from(v.value) - t;
        let ok = d.abs() <= 3.0 * u;
        all_ok &= ok;
        let unit = if v.unit == "um" { "µm" } else { "″" };
        println!(
            "{:<10} {:>8.3}{unit:<2} {:>10.3}{unit:<2} {:>9.4} {:>9.4} {:>7.2}  {}",
            v.name,
            t,
            v.value,
            u,
            d,
            d.abs() / u.max(1e-12),
            if ok { "ok" } else { "FAIL" }
        );
    }
    println!(
        "check: |identified − truth| ≤ U = 3u (k = 3: ≈ 97 % joint coverage for 10 values): {}",
        if all_ok { "all pass" } else { "FAILED" }
    );
    println!("\neccentricity of each step (the pod's results), ex and ez/ey ± u, µm");
    for step in ballpod::app::Pattern::SEED002 {
        let n = step.name();
        let second = if matches!(step, ballpod::app::Pattern::Bx | ballpod::app::Pattern::By) {
            "z"
        } else {
            "y"
        };
        let (Some(a), Some(b)) = (
            r.result(&format!("e_{n}_x")),
            r.result(&format!("e_{n}_{second}")),
        ) else {
            continue;
        };
        println!(
            "{:<5} {:>12.4} ± {:<7.4} {:>12.4} ± {:<7.4}",
            n,
            a.value,
            a.u.unwrap_or(f32::NAN),
            b.value,
            b.u.unwrap_or(f32::NAN)
        );
    }
    if !thesis {
        return;
    }
    println!(
        "\nthesis mode (eqs 4.10–4.18 verbatim; lever arms Z_T/X_T of the thesis, spec §9.1):"
    );
    let d = m.seed002.deviations();
    let truth_thesis = [
        ("th_alpha_CZ", urad_to_arcsec(d.alpha_cz_urad)),
        ("th_beta_CZ", urad_to_arcsec(d.beta_cz_urad)),
        ("th_alpha_XB", urad_to_arcsec(d.alpha_xb_urad)),
        ("th_beta_XB", urad_to_arcsec(d.beta_xb_urad)),
        ("th_gamma_XB", urad_to_arcsec(d.gamma_xb_urad)),
        ("th_alpha_BT", urad_to_arcsec(d.alpha_bt_urad)),
        ("th_dx_CZ_minus_dx_BT", d.dx_cz_um - d.dx_bt_um),
        ("th_dy_CZ", d.dy_cz_um),
    ];
    for (name, t) in truth_thesis {
        if let Some(v) = r.result(name) {
            println!(
                "{:<22} truth {:>9.3}  thesis {:>9.3} ± {:<7.4} {}",
                name,
                t,
                v.value,
                v.u.unwrap_or(f32::NAN),
                v.unit
            );
        }
    }
}

fn print_iso(m: &MachineFile, r: &Report) {
    let f = |n: &str| r.result(n).map_or(f64::NAN, |v| f64::from(v.value));
    if r.result("G_bidir").is_none() {
        return;
    }
    let c = &m.circle;
    println!(
        "\nISO 230-4 circular test, R = {} mm, F{} mm/min (from the pod's results)",
        c.radius_mm, c.feed_mm_per_min
    );
    println!(
        "G ccw {:.3} µm, G cw {:.3} µm, G(b) {:.3} µm, H {:.3} µm, F ccw {:+.3}/{:+.3} µm",
        f("G_ccw"),
        f("G_cw"),
        f("G_bidir"),
        f("H"),
        f("F_max_ccw"),
        f("F_min_ccw")
    );
    let mut rows = vec![
        ("squareness (µrad)", c.squareness_urad, f("squareness")),
        (
            "scale mismatch x−y (µm/m)",
            c.scale_x_um_per_m - c.scale_y_um_per_m,
            f("scale_mismatch"),
        ),
        ("reversal X (µm)", c.backlash_x_um, f("reversal_u")),
        ("reversal Y (µm)", c.backlash_y_um, f("reversal_v")),
        (
            "cyclic amplitude (µm)",
            c.cyclic_amplitude_um,
            f("cyclic_amplitude"),
        ),
        (
            "servo mismatch x−y (ms)",
            c.servo_mismatch_ms(),
            f("servo_mismatch"),
        ),
        // each reversal point (the machine's step is the same at both ends of an axis)
        (
            "reversal X at 0° (µm)",
            c.backlash_x_um,
            f("reversal_u_pos"),
        ),
        (
            "reversal X at 180° (µm)",
            c.backlash_x_um,
            f("reversal_u_neg"),
        ),
        (
            "reversal Y at 90° (µm)",
            c.backlash_y_um,
            f("reversal_v_pos"),
        ),
        (
            "reversal Y at 270° (µm)",
            c.backlash_y_um,
            f("reversal_v_neg"),
        ),
    ];
    // the faults the default machine leaves out, where this one has them: straightness (E_y =
    // s·(x/R)² is X's, `straightness_u`), spikes (X's at 180°, Y's at 90° and 270°; a run's
    // start and end at 0° is no reversal), lateral play
    for (name, injected, result) in [
        (
            "straightness X (µm)",
            c.straightness_y_along_x_um,
            "straightness_u",
        ),
        (
            "straightness Y (µm)",
            c.straightness_x_along_y_um,
            "straightness_v",
        ),
        ("spike X at 180° (µm)", c.reversal_spike_x_um, "spike_u_neg"),
        ("spike Y at 90° (µm)", c.reversal_spike_y_um, "spike_v_pos"),
        ("spike Y at 270° (µm)", c.reversal_spike_y_um, "spike_v_neg"),
        ("lateral play X (µm)", c.lateral_play_x_um, "lateral_play_u"),
        ("lateral play Y (µm)", c.lateral_play_y_um, "lateral_play_v"),
        ("vibration X (µm)", c.vibration_x_um, "vibration_u"),
        ("vibration Y (µm)", c.vibration_y_um, "vibration_v"),
        ("stick-slip X (µm)", c.stick_slip_x_um, "stick_slip_u"),
        ("stick-slip Y (µm)", c.stick_slip_y_um, "stick_slip_v"),
    ] {
        if injected != 0.0 {
            rows.push((name, injected, f(result)));
        }
    }
    println!(
        "{:<28} {:>9} {:>10} {:>8}  check (±10 %)",
        "fault", "injected", "diagnosed", "ratio"
    );
    for (name, inj, diag) in rows {
        let ratio = diag / inj;
        let ok = (ratio - 1.0).abs() <= 0.10;
        println!(
            "{name:<28} {inj:>9.3} {diag:>10.3} {ratio:>8.3}  {}",
            if ok { "ok" } else { "FAIL" }
        );
    }
    println!(
        "cyclic order: injected {}, diagnosed {}",
        c.cyclic_order,
        f("cyclic_order")
    );
}

fn print_planes(m: &MachineFile, r: &Report) {
    if r.result("squareness_yz").is_none() {
        return;
    }
    let (xy, p) = (&m.circle, &m.planes);
    println!(
        "\nthree-plane summary, R = {} mm, XY full circle, YZ and ZX {}° arcs (from the pod's results; scales relative to the bar's calibrated length, whose u is most of theirs): truth vs summary, U = 2u",
        xy.radius_mm, p.vertical_arc_deg
    );
    println!(
        "{:<14} {:>9} {:>10} {:>8} {:>14}  check",
        "", "injected", "summary", "U", "U without bar"
    );
    let scales = p.scales_um_per_m(xy);
    let rows = [
        ("squareness_xy", xy.squareness_urad, "µrad"),
        ("squareness_yz", p.squareness_yz_urad, "µrad"),
        ("squareness_zx", p.squareness_zx_urad, "µrad"),
        ("scale_x", scales[0], "µm/m"),
        ("scale_y", scales[1], "µm/m"),
        ("scale_z", scales[2], "µm/m"),
    ];
    for (name, truth, unit) in rows {
        match r.result(name) {
            Some(v) => {
                let big_u = 2.0 * f64::from(v.u.unwrap_or(f32::NAN));
                let bar = v
                    .contributors
                    .iter()
                    .find(|c| c.name == "bar_offset")
                    .map_or(0.0, |c| f64::from(c.u));
                let without = (big_u * big_u - 4.0 * bar * bar).max(0.0).sqrt();
                let ok = (f64::from(v.value) - truth).abs() <= big_u;
                println!(
                    "{name:<14} {truth:>9.3} {:>10.3} {big_u:>8.3} {without:>14.3}  {} {unit}",
                    v.value,
                    if ok { "ok" } else { "outside U" }
                );
            }
            None => println!("{name:<14} {truth:>9.3} {:>10}", "invalid"),
        }
    }
}

fn print_sweep(m: &MachineFile, s: &ballpod_host::simulate::SimSession) {
    if s.sweep.is_empty() {
        return;
    }
    println!(
        "\nfeed-rate sweep, R = {} mm, injected servo mismatch {:.3} ms (from the pod's results after each feed's circle)",
        m.circle.radius_mm,
        m.circle.servo_mismatch_ms()
    );
    println!(
        "{:>10} {:>18} {:>22}",
        "feed", "G(b) µm", "servo mismatch ms"
    );
    for r in &s.sweep {
        println!(
            "{:>10.0} {:>9.3} ± {:<6.3} {:>11.4} ± {:<7.4}",
            r.feed_mm_per_min,
            r.g_bidir_um[0],
            r.g_bidir_um[1],
            r.servo_mismatch_ms[0],
            r.servo_mismatch_ms[1]
        );
    }
    let f = |n: &str| s.report.result(n);
    if let Some(t) = f("sweep_servo_mismatch") {
        println!(
            "sweep servo mismatch {:.4} ± {:.4} ms",
            t.value,
            t.u.unwrap_or(f32::NAN)
        );
    }
    match f("sweep_feed_limit") {
        Some(l) => println!(
            "feed limit (G(b) 20 % past the lowest feed's) {:.0} ± {:.0} mm/min",
            l.value,
            l.u.unwrap_or(f32::NAN)
        ),
        None => println!("feed limit: not reached up to the highest feed"),
    }
}
