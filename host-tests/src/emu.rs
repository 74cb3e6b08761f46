//! `emu --serve`: the firmware on the emulated board (`host-tests/emu-board`, QEMU's
//! mps2-an386) with its ports on loopback TCP as `sim --serve` offers them, and this harness as
//! its ADC, encoders, probe and thermistor.
//!
//! - QEMU runs the firmware with `-icount shift=3,sleep=on`: every instruction takes 8 ns of
//!   emulated time (125 M instructions per emulated second, pessimistic against the G474's 170
//!   MHz), and while the firmware idles emulated time follows real time, so the clients
//!   measure in real time what the firmware does in emulated time (as long as QEMU keeps up
//!   with 125 M instructions a second when the firmware is busy).
//! - Its UARTs 0, 1 and 2 are QEMU TCP servers: SLCAN (the CAN bus), the SCPI command port,
//!   the sample stream — the JSON line names their ports, as `sim --serve`'s does.
//! - The harness shares the emulator's machine RAM (a file both map, [`SharedLayout`]) and
//!   writes the sensors' readings into its block ring ahead of the firmware: each sample
//!   period the secondaries' 12-bit ADC codes (the LVDT model of [`crate::vmt::sensors`]), the
//!   encoder counters, the thermistor code. The firmware takes one record per tick of its sample
//!   clock, in emulated time; a record not there in time is a lost period, as on the pod.
//! - The machine stands at its home (every axis at 0, the bar at its nominal length): the
//!   counters read from 0 at boot, so the pod's axis positions are the machine's. The session
//!   the firmware publishes ([`SharedLayout`]'s session words) is read and reported, for a
//!   virtual CNC to move the machine through a run's pattern (not yet: the runs that need
//!   motion are `sim --serve`'s).

use std::fs::{File, OpenOptions};
use std::io::{self, Write};
use std::net::TcpListener;
use std::os::unix::fs::FileExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use ballpod::acquisition::MAX_AXES;
use ballpod::config::Config;

use crate::vmt::sensors::{Instrument, Sensors};

/// Options of `emu --serve`.
#[derive(Clone, Debug)]
pub struct EmuOptions {
    /// The firmware's ELF (the emulated board's build).
    pub elf: PathBuf,
    /// SLCAN port (0: any free port).
    pub can_port: u16,
    /// SCPI port (0: any free port).
    pub usb_port: u16,
    /// Sample stream port (0: any free port).
    pub stream_port: u16,
    /// Stop after this many seconds of real time.
    pub max_seconds: f64,
    /// Noise seed.
    pub seed: u64,
    /// QEMU's `-icount shift`: 2^shift ns of emulated time per instruction.
    pub icount_shift: u32,
}

/// The shared region's layout: `host-tests/emu-board/src/board/shared.rs` (`Shared`,
/// `Record`), offsets in bytes. Change both together.
pub struct SharedLayout;

impl SharedLayout {
    /// Bytes of the region (QEMU's machine RAM of the mps2).
    pub const SIZE: u64 = 16 << 20;
    /// "BPOD" once the firmware has booted.
    pub const MAGIC: u32 = 0x444F_5042;
    /// Layout version.
    pub const VERSION: u32 = 1;
    const MAGIC_AT: u64 = 0;
    const VERSION_AT: u64 = 4;
    const BOOTS_AT: u64 = 8;
    const WRITTEN_AT: u64 = 12;
    const TAKEN_AT: u64 = 16;
    const SESSION_SEQ_AT: u64 = 20;
    const SESSION_AT: u64 = 24;
    const RUN_AT: u64 = 28;
    const CONFIG_LEN_AT: u64 = 32;
    const CONFIG_AT: u64 = 36;
    const CONFIG_BYTES: u64 = 512;
    const RING_AT: u64 = Self::CONFIG_AT + Self::CONFIG_BYTES;
    /// Records in the ring.
    pub const RING: u32 = 64;
    /// ADC codes per channel a record holds (`block::BLOCK_MAX`).
    pub const BLOCK_MAX: usize = 100;
    /// Bytes of one record: raw[5], thermistor, seated, edge, edge_raw[5], tripped (u32 each),
    /// then a[100], b[100] (u16).
    pub const RECORD: u64 = 4 * (5 + 1 + 1 + 1 + 5 + 1) + 2 * 2 * Self::BLOCK_MAX as u64;
}

