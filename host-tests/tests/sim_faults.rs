//! Fault scenarios on the simulated pod (issue 7 item 1): each fault is injected into a running
//! circle test of `vmt::virtual_pod::VirtualPod` (the pod's own acquisition, run monitor, fit,
//! log, CANopen slave and SCPI server on a virtual machine), and its documented reaction is
//! asserted — a flag on the affected samples, an EMCY frame, an SCPI error or status, or an
//! aborted run with its reason — together with the accounting: the run's counters add up
//! exactly to the sample periods this test stepped (`seen + lost = stepped`,
//! `seen = used + skipped`), so no sample goes missing without being counted.
//!
//! Expected values come from what the test controls (how many samples it stepped and spoiled,
//! which edges it made) and from CiA 301 / SCPI-99 / README, not from the implementation.

use std::path::Path;

use ballpod::acquisition::SampleFlags;
use ballpod::acquisition::probe::TriggerOutcome;
use ballpod::protocol::canopen::{BusState, CanFrame};
use ballpod::protocol::pod::SessionState;
use ballpod::session::run::RunCounters;
use ballpod_host::logfile::read_log;
use ballpod_host::vmt::virtual_pod::{VirtualPod, VirtualSetup};

const NODE: u16 = 16;
const EMCY: u16 = 0x080 + NODE;
const SDO_TX: u16 = 0x580 + NODE;
const SDO_RX: u16 = 0x600 + NODE;
const HEARTBEAT: u16 = 0x700 + NODE;

/// Feed 6000 mm/min on the 150 mm bar: a full circle in 9.4 s = 9425 samples at 1 kHz.
const FEED: f64 = 6000.0;
/// Sample periods of a run long enough for the circle fit (≥ 60° of arc: 2 618 samples).
const RUN: u32 = 4000;

/// The CNC (CAN), the technician (USB) and the virtual machine around one pod.
/// Log capacity of the test pod (every test run is shorter).
const LOG: usize = 8192;

struct Bench {
    vp: VirtualPod<LOG>,
    /// Every frame the pod sent.
    frames: Vec<CanFrame>,
    /// Sample periods stepped while the session was running.
    stepped: u32,
}

impl Bench {
    /// A pod that has booted (boot-up sent) with the circle pattern armed and started over
    /// SCPI. Nothing is injected yet.
    fn running() -> Self {
        let mut b = Self::idle();
        assert_eq!(b.scpi("SESS:PATT CIRC;DIR CCW;:SESS:ARM;STAR"), "");
        assert_eq!(b.vp.pod.session, SessionState::Running);
        b
    }

    fn idle() -> Self {
        let mut b = Self {
            vp: VirtualPod::new(VirtualSetup {
                feed_mm_per_min: FEED,
                ..VirtualSetup::default()
            }),
            frames: Vec::new(),
            stepped: 0,
        };
        b.step(1);
        assert_eq!(b.take(), vec![frame(HEARTBEAT, &[0])], "boot-up");
        b
    }

    /// `n` sample periods.
    fn step(&mut self, n: u32) {
        for _ in 0..n {
            if self.vp.pod.session == SessionState::Running {
                self.stepped += 1;
            }
            let f = self.vp.step();
            self.frames.extend(f);
        }
    }

    fn take(&mut self) -> Vec<CanFrame> {
        std::mem::take(&mut self.frames)
    }

    /// One SCPI line; the response without its terminator.
    fn scpi(&mut self, line: &str) -> String {
        let out = self.vp.usb(format!("{line}\n").as_bytes());
        String::from_utf8(out).unwrap().trim_end().to_string()
    }

    /// The EMCY error codes sent since the last `take`, in order (frames stay).
    fn emcy_codes(&self) -> Vec<u16> {
        self.frames
            .iter()
            .filter(|f| f.id == EMCY)
            .map(|f| u16::from_le_bytes([f.data[0], f.data[1]]))
            .collect()
    }

    /// An SDO request; the server's single response.
    fn sdo(&mut self, req: [u8; 8]) -> [u8; 8] {
        let out: Vec<_> = self
            .vp
            .can_frame(&frame(SDO_RX, &req))
            .into_iter()
            .filter(|f| f.id == SDO_TX)
            .collect();
        assert_eq!(out.len(), 1, "one SDO response");
        out[0].data
    }

