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
//! - The machine starts at its home (every axis at 0, the bar at its nominal length: the
//!   counters read from 0 at boot). [`VirtualCnc`], `sim --serve`'s virtual CNC, moves it
//!   through each run's pattern from the session the firmware publishes ([`SharedLayout`]'s
//!   session words); it homes the axes at a program's start and ends a run with its program
//!   through the records (the emulated board's `cnc` module).
//! - `--set NAME=VALUE`: settings the board boots with, stored in its settings pages before
//!   its first boot (the region's settings area) as on a pod configured and saved before; the
//!   harness reads the sensors at their sample rate and excitation (`Sensors::with_config`).
//!   A reset keeps them (the pages survive it); a client's `*SAV` then a reset changes them,
//!   but the harness goes on at the first boot's rate.
//! - `--figures FILE`: what the board measures of itself in emulated time (its CAN adapter's
//!   SDO answer times and heartbeat gaps, the boots) with the records and `positioned`, a JSON
//!   object rewritten as it changes (at most every 100 ms while only a run's CPU time grows).

use std::fs::{File, OpenOptions};
use std::io::{self, Write};
use std::net::TcpListener;
use std::os::unix::fs::FileExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use ballpod::acquisition::MAX_AXES;
use ballpod::config::Config;

use ballpod::app::{Direction, Pattern, SessionState};
use ballpod::config::RunTrigger;

