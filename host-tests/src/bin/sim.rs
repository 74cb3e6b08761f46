//! `cargo sim`: the pod on a virtual machine tool — the seed 002 ball-bar procedure (BX, BY,
//! CR, CA, CR′, CW and CCW, repeated) on a machine whose deviations are the thesis's identified
//! values, and an ISO 230-4 circular test with typical linear-axis faults. Prints truth vs
//! identified ± uncertainty, writes `results.json`, `truth.json` and SVG polar plots.
//!
//! Options: `--seed N`, `--noise UM` (bar noise σ, µm), `--machine FILE` (TOML/JSON),
//! `--out DIR` (default `sim-out`), `--write-logs DIR`, `--repeats N`.
//!
//! `--serve`: instead, the simulated pod on loopback TCP for CANopen / SCPI clients (SLCAN and
//! the USB command stream; see `ballpod_host::serve`).

use std::path::PathBuf;
use std::time::Instant;

use ballpod::identify::multitasking::model_lsq::ModelLsq;
use ballpod::identify::multitasking::{Parameter, urad_to_arcsec};
use ballpod_host::analysis::{Results, analyse};
use ballpod_host::report;
use ballpod_host::simulate::{SimOptions, simulate};
use ballpod_host::vmt::machine::MachineFile;

const USAGE: &str = "usage: cargo sim [--seed N] [--noise UM] [--machine FILE] [--out DIR] \
                     [--write-logs DIR] [--repeats N]\n       cargo sim -- --serve [--can-port N] \
                     [--usb-port N] [--realtime] [--speed X] [--seed N] [--noise COUNTS] \
                     [--max-seconds S]";

struct Args {
    opts: SimOptions,
    noise_um: Option<f64>,
    machine: Option<PathBuf>,
    out: PathBuf,
    logs: Option<PathBuf>,
}

fn parse_args() -> Result<Args, String> {
    let mut a = Args {
        opts: SimOptions::default(),
        noise_um: None,
        machine: None,
        out: PathBuf::from("sim-out"),
        logs: None,
    };
    let mut it = std::env::args().skip(1);
    while let Some(k) = it.next() {
        let mut v = || it.next().ok_or(format!("{k} needs a value"));
        let bad = |k: &str| format!("{k}: not a valid value");
        match k.as_str() {
            "--seed" => a.opts.seed = v()?.parse().map_err(|_| bad(&k))?,
            "--noise" => {
                let n: f64 = v()?.parse().map_err(|_| bad(&k))?;
                if !(n >= 0.0 && n.is_finite()) {
                    return Err(bad(&k));
                }
                a.noise_um = Some(n);
            }
            "--repeats" => {
                a.opts.repeats = v()?.parse().map_err(|_| bad(&k))?;
                if !(1..=ballpod::session::seed002::MAX_REPEATS).contains(&a.opts.repeats) {
                    return Err(bad(&k));
                }
            }
            "--machine" => a.machine = Some(PathBuf::from(v()?)),
            "--out" => a.out = PathBuf::from(v()?),
            "--write-logs" => a.logs = Some(PathBuf::from(v()?)),
            "-h" | "--help" => return Err(String::new()),
            _ => return Err(format!("unknown option {k}")),
        }
    }
    Ok(a)
}

fn main() {
    let raw: Vec<String> = std::env::args().skip(1).collect();
    if raw.iter().any(|a| a == "--serve") {
        serve(&raw);
        return;
    }
    let args = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            if !e.is_empty() {
                eprintln!("sim: {e}");
            }
            eprintln!("{USAGE}");
            std::process::exit(2);
        }
    };
    if let Err(e) = run(&args) {
        eprintln!("sim: {e}");
        std::process::exit(1);
    }
}