    /// Expedited upload of a ≤ 4-byte object (CiA 301 §7.2.4.3.6), as u32.
    fn read(&mut self, index: u16, sub: u8) -> u32 {
        let i = index.to_le_bytes();
        let r = self.sdo([0x40, i[0], i[1], sub, 0, 0, 0, 0]);
        assert_eq!(
            r[0] & 0xF3,
            0x43,
            "expedited upload response to {index:#x}:{sub}"
        );
        u32::from_le_bytes([r[4], r[5], r[6], r[7]])
    }

    /// Expedited download of one byte; the response command byte (0x60 = done).
    fn write_u8(&mut self, index: u16, sub: u8, v: u8) -> u8 {
        let i = index.to_le_bytes();
        self.sdo([0x2F, i[0], i[1], sub, v, 0, 0, 0])[0]
    }

    /// The run counters as the CNC reads them: 0x3005:1…10.
    fn counters_over_can(&mut self) -> [u32; RunCounters::LEN] {
        assert_eq!(self.read(0x3005, 0), RunCounters::LEN as u32);
        std::array::from_fn(|k| self.read(0x3005, k as u8 + 1))
    }

    /// The run counters as the technician reads them: `SESS:COUN?`.
    fn counters_over_usb(&mut self) -> Vec<u32> {
        self.scpi("SESS:COUN?")
            .split(',')
            .map(|v| v.parse().unwrap())
            .collect()
    }

    /// Samples in the log whose flags contain `f`.
    fn logged_with(&self, f: SampleFlags) -> usize {
        self.vp
            .log()
            .iter()
            .filter(|s| SampleFlags(s.record.flags).contains(f))
            .count()
    }

    /// The accounting holds: every sample period stepped in the run is seen or lost, every
    /// seen sample used or skipped, and both protocols report the same counters.
    fn assert_accounts(&mut self) -> RunCounters {
        let c = self.vp.monitor().counters();
        assert_eq!(
            c, self.vp.pod.run,
            "the pod model carries the monitor's counters"
        );
        assert_eq!(
            c.seen + c.lost,
            self.stepped,
            "seen + lost = stepped: {c:?}"
        );
        assert_eq!(c.seen, c.used + c.skipped(), "seen = used + skipped: {c:?}");
        assert_eq!(self.counters_over_can(), c.as_array());
        assert_eq!(self.counters_over_usb(), c.as_array().to_vec());
        assert_eq!(
            self.vp.log().len(),
            c.seen as usize,
            "every seen sample is logged"
        );
        c
    }

    /// The results the CNC sees as valid (0x4002 bit mask).
    fn valid_results(&mut self) -> u32 {
        self.read(0x4002, 0)
    }

    /// Session state (0x3003) and abort reason (0x3004) over CANopen, and `SESS:STAT?`,
    /// `SESS:REAS?` over USB.
    fn state(&mut self) -> (u32, u32, String, String) {
        (
            self.read(0x3003, 0),
            self.read(0x3004, 0),
            self.scpi("SESS:STAT?"),
            self.scpi("SESS:REAS?"),
        )
    }
}

fn frame(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::new(id, data).unwrap()
}

/// Stops the run over SCPI; it must end DONE with the eccentricity near the truth (5, −3) µm.
fn stop_done(b: &mut Bench) {
    assert_eq!(b.scpi("SESS:STOP"), "");
    assert_eq!(b.state(), (3, 0, "DONE".into(), "NONE".into()));
    assert_eq!(b.valid_results() & 0b111, 0b111, "ecc_x, ecc_y, r0 valid");
    let ex: f64 = b
        .scpi("FETC:RES? ecc_x")
        .split(',')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    let ey: f64 = b
        .scpi("FETC:RES? ecc_y")
        .split(',')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(
        (ex - 5.0).abs() < 0.5 && (ey + 3.0).abs() < 0.5,
        "e = ({ex}, {ey}) µm"
    );
}

#[test]
fn a_clean_run_uses_every_sample() {
    let mut b = Bench::running();
    b.step(RUN);
    let c = b.assert_accounts();
    assert_eq!((c.seen, c.used, c.skipped(), c.lost), (RUN, RUN, 0, 0));
    assert!(b.emcy_codes().is_empty());
    stop_done(&mut b);
}