use crate::vmt::machine::MachineFile;
use crate::vmt::motion::{Motion, ServeTruth};
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
    /// The served machine (`--machine`), instead of the default truth's.
    pub machine: Option<MachineFile>,
    /// Where to keep the board's figures (`--figures`): a JSON object, rewritten as they change.
    pub figures: Option<PathBuf>,
    /// The settings the board boots with the first time (`--set`): stored in its settings
    /// pages as a pod configured and saved before; the sensors are read at its sample rate and
    /// excitation.
    pub settings: Config,
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
    pub const VERSION: u32 = 6;
    const MAGIC_AT: u64 = 0;
    const VERSION_AT: u64 = 4;
    const BOOTS_AT: u64 = 8;
    const WRITTEN_AT: u64 = 12;
    const TAKEN_AT: u64 = 16;
    const SESSION_SEQ_AT: u64 = 20;
    const SESSION_AT: u64 = 24;
    const RUN_AT: u64 = 28;
    const FIGURES_AT: u64 = 32;
    const FIGURES: u64 = 21;
    /// Figures `RunBusyUs` and `RunMeasuredUs` (board/shared.rs `Figure`): a run's CPU time.
    const RUN_CPU_FIGURES: [usize; 2] = [10, 11];
    const CONFIG_LEN_AT: u64 = Self::FIGURES_AT + 4 * Self::FIGURES;
    const CONFIG_AT: u64 = Self::CONFIG_LEN_AT + 4;
    const CONFIG_BYTES: u64 = 512;
    const SETTINGS_LEN_AT: u64 = Self::CONFIG_AT + Self::CONFIG_BYTES;
    const SETTINGS_AT: u64 = Self::SETTINGS_LEN_AT + 4;
    const RING_AT: u64 = Self::SETTINGS_AT + Self::CONFIG_BYTES;
    /// Records in the ring.
    pub const RING: u32 = 512;
    /// Time the harness writes ahead of the firmware, µs (48 records at 1 kHz, 480 at 10 kHz:
    /// the harness's own scheduling on the host has that long).
    pub const LEAD_US: f64 = 48_000.0;
    /// ADC codes per channel a record holds (`block::BLOCK_MAX`).
    pub const BLOCK_MAX: usize = 100;
    /// Bytes of one record: raw[5], thermistor, seated, edge, edge_raw[5], tripped, cnc,
    /// reference_raw[5], reference_pos[10] (u32 each), then a[100], b[100] (u16).
    pub const RECORD: u64 =
        4 * (5 + 1 + 1 + 1 + 5 + 1 + 1 + 5 + 10) + 2 * 2 * Self::BLOCK_MAX as u64;
    /// `Record::cnc`: the axes were homed before this block.
    const CNC_REFERENCE: u32 = 1;
    /// `Record::cnc`: the part program ended before this block.
    const CNC_PROGRAM_END: u32 = 2;
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
    /// The virtual CNC homed the machine before this block: the counters that read these
    /// positions (mm / degrees).
    pub reference: Option<([u32; MAX_AXES], [f64; MAX_AXES])>,
    /// The virtual CNC's part program ended before this block (the run stops).
    pub program_end: bool,
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
        let cnc = if self.reference.is_some() {
            SharedLayout::CNC_REFERENCE
        } else {
            0
        } | if self.program_end {
            SharedLayout::CNC_PROGRAM_END
        } else {
            0
        };
        w(cnc);
        let (raw, pos) = self.reference.unwrap_or(([0; MAX_AXES], [0.0; MAX_AXES]));
        raw.iter().for_each(|&r| w(r));
        for p in pos {
            let bits = p.to_bits();
            w(bits as u32);
            w((bits >> 32) as u32);
        }
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

    /// What the board measured of itself (`shared::Figure` of the emulated board): SDO answers,
    /// worst SDO answer time µs, heartbeat gaps measured, shortest and longest gap µs, boots
    /// after a watchdog reset; then the device counters `adc_blocks_lost`,
    /// `block_queue_overruns`, `watchdog_misses`, `stack_high_water_bytes`; then the CPU load
    /// while a run ran: busy µs, measured µs, the busiest 100 ms in ‰; the application task's
    /// longest turn, µs, and what it handled (1 block, 2 CAN frame, 3 USB, 4 tick, 5 work done);
    /// the blocks dropped while a run ran or a job computed; the periods delivered at a later
    /// tick than their own, the most periods owed at one tick (QEMU's stalls on the host); the
    /// boots that would have entered the ROM bootloader; the heartbeat gaps left out (a stall
    /// of QEMU); the watchdog expiries excused (a stall of QEMU while the firmware slept).
    pub fn figures(&self) -> io::Result<[u32; SharedLayout::FIGURES as usize]> {
        let mut f = [0u32; SharedLayout::FIGURES as usize];
        for (k, v) in f.iter_mut().enumerate() {
            *v = self.u32_at(SharedLayout::FIGURES_AT + 4 * k as u64)?;
        }
        Ok(f)
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

    /// Leaves `settings` for the firmware's first boot (before QEMU starts).
    pub fn preset_settings(&self, settings: &Config) -> io::Result<()> {
        let mut bytes = vec![0u8; ballpod::config::ENCODED_LEN];
        let n = settings
            .encode(&mut bytes)
            .map_err(|e| io::Error::other(format!("{e:?}")))?;
        self.file
            .write_all_at(&bytes[..n], SharedLayout::SETTINGS_AT)?;
        self.file
            .write_all_at(&(n as u32).to_le_bytes(), SharedLayout::SETTINGS_LEN_AT)
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

/// The virtual CNC of the emulated board: the simulated pod's ([`crate::vmt::motion`]) driven
/// by the session the firmware publishes. When a run is armed (or found running) it puts the
/// machine at its program's start and homes the axes there (the record's reference, as the
/// simulated pod's `home`); once the run is running it moves through the pattern, and the
/// record after the last step ends the program (the run stops before that block). A
/// self-triggered circle (`run_trigger = FEED_IN`) gets its whole part program at once and
/// the pod starts and ends the run itself. Between runs the machine stands where it stopped.
///
/// The harness writes records ahead of the firmware and sees the session a few periods late,
/// and it plans a run's motion beside its record loop (10–30 ms; the machine rests meanwhile):
/// a run started in the same turn as it was armed (`SESS:ARM;STAR`) starts where the machine
/// stands, and the machine is put at the start a few periods into it. A client acting as the
/// CNC therefore starts a run once the machine is at its start, as a CNC starts a run after
/// its positioning move: `--figures`'s `positioned` counts the programs the machine was put
/// at the start of, once the firmware has taken that period. A run starts with the machine
/// resting at its start for the periods between START and the harness seeing it (a CNC's
/// dwell); its end is exact. At rest the bar reads what it read at the last step.
pub struct VirtualCnc {
    truth: ServeTruth,
    /// Where the machine stands (mm / degrees).
    at: [f64; MAX_AXES],
    /// The true bar-length deviation there, µm (the bar reads on while the machine rests).
    dl_um: f64,
    motion: Motion,
    /// The run the motion is planned for.
    planned: Option<u32>,
    /// The plan being made for it (`Motion::plan_run` takes 10–30 ms, on a loaded host more
    /// than the records written ahead of the firmware last).
    planning: Option<std::thread::JoinHandle<Result<Motion, String>>>,
    /// The motion is playing (the run runs, or a self-triggered program).
    playing: bool,
    self_triggered: bool,
    /// The program's end was written for the planned run.
    ended: bool,
    probe_runs: u32,
}

/// What the virtual CNC does in one sample period.
pub struct CncStep {
    /// True bar-length deviation, µm.
    pub dl_um: f64,
    /// Axis positions (mm / degrees).
    pub axes: [f64; MAX_AXES],
    /// A probe edge this period at these positions.
    pub edge: Option<[f64; MAX_AXES]>,
    /// The stylus is seated.
    pub seated: bool,
    /// The machine was homed at `axes` before this period.
    pub homed: bool,
    /// The program ended before this period.
    pub program_end: bool,
}

impl VirtualCnc {
    /// At home (every axis at 0, where the counters read 0 at boot).
    pub fn new(truth: ServeTruth) -> Self {
        Self {
            truth,
            at: [0.0; MAX_AXES],
            dl_um: 0.0,
            motion: Motion::none(),
            planned: None,
            planning: None,
            playing: false,
            self_triggered: false,
            ended: false,
            probe_runs: 0,
        }
    }

    /// The next sample period, with the session as last published; `sensors` get the bar
    /// the run's configuration names.
    pub fn step(&mut self, s: Option<&PublishedSession>, sensors: &mut Sensors) -> CncStep {
        const ARMED: u8 = SessionState::Armed as u8;
        const RUNNING: u8 = SessionState::Running as u8;
        let mut homed = false;
        let active = s.filter(|s| s.state == ARMED || s.state == RUNNING);
        match active {
            None => {
                self.planned = None;
                self.playing = false;
                // (a plan still being made is left to finish alone)
                self.planning = None;
            }
            Some(s) if self.planned != Some(s.run) => {
                self.planned = Some(s.run);
                self.ended = false;
                let cfg = s.config.unwrap_or_default();
                sensors.set_bar_length(f64::from(cfg.bar_length_mm));
                let pattern_code = s.pattern;
                let pattern = Pattern::from_u8(s.pattern);
                let direction = if s.direction == Direction::Cw as u8 {
                    Direction::Cw
                } else {
                    Direction::Ccw
                };
                self.self_triggered = s.state == ARMED
                    && pattern == Some(Pattern::Circle)
                    && cfg.setup.run_trigger == RunTrigger::FeedIn;
                let (truth, probe_runs, self_triggered) =
                    (self.truth, self.probe_runs, self.self_triggered);
                let run = s.run;
                if pattern == Some(Pattern::Probe) {
                    self.probe_runs += 1;
                }
                // planned beside the record loop, which goes on writing the machine at rest
                self.planning = Some(std::thread::spawn(move || {
                    let planning = Instant::now();
                    let planned = match pattern {
                        Some(p) => {
                            Motion::plan_run(&truth, &cfg, p, direction, self_triggered, probe_runs)
                        }
                        None => Err(format!("pattern {pattern_code} unknown")),
                    };
                    eprintln!(
                        "emu: the virtual CNC planned run {run} in {:.1} ms",
                        planning.elapsed().as_secs_f64() * 1e3
                    );
                    planned.map_err(|e| format!("no program for run {run}: {e}"))
                }));
                self.playing = false;
            }
            Some(s) => self.playing |= self.planning.is_none() && s.state == RUNNING,
        }
        // a plan that has come in: the machine is put at its start (homed there, or where it
        // stands without one) and plays if the run runs or triggers itself
        if let (Some(s), Some(p)) = (active, &self.planning)
            && p.is_finished()
            && let Some(planning) = self.planning.take()
        {
            let planned = planning
                .join()
                .unwrap_or_else(|_| Err("the planning thread panicked".into()));
            match planned {
                Ok(m) => {
                    if let Some((start, dl_um)) = m.start_step() {
                        self.at = start;
                        self.dl_um = dl_um;
                    }
                    self.motion = m;
                }
                Err(e) => {
                    eprintln!("emu: the virtual CNC has {e}");
                    self.motion = Motion::none();
                }
            }
            homed = true;
            self.playing = self.self_triggered || s.state == RUNNING;
        }
        let mut step = CncStep {
            dl_um: self.dl_um,
            axes: self.at,
            edge: None,
            seated: true,
            homed,
            program_end: false,
        };
        if !self.playing {
            return step;
        }
        match self.motion.next_step() {
            Some(m) => {
                self.at = m.axes;
                self.dl_um = m.dl_um;
                step.dl_um = m.dl_um;
                step.axes = m.axes;
                step.edge = m.edge;
                step.seated = m.seated;
            }
            None if !self.self_triggered && !self.ended => {
                // the part program's last block: the run ends with the motion
                step.program_end = true;
                self.ended = true;
            }
            None => {}
        }
        step
    }
}

/// How often the figures file is rewritten while only the steadily growing CPU-time figures
/// change (every loop while a run runs: 2 000 writes a second competed with QEMU for the host).
const FIGURES_EVERY: Duration = Duration::from_millis(100);

/// The figures with the steadily growing ones (a run's busy and measured µs) left out: any
/// other change — a count, a worst case, a boot, a positioned program — is written at once.
type Figures = ([u32; SharedLayout::FIGURES as usize], u32, u32);
fn steady_masked((mut f, boots, positioned): Figures) -> Figures {
    for i in SharedLayout::RUN_CPU_FIGURES {
        if let Some(v) = f.get_mut(i) {
            *v = 0;
        }
    }
    (f, boots, positioned)
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
    if opts.settings != Config::default() {
        region.preset_settings(&opts.settings)?;
    }
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
    let cfg = opts.settings;
    let mut truth = ServeTruth::default();
    if let Some(m) = opts.machine {
        truth.machine = m;
    }
    let instrument = Instrument {
        bar_noise_um: 0.2,
        ..Instrument::default()
    };
    let mut sensors = Sensors::with_config(&cfg, &instrument, opts.seed);
    let mut cnc = VirtualCnc::new(truth);
    let lead = ((SharedLayout::LEAD_US * 1e-6 * f64::from(cfg.sample_rate_hz)) as u32)
        .clamp(8, SharedLayout::RING * 3 / 4);
    let truth = serde_json::to_string(&truth).map_err(io::Error::other)?;
    println!(
        "{{\"can_port\":{},\"usb_port\":{},\"stream_port\":{},\"node_id\":{},\"emulated\":true,\"icount_shift\":{},\"truth\":{truth}}}",
        ports[0], ports[1], ports[2], cfg.can_node_id, opts.icount_shift
    );
    io::stdout().flush()?;
    let mut last_boots = region.boots()?.unwrap_or(0);
    let mut session: Option<PublishedSession> = None;
    let mut last_figures = None;
    let mut last_written = Instant::now();
    // the record that homed the machine for the latest program, until the firmware takes it
    let mut homing: Option<u32> = None;
    let mut positioned = 0u32;
    while start.elapsed().as_secs_f64() < opts.max_seconds {
        if let Some(now) = region.session()? {
            let key = |s: &PublishedSession| (s.state, s.pattern, s.direction, s.run);
            if session.as_ref().map(key) != Some(key(&now)) {
                eprintln!(
                    "emu: session state {} pattern {} direction {} run {}",
                    now.state, now.pattern, now.direction, now.run
                );
            }
            session = Some(now);
        }
        let (written, taken) = region.counts()?;
        // keep `LEAD_US` of records ahead of the firmware
        let mut k = written;
        while k.wrapping_sub(taken) < lead {
            let step = cnc.step(session.as_ref(), &mut sensors);
            if step.homed {
                homing = Some(k);
            }
            let r = sensors.read(step.dl_um, &step.axes);
            region.push(
                k,
                &Record {
                    raw: r.raw,
                    thermistor: r.thermistor,
                    seated: step.seated,
                    edge: step.edge.map(|e| sensors.raw(&e)),
                    a: &r.adc.0,
                    b: &r.adc.1,
                    reference: step.homed.then(|| sensors.reference(&step.axes)),
                    program_end: step.program_end,
                },
            )?;
            k = k.wrapping_add(1);
        }
        if let Some(b) = region.boots()?
            && b != last_boots
        {
            eprintln!("emu: the firmware booted again (boot {b}): a reset");
            last_boots = b;
        }
        let (_, taken) = region.counts()?;
        if let Some(h) = homing
            && taken.wrapping_sub(h) as i32 > 0
        {
            positioned += 1;
            homing = None;
        }
        let figures = (region.figures()?, region.boots()?.unwrap_or(0), positioned);
        if let Some(path) = &opts.figures
            && last_figures != Some(figures)
            && (last_written.elapsed() >= FIGURES_EVERY
                || last_figures.map(steady_masked) != Some(steady_masked(figures)))
        {
            let (
                [
                    answers,
                    worst,
                    gaps,
                    gap_min,
                    gap_max,
                    watchdog,
                    adc_lost,
                    queue,
                    misses,
                    stack,
                    run_busy,
                    run_measured,
                    run_peak,
                    longest_turn,
                    longest_turn_kind,
                    run_dropped,
                    delivered_late,
                    most_owed,
                    rom_bootloader,
                    heartbeat_gaps_left_out,
                    stalls_excused,
                ],
                boots,
                positioned,
            ) = figures;
            let (written, taken) = region.counts()?;
            let json = format!(
                "{{\"sdo_answers\":{answers},\"sdo_worst_us\":{worst},\"heartbeat_gaps\":{gaps},\"heartbeat_gap_min_us\":{gap_min},\"heartbeat_gap_max_us\":{gap_max},\"boots\":{boots},\"watchdog_resets\":{watchdog},\"records_written\":{written},\"records_taken\":{taken},\"adc_blocks_lost\":{adc_lost},\"block_queue_overruns\":{queue},\"watchdog_misses\":{misses},\"stack_high_water_bytes\":{stack},\"run_busy_us\":{run_busy},\"run_measured_us\":{run_measured},\"run_load_peak_permille\":{run_peak},\"longest_turn_us\":{longest_turn},\"longest_turn_kind\":{longest_turn_kind},\"run_blocks_dropped\":{run_dropped},\"periods_delivered_late\":{delivered_late},\"most_periods_owed\":{most_owed},\"rom_bootloader_entries\":{rom_bootloader},\"heartbeat_gaps_left_out\":{heartbeat_gaps_left_out},\"watchdog_stalls_excused\":{stalls_excused},\"positioned\":{positioned}}}\n"
            );
            // written whole, then renamed over the old (a reader never sees half of it)
            let tmp = path.with_extension("tmp");
            std::fs::write(&tmp, json)?;
            std::fs::rename(&tmp, path)?;
            last_figures = Some(figures);
            last_written = Instant::now();
        }
        std::thread::sleep(Duration::from_micros(500));
    }
    Ok(())
}
