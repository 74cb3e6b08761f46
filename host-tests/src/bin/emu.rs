//! `cargo emu -- --serve`: the firmware on the emulated board (QEMU mps2-an386; build it with
//! `cargo emu-fw`) with its CAN (SLCAN), SCPI and stream ports on loopback TCP, as
//! `sim --serve` offers the simulated pod (see `ballpod_host::emu`). Needs `qemu-system-arm`
//! (Debian package qemu-system-arm).

use std::path::PathBuf;

use ballpod_host::vmt::machine::MachineFile;
use clap::Parser;

/// The firmware on an emulated Cortex-M4F, served to CANopen / SCPI clients on loopback TCP.
#[derive(Parser, Debug)]
#[command(name = "cargo emu", version)]
struct Args {
    /// Serve (the only mode: the flag keeps `sim --serve`'s command line).
    #[arg(long)]
    serve: bool,
    /// The emulated board's firmware (`cargo emu-fw` builds it).
    #[arg(
        long,
        default_value = "host-tests/emu-board/target/thumbv7em-none-eabihf/release/ballpod-emu"
    )]
    elf: PathBuf,
    /// SLCAN port (0: any free port).
    #[arg(long, default_value_t = 0)]
    can_port: u16,
    /// SCPI (USB command) port (0: any free port).
    #[arg(long, default_value_t = 0)]
    usb_port: u16,
    /// Sample stream port (0: any free port).
    #[arg(long, default_value_t = 0)]
    stream_port: u16,
    /// Stop after this many seconds of real time.
    #[arg(long, default_value_t = 600.0)]
    max_seconds: f64,
    /// Noise seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// QEMU's `-icount shift` (2^shift ns per instruction; 3: 125 M instructions per second).
    #[arg(long, default_value_t = 3)]
    icount_shift: u32,
    /// The served machine (TOML or JSON; every key optional), as `sim --serve --machine`.
    #[arg(long)]
    machine: Option<PathBuf>,
    /// Keep what the board measures of itself in emulated time here (a JSON object: SDO
    /// answers and the worst answer time, heartbeat gaps, boots, records), rewritten as it
    /// changes.
    #[arg(long)]
    figures: Option<PathBuf>,
    /// A setting the board boots with (repeatable; `NAME=VALUE`, NAME as in `CONFigure:LIST?`,
    /// VALUE a number or a choice's name), stored in its settings pages before its first boot
    /// as on a pod configured and saved before: e.g. `--set sample_rate=10000 --set
    /// excitation=10000` for the highest sample rate.
    #[arg(long = "set", value_name = "NAME=VALUE")]
    set: Vec<String>,
}

fn main() {
    let a = Args::parse();
    let machine = match a.machine.as_deref().map(MachineFile::read).transpose() {
        Ok(m) => m,
        Err(e) => {
            eprintln!("emu: --machine: {e}");
            std::process::exit(2);
        }
    };
    let settings = match ballpod_host::cli::settings(&a.set) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("emu: --set {e}");
            std::process::exit(2);
        }
    };
    let r = ballpod_host::emu::run(ballpod_host::emu::EmuOptions {
        elf: a.elf,
        can_port: a.can_port,
        usb_port: a.usb_port,
        stream_port: a.stream_port,
        max_seconds: a.max_seconds,
        seed: a.seed,
        icount_shift: a.icount_shift,
        machine,
        figures: a.figures,
        settings,
    });
    if let Err(e) = r {
        eprintln!("emu: {e}");
        std::process::exit(1);
    }
}