#[test]
fn lvdt_open_for_a_moment_is_flagged_skipped_counted_and_sent_as_emcy_5001() {
    let mut b = Bench::running();
    b.step(1000);
    b.vp.sensors.faults.lvdt_open_samples = 20;
    b.step(RUN - 1000);
    let c = b.assert_accounts();
    assert_eq!(c.skipped_lvdt_open, 20);
    assert_eq!((c.used, c.skipped()), (RUN - 20, 20));
    assert_eq!(b.logged_with(SampleFlags::LVDT_OPEN), 20);
    // CiA 301: one EMCY when the fault appears, "error reset" when it has gone.
    assert_eq!(b.emcy_codes(), vec![0x5001, 0x0000]);
    stop_done(&mut b);
}

#[test]
fn lvdt_over_range_for_a_moment_is_flagged_skipped_counted_and_sent_as_emcy_5002() {
    let mut b = Bench::running();
    b.step(1000);
    b.vp.sensors.faults.lvdt_over_range_samples = 30;
    b.step(RUN - 1000);
    let c = b.assert_accounts();
    assert_eq!(c.skipped_lvdt_over_range, 30);
    assert_eq!((c.used, c.skipped()), (RUN - 30, 30));
    assert_eq!(b.logged_with(SampleFlags::LVDT_OVER_RANGE), 30);
    assert_eq!(b.emcy_codes(), vec![0x5002, 0x0000]);
    stop_done(&mut b);
}

#[test]
fn lvdt_open_for_100_samples_aborts_the_run_with_lvdt_fault() {
    let mut b = Bench::running();
    b.step(1000);
    b.vp.sensors.faults.lvdt_open_samples = 500;
    b.step(300);
    // The 100th open sample in a row aborts; later samples are not part of the run.
    assert_eq!(b.state(), (4, 2, "ABORTED".into(), "LVDT".into()));
    assert_eq!(b.stepped, 1100, "sample periods of the run");
    let c = b.assert_accounts();
    assert_eq!((c.used, c.skipped_lvdt_open, c.seen), (1000, 100, 1100));
    assert_eq!(b.valid_results(), 0, "an aborted run has no results");
    assert!(b.emcy_codes().starts_with(&[0x5001]));
    // The status word says aborted (bit 11) while the open coil stays flagged (bit 1).
    let status: u32 = b.scpi("STAT:POD?").parse().unwrap();
    assert_eq!(status & (1 << 11 | 1 << 1), 1 << 11 | 1 << 1);
}

#[test]
fn lvdt_over_range_for_100_samples_aborts_the_run_with_lvdt_fault() {
    let mut b = Bench::running();
    b.step(500);
    b.vp.sensors.faults.lvdt_over_range_samples = 100;
    b.step(600);
    assert_eq!(b.state(), (4, 2, "ABORTED".into(), "LVDT".into()));
    assert_eq!(b.stepped, 600, "sample periods of the run");
    let c = b.assert_accounts();
    assert_eq!((c.used, c.skipped_lvdt_over_range), (500, 100));
}

#[test]
fn ball_dropped_from_the_socket_aborts_the_run_on_the_jump() {
    let mut b = Bench::running();
    b.step(2000);
    // The ball leaves its cup and rests 0.4 mm further out: in range, but a jump.
    b.vp.sensors.faults.bar_offset_um = 400.0;
    b.step(500);
    assert_eq!(b.state(), (4, 2, "ABORTED".into(), "LVDT".into()));
    assert_eq!(b.stepped, 2001, "sample periods of the run");
    let c = b.assert_accounts();
    assert_eq!((c.used, c.skipped_jump, c.skipped()), (2000, 1, 1));
    // The jump sample itself is valid as a measurement: no flag, no EMCY; the abort is the
    // reaction, and the log shows the jump.
    assert!(b.emcy_codes().is_empty());
    let dl: Vec<f32> = b.vp.log().iter().map(|s| s.record.delta_l_um).collect();
    let step = dl[2000] - dl[1999];
    assert!((step - 400.0).abs() < 1.0, "logged jump {step} µm");
    assert_eq!(b.valid_results(), 0);
}

#[test]
fn a_slow_bar_change_is_not_a_jump() {
    // The limit is per sample: 60 µm per sample twice (below 100 µm) keeps the run going.
    let mut b = Bench::running();
    b.step(1000);
    b.vp.sensors.faults.bar_offset_um = 60.0;
    b.step(1);
    b.vp.sensors.faults.bar_offset_um = 120.0;
    b.step(RUN - 1001);
    let c = b.assert_accounts();
    assert_eq!((c.used, c.skipped()), (RUN, 0));
    assert_eq!(b.vp.pod.session, SessionState::Running);
}

