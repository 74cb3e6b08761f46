//! Soak: the served simulated pod (`VirtualPod::step`, what `sim --serve` runs) for hours of
//! virtual time — every pattern back to back (CIRCLE both ways, SSM, PROBE, the five seed 002
//! steps), driven by a CNC over CANopen SDO and a technician over SCPI in turn, with random
//! SDO and SCPI traffic, frames for other nodes, sensor faults, lost samples, bus-off and
//! recovery, log downloads cut by a USB disconnect, configuration writes and power cuts during
//! settings saves. Throughout and at the end:
//!
//! - every sample balances: per run `seen = used + skipped` (by cause) and `seen + lost` = the
//!   sample periods the run lasted (to the sample at its ends: the stop comes with a step, and
//!   a loss just before it is counted by the next sample); per boot, samples produced + lost =
//!   the periods stepped;
//! - every frame balances: each SDO request is answered by exactly one response, or — while
//!   bus-off — counted as dropped; each frame for another node is counted as ignored;
//! - every completed run's own results equal a recomputation from its recorded stream in a
//!   fresh application (`replay::replay_run`), with the same outcome;
//! - the configuration is always one that was written (each field's value was written or is
//!   the default), and after a power cut one of the two saves it was between;
//! - memory stays flat (resident set after the first cycles vs at the end).
//!
//! `BALLPOD_SOAK_HOURS` sets the virtual time (default 2). The totals are printed (visible with
//! `--nocapture`) and written to `target/soak-summary.txt`, which `.ci/run` shows.

use std::collections::{BTreeMap, BTreeSet};

use ballpod::acquisition::MAX_AXES;
use ballpod::app::{App, Direction, Pattern, ResultId, SessionState};
use ballpod::protocol::canopen::{BusState, CanFrame};
use ballpod_host::replay::{figures, replay_run};
use ballpod_host::rng::Rng;
use ballpod_host::vmt::virtual_pod::{VirtualPod, VirtualSetup};

const NODE: u16 = 16;
const SDO_RX: u16 = 0x600 + NODE;
const SDO_TX: u16 = 0x580 + NODE;
/// A COB-ID no node of ours consumes (another node's TPDO).
const FOREIGN: u16 = 0x1A5;

/// Objects the CNC reads at random (index, sub-index); the last does not exist (abort).
const READS: [(u16, u8); 9] = [
    (0x1000, 0),
    (0x1017, 0),
    (0x2000, 0),
    (0x2100, 1),
    (0x2102, 0),
    (0x3003, 0),
    (0x3005, 1),
    (0x4000, 1),
    (0x5A5A, 0),
];

/// Queries the technician sends at random (the last is not a command: an error is queued).
const QUERIES: [&str; 8] = [
    "*IDN?",
    "SESS:STAT?",
    "SESS:COUN?",
    "MEAS:ALL?",
    "STAT:POD?",
    "FETC:RES? ecc_u",
    "SYST:ERR?",
    "NOT:A:COMMAND?",
];

/// The patterns of one cycle, in order (seed 002 steps in both directions over the cycles).
const CYCLE: [Pattern; 9] = [
    Pattern::Circle,
    Pattern::Circle,
    Pattern::Ssm,
    Pattern::Probe,
    Pattern::Bx,
    Pattern::By,
    Pattern::Cr,
    Pattern::Ca,
    Pattern::Cr2,
];

/// Resident set size of this process, bytes.
fn rss_bytes() -> u64 {
    std::fs::read_to_string("/proc/self/statm")
        .ok()
        .and_then(|s| s.split_whitespace().nth(1)?.parse::<u64>().ok())
        .map_or(0, |pages| pages * 4096)
}

#[derive(Default, Debug)]
struct Totals {
    periods: u64,
    runs_done: u32,
    runs_aborted: u32,
    runs_replayed: u32,
    sdo_requests: u32,
    sdo_answered: u32,
    sdo_dropped_bus_off: u32,
    foreign_frames: u32,
    scpi_queries: u32,
    faults: u32,
    lost_samples: u32,
    bus_offs: u32,
    downloads_cut: u32,
    config_writes: u32,
    power_cuts: u32,
}

