//! Fault scenarios on the simulated pod (issue 7 item 1): each fault is injected into a running
//! circle test of `vmt::virtual_pod::VirtualPod` (the pod's own application — acquisition, run
//! monitor, circle fit, results — with its log, CANopen slave and SCPI server, on the sensor
//! model), and its documented reaction is asserted — a flag on the affected samples, an EMCY
//! frame, an SCPI error or status, or an aborted run with its reason — together with the
//! accounting: the run's counters add up exactly to the sample periods this test stepped
//! (`seen + lost = stepped`, `seen = used + skipped`), both protocols report them, and the log
//! and the host's recording hold every seen sample, so no sample goes missing without being
//! counted.
//!
//! The machine is moved by the test itself, one sample period at a time: the circular-test
//! machine of `vmt::machine` (the forward model) without faults but a socket 5 µm / 3 µm off
//! where the pod believes it, so the fitted eccentricity is (5, −3) µm. Expected values come from
//! what the test controls (how many samples it stepped and spoiled, which edges it made, the
//! injected sizes) and from CiA 301 / SCPI-99 / the documented limits, not from the
//! implementation.

use std::path::Path;

use ballpod::acquisition::probe::TriggerOutcome;
use ballpod::acquisition::{MAX_AXES, SampleFlags};
use ballpod::app::{Live, RESULT_COUNT, ResultId, RunCounters, SessionState};
use ballpod::config::Config;
use ballpod::protocol::canopen::{BusState, CanFrame};
use ballpod_host::flash_model::FlashModel;
use ballpod_host::recording::{Event, parse_runs};
use ballpod_host::vmt::machine::CircleMachine;
use ballpod_host::vmt::sensors::Instrument;
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
/// The minimum arc the test sets up, degrees.
const MIN_ARC_DEG: f64 = 60.0;
/// The true eccentricity of the circle (the socket is at −e from where the pod believes), µm.
const E_UM: [f64; 2] = [5.0, -3.0];
/// The bar's temperature, °C.
const BAR_C: f64 = 20.0;
/// Log capacity of the test pod (every test run is shorter: the log keeps every sample).
const LOG: usize = 8192;

/// The CNC (CAN), the technician (USB) and the machine around one pod.
struct Bench {
    vp: VirtualPod<LOG>,
    /// The machine (forward model).
    machine: CircleMachine,
    /// Samples per revolution.
    per_rev: usize,
    /// Sample periods since power-on: where the machine is on its circle.
    k: usize,
    /// Every frame the pod sent.
    frames: Vec<CanFrame>,
    /// Sample periods stepped while the session was running.
    stepped: u32,
}

impl Bench {
    /// A pod that has booted (boot-up sent) and was given the circle's set-up over SCPI, the
    /// circle pattern armed and started. Nothing is injected yet.
    fn running() -> Self {
        let mut b = Self::idle();
        assert_eq!(b.scpi("SESS:PATT CIRCLE;DIR CCW;:SESS:ARM;STAR"), "");
        assert_eq!(b.scpi("SYST:ERR?"), "0,\"No error\"");
        assert_eq!(b.vp.app.session(), SessionState::Running);
        b
    }

    /// A pod that has booted, homed at the machine's start, with the circle's set-up.
    fn idle() -> Self {
        let vp = VirtualPod::new(VirtualSetup {
            seed: 1,
            instrument: Instrument {
                bar_temp_c: BAR_C,
                ..Instrument::default()
            },
            ..VirtualSetup::default()
        });
        let mut b = Self::on(vp);
        b.step(1);
        assert_eq!(b.take(), vec![frame(HEARTBEAT, &[0])], "boot-up");
        assert_eq!(
            b.scpi(&format!(
                "CONF:UNL;:CONF:CIRCLE_CENTRE_X 0;CIRCLE_CENTRE_Y 0;CIRCLE_RADIUS 150;\
                 CIRCLE_MIN_ARC {MIN_ARC_DEG};:CONF:LOCK"
            )),
            ""
        );
        assert_eq!(b.scpi("SYST:ERR?"), "0,\"No error\"");
        b
    }