#[test]
fn encoder_glitch_flags_the_spike_and_the_step_back_and_sends_emcy_5003() {
    let mut b = Bench::running();
    b.step(1500);
    // 25 000 counts = 2.5 mm in 1 ms: beyond 2 × the 1000 mm/s axis limit (20 000 counts).
    b.vp.sensors.faults.encoder_glitch_counts = 25_000;
    b.step(RUN - 1500);
    let c = b.assert_accounts();
    assert_eq!(c.skipped_quadrature, 2, "the spike and the step back");
    assert_eq!(b.logged_with(SampleFlags::QUADRATURE_ERROR), 2);
    assert_eq!(b.vp.sensors.counters().quadrature_errors, 2);
    assert_eq!(b.emcy_codes(), vec![0x5003, 0x0000]);
    stop_done(&mut b);
}

#[test]
fn probe_bounce_and_a_missed_reseat_are_counted_and_not_touch_points() {
    let mut b = Bench::running();
    b.step(100);
    assert!(matches!(
        b.vp.sensors.probe_edge(),
        TriggerOutcome::Accepted(_)
    ));
    b.vp.sensors.set_probe_seated(false);
    // contact bounce: within the 2 ms debounce time
    assert_eq!(b.vp.sensors.probe_edge(), TriggerOutcome::Bounce);
    b.step(1);
    assert_eq!(b.vp.sensors.probe_edge(), TriggerOutcome::Bounce);
    // the stylus never came back (no 50 ms seated): a missed re-seat
    b.step(5);
    assert_eq!(b.vp.sensors.probe_edge(), TriggerOutcome::NotReseated);
    // seated for longer than the re-seat time: the next edge is a touch point again
    b.vp.sensors.set_probe_seated(true);
    b.step(60);
    assert!(matches!(
        b.vp.sensors.probe_edge(),
        TriggerOutcome::Accepted(_)
    ));
    b.step(100);
    assert_eq!(b.vp.sensors.probe_counts(), (2, 2, 1));
    assert_eq!(
        b.logged_with(SampleFlags::PROBE_EVENT),
        2,
        "only touch points flag"
    );
    let c = b.assert_accounts();
    assert_eq!(
        (c.used, c.skipped()),
        (c.seen, 0),
        "probe events do not spoil ΔL"
    );
}

#[test]
fn a_few_lost_samples_are_counted_flagged_and_sent_as_emcy_6101() {
    let mut b = Bench::running();
    b.step(2000);
    b.vp.lose_samples(5);
    b.step(RUN - 2000);
    let c = b.assert_accounts();
    assert_eq!((c.lost, c.after_overrun, c.seen), (5, 1, RUN - 5));
    assert_eq!((c.used, c.skipped()), (RUN - 5, 0));
    assert_eq!(b.logged_with(SampleFlags::OVERRUN), 1);
    assert_eq!(b.emcy_codes(), vec![0x6101, 0x0000]);
    stop_done(&mut b);
}

#[test]
fn a_burst_of_lost_samples_aborts_the_run_with_overrun() {
    let mut b = Bench::running();
    b.step(1000);
    // 12 lost after 1000: more than max(10, 1 % of 1013). (At 100 mm/s, 12 ms of travel is
    // 12 000 counts, below the 20 000-count glitch limit: the encoders still follow.)
    b.vp.lose_samples(12);
    b.step(500);
    assert_eq!(b.state(), (4, 3, "ABORTED".into(), "OVERRUN".into()));
    assert_eq!(b.stepped, 1013, "sample periods of the run");
    let c = b.assert_accounts();
    assert_eq!((c.lost, c.used, c.skipped_overrun), (12, 1000, 1), "{c:?}");
    assert!(b.emcy_codes().starts_with(&[0x6101]));
}

#[test]
fn a_long_gap_also_loses_the_encoder_count_and_aborts_with_overrun() {
    let mut b = Bench::running();
    b.step(1000);
    // 50 ms at 100 mm/s: 50 000 counts, beyond half the 16-bit counter range: the sample after
    // the gap is a quadrature error as well as the one that passes the loss limit.
    b.vp.lose_samples(50);
    b.step(500);
    assert_eq!(b.state(), (4, 3, "ABORTED".into(), "OVERRUN".into()));
    assert_eq!(b.stepped, 1051, "sample periods of the run");
    let c = b.assert_accounts();
    assert_eq!(
        (c.lost, c.used, c.skipped_quadrature),
        (50, 1000, 1),
        "{c:?}"
    );
    assert_eq!(b.emcy_codes()[..2], [0x5003, 0x6101]);
}