struct Soak {
    vp: VirtualPod,
    rng: Rng,
    t: Totals,
    /// Sample periods stepped since this pod booted.
    periods_since_boot: u64,
    /// Lost samples injected since this pod booted.
    lost_since_boot: u64,
    /// The node's counters at this boot (its Stats restart with the pod): frames ignored, frames
    /// dropped while bus-off, bus-off events.
    ignored_at_boot: u32,
    dropped_at_boot: u32,
    bus_offs_at_boot: u32,
    foreign_since_boot: u32,
    /// SDO requests sent while bus-off and bus-offs caused, since this boot.
    sdo_dropped_since_boot: u32,
    bus_offs_since_boot: u32,
    /// Steps the bus stays off (0: on).
    bus_off_steps: u32,
    /// Every value written to a field, by name (the defaults included).
    written: BTreeMap<&'static str, BTreeSet<u32>>,
}

impl Soak {
    fn new() -> Self {
        let mut s = Self {
            vp: VirtualPod::new(VirtualSetup {
                seed: 11,
                ..VirtualSetup::default()
            }),
            rng: Rng::new(0x50a6),
            t: Totals::default(),
            periods_since_boot: 0,
            lost_since_boot: 0,
            ignored_at_boot: 0,
            dropped_at_boot: 0,
            bus_offs_at_boot: 0,
            foreign_since_boot: 0,
            sdo_dropped_since_boot: 0,
            bus_offs_since_boot: 0,
            bus_off_steps: 0,
            written: BTreeMap::new(),
        };
        s.boot();
        // the set-up of every pattern (seed 002: Table 4.3; circle and SSM about the origin),
        // saved whole once so that any later boot has it
        for line in [
            "CONF:UNL;:CONF:CIRCLE_CENTRE_X 0;CIRCLE_CENTRE_Y 0;CIRCLE_CENTRE_Z 0;\
             CIRCLE_RADIUS 150;CIRCLE_FEED 6000",
            "CONF:SSM_SOCKET_X 0;SSM_SOCKET_Y 0;SSM_SOCKET_Z 0",
            "CONF:S002_L_B 100;S002_R_B 356.3945;S002_R_B2 406.4608;S002_R_C 50;\
             S002_Z_C 65.5348",
            "CONF:S002_ORIGIN_X 0;S002_ORIGIN_Y 0;S002_ORIGIN_Z 0;:CONF:LOCK",
        ] {
            assert_eq!(s.scpi(line), "", "{line}");
        }
        for (name, v) in [("bar_length", 150.0), ("circle_min_arc", 300.0)] {
            s.note(name, v);
        }
        assert_eq!(s.scpi("CONF:UNL;*SAV 0;:CONF:LOCK"), "");
        assert_eq!(s.scpi("SYST:ERR?"), "0,\"No error\"");
        s
    }

    /// Accounting of a fresh boot.
    fn boot(&mut self) {
        self.periods_since_boot = 0;
        self.lost_since_boot = 0;
        let s = *self.vp.node.stats();
        self.ignored_at_boot = s.frames_ignored;
        self.dropped_at_boot = s.frames_dropped_bus_off;
        self.bus_offs_at_boot = s.bus_off_events;
        self.foreign_since_boot = 0;
        self.sdo_dropped_since_boot = 0;
        self.bus_offs_since_boot = 0;
        self.bus_off_steps = 0;
        self.vp.step();
        self.periods_since_boot += 1;
        self.t.periods += 1;
    }

    fn note(&mut self, name: &'static str, v: f32) {
        self.written.entry(name).or_default().insert(v.to_bits());
    }

    fn scpi(&mut self, line: &str) -> String {
        let out = self.vp.usb(format!("{line}\n").as_bytes());
        String::from_utf8(out)
            .expect("SCPI answers text")
            .trim_end()
            .to_string()
    }

    /// One SDO request; its answer (None while bus-off: dropped and counted).
    fn sdo(&mut self, data: [u8; 8]) -> Option<[u8; 8]> {
        let tx = self
            .vp
            .can_frame(&CanFrame::new(SDO_RX, &data).expect("frame"));
        self.t.sdo_requests += 1;
        let answers: Vec<&CanFrame> = tx.iter().filter(|f| f.id == SDO_TX).collect();
        if self.bus_off_steps > 0 {
            assert!(answers.is_empty(), "nothing is sent while bus-off");
            self.t.sdo_dropped_bus_off += 1;
            self.sdo_dropped_since_boot += 1;
            return None;
        }
        assert_eq!(answers.len(), 1, "one answer per request: {tx:?}");
        self.t.sdo_answered += 1;
        answers[0].payload().try_into().ok()
    }