/// One sample period for the firmware's ring.
pub struct Record<'a> {
    /// Encoder counters (16 bits).
    pub raw: [u32; MAX_AXES],
    /// Thermistor code, if read this period.
    pub thermistor: Option<u16>,
    /// Stylus seated.
    pub seated: bool,
    /// A probe edge this period: the counters at it.
    pub edge: Option<[u32; MAX_AXES]>,
    /// ADC codes, secondary A.
    pub a: &'a [u16],
    /// ADC codes, secondary B.
    pub b: &'a [u16],
}

impl Record<'_> {
    fn bytes(&self) -> Vec<u8> {
        let mut v = Vec::with_capacity(SharedLayout::RECORD as usize);
        let mut w = |x: u32| v.extend_from_slice(&x.to_le_bytes());
        self.raw.iter().for_each(|&r| w(r));
        w(self.thermistor.map_or(u32::MAX, u32::from));
        w(u32::from(self.seated));
        w(u32::from(self.edge.is_some()));
        self.edge
            .unwrap_or([0; MAX_AXES])
            .iter()
            .for_each(|&r| w(r));
        let rail = |c: &u16| *c == 0 || *c >= 4095;
        w(u32::from(
            self.a.iter().any(rail) || self.b.iter().any(rail),
        ));
        for codes in [self.a, self.b] {
            for k in 0..SharedLayout::BLOCK_MAX {
                v.extend_from_slice(&codes.get(k).copied().unwrap_or(0).to_le_bytes());
            }
        }
        v
    }
}

/// The session as the firmware publishes it for the virtual CNC (`App::session`, `pattern`,
/// `direction` as their `u8`, the run's number, the running configuration).
#[derive(Clone, Debug, PartialEq)]
pub struct PublishedSession {
    /// Session state (0 IDLE, 1 ARMED, 2 RUNNING, 3 DONE, 4 ABORTED).
    pub state: u8,
    /// Pattern (CANopen 0x3000's value).
    pub pattern: u8,
    /// Direction (0 CCW, 1 CW).
    pub direction: u8,
    /// The run's number.
    pub run: u32,
    /// The running configuration, if it decodes.
    pub config: Option<Config>,
}

/// The region as the harness sees it (positional reads and writes of the shared file).
pub struct Region {
    file: File,
    path: PathBuf,
}

impl Region {
    /// A new zeroed region at `path`.
    pub fn create(path: &Path) -> io::Result<Self> {
        let file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(true)
            .open(path)?;
        file.set_len(SharedLayout::SIZE)?;
        Ok(Self {
            file,
            path: path.to_path_buf(),
        })
    }

    fn u32_at(&self, at: u64) -> io::Result<u32> {
        let mut b = [0u8; 4];
        self.file.read_exact_at(&mut b, at)?;
        Ok(u32::from_le_bytes(b))
    }

    /// The firmware has booted (`MAGIC`), its boots so far.
    pub fn boots(&self) -> io::Result<Option<u32>> {
        let ok = self.u32_at(SharedLayout::MAGIC_AT)? == SharedLayout::MAGIC
            && self.u32_at(SharedLayout::VERSION_AT)? == SharedLayout::VERSION;
        Ok(if ok {
            Some(self.u32_at(SharedLayout::BOOTS_AT)?)
        } else {
            None
        })
    }

    /// Records written and taken.
    pub fn counts(&self) -> io::Result<(u32, u32)> {
        Ok((
            self.u32_at(SharedLayout::WRITTEN_AT)?,
            self.u32_at(SharedLayout::TAKEN_AT)?,
        ))
    }

    /// Writes record `k`, then publishes it (`written = k + 1`).
    pub fn push(&self, k: u32, r: &Record<'_>) -> io::Result<()> {
        let at = SharedLayout::RING_AT + u64::from(k % SharedLayout::RING) * SharedLayout::RECORD;
        self.file.write_all_at(&r.bytes(), at)?;
        self.file
            .write_all_at(&k.wrapping_add(1).to_le_bytes(), SharedLayout::WRITTEN_AT)
    }

    /// The session the firmware published; `None` while it is being written.
    pub fn session(&self) -> io::Result<Option<PublishedSession>> {
        let seq = self.u32_at(SharedLayout::SESSION_SEQ_AT)?;
        if seq % 2 == 1 {
            return Ok(None);
        }
        let word = self.u32_at(SharedLayout::SESSION_AT)?;
        let run = self.u32_at(SharedLayout::RUN_AT)?;
        let len =
            (self.u32_at(SharedLayout::CONFIG_LEN_AT)? as u64).min(SharedLayout::CONFIG_BYTES);
        let mut cfg = vec![0u8; len as usize];
        self.file.read_exact_at(&mut cfg, SharedLayout::CONFIG_AT)?;
        if self.u32_at(SharedLayout::SESSION_SEQ_AT)? != seq {
            return Ok(None);
        }
        let [state, pattern, direction, _] = word.to_le_bytes();
        Ok(Some(PublishedSession {
            state,
            pattern,
            direction,
            run,
            config: Config::decode(&cfg).ok(),
        }))
    }
}