#[test]
fn stopping_with_too_few_samples_or_too_short_an_arc_is_not_observable() {
    // 50 valid samples < 100
    let mut b = Bench::running();
    b.step(50);
    assert_eq!(b.scpi("SESS:STOP"), "");
    assert_eq!(b.state(), (4, 4, "ABORTED".into(), "UNOBSERVABLE".into()));
    assert_eq!(b.assert_accounts().used, 50);
    assert_eq!(b.valid_results(), 0);
    // 1000 valid samples but only 38° of arc (the fit needs 60°)
    let mut b = Bench::running();
    b.step(1000);
    assert_eq!(b.scpi("SESS:STOP"), "");
    assert_eq!(b.state(), (4, 4, "ABORTED".into(), "UNOBSERVABLE".into()));
    assert_eq!(b.valid_results(), 0);
}

#[test]
fn thermistor_open_and_short_keep_the_last_temperature_flag_and_send_emcy_5004() {
    let mut b = Bench::running();
    b.step(1000);
    let t_good = b.vp.last_sample().unwrap().temp_c;
    assert!((t_good - 20.0).abs() < 0.05, "bar at 20 °C: {t_good}");
    // open: the divider pin pulled to the rail
    assert!(b.vp.sensors.thermistor_code(4095).is_err());
    b.step(300);
    // shorted: the pin at ground
    assert!(b.vp.sensors.thermistor_code(0).is_err());
    b.step(200);
    let s = b.vp.last_sample().unwrap();
    assert!(s.flags.contains(SampleFlags::TEMPERATURE_FAULT));
    assert_eq!(s.temp_c, t_good, "the last good temperature is kept");
    let code = b.vp.sensors.thermistor_good_code();
    assert!(b.vp.sensors.thermistor_code(code).is_ok());
    b.step(RUN - 1500);
    let c = b.assert_accounts();
    assert_eq!(c.temperature_faults, 500, "flagged but used");
    assert_eq!((c.used, c.skipped()), (RUN, 0));
    assert_eq!(b.logged_with(SampleFlags::TEMPERATURE_FAULT), 500);
    assert_eq!(b.emcy_codes(), vec![0x5004, 0x0000]);
    stop_done(&mut b);
}

#[test]
fn the_cnc_aborts_a_run_over_canopen() {
    let mut b = Bench::running();
    b.step(1500);
    assert_eq!(b.write_u8(0x3002, 0, 4), 0x60, "session command 4 = abort");
    assert_eq!(b.state(), (4, 1, "ABORTED".into(), "COMMAND".into()));
    b.step(500); // not part of the run any more
    assert_eq!(b.stepped, 1500, "sample periods of the run");
    let c = b.assert_accounts();
    assert_eq!((c.seen, c.used), (1500, 1500));
    assert_eq!(b.valid_results(), 0, "no result valid");
    // stop is refused now (CiA 301 0x0800 0022: wrong device state)
    let r = b.sdo([0x2F, 0x02, 0x30, 0, 3, 0, 0, 0]);
    assert_eq!(r[0], 0x80);
    assert_eq!(u32::from_le_bytes([r[4], r[5], r[6], r[7]]), 0x0800_0022);
}

#[test]
fn sdo_client_silent_mid_segment_is_aborted_and_the_run_goes_on() {
    let mut b = Bench::running();
    b.step(1000);
    let bar = 0x2000u16.to_le_bytes();
    let before = b.vp.pod.config;
    // segmented download of bar_length (4 bytes), one segment of 3 bytes, then silence
    assert_eq!(b.sdo([0x21, bar[0], bar[1], 0, 4, 0, 0, 0])[0], 0x60);
    assert_eq!(b.sdo([0x08, 0, 0, 0x16, 0, 0, 0, 0])[0], 0x20);
    b.take();
    b.step(999);
    assert!(
        b.frames.iter().all(|f| f.id != SDO_TX),
        "no abort before 1 s"
    );
    b.step(2);
    let aborts: Vec<_> = b.take().into_iter().filter(|f| f.id == SDO_TX).collect();
    assert_eq!(aborts.len(), 1);
    assert_eq!(aborts[0].data[0], 0x80);
    assert_eq!(
        u32::from_le_bytes(aborts[0].data[4..8].try_into().unwrap()),
        0x0504_0000,
        "SDO protocol timed out"
    );
    assert_eq!(b.vp.node.stats().sdo_aborts, 1);
    assert_eq!(b.vp.pod.config, before, "nothing written");
    b.step(RUN - 2001);
    let c = b.assert_accounts();
    assert_eq!((c.used, c.skipped()), (RUN, 0));
    stop_done(&mut b);
}