    fn sdo_write_u8(&mut self, index: u16, v: u8) -> bool {
        let [lo, hi] = index.to_le_bytes();
        self.sdo([0x2F, lo, hi, 0, v, 0, 0, 0])
            .is_some_and(|a| a[0] == 0x60)
    }

    fn step(&mut self) {
        self.vp.step();
        self.periods_since_boot += 1;
        self.t.periods += 1;
        if self.bus_off_steps > 0 {
            self.bus_off_steps -= 1;
            if self.bus_off_steps == 0 {
                self.vp.bus_state(BusState::ErrorActive);
            }
        }
    }

    /// Random traffic and faults, now and then.
    fn traffic(&mut self, running: bool) {
        let r = self.rng.uniform();
        if r < 0.02 {
            let (index, sub) = READS[(self.rng.uniform() * READS.len() as f64) as usize];
            let [lo, hi] = index.to_le_bytes();
            if let Some(a) = self.sdo([0x40, lo, hi, sub, 0, 0, 0, 0]) {
                assert!(
                    a[0] & 0xE0 == 0x40 || a[0] == 0x80,
                    "an upload answer or an abort"
                );
            }
        } else if r < 0.03 {
            let tx = self
                .vp
                .can_frame(&CanFrame::new(FOREIGN, &[1, 2, 3]).expect("frame"));
            assert!(tx.is_empty(), "a frame for another node is not answered");
            self.t.foreign_frames += 1;
            self.foreign_since_boot += 1;
        } else if r < 0.05 {
            let q = QUERIES[(self.rng.uniform() * QUERIES.len() as f64) as usize];
            let a = self.scpi(q);
            if a.is_empty() {
                // no answer only with an error queued (a result not valid yet: -230; not a
                // command: -113)
                let e = self.scpi("SYST:ERR?");
                assert!(!e.starts_with("0,"), "{q}: no answer and no error");
            }
            self.t.scpi_queries += 1;
        } else if r < 0.052 && running {
            // a short sensor fault: flagged, skipped, counted (never an abort by itself)
            let f = &mut self.vp.sensors.faults;
            if self.rng.uniform() < 0.5 {
                f.lvdt_open_samples = 3;
            } else {
                f.encoder_glitch_counts = 500;
            }
            self.t.faults += 1;
        } else if r < 0.053 && running {
            self.vp.lose_samples(2);
            self.lost_since_boot += 2;
            self.t.lost_samples += 2;
        } else if r < 0.0535 && self.bus_off_steps == 0 {
            self.vp.bus_state(BusState::BusOff);
            self.bus_off_steps = 50 + (self.rng.uniform() * 300.0) as u32;
            self.t.bus_offs += 1;
            self.bus_offs_since_boot += 1;
        }
    }

