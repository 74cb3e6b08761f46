//! The region the emulated board shares with the host's harness: QEMU's machine RAM at
//! 0x2100_0000, backed by a file the harness maps too (`-machine memory-backend=…` with a
//! shared `memory-backend-file`). The harness writes one block record per sample period into a
//! ring — the secondaries' ADC codes, the encoder counters at the block's centre, a probe edge,
//! the thermistor code — ahead of the firmware, which takes one at each tick of its sample
//! clock (the emulated ADC DMA). The firmware writes its session there for the harness's
//! virtual CNC. The layout is `host-tests/src/emu.rs`'s too (`SharedLayout`): change both.

use core::sync::atomic::{AtomicU32, Ordering};

use ballpod::acquisition::MAX_AXES;
use ballpod::app::App;
use ballpod::config::Config;

use super::block::BLOCK_MAX;

/// Words of [`Shared::figures`].
pub const FIGURES: usize = 21;

/// What the emulated CAN adapter measures in emulated time, at the bus side of the node (the
/// word of [`Shared::figures`] each is in).
#[derive(Clone, Copy)]
pub enum Figure {
    /// SDO requests answered.
    SdoAnswers = 0,
    /// The longest time from an SDO request's frame received to its answer's sent, µs.
    SdoWorstUs = 1,
    /// Gaps between two heartbeats measured (boot-up frames start again).
    Heartbeats = 2,
    /// The shortest time between two heartbeats, µs.
    HeartbeatGapMinUs = 3,
    /// The longest time between two heartbeats, µs.
    HeartbeatGapMaxUs = 4,
    /// Boots after a watchdog reset (the other boots: power-on, NMT reset node).
    WatchdogResets = 5,
    /// The device counters' `adc_blocks_lost` (as the application task last set them).
    AdcBlocksLost = 6,
    /// `block_queue_overruns`: blocks dropped because the application task had not taken the
    /// previous ones.
    BlockQueueOverruns = 7,
    /// `watchdog_misses`.
    WatchdogMisses = 8,
    /// `stack_high_water_bytes`.
    StackHighWaterBytes = 9,
    /// Time the CPU was busy while a run ran, µs (interrupts and the tasks above the worker:
    /// `load`).
    RunBusyUs = 10,
    /// Time measured for [`Figure::RunBusyUs`], µs.
    RunMeasuredUs = 11,
    /// The busiest 100 ms while a run ran, ‰ of the CPU.
    RunLoadPeakPermille = 12,
    /// The application task's longest turn, µs (`compute::LONGEST_TURN_US`).
    LongestTurnUs = 13,
    /// What it handled (`compute::TurnKind`).
    LongestTurnKind = 14,
    /// Blocks dropped on the way to the application task while a run ran or a job computed
    /// (`load`).
    RunBlocksDropped = 15,
    /// Sample periods delivered at a later tick than their own (the harness had not written
    /// their records yet, or a late tick's periods waited for room in the tick queue; they keep
    /// their times: not a loss; `lvdt::block_latch`).
    PeriodsDeliveredLate = 16,
    /// The most periods owed at one tick of the sample clock (QEMU delivering the timer's
    /// interrupt late after a stall on the host, or the harness behind).
    MostPeriodsOwed = 17,
    /// Boots that would have entered the STM32's ROM bootloader (`SYSTem:BOOTloader`).
    RomBootloaderEntries = 18,
    /// Heartbeat gaps left out of [`Figure::HeartbeatGapMinUs`] and
    /// [`Figure::HeartbeatGapMaxUs`]: the heartbeat between them went out just after a late
    /// tick of the sample clock (QEMU stalled on the host, its timers late in emulated time;
    /// `lvdt::last_stall`).
    HeartbeatGapsLeftOut = 19,
    /// Watchdog expiries excused: QEMU stalled on the host while the firmware slept and
    /// emulated time jumped past the watchdog's timeout (`watchdog`).
    WatchdogStallsExcused = 20,
}

/// Sets a figure.
pub fn set_figure(f: Figure, v: u32) {
    if let Some(w) = region().figures.get(f as usize) {
        w.store(v, Ordering::Relaxed);
    }
}

/// Adds `n` to a figure.
pub fn add_figure(f: Figure, n: u32) {
    if let Some(w) = region().figures.get(f as usize) {
        w.fetch_add(n, Ordering::Relaxed);
    }
}

/// Raises a figure to `v` if it is below.
pub fn raise_figure(f: Figure, v: u32) {
    if let Some(w) = region().figures.get(f as usize) {
        w.fetch_max(v, Ordering::Relaxed);
    }
}

/// A figure (0 until set; kept across resets: the region is the harness's).
pub fn figure(f: Figure) -> u32 {
    region()
        .figures
        .get(f as usize)
        .map_or(0, |w| w.load(Ordering::Relaxed))
}

/// Where the region is.
pub const BASE: usize = 0x2100_0000;
/// `magic` once the firmware has booted ("BPOD").
pub const MAGIC: u32 = 0x444F_5042;
/// Layout version (`version`).
pub const VERSION: u32 = 6;
/// Block records in the ring (the harness keeps 48 ms of them ahead: 480 at 10 kHz).
pub const RING: usize = 512;
/// Bytes of the configuration's encoding the session carries.
pub const CONFIG_BYTES: usize = 512;