/// Heartbeats and EMCYs a pod sends over `n` steps from now.
fn frames_over(b: &mut Bench, n: u32) -> Vec<CanFrame> {
    b.take();
    b.step(n);
    b.take()
}

#[test]
fn can_bus_off_drops_and_counts_frames_then_recovers_with_emcy_8140() {
    // Two identical pods in lock-step; one goes bus-off for 2.5 s. What the other sends in that
    // time is what the first must have dropped and counted.
    let (mut a, mut reference) = (Bench::running(), Bench::running());
    a.step(700);
    reference.step(700);
    assert!(a.vp.bus_state(BusState::BusOff).is_empty());
    assert_eq!(
        a.vp.node.error_register() & 0x11,
        0x11,
        "generic + communication"
    );
    // an LVDT fault while bus-off: its EMCY waits for the recovery
    a.vp.sensors.faults.lvdt_open_samples = 10;
    reference.vp.sensors.faults.lvdt_open_samples = 10;
    assert!(
        frames_over(&mut a, 2500).is_empty(),
        "nothing goes out while bus-off"
    );
    let missed = frames_over(&mut reference, 2500);
    let heartbeats = missed.iter().filter(|f| f.id == HEARTBEAT).count();
    assert_eq!(heartbeats, 3, "at 1 s, 2 s and 3 s");
    let stats = *a.vp.node.stats();
    assert_eq!(stats.bus_off_events, 1);
    // EMCYs are held back, not dropped: only the heartbeats were lost
    assert_eq!(stats.frames_dropped_bus_off as usize, heartbeats);
    // recovery: EMCY 0x8140 at once with the communication bit in its error register byte
    let out = a.vp.bus_state(BusState::ErrorActive);
    assert_eq!(out.len(), 1);
    assert_eq!(out[0].id, EMCY);
    assert_eq!(u16::from_le_bytes([out[0].data[0], out[0].data[1]]), 0x8140);
    assert_eq!(out[0].data[2] & 0x11, 0x11);
    // then the heartbeat (pre-operational, 0x7F) and the held-back LVDT fault and its reset
    let after = frames_over(&mut a, 300);
    assert_eq!(after[0], frame(HEARTBEAT, &[0x7F]));
    a.frames = after;
    assert_eq!(a.emcy_codes(), vec![0x5001, 0x0000]);
    assert_eq!(a.vp.node.error_register(), 0, "no error left");
    // error history, newest first: the held-back fault, then the recovery
    assert_eq!((a.read(0x1003, 1), a.read(0x1003, 2)), (0x5001, 0x8140));
    // the run itself went on: sampling does not depend on the bus
    let c = a.assert_accounts();
    assert_eq!((c.seen, c.skipped_lvdt_open), (3500, 10));
}

#[test]
fn can_error_passive_sends_emcy_8120() {
    let mut b = Bench::running();
    b.step(10);
    let out = b.vp.bus_state(BusState::ErrorPassive);
    assert_eq!(out.len(), 1);
    assert_eq!(u16::from_le_bytes([out[0].data[0], out[0].data[1]]), 0x8120);
    assert_eq!(b.vp.node.error_register() & 0x11, 0x11);
    // error passive still sends: the heartbeat goes on
    assert!(frames_over(&mut b, 1000).contains(&frame(HEARTBEAT, &[0x7F])));
    assert!(b.vp.bus_state(BusState::ErrorActive).is_empty());
    assert_eq!(b.vp.node.error_register(), 0);
    assert_eq!(b.read(0x1003, 1), 0x0000_8120);
}