fn run(args: &Args) -> Result<(), String> {
    let t0 = Instant::now();
    let mut machine = match &args.machine {
        Some(p) => MachineFile::read(p)?,
        None => MachineFile::default(),
    };
    if let Some(n) = args.noise_um {
        machine.instrument.bar_noise_um = n;
    }
    let mut progress = |done: usize, total: usize, what: &str| {
        eprint!(
            "\rsim: run {:>2}/{total} {what:<24} {:>5.1} s",
            (done + 1).min(total),
            t0.elapsed().as_secs_f64()
        );
        if done == total {
            eprintln!();
        }
    };
    let session = simulate(&machine, &args.opts, &mut progress);
    let results = analyse(&session.desc, &session.runs)?;
    print_seed002(&machine, &results);
    print_iso(&machine, &results);
    std::fs::create_dir_all(&args.out).map_err(|e| format!("{}: {e}", args.out.display()))?;
    let write = |name: &str, text: &str| -> Result<(), String> {
        let p = args.out.join(name);
        std::fs::write(&p, text).map_err(|e| format!("{}: {e}", p.display()))
    };
    write("results.json", &report::results_json(&results)?)?;
    write("truth.json", &report::truth_json(&machine)?)?;
    for (name, svg) in report::plots(&session.desc, &session.runs, &results) {
        write(&name, &svg)?;
    }
    if let Some(dir) = &args.logs {
        ballpod_host::logfile::write_session(dir, &session.desc, &session.runs)?;
        println!("logs and session.json written to {}", dir.display());
    }
    println!(
        "results written to {} ({:.1} s)",
        args.out.display(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}

/// Truth of each model-mode deviation in the report's units (µm / arc-seconds).
fn truth_of(m: &MachineFile, p: Parameter) -> f64 {
    let v = m.seed002.deviations().get(p);
    if p.is_positional() {
        v
    } else {
        urad_to_arcsec(v)
    }
}

fn print_seed002(m: &MachineFile, r: &Results) {
    let Some(s) = &r.seed002 else {
        return;
    };
    println!(
        "\nseed 002 ball-bar procedure (BX, BY, CR, CA, CR2; CW+CCW each; thesis Table 4.3 set-up)"
    );
    println!(
        "{:<5} {:>22} {:>22} {:>8} {:>8}",
        "step", "e1 ± u (µm)", "e2 ± u (µm)", "pairs", "rms µm"
    );
    for (st, run) in s.steps.iter().zip(
        ballpod::session::seed002::Step::ALL
            .iter()
            .map(|x| x.name()),
    ) {
        let rms = r
            .runs
            .iter()
            .filter(|x| x.method == run)
            .map(|x| x.residual_rms_um)
            .fold(0.0f32, f32::max);
        println!(
            "{:<5} {:>12.4} ± {:<7.4} {:>12.4} ± {:<7.4} {:>8} {:>8.3}",
            st.step, st.e_um[0], st.u_e_um[0], st.e_um[1], st.u_e_um[1], st.repeats, rms
        );
    }
    println!(
        "\nmodel mode (literal HTM model, 10 deviations): truth vs identified, u standard, U = 3u expanded"
    );
    println!(
        "{:<10} {:>10} {:>12} {:>9} {:>9} {:>7}  check",
        "deviation", "truth", "identified", "u", "diff", "|d|/u"
    );
    let lsq = ModelLsq::without_squareness();
    let mut all_ok = true;
    for v in &s.model {
        let Some(p) = Parameter::ALL.iter().copied().find(|p| p.name() == v.name) else {
            continue;
        };
        if !lsq.free[p.index()] {
            continue;
        }
        let t = truth_of(m, p);
        let d = v.value - t;
        let ok = d.abs() <= 3.0 * v.u && d.abs() <= 0.5;
        all_ok &= ok;
        let unit = if v.unit == "um" { "µm" } else { "″" };
        println!(
            "{:<10} {:>8.3}{unit:<2} {:>10.3}{unit:<2} {:>9.4} {:>9.4} {:>7.2}  {}",
            v.name,
            t,
            v.value,
            v.u,
            d,
            d.abs() / v.u.max(1e-12),
            if ok { "ok" } else { "FAIL" }
        );
    }
    println!(
        "check: |identified − truth| ≤ U = 3u (k = 3: ≈ 97 % joint coverage for 10 values) and ≤ 0.5 µm / 0.5″: {}",
        if all_ok { "all pass" } else { "FAILED" }
    );
    println!(
        "\nthesis mode (eqs 4.10–4.18 verbatim; lever arms Z_T/X_T of the thesis, spec §9.1):"
    );
    let d = m.seed002.deviations();
    let truth_thesis = [
        ("alpha_CZ", urad_to_arcsec(d.alpha_cz_urad)),
        ("beta_CZ", urad_to_arcsec(d.beta_cz_urad)),
        ("alpha_XB", urad_to_arcsec(d.alpha_xb_urad)),
        ("beta_XB", urad_to_arcsec(d.beta_xb_urad)),
        ("gamma_XB", urad_to_arcsec(d.gamma_xb_urad)),
        ("alpha_BT", urad_to_arcsec(d.alpha_bt_urad)),
        ("dx_CZ-dx_BT", d.dx_cz_um - d.dx_bt_um),
        ("dy_CZ", d.dy_cz_um),
    ];
    for (v, (_, t)) in s.thesis.iter().zip(truth_thesis) {
        println!(
            "{:<12} truth {:>9.3}  thesis {:>9.3} ± {:<7.4} {}",
            v.name, t, v.value, v.u, v.unit
        );
    }
}

fn print_iso(m: &MachineFile, r: &Results) {
    let Some(i) = &r.iso230_4 else {
        return;
    };
    let c = &m.circle;
    println!(
        "\nISO 230-4 circular test, R = {} mm, F{} mm/min",
        i.radius_mm, c.feed_mm_per_min
    );
    println!(
        "G ccw {:.3} µm, G cw {:.3} µm, G(b) {:.3} µm, H {:.3} µm, F ccw {:+.3}/{:+.3} µm",
        i.ccw.g_um,
        i.cw.g_um,
        i.bidirectional_g_um,
        i.hysteresis_h_um,
        i.ccw.f_max_um,
        i.ccw.f_min_um
    );
    let d = &i.diagnostics;
    let rows = [
        (
            "squareness (µrad)",
            c.squareness_urad,
            f64::from(d.squareness_urad),
        ),
        (
            "scale mismatch x−y (µm/m)",
            c.scale_x_um_per_m - c.scale_y_um_per_m,
            f64::from(d.scale_mismatch_um_per_m),
        ),
        (
            "reversal X (µm)",
            c.backlash_x_um,
            f64::from(d.reversal_x_um),
        ),
        (
            "reversal Y (µm)",
            c.backlash_y_um,
            f64::from(d.reversal_y_um),
        ),
        (
            "cyclic amplitude (µm)",
            c.cyclic_amplitude_um,
            f64::from(d.cyclic_amplitude_um),
        ),
        (
            "servo mismatch x−y (ms)",
            c.servo_mismatch_ms(),
            i.servo_mismatch_ms,
        ),
    ];
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
        c.cyclic_order, d.cyclic_order
    );
}

fn arg<T: std::str::FromStr>(args: &[String], name: &str, default: T) -> Result<T, String> {
    match args.iter().position(|a| a == name) {
        None => Ok(default),
        Some(i) => args
            .get(i + 1)
            .ok_or(format!("{name} needs a value"))?
            .parse()
            .map_err(|_| format!("{name}: not a valid value")),
    }
}

/// `--serve`: the simulated pod on loopback TCP (SLCAN and SCPI), see `ballpod_host::serve`.
fn serve(args: &[String]) {
    let d = ballpod_host::serve::ServeOptions::default();
    let parsed = (|| -> Result<ballpod_host::serve::ServeOptions, String> {
        Ok(ballpod_host::serve::ServeOptions {
            can_port: arg(args, "--can-port", d.can_port)?,
            usb_port: arg(args, "--usb-port", d.usb_port)?,
            realtime: args.iter().any(|a| a == "--realtime"),
            speed: arg(args, "--speed", d.speed)?,
            seed: arg(args, "--seed", d.seed)?,
            noise_counts: arg(args, "--noise", d.noise_counts)?,
            max_seconds: arg(args, "--max-seconds", d.max_seconds)?,
            ..d.clone()
        })
    })();
    match parsed {
        Ok(opts) => {
            if let Err(e) = ballpod_host::serve::run(opts) {
                eprintln!("sim --serve: {e}");
                std::process::exit(1);
            }
        }
        Err(e) => {
            eprintln!("sim --serve: {e}\n{USAGE}");
            std::process::exit(2);
        }
    }
}