    /// The bench around a pod that has just powered on.
    fn on(mut vp: VirtualPod<LOG>) -> Self {
        let machine = CircleMachine {
            radius_mm: 150.0,
            feed_mm_per_min: FEED,
            socket_offset_um: [-E_UM[0], -E_UM[1]],
            ..CircleMachine::perfect()
        };
        let per_rev = machine.samples_per_rev(1000.0);
        vp.home(&machine.pose(0.0, 1.0).1);
        Self {
            vp,
            machine,
            per_rev,
            k: 0,
            frames: Vec::new(),
            stepped: 0,
        }
    }

    /// Where the machine is at sample period `k`: (true ΔL µm, axes).
    fn pose(&self, k: usize) -> (f64, [f64; MAX_AXES]) {
        let th = 2.0 * std::f64::consts::PI * k as f64 / self.per_rev as f64;
        self.machine.pose(th, 1.0)
    }

    /// `n` sample periods of the machine turning CCW.
    fn step(&mut self, n: u32) {
        for _ in 0..n {
            if self.vp.app.session() == SessionState::Running {
                self.stepped += 1;
            }
            let (dl, axes) = self.pose(self.k);
            let (_, f) = self.vp.sample_at(dl, &axes);
            self.frames.extend(f);
            self.k += 1;
        }
    }

    /// Stops the run over SCPI (no response); the application hands the run's end to its
    /// recorders with the next sample, one period later.
    fn stop(&mut self) {
        assert_eq!(self.scpi("SESS:STOP"), "");
        self.step(1);
    }