/// [`Record::cnc`]: the machine was homed before this block (the virtual CNC put it at its
/// program's start): the axes are referenced at the record's reference, as the simulated
/// pod's virtual CNC does with `App::reference_axes`.
pub const CNC_REFERENCE: u32 = 1;
/// [`Record::cnc`]: the part program's last block ran before this block: the run ends (the
/// simulated pod's virtual CNC gives the STOP command then; a CNC gives it over CAN).
pub const CNC_PROGRAM_END: u32 = 2;

/// One sample period as the harness writes it.
#[repr(C)]
pub struct Record {
    /// The encoder counters at the block's centre (low 16 bits significant).
    pub raw: [u32; MAX_AXES],
    /// A thermistor reading in this period (12-bit code), or `u32::MAX`.
    pub thermistor: u32,
    /// The probe's stylus is seated (1) or deflected (0).
    pub seated: u32,
    /// 1: a probe edge in this period, the counters at it in `edge_raw`.
    pub edge: u32,
    /// The encoder counters at the edge.
    pub edge_raw: [u32; MAX_AXES],
    /// 1: a code of this block is at a rail (the ADCs' analog watchdogs would trip).
    pub tripped: u32,
    /// The virtual CNC before this block ([`CNC_REFERENCE`], [`CNC_PROGRAM_END`]; 0: nothing).
    pub cnc: u32,
    /// [`CNC_REFERENCE`]: the counters that read the positions `reference_pos` …
    pub reference_raw: [u32; MAX_AXES],
    /// … (f64 bits, low word first; mm / degrees).
    pub reference_pos: [u32; 2 * MAX_AXES],
    /// ADC codes of secondary A, then B (the block's length: the running configuration's).
    pub a: [u16; BLOCK_MAX],
    /// Secondary B.
    pub b: [u16; BLOCK_MAX],
}

/// The region's layout.
#[repr(C)]
pub struct Shared {
    /// [`MAGIC`] once booted (0 while booting: the harness waits for it).
    pub magic: AtomicU32,
    /// [`VERSION`].
    pub version: AtomicU32,
    /// Boots since the region was made (a watchdog reset shows as one more).
    pub boots: AtomicU32,
    /// Records the harness has written since the region was made.
    pub written: AtomicU32,
    /// Records the firmware has taken.
    pub taken: AtomicU32,
    /// Updates of the session below (odd while one is being written).
    pub session_seq: AtomicU32,
    /// Session state, pattern and direction (`App::session`, `pattern`, `direction` as u8,
    /// bytes 0, 1, 2).
    pub session: AtomicU32,
    /// The run's number.
    pub run: AtomicU32,
    /// What the board measures of itself in emulated time ([`Figure`]).
    pub figures: [AtomicU32; FIGURES],
    /// Bytes of `config` used.
    pub config_len: AtomicU32,
    /// The running configuration's encoding (`Config::encode`).
    pub config: [u8; CONFIG_BYTES],
    /// Bytes of `settings` used (0: none).
    pub settings_len: AtomicU32,
    /// Settings the harness left before the first boot (`emu --set`; `Config::encode`): the
    /// firmware stores them in its settings pages at that boot, as on a pod configured and
    /// saved before (the harness writes it once, before QEMU starts).
    pub settings: [u8; CONFIG_BYTES],
    /// The block ring (record `k` at `k % RING`).
    pub ring: [Record; RING],
}

/// The region.
pub fn region() -> &'static Shared {
    // SAFETY: the machine RAM at BASE (16 MiB) holds a `Shared` (far smaller); every field the
    // harness writes while the firmware reads it is an atomic or written before `written`
    // (release) and read after it (acquire).
    unsafe { &*(BASE as *const Shared) }
}

/// The record `k`.
pub fn record(k: u32) -> &'static Record {
    let r = region();
    let i = k as usize % RING;
    // (in range: i < RING)
    &r.ring[i]
}

/// The settings the harness left for the first boot (`emu --set`), if any and valid.
pub fn preset_settings() -> Option<Config> {
    let r = region();
    let n = (r.settings_len.load(Ordering::Acquire) as usize).min(CONFIG_BYTES);
    Config::decode(r.settings.get(..n).filter(|b| !b.is_empty())?).ok()
}

/// Marks the region booted (the harness starts writing blocks).
pub fn booted() {
    let r = region();
    r.boots.fetch_add(1, Ordering::Relaxed);
    r.version.store(VERSION, Ordering::Relaxed);
    r.magic.store(MAGIC, Ordering::Release);
}

/// The session for the virtual CNC, when it changed.
pub fn publish_session(app: &App) {
    let r = region();
    let word = u32::from(app.session() as u8)
        | u32::from(app.pattern() as u8) << 8
        | u32::from(app.direction() as u8) << 16;
    if r.session.load(Ordering::Relaxed) == word
        && r.run.load(Ordering::Relaxed) == app.run_number()
    {
        return;
    }
    let seq = r.session_seq.load(Ordering::Relaxed);
    r.session_seq.store(seq.wrapping_add(1), Ordering::Release);
    let mut bytes = [0u8; CONFIG_BYTES];
    let n = app.running_config().encode(&mut bytes).unwrap_or(0);
    // SAFETY: the region's config area (see `region`); the firmware is its only writer, and
    // the harness reads it between two equal even `session_seq`s.
    unsafe { core::ptr::addr_of_mut!((*(BASE as *mut Shared)).config).write_volatile(bytes) };
    r.config_len.store(n as u32, Ordering::Relaxed);
    r.session.store(word, Ordering::Relaxed);
    r.run.store(app.run_number(), Ordering::Relaxed);
    r.session_seq.store(seq.wrapping_add(2), Ordering::Release);
}