    /// A run of `pattern` in `dir`, controlled over CANopen or SCPI; checked against its replay.
    fn run(&mut self, pattern: Pattern, dir: Direction) {
        // the bar the pattern needs (seed 002: L_B; else the circle's 150 mm)
        let bar = if pattern.seed002_step().is_some() {
            100.0
        } else {
            150.0
        };
        if self.vp.app.config().bar_length_mm != bar {
            assert_eq!(
                self.scpi(&format!("CONF:UNL;:CONF:BAR_LENGTH {bar};:CONF:LOCK")),
                ""
            );
            self.note("bar_length", bar);
            self.t.config_writes += 1;
        }
        while self.bus_off_steps > 0 {
            self.step();
        }
        let by_can = self.rng.uniform() < 0.5;
        if by_can {
            assert!(self.sdo_write_u8(0x3000, pattern as u8), "pattern");
            assert!(self.sdo_write_u8(0x3001, dir as u8), "direction");
            assert!(self.sdo_write_u8(0x3002, 1), "arm");
            assert!(self.sdo_write_u8(0x3002, 2), "start");
        } else {
            let line = format!(
                "SESS:PATT {};DIR {};:SESS:ARM;STAR",
                pattern.name(),
                dir.name()
            );
            assert_eq!(self.scpi(&line), "", "{line}");
        }
        assert_eq!(self.vp.app.session(), SessionState::Running);
        let (periods0, lost0) = (self.periods_since_boot, self.lost_since_boot);
        // one run in twenty is aborted by the CNC part-way
        let abort_at =
            (self.rng.uniform() < 0.05).then(|| 500 + (self.rng.uniform() * 3000.0) as u32);
        let mut guard = 0;
        while self.vp.app.session() == SessionState::Running {
            self.traffic(true);
            self.step();
            guard += 1;
            if Some(guard) == abort_at && self.bus_off_steps == 0 {
                assert!(self.sdo_write_u8(0x3002, 4), "abort");
            }
            assert!(guard < 400_000, "{pattern:?} ends with its motion");
        }
        let done = self.vp.app.session() == SessionState::Done;
        let pod_figures = figures(&self.vp.app, ResultId::of_run(pattern));
        let c = self.vp.app.run_counters();
        // per run: every sample seen is used or skipped for a reason, and seen + lost are the
        // periods the run lasted (the periods of lost samples were stepped too)
        let skipped = c.skipped_lvdt_open
            + c.skipped_lvdt_over_range
            + c.skipped_quadrature
            + c.skipped_jump
            + c.skipped_overrun;
        assert_eq!(c.seen, c.used + skipped, "{c:?}");
        let lasted = self.periods_since_boot - periods0;
        let lost_in_run = self.lost_since_boot - lost0;
        assert!(u64::from(c.lost) <= lost_in_run, "{c:?}");
        assert!(
            (u64::from(c.seen) + u64::from(c.lost)).abs_diff(lasted) <= lost_in_run.min(2) + 1,
            "seen {} + lost {} vs {lasted} periods",
            c.seen,
            c.lost
        );
        if done {
            self.t.runs_done += 1;
        } else {
            self.t.runs_aborted += 1;
        }
        // the end reaches the recorders with the next sample
        self.step();
        let recorded = std::mem::take(&mut self.vp.recording.runs);
        let rec = recorded.last().expect("the run was recorded");
        assert_eq!(rec.meta.pattern, pattern);
        let mut fresh = App::new(rec.meta.config, [16; MAX_AXES]);
        replay_run(&mut fresh, rec).unwrap_or_else(|e| panic!("replay: {e}"));
        assert_eq!(fresh.session(), self.vp.app.session(), "outcome");
        assert_eq!(
            figures(&fresh, ResultId::of_run(pattern)),
            pod_figures,
            "run {} ({pattern:?} {dir:?}): replay = pod",
            rec.meta.run
        );
        assert_eq!(fresh.run_counters().used, c.used);
        self.t.runs_replayed += 1;
    }

    /// Between runs: a log download cut by a disconnect, a configuration write, sometimes a
    /// power cut during a save.
    fn between(&mut self, cycle: u32) {
        if self.rng.uniform() < 0.5 {
            let cut = self.vp.scpi.counters().downloads_cut;
            let header = self.vp.usb(b"DATA:LOG?\n");
            assert!(header.starts_with(b"#"), "block header");
            for _ in 0..1 + (self.rng.uniform() * 3.0) as usize {
                let _ = self.vp.pull_download(512);
            }
            let pending = self.vp.scpi.download_pending();
            self.vp.usb_disconnected();
            if pending {
                assert_eq!(self.vp.scpi.counters().downloads_cut, cut + 1);
                self.t.downloads_cut += 1;
            }
        }
        let arc = [250.0f32, 270.0, 300.0][(self.rng.uniform() * 3.0) as usize];
        assert_eq!(
            self.scpi(&format!("CONF:UNL;:CONF:CIRCLE_MIN_ARC {arc};:CONF:LOCK")),
            ""
        );
        self.note("circle_min_arc", arc);
        self.t.config_writes += 1;
        if cycle % 4 == 3 {
            self.power_cut();
        }
    }