    /// A probe edge now, the counters latched where the machine is.
    fn edge(&mut self) -> TriggerOutcome {
        let axes = self.pose(self.k).1;
        self.vp.probe_edge_at(&axes)
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

    /// Upload of a visible string, expedited or segmented (CiA 301 §7.2.4.3.7–8).
    fn read_string(&mut self, index: u16, sub: u8) -> String {
        let i = index.to_le_bytes();
        let r = self.sdo([0x40, i[0], i[1], sub, 0, 0, 0, 0]);
        assert_eq!(r[0] & 0xE0, 0x40, "upload response to {index:#x}:{sub}");
        if r[0] & 0x02 != 0 {
            let n = if r[0] & 0x01 != 0 {
                4 - usize::from((r[0] >> 2) & 3)
            } else {
                4
            };
            return String::from_utf8(r[4..4 + n].to_vec()).unwrap();
        }
        let size = u32::from_le_bytes([r[4], r[5], r[6], r[7]]) as usize;
        let mut bytes = Vec::new();
        let mut toggle = 0u8;
        loop {
            let s = self.sdo([0x60 | toggle << 4, 0, 0, 0, 0, 0, 0, 0]);
            assert_eq!(s[0] & 0xF0, toggle << 4, "segment toggle");
            let n = 7 - usize::from((s[0] >> 1) & 7);
            bytes.extend_from_slice(&s[1..1 + n]);
            if s[0] & 1 != 0 {
                break;
            }
            toggle ^= 1;
        }
        assert_eq!(bytes.len(), size, "the announced size");
        String::from_utf8(bytes).unwrap()
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
    /// seen sample used or skipped, both protocols report the same counters, the log and the
    /// host's recording hold every seen sample, and an ended run recorded these counters.
    fn assert_accounts(&mut self) -> RunCounters {
        let c = self.vp.app.run_counters();
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
        let rec = self.vp.recording.runs.last().expect("the run is recorded");
        assert_eq!(rec.samples().count(), c.seen as usize, "and recorded");
        let ended = !matches!(
            self.vp.app.session(),
            SessionState::Armed | SessionState::Running
        );
        if ended {
            assert_eq!(rec.end.expect("the end is recorded").counters, c);
            assert_eq!(self.vp.log().end().expect("the end is logged").counters, c);
        }
        c
    }

    /// How many results the CNC sees as valid (0x4002:1…).
    fn valid_results(&mut self) -> usize {
        assert_eq!(self.read(0x4002, 0), RESULT_COUNT as u32);
        (1..=RESULT_COUNT as u8)
            .filter(|&k| self.read(0x4002, k) == 1)
            .count()
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

    /// A result as the technician fetches it (`FETC:RES?`): value and unit; the CNC's 0x4000
    /// reads the same value.
    fn fetch(&mut self, id: ResultId) -> (f64, String) {
        let r = self.scpi(&format!("FETC:RES? {}", id.info().name));
        let parts: Vec<&str> = r.split(',').collect();
        assert_eq!(parts.len(), 3, "{r}");
        let v: f64 = parts[0].parse().unwrap();
        let sub = id.index() as u8 + 1;
        let can = f64::from(f32::from_bits(self.read(0x4000, sub)));
        assert!(
            (can - v).abs() < 1e-4,
            "{}: CAN {can} vs USB {v}",
            id.info().name
        );
        (v, parts[2].to_string())
    }
}

fn frame(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::new(id, data).unwrap()
}

/// Stops the run over SCPI; it must end DONE with its own results valid: the eccentricity near
/// the truth, the arc the test turned.
fn stop_done(b: &mut Bench) {
    b.stop();
    assert_eq!(b.state(), (3, 0, "DONE".into(), "NONE".into()));
    for id in [
        ResultId::EccU,
        ResultId::EccV,
        ResultId::R0,
        ResultId::ResidualRms,
        ResultId::Arc,
    ] {
        assert_eq!(
            b.read(0x4002, id.index() as u8 + 1),
            1,
            "{} valid",
            id.info().name
        );
    }
    // no CW run: its figures are not valid
    assert_eq!(b.read(0x4002, ResultId::GCw.index() as u8 + 1), 0);
    let (ex, unit) = b.fetch(ResultId::EccU);
    let (ey, _) = b.fetch(ResultId::EccV);
    assert_eq!(unit, "UM");
    assert!(
        (ex - E_UM[0]).abs() < 0.5 && (ey - E_UM[1]).abs() < 0.5,
        "e = ({ex}, {ey}) µm"
    );
    // the arc from the first to the last sample of the run
    let (arc, unit) = b.fetch(ResultId::Arc);
    let turned = 360.0 * f64::from(b.stepped - 1) / b.per_rev as f64;
    assert_eq!(unit, "DEG");
    assert!((arc - turned).abs() < 0.1, "arc {arc}° vs {turned}°");
}

#[test]
fn a_clean_run_uses_every_sample() {
    let mut b = Bench::running();
    b.step(RUN);
    let c = b.assert_accounts();
    assert_eq!((c.seen, c.used, c.skipped(), c.lost), (RUN, RUN, 0, 0));
    assert!(b.emcy_codes().is_empty());
    // the live eccentricity is valid once the arc is turned
    let status: u32 = b.scpi("STAT:POD?").parse().unwrap();
    assert_eq!(
        status & (1 << 9 | 1 << 12 | 1 << 15),
        1 << 9 | 1 << 12,
        "running, live valid, no error"
    );
    stop_done(&mut b);
}

#[test]
fn lvdt_open_for_a_moment_is_flagged_skipped_counted_and_sent_as_emcy_5001() {
    let mut b = Bench::running();
    b.step(1000);
    b.vp.sensors.faults.lvdt_open_samples = 20;
    b.step(10);
    // the live ΔL is not valid while the coil is open; the status word says so
    assert_eq!(b.vp.app.live().get(Live::DeltaL), None);
    assert_eq!(b.read(0x2103, 0) & 1, 0, "live_valid bit 0 (delta_l) clear");
    assert_eq!(b.scpi("MEAS:DL?"), "9.91E+37", "SCPI NaN");
    let status: u32 = b.scpi("STAT:POD?").parse().unwrap();
    assert_eq!(status & (1 << 1 | 1 << 15), 1 << 1 | 1 << 15, "open, error");
    b.step(RUN - 1010);
    assert!(b.vp.app.live().get(Live::DeltaL).is_some());
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
    // The status word says aborted (bit 11) while the open coil stays flagged (bit 1) and is a
    // fault (bit 15).
    let status: u32 = b.scpi("STAT:POD?").parse().unwrap();
    assert_eq!(
        status & (1 << 11 | 1 << 9 | 1 << 1 | 1 << 15),
        1 << 11 | 1 << 1 | 1 << 15
    );
    // a result of the aborted run: SCPI -230 naming it
    assert_eq!(b.scpi("FETC:RES? ecc_u"), "");
    let e = b.scpi("SYST:ERR?");
    assert!(e.starts_with("-230,") && e.contains("ecc_u"), "{e}");
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
    assert!(b.emcy_codes().starts_with(&[0x5002]));
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
    assert_eq!(b.vp.app.session(), SessionState::Running);
    assert!(b.emcy_codes().is_empty());
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
    assert_eq!(b.vp.app.acquisition_counters().quadrature_errors, 2);
    assert_eq!(b.emcy_codes(), vec![0x5003, 0x0000]);
    // the spike is in the log where it happened (X 2.5 mm off), the next sample is back
    let logged: Vec<_> = b.vp.log().iter().collect();
    let spike = logged
        .iter()
        .position(|r| SampleFlags(r.record.flags).contains(SampleFlags::QUADRATURE_ERROR))
        .expect("spike logged");
    // (the sample number is the sample period: nothing was lost; 0.1 µm counts, f32)
    let x = |i: usize| f64::from(logged[i].record.axes[0]);
    let machine_x = |i: usize| b.pose(logged[i].record.seq as usize).1[0];
    assert!(
        (x(spike) - machine_x(spike) - 2.5).abs() < 1e-3,
        "{}",
        x(spike) - machine_x(spike)
    );
    assert!((x(spike + 1) - machine_x(spike + 1)).abs() < 1e-3);
    assert!((x(spike - 1) - machine_x(spike - 1)).abs() < 1e-3);
    stop_done(&mut b);
}

#[test]
fn probe_bounce_and_a_missed_reseat_are_counted_and_not_touch_points() {
    let mut b = Bench::running();
    b.step(100);
    assert!(matches!(b.edge(), TriggerOutcome::Accepted(_)));
    b.vp.set_probe_seated(false);
    // contact bounce: within the 2 ms debounce time
    assert_eq!(b.edge(), TriggerOutcome::Bounce);
    b.step(1);
    assert_eq!(b.edge(), TriggerOutcome::Bounce);
    // the stylus never came back (no 50 ms seated): a missed re-seat
    b.step(5);
    assert_eq!(b.edge(), TriggerOutcome::NotReseated);
    // seated for longer than the re-seat time: the next edge is a touch again
    b.vp.set_probe_seated(true);
    b.step(60);
    assert!(matches!(b.edge(), TriggerOutcome::Accepted(_)));
    b.step(100);
    assert_eq!(b.vp.app.probe_counts(), (2, 2, 1));
    assert_eq!(
        b.logged_with(SampleFlags::PROBE_EVENT),
        2,
        "only accepted touches flag"
    );
    // a CIRCLE run takes no touch points: both touches are counted outside a PROBE run
    assert_eq!(b.vp.app.touches_outside_run(), 2);
    assert!(b.vp.app.touch_points().is_empty());
    assert_eq!(b.scpi("FETC:TOUC:COUN?"), "0");
    let rec = b.vp.recording.runs.last().expect("recorded");
    assert!(rec.events.iter().all(|e| matches!(e, Event::Sample(_))));
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
    assert_eq!(b.vp.app.acquisition_counters().lost_upstream, 5);
    // the gap is in the sample numbers: the log's sample after it is 6 on from the one before
    let seqs: Vec<u32> = b.vp.log().iter().map(|r| r.record.seq).collect();
    let gaps: Vec<u32> = seqs
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|&d| d != 1)
        .collect();
    assert_eq!(gaps, vec![6]);
    assert_eq!(b.emcy_codes(), vec![0x6101, 0x0000]);
    // the device counter of lost blocks says the same over both protocols (0x2110:1,
    // SYST:COUN? first field); the two figures a simulated pod cannot measure read as such
    assert_eq!(b.read(0x2110, 1), 5);
    let dev = b.scpi("SYST:COUN?");
    let dev: Vec<&str> = dev.split(',').collect();
    assert_eq!(dev.len(), ballpod::app::DEVICE_COUNTERS.len());
    assert_eq!(dev[0], "5");
    assert_eq!(dev[14..16], ["9.91E+37", "9.91E+37"]);
    assert_eq!(dev[16], "0", "settings_slots_unreadable");
    assert_eq!(b.read(0x2110, 15), u32::MAX, "masked_max_ns not measured");
    stop_done(&mut b);
}

#[test]
fn a_burst_of_lost_samples_aborts_the_run_with_overrun() {
    let mut b = Bench::running();
    b.step(1000);
    // 12 lost after 1000: more than max(10, 1 % of 1013). (At 100 mm/s, 13 ms of travel is
    // 13 000 counts, below the 20 000-count glitch limit: the encoders still follow.)
    b.vp.lose_samples(12);
    b.step(500);
    assert_eq!(b.state(), (4, 3, "ABORTED".into(), "OVERRUN".into()));
    assert_eq!(b.stepped, 1013, "sample periods of the run");
    let c = b.assert_accounts();
    assert_eq!((c.lost, c.used, c.skipped_overrun), (12, 1000, 1), "{c:?}");
    assert!(b.emcy_codes().starts_with(&[0x6101]));
    assert_eq!(b.valid_results(), 0);
}

#[test]
fn a_long_gap_also_loses_the_encoder_count_and_aborts_with_overrun() {
    let mut b = Bench::running();
    b.step(1000);
    // 50 ms at 100 mm/s: 5.1 mm of travel, 4 mm of it along Y here (θ ≈ 38°): beyond half the
    // 16-bit counter range (3.3 mm): the sample after the gap is a quadrature error as well as
    // the one that passes the loss limit.
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
    b.stop();
    assert_eq!(b.state(), (4, 4, "ABORTED".into(), "UNOBSERVABLE".into()));
    assert_eq!(b.assert_accounts().used, 50);
    assert_eq!(b.valid_results(), 0);
    // 1000 valid samples but only 38° of arc (the set-up asks for 60°)
    let mut b = Bench::running();
    b.step(1000);
    assert!(360.0 * 1000.0 / (b.per_rev as f64) < MIN_ARC_DEG);
    b.stop();
    assert_eq!(b.state(), (4, 4, "ABORTED".into(), "UNOBSERVABLE".into()));
    assert_eq!(b.assert_accounts().used, 1000);
    assert_eq!(b.valid_results(), 0);
}

#[test]
fn arming_without_the_circles_geometry_is_refused_with_the_field() {
    // a pod fresh from the factory: no circle set-up
    let mut b = Bench::on(VirtualPod::new(VirtualSetup::default()));
    b.step(1);
    assert_eq!(b.scpi("SESS:PATT CIRCLE;:SESS:ARM"), "");
    assert_eq!(
        b.scpi("SYST:ERR?"),
        "-221,\"Settings conflict;circle_centre_x not set\""
    );
    assert_eq!(b.scpi("SESS:STAT?"), "IDLE");
    // over CANopen: wrong device state (0x3002 = 1: arm), the reason in words in 0x3006
    let r = b.sdo([0x2F, 0x02, 0x30, 0, 1, 0, 0, 0]);
    assert_eq!(
        (r[0], u32::from_le_bytes([r[4], r[5], r[6], r[7]])),
        (0x80, 0x0800_0022)
    );
    assert_eq!(b.read_string(0x3006, 0), "circle_centre_x not set");
    // the centre given, the radius is next
    assert_eq!(
        b.scpi("CONF:UNL;:CONF:CIRCLE_CENTRE_X 0;CIRCLE_CENTRE_Y 0;:SESS:ARM"),
        ""
    );
    assert_eq!(
        b.scpi("SYST:ERR?"),
        "-221,\"Settings conflict;circle_radius not set\""
    );
    assert_eq!(b.scpi("CONF:CIRCLE_RADIUS 150;:SESS:ARM;STAT?"), "ARMED");
    // the set-up does not change while a run is armed
    assert_eq!(b.scpi("CONF:CIRCLE_RADIUS 100"), "");
    let e = b.scpi("SYST:ERR?");
    assert!(e.starts_with("-221,"), "{e}");
    assert_eq!(b.vp.app.config().setup.circle_radius_mm, 150.0);
}

#[test]
fn thermistor_open_and_short_keep_the_last_temperature_flag_and_send_emcy_5004() {
    let mut b = Bench::running();
    b.step(1000);
    let t_good = b.vp.last_sample().unwrap().temp_c;
    assert!(
        (f64::from(t_good) - BAR_C).abs() < 0.05,
        "bar at {BAR_C} °C: {t_good}"
    );
    // open: the divider pin pulled to the rail, from now on
    b.vp.sensors.thermistor_fault = Some(4095);
    b.vp.thermistor(4095);
    b.step(300);
    assert_eq!(
        b.vp.app.live().get(Live::Temp),
        None,
        "no valid temperature"
    );
    assert_eq!(
        b.read(0x2103, 0) & (1 << 7),
        0,
        "live_valid bit 7 (temp) clear"
    );
    // shorted: the pin at ground
    b.vp.sensors.thermistor_fault = Some(0);
    b.vp.thermistor(0);
    b.step(200);
    let s = b.vp.last_sample().unwrap();
    assert!(s.flags.contains(SampleFlags::TEMPERATURE_FAULT));
    assert_eq!(s.temp_c, t_good, "the last good temperature is kept");
    let status: u32 = b.scpi("STAT:POD?").parse().unwrap();
    assert_eq!(
        status & (1 << 5 | 1 << 15),
        1 << 5 | 1 << 15,
        "temperature fault, error"
    );
    // repaired: a good reading at once
    b.vp.sensors.thermistor_fault = None;
    let code = b.vp.sensors.thermistor_code();
    b.vp.thermistor(code);
    b.step(RUN - 1500);
    assert!(b.vp.app.live().get(Live::Temp).is_some());
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
    // stop is refused now (CiA 301 0x0800 0022: wrong device state), the reason in 0x3006
    let r = b.sdo([0x2F, 0x02, 0x30, 0, 3, 0, 0, 0]);
    assert_eq!(r[0], 0x80);
    assert_eq!(u32::from_le_bytes([r[4], r[5], r[6], r[7]]), 0x0800_0022);
    assert_eq!(b.read_string(0x3006, 0), "STOP needs RUNNING");
    // and over SCPI: -221 with the same reason, nothing changed
    assert_eq!(b.scpi("SESS:STOP"), "");
    assert_eq!(
        b.scpi("SYST:ERR?"),
        "-221,\"Settings conflict;STOP needs RUNNING\""
    );
    assert_eq!(b.scpi("SESS:STAT?"), "ABORTED");
}

#[test]
fn sdo_client_silent_mid_segment_is_aborted_and_the_run_goes_on() {
    let mut b = Bench::running();
    b.step(1000);
    let bar = 0x2000u16.to_le_bytes();
    let before = b.vp.app.config().bar_length_mm;
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
    assert_eq!(b.vp.app.config().bar_length_mm, before, "nothing written");
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
    b.stop();
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
    assert_eq!(second[len], b'\n');
    assert_eq!(
        &second[..first.len()],
        &first[..],
        "the same bytes up to the cut"
    );
    // parsed back by the host's strict reader: the run, every logged sample, in order, and
    // how it ended
    let text = std::str::from_utf8(&second[..len]).unwrap();
    let runs = parse_runs(Path::new("download.csv"), text).expect("the download reads");
    assert_eq!(runs.len(), 1);
    let run = &runs[0];
    assert_eq!(run.meta.run, b.vp.app.run_number());
    assert_eq!(run.meta.pattern.name(), "CIRCLE");
    let samples: Vec<_> = run.samples().collect();
    assert_eq!(samples.len(), n);
    for (got, want) in samples.iter().zip(b.vp.log().iter()) {
        assert_eq!((got.seq, got.t_us), (want.record.seq, want.t_us));
        // 9 significant digits: the same f32
        assert_eq!(got.delta_l_um.to_bits(), want.record.delta_l_um.to_bits());
        assert_eq!(
            got.axes.map(f32::to_bits),
            want.record.axes.map(f32::to_bits)
        );
        assert_eq!(got.flags.0, want.record.flags);
    }
    let end = run.end.expect("the end is in the download");
    assert_eq!((end.abort, end.counters), (None, b.vp.app.run_counters()));
    assert_eq!(b.scpi("SYST:ERR?"), "0,\"No error\"");
}

/// `settings_store_failures` of `SYST:COUN?` (the 12th device counter).
fn settings_failures_scpi(b: &mut Bench) -> u32 {
    let all = b.scpi("SYST:COUN?");
    all.split(',').nth(11).unwrap().parse().unwrap()
}

#[test]
fn power_lost_during_a_settings_save_boots_with_the_previous_settings() {
    // One good save of bar_length 200 mm (slot A, sequence 1); then 250 mm saved with the
    // power cut after k byte steps, for k across the whole save (2048 erase steps of slot B,
    // then the programmed double-words, the CRC last, then the read-back). Until the record is
    // complete the pod boots with 200 mm, afterwards with 250 mm — never the defaults
    // (150 mm), never a mix. A cut during the read-back leaves the new record complete but the
    // save reported as failed: the pod then boots with the new settings.
    use ballpod::settings::RECORD_LEN;
    // the whole save: the page erase, the record's bytes, a margin for the read-back
    let save_steps = 2048 + RECORD_LEN + 64;
    let mut new_from = None;
    for k in (0..save_steps).step_by(7) {
        let mut b = Bench::idle();
        assert_eq!(b.scpi("CONF:UNL;:CONF:BAR_LENGTH 200"), "");
        assert_eq!(b.scpi("*SAV 0"), "");
        let failures = settings_failures_scpi(&mut b);
        assert_eq!(b.scpi("CONF:BAR_LENGTH 250"), "");
        b.vp.flash.budget = Some(k);
        assert_eq!(b.scpi("*SAV 0"), "");
        let failed = settings_failures_scpi(&mut b) == failures + 1;
        // the CNC reads the same count: 0x2110:12 settings_store_failures
        assert_eq!(b.read(0x2110, 12), settings_failures_scpi(&mut b));
        if failed {
            // the failed save is a fault in the status word (from the next sample on) until a
            // save succeeds
            b.step(1);
            let status: u32 = b.scpi("STAT:POD?").parse().unwrap();
            assert_ne!(status & 1 << 15, 0, "cut after {k} steps");
        }
        let mut after = Bench::on(b.vp.power_on());
        let got = after.vp.app.config().bar_length_mm;
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
    // complete once the erase and the record's last byte (its CRC) are done
    assert!(
        (2048 + RECORD_LEN - 8..2048 + RECORD_LEN + 7).contains(&new_from),
        "complete after {new_from} steps"
    );
}

/// A stored configuration the firmware rejects (intact record, CRC good, but a bar length out
/// of range: a value a later firmware no longer accepts) boots into the defaults and says so
/// once on both protocols: EMCY 0x6300 (data set, byte 3 = 3) right after the boot-up and
/// -315 in `SYST:ERR?` naming the field. The record is built here with the public encoding.
#[test]
fn a_stored_configuration_the_firmware_rejects_boots_into_the_defaults_with_a_report() {
    let bad = Config {
        bar_length_mm: 5000.0,
        ..Config::default()
    };
    assert!(bad.validate().is_err(), "the value is out of range");
    let rec = ballpod::settings::encode_record(&bad, 7).unwrap();
    let mut flash = FlashModel::erased();
    flash.pages[0][..rec.len()].copy_from_slice(&rec);
    let vp = VirtualPod::boot(VirtualSetup::default(), flash);
    assert!(vp.boot_settings().is_defaults());
    assert!(matches!(
        vp.boot_settings().rejected(),
        Some(ballpod::config::ConfigError::OutOfRange {
            field: ballpod::config::Field::BarLengthMm,
            ..
        })
    ));
    let mut b = Bench::on(vp);
    b.step(1);
    let frames = b.take();
    assert_eq!(frames[0], frame(HEARTBEAT, &[0]), "boot-up first");
    let emcy: Vec<_> = frames.iter().filter(|f| f.id == EMCY).collect();
    assert_eq!(emcy.len(), 1, "{frames:?}");
    assert_eq!(
        (
            u16::from_le_bytes([emcy[0].data[0], emcy[0].data[1]]),
            emcy[0].data[3]
        ),
        (0x6300, 3)
    );
    assert_eq!(
        b.scpi("SYST:ERR?"),
        "-315,\"Configuration memory lost;bar_length out of range\""
    );
    assert_eq!(b.scpi("SYST:ERR?"), "0,\"No error\"", "reported once");
    // the defaults are what the CNC reads: 0x2000 bar_length 150 mm
    assert_eq!(
        f32::from_bits(b.read(0x2000, 0)),
        Config::default().bar_length_mm
    );
}

/// A save cut by a power loss inside a double-word of the record leaves it with data and ECC
/// that disagree: the pod's read of that slot is a double ECC error (on the board an NMI, here
/// the flash model's failed read). The pod boots with the other slot's settings and says so
/// once: EMCY 0x6300 byte 3 = 7, -315 in `SYST:ERR?`, device counter
/// `settings_slots_unreadable` (0x2110:17) = 1.
#[test]
fn a_slot_torn_by_a_power_loss_boots_from_the_other_with_a_report() {
    let mut flash = FlashModel::erased();
    let older = Config {
        bar_length_mm: 200.0,
        ..Config::default()
    };
    ballpod::settings::store(&mut flash, &older).unwrap(); // slot A
    let mut cut = flash.power_on();
    // the next save (slot B) cut 5 bytes into the record's third double-word
    cut.budget = Some(2048 + 2 * 8 + 5);
    let newer = Config {
        bar_length_mm: 300.0,
        ..Config::default()
    };
    assert!(ballpod::settings::store(&mut cut, &newer).is_err());
    let vp = VirtualPod::boot(VirtualSetup::default(), cut.power_on());
    assert_eq!(vp.boot_settings().unreadable(), 1);
    let mut b = Bench::on(vp);
    b.step(1);
    let frames = b.take();
    let emcy: Vec<_> = frames.iter().filter(|f| f.id == EMCY).collect();
    assert_eq!(emcy.len(), 1, "{frames:?}");
    assert_eq!(
        (
            u16::from_le_bytes([emcy[0].data[0], emcy[0].data[1]]),
            emcy[0].data[3]
        ),
        (0x6300, 7)
    );
    assert_eq!(
        b.scpi("SYST:ERR?"),
        "-315,\"Configuration memory lost;settings slot unreadable (flash ECC error: a save cut by a power loss)\""
    );
    assert_eq!(b.read(0x2110, 17), 1);
    // the older settings run
    assert_eq!(f32::from_bits(b.read(0x2000, 0)), 200.0);
}

/// A complete save is reported done: no failure counted, no error bit, and the pod boots with
/// it.
#[test]
fn a_complete_save_is_reported_done() {
    let mut b = Bench::idle();
    assert_eq!(b.scpi("CONF:UNL;:CONF:BAR_LENGTH 200;*SAV 0"), "");
    assert_eq!(b.scpi("SYST:ERR?"), "0,\"No error\"");
    assert_eq!(settings_failures_scpi(&mut b), 0);
    assert_eq!(b.read(0x2110, 12), 0);
    b.step(1);
    let status: u32 = b.scpi("STAT:POD?").parse().unwrap();
    assert_eq!(status & 1 << 15, 0, "no error bit");
    let after = Bench::on(b.vp.power_on());
    assert_eq!(after.vp.app.config().bar_length_mm, 200.0);
}