#[test]
fn usb_disconnect_mid_download_loses_nothing() {
    let mut b = Bench::running();
    b.step(3000);
    assert_eq!(b.scpi("SESS:STOP"), "");
    let n = b.vp.log().len();
    assert_eq!(n, 3000);
    let whole_len = |header: &[u8]| -> usize {
        assert_eq!(header[0], b'#');
        let d = usize::from(header[1] - b'0');
        std::str::from_utf8(&header[2..2 + d])
            .unwrap()
            .parse()
            .unwrap()
    };
    // first download: the cable is pulled half-way
    let header = b.vp.usb(b"DATA:LOG?\n");
    let len = whole_len(&header);
    let mut first = Vec::new();
    while first.len() < len / 2 {
        first.extend(b.vp.pull_download(64));
    }
    b.vp.usb_disconnected();
    assert!(
        !b.vp.scpi.download_pending(),
        "the rest is dropped, not sent later"
    );
    assert_eq!(b.vp.scpi.counters().downloads_cut, 1);
    // reconnect: the cut is reported, the log is whole
    assert_eq!(
        b.scpi("SYST:ERR?"),
        "-410,\"Query INTERRUPTED;DATA:LOG? cut by disconnect\""
    );
    assert_eq!(b.scpi("DATA:LOG:COUN?"), n.to_string());
    let header2 = b.vp.usb(b"DATA:LOG?\n");
    assert_eq!(header2, header, "same length announced");
    let mut second = Vec::new();
    loop {
        let chunk = b.vp.pull_download(64);
        if chunk.is_empty() {
            break;
        }
        second.extend(chunk);
    }
    assert_eq!(second.len(), len + 1, "the block and its terminator");
    assert_eq!(
        &second[..first.len()],
        &first[..],
        "the same bytes up to the cut"
    );
    // parsed back independently: every logged sample, in order
    let text = std::str::from_utf8(&second[..len]).unwrap();
    let samples = read_log(Path::new("download.csv"), text, "ISO230-4").unwrap();
    assert_eq!(samples.len(), n);
    for (got, want) in samples.iter().zip(b.vp.log().iter()) {
        assert_eq!(got.t_us, want.t_us);
        // printed to 0.1 nm: half of it plus the f32 rounding of the parsed value
        assert!((got.delta_l_um - want.record.delta_l_um).abs() <= 6e-5);
        assert_eq!(got.flags.0, want.record.flags);
    }
    assert_eq!(b.scpi("SYST:ERR?"), "0,\"No error\"");
}

#[test]
fn power_lost_during_a_settings_save_boots_with_the_previous_settings() {
    // One good save of bar_length 200 mm (slot A, sequence 1); then 250 mm saved with the
    // power cut after k byte steps, for k across the whole save (2048 erase steps of slot B,
    // then the programmed double-words, the CRC last, then the read-back). Until the record is
    // complete the pod boots with 200 mm, afterwards with 250 mm — never the defaults
    // (150 mm), never a mix. A cut during the read-back leaves the new record complete but the
    // save reported as failed: the pod then boots with the new settings.
    let mut new_from = None;
    for k in (0..2400).step_by(7) {
        let mut b = Bench::idle();
        assert_eq!(b.scpi("CONF:UNL;:CONF:BAR_LENGTH 200"), "");
        assert_eq!(b.scpi("*SAV 0"), "");
        assert_eq!(b.vp.settings_store_failures(), 0);
        assert_eq!(b.scpi("CONF:BAR_LENGTH 250"), "");
        b.vp.flash.budget = Some(k);
        assert_eq!(b.scpi("*SAV 0"), "");
        let failed = b.vp.settings_store_failures() == 1;
        let mut after = Bench {
            vp: b.vp.power_on(),
            frames: Vec::new(),
            stepped: 0,
        };
        let got = after.vp.pod.config.bar_length_mm;
        let seq = after.vp.boot_settings().from.map(|(_, s)| s);
        assert!(
            (got, seq) == (200.0, Some(1)) || (got, seq) == (250.0, Some(2)),
            "cut after {k} steps: {got} mm from {seq:?}"
        );
        if !failed {
            assert_eq!(got, 250.0, "a save reported done is there");
        }
        if got == 250.0 {
            new_from.get_or_insert(k);
        } else {
            assert!(
                new_from.is_none(),
                "once complete, a record stays complete ({k})"
            );
        }
        // what the CNC reads: 0x2000 bar_length (REAL32)
        after.step(1);
        assert_eq!(f32::from_bits(after.read(0x2000, 0)), got);
    }
    let new_from = new_from.expect("a long enough budget completes the save");
    assert!(
        (2048..2400).contains(&new_from),
        "complete after {new_from} steps"
    );
}