impl Drop for Region {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}

/// A free loopback port (for QEMU's TCP servers, which cannot report the one they took).
fn free_port(asked: u16) -> io::Result<u16> {
    if asked != 0 {
        return Ok(asked);
    }
    Ok(TcpListener::bind(("127.0.0.1", 0))?.local_addr()?.port())
}

/// QEMU running the firmware; killed when dropped.
struct Qemu(Child);

impl Drop for Qemu {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Runs `emu --serve` until `max_seconds` of real time have passed.
pub fn run(opts: EmuOptions) -> io::Result<()> {
    let dir = if Path::new("/dev/shm").is_dir() {
        PathBuf::from("/dev/shm")
    } else {
        std::env::temp_dir()
    };
    let region = Region::create(&dir.join(format!("ballpod-emu-{}", std::process::id())))?;
    let ports = [
        free_port(opts.can_port)?,
        free_port(opts.usb_port)?,
        free_port(opts.stream_port)?,
    ];
    let mut cmd = Command::new("qemu-system-arm");
    cmd.args([
        "-machine",
        "mps2-an386,memory-backend=mem",
        "-cpu",
        "cortex-m4",
    ])
    .arg("-object")
    .arg(format!(
        "memory-backend-file,id=mem,size=16M,mem-path={},share=on",
        region.path.display()
    ))
    .args(["-nographic", "-monitor", "none"]);
    for p in ports {
        cmd.arg("-serial")
            .arg(format!("tcp:127.0.0.1:{p},server=on,wait=off"));
    }
    cmd.arg("-icount")
        .arg(format!("shift={},sleep=on", opts.icount_shift))
        .arg("-kernel")
        .arg(&opts.elf)
        .stdin(Stdio::null())
        .stdout(Stdio::null());
    let _qemu = Qemu(cmd.spawn()?);
    let start = Instant::now();
    while region.boots()?.is_none() {
        if start.elapsed() > Duration::from_secs(20) {
            return Err(io::Error::other(
                "the emulated firmware did not boot within 20 s",
            ));
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    // the machine at home: every axis at 0, the bar at its nominal length
    let cfg = Config::default();
    let mut sensors = Sensors::new(
        f64::from(cfg.bar_length_mm),
        &Instrument::default(),
        opts.seed,
    );
    let home = [0.0; MAX_AXES];
    // the served machine's truth, as `sim --serve` states it (its set-up configures a test; this
    // harness does not move it through one yet)
    let truth = serde_json::to_string(&crate::vmt::motion::ServeTruth::default())
        .map_err(io::Error::other)?;
    println!(
        "{{\"can_port\":{},\"usb_port\":{},\"stream_port\":{},\"node_id\":{},\"emulated\":true,\"icount_shift\":{},\"truth\":{truth}}}",
        ports[0], ports[1], ports[2], cfg.can_node_id, opts.icount_shift
    );
    io::stdout().flush()?;
    let mut last_boots = region.boots()?.unwrap_or(0);
    let mut last_session = None;
    while start.elapsed().as_secs_f64() < opts.max_seconds {
        let (written, taken) = region.counts()?;
        // keep the ring three quarters full ahead of the firmware
        let mut k = written;
        while k.wrapping_sub(taken) < SharedLayout::RING * 3 / 4 {
            let r = sensors.read(0.0, &home);
            region.push(
                k,
                &Record {
                    raw: r.raw,
                    thermistor: r.thermistor,
                    seated: true,
                    edge: None,
                    a: &r.adc.0,
                    b: &r.adc.1,
                },
            )?;
            k = k.wrapping_add(1);
        }
        // the session on stderr as it changes (what a virtual CNC will move the machine by)
        if let Some(now) = region.session()?
            && last_session.as_ref().is_none_or(|l: &PublishedSession| {
                (l.state, l.pattern, l.direction, l.run)
                    != (now.state, now.pattern, now.direction, now.run)
            })
        {
            eprintln!(
                "emu: session state {} pattern {} direction {} run {}",
                now.state, now.pattern, now.direction, now.run
            );
            last_session = Some(now);
        }
        if let Some(b) = region.boots()?
            && b != last_boots
        {
            eprintln!("emu: the firmware booted again (boot {b}): a reset");
            last_boots = b;
        }
        std::thread::sleep(Duration::from_micros(500));
    }
    Ok(())
}