    /// `*SAV 0` with the power cut somewhere in it: the pod boots with the previous save or
    /// with this one, never a mix.
    fn power_cut(&mut self) {
        self.check_boot_balance();
        let before = *self.vp.app.config();
        assert_eq!(self.scpi("CONF:UNL;*SAV 0;:CONF:LOCK"), "");
        let saved = *self.vp.app.config();
        let arc = if saved.setup.circle_min_arc_deg == 270.0 {
            300.0
        } else {
            270.0
        };
        assert_eq!(
            self.scpi(&format!("CONF:UNL;:CONF:CIRCLE_MIN_ARC {arc};:CONF:LOCK")),
            ""
        );
        self.note("circle_min_arc", arc);
        let new = *self.vp.app.config();
        self.vp.flash.budget = Some((self.rng.uniform() * 2300.0) as usize);
        assert_eq!(self.scpi("CONF:UNL;*SAV 0;:CONF:LOCK"), "");
        self.vp = self.vp.power_on();
        let got = *self.vp.app.config();
        assert!(
            got.setup.circle_min_arc_deg == saved.setup.circle_min_arc_deg
                || got.setup.circle_min_arc_deg == new.setup.circle_min_arc_deg,
            "booted with {} (saved {}, then {})",
            got.setup.circle_min_arc_deg,
            saved.setup.circle_min_arc_deg,
            new.setup.circle_min_arc_deg
        );
        assert_eq!(got.bar_length_mm, before.bar_length_mm);
        self.t.power_cuts += 1;
        self.boot();
    }

    /// The pod's own counters against what was stepped and sent since it booted.
    fn check_boot_balance(&mut self) {
        let a = self.vp.app.acquisition_counters();
        assert_eq!(
            u64::from(a.samples) + u64::from(a.lost_upstream),
            self.periods_since_boot,
            "samples produced + lost = periods stepped ({a:?})"
        );
        assert_eq!(u64::from(a.lost_upstream), self.lost_since_boot);
        let s = self.vp.node.stats();
        assert_eq!(
            s.frames_ignored - self.ignored_at_boot,
            self.foreign_since_boot,
            "frames for other nodes ignored and counted"
        );
        // the node's own counts of what the bus-offs cost: every SDO answer it could not send
        // is among its dropped frames (with the heartbeats and TPDOs of those times)
        assert_eq!(
            s.bus_off_events - self.bus_offs_at_boot,
            self.bus_offs_since_boot
        );
        assert!(
            s.frames_dropped_bus_off - self.dropped_at_boot >= self.sdo_dropped_since_boot,
            "{} frames dropped while bus-off, {} SDO answers among them",
            s.frames_dropped_bus_off - self.dropped_at_boot,
            self.sdo_dropped_since_boot
        );
    }

    /// The configuration holds only values that were written.
    fn check_config(&self) {
        let c = self.vp.app.config();
        for (name, v) in [
            ("bar_length", c.bar_length_mm),
            ("circle_min_arc", c.setup.circle_min_arc_deg),
        ] {
            assert!(
                self.written[name].contains(&v.to_bits()),
                "{name} = {v}, never written"
            );
        }
    }
}

#[test]
fn hours_of_served_sessions_lose_nothing() {
    let hours: f64 = std::env::var("BALLPOD_SOAK_HOURS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(2.0);
    let mut s = Soak::new();
    let period_s = s.vp.period_us() * 1e-6;
    let wall = std::time::Instant::now();
    let mut rss_early = 0;
    let mut cycle = 0u32;
    while s.t.periods as f64 * period_s < hours * 3600.0 {
        for (k, &p) in CYCLE.iter().enumerate() {
            let dir = if (cycle + k as u32).is_multiple_of(2) {
                Direction::Ccw
            } else {
                Direction::Cw
            };
            s.run(p, dir);
            // idle a moment, with traffic
            for _ in 0..200 {
                s.traffic(false);
                s.step();
            }
        }
        s.between(cycle);
        s.check_config();
        cycle += 1;
        if cycle == 2 {
            rss_early = rss_bytes();
        }
    }
    s.check_boot_balance();
    s.check_config();
    let rss_end = rss_bytes();
    let summary = format!(
        "soak: {:.2} h virtual in {:.0} s, {} cycles: {:?}, resident set {} → {} MiB\n",
        s.t.periods as f64 * period_s / 3600.0,
        wall.elapsed().as_secs_f64(),
        cycle,
        s.t,
        rss_early >> 20,
        rss_end >> 20
    );
    print!("{summary}");
    let _ = std::fs::write(
        concat!(env!("CARGO_MANIFEST_DIR"), "/target/soak-summary.txt"),
        &summary,
    );
    assert!(
        s.t.runs_replayed > 0
            && s.t.runs_aborted > 0
            && s.t.power_cuts > 0
            && s.t.bus_offs > 0
            && s.t.downloads_cut > 0
    );
    // flat: the pod's memory is fixed; the host keeps no run beyond its check
    assert!(
        rss_end <= rss_early + (16 << 20),
        "resident set grew from {rss_early} to {rss_end} bytes"
    );
}
