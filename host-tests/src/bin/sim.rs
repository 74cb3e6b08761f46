//! `cargo sim`: the pod on a virtual machine tool.
//!
//! Until the full simulator lands (issue 8), this runs the acquisition chain end to end: a
//! machine moves the tool ball on a circle about the socket with a centre offset; the ball
//! bar's LVDT secondaries are synthesised as 12-bit ADC blocks with noise, the encoders as
//! 16-bit counters, the bar thermistor as an ADC code; the pod's own acquisition code turns
//! them into samples, and the demo compares ΔL with the truth.
//!
//! Options: `--seed N` (noise seed, default 1), `--noise COUNTS` (ADC noise σ per sample,
//! default 1.0), `--temp C` (bar temperature, default 22.5).
use ballpod::acquisition::lvdt::{ExcitationTable, demodulate};
use ballpod::acquisition::thermal::bar_expansion_um;
use ballpod::acquisition::{Acquisition, SampleFlags};
use ballpod::config::Config;
use ballpod_host::lvdt_model::LvdtModel;
use ballpod_host::rng::Rng;

const P: usize = 20;

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

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.iter().any(|a| a == "--serve") {
        serve(&args);
        return;
    }
    let parsed = (|| -> Result<(u64, f64, f64), String> {
        Ok((
            arg(&args, "--seed", 1)?,
            arg(&args, "--noise", 1.0)?,
            arg(&args, "--temp", 22.5)?,
        ))
    })();
    let (seed, noise, temp_c) = match parsed {
        Ok(v) => v,
        Err(e) => {
            eprintln!("sim: {e}\nusage: cargo sim [--seed N] [--noise COUNTS] [--temp C]");
            std::process::exit(2);
        }
    };
    let cfg = Config::default();
    let mut acq = Acquisition::new(&cfg, [16; 5]);
    let table = ExcitationTable::<P>::new();
    let lvdt = LvdtModel::default();
    let mut rng = Rng::new(seed);
    let periods = (f64::from(cfg.excitation_hz) / f64::from(cfg.sample_rate_hz)).round() as usize;

    // Thermistor code for the bar temperature (β model of the default NTC).
    let r = f64::from(cfg.thermistor_r25_ohm)
        * (f64::from(cfg.thermistor_beta_k) * (1.0 / (temp_c + 273.15) - 1.0 / 298.15)).exp();
    let code = (4095.0 * r / (r + f64::from(cfg.thermistor_r_fixed_ohm))).round() as u16;
    let measured_t = acq.update_temperature(code);

    // Machine: circle of radius = bar length about the socket at the origin, CCW, 1000 mm/min,
    // with the actual path's centre off by (e_x, e_y).
    let radius_mm = f64::from(cfg.bar_length_mm);
    let (ex_um, ey_um) = (5.0, -3.0);
    let rate = f64::from(cfg.sample_rate_hz);
    let n = (2.0 * std::f64::consts::PI * radius_mm / (1000.0 / 60.0) * rate) as usize;
    println!(
        "ballpod acquisition demo (seed {seed}, ADC noise {noise} counts, bar at {temp_c} °C)"
    );
    println!(
        "circle R = {radius_mm} mm about the socket, F1000 mm/min, centre offset ({ex_um}, {ey_um}) µm, {n} samples at {rate} Hz"
    );
    match measured_t {
        Ok(t) => println!("bar thermistor: {t:.3} °C"),
        Err(e) => println!("bar thermistor fault: {e:?}"),
    }
    let counts = |mm: f64| ((mm * 10_000.0).round() as i64).rem_euclid(1 << 16) as u32;
    acq.reference_axes(
        [counts(radius_mm), counts(0.0), 0, 0, 0],
        [radius_mm, 0.0, 0.0, 0.0, 0.0],
    );
    println!(
        "{:>6} {:>10} {:>10} {:>10} {:>10} {:>6}",
        "seq", "x_mm", "y_mm", "dl_um", "truth_um", "flags"
    );
    let (mut sum2, mut worst, mut valid) = (0.0f64, 0.0f64, 0usize);
    let mut flagged = 0usize;
    for k in 0..n {
        let th = 2.0 * std::f64::consts::PI * k as f64 / n as f64;
        let (x, y) = (radius_mm * th.cos(), radius_mm * th.sin());
        // true ball-to-ball distance minus the calibrated length, µm
        let truth_um = ((x + ex_um * 1e-3).hypot(y + ey_um * 1e-3) - radius_mm) * 1e3;
        // the LVDT sees the distance minus the thermally grown bar body
        let lvdt_um = truth_um
            - f64::from(bar_expansion_um(
                cfg.bar_length_mm,
                cfg.bar_cte_ppm_per_k,
                temp_c as f32,
            ));
        let (a, b) = lvdt.block_adc(lvdt_um, P, periods, noise, &mut rng);
        let reading = demodulate(&a, &b, &table);
        let raw = [counts(x), counts(y), 0, 0, 0];
        let s = acq.sample((k as u64) * 1_000, reading, raw, 0, false);
        if s.flags.is_valid_for_metrology() {
            let err = f64::from(s.delta_l_um) - truth_um;
            sum2 += err * err;
            worst = worst.max(err.abs());
            valid += 1;
        }
        if s.flags != SampleFlags::NONE {
            flagged += 1;
        }
        if k % (n / 8).max(1) == 0 {
            println!(
                "{:>6} {:>10.4} {:>10.4} {:>10.4} {:>10.4} {:>6}",
                s.seq, s.axes[0], s.axes[1], s.delta_l_um, truth_um, s.flags.0
            );
        }
    }
    let c = acq.counters;
    println!(
        "samples {} (valid {valid}, flagged {flagged}); ΔL − truth: RMS {:.4} µm, max {:.4} µm",
        c.samples,
        (sum2 / valid.max(1) as f64).sqrt(),
        worst
    );
    println!(
        "counters: over-range {}, open {}, quadrature {}, temperature {}, lost {}",
        c.lvdt_over_range, c.lvdt_open, c.quadrature_errors, c.temperature_faults, c.lost_upstream
    );
}

/// `--serve [--can-port N] [--usb-port N] [--realtime] [--speed X] [--seed N] [--noise COUNTS]
/// [--max-seconds S]`: the simulated pod on loopback TCP (SLCAN and SCPI), see `serve.rs`.
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
    match parsed.map(ballpod_host::serve::run) {
        Ok(Ok(())) => {}
        Ok(Err(e)) => {
            eprintln!("sim --serve: {e}");
            std::process::exit(1);
        }
        Err(e) => {
            eprintln!("sim --serve: {e}");
            std::process::exit(2);
        }
    }
}
