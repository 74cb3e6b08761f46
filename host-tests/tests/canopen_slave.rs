//! CANopen slave: NMT, heartbeat, SDO, SYNC/TPDO and EMCY checked against the frame layouts and
//! abort codes of CiA 301 (v4.2.0). Expected bytes are written out from the standard's tables,
//! not taken from the implementation. The node serves the pod application ([`App`]): the
//! application's state is only ever changed by driving it (SDO writes, session commands,
//! samples), and the values read back are checked against independent sources (the CiA 301
//! tables, the documented codes, a forward model of the ball bar).
use ballpod::acquisition::{MAX_AXES, Sample, SampleFlags};
use ballpod::app::log::SampleLog;
use ballpod::app::{App, Direction, Pattern, ResultInfo, SessionState, SettingsRequest, Touch};
use ballpod::config::{Config, FIELDS};
use ballpod::protocol::canopen::{CanFrame, CanOpenNode, NmtState};
use ballpod::protocol::scpi::ScpiServer;
use ballpod_host::app_state::snapshot as state;
use ballpod_host::vmt::machine::linear_circle_sample;

const NODE: u8 = 16;
const SDO_RX: u16 = 0x600 + NODE as u16;
const SDO_TX: u16 = 0x580 + NODE as u16;
const HEARTBEAT: u16 = 0x700 + NODE as u16;

// CiA 301 table 22.
const TOGGLE: u32 = 0x0503_0000;
const TIMEOUT: u32 = 0x0504_0000;
const BAD_CS: u32 = 0x0504_0001;
const UNSUPPORTED_ACCESS: u32 = 0x0601_0000;
const WRITE_ONLY: u32 = 0x0601_0001;
const READ_ONLY: u32 = 0x0601_0002;
const NO_OBJECT: u32 = 0x0602_0000;
const NOT_MAPPABLE: u32 = 0x0604_0041;
const PDO_LENGTH: u32 = 0x0604_0042;
const INCOMPATIBLE: u32 = 0x0604_0043;
const LENGTH: u32 = 0x0607_0010;
const NO_SUB: u32 = 0x0609_0011;
const INVALID: u32 = 0x0609_0030;
const TOO_HIGH: u32 = 0x0609_0031;
const TOO_LOW: u32 = 0x0609_0032;
const CANNOT_STORE: u32 = 0x0800_0020;
const WRONG_STATE: u32 = 0x0800_0022;
const NO_DATA: u32 = 0x0800_0024;

// Codes of the session objects (book reference "CANopen objects" / EDS comments: 0x3000 pattern, 0x3001 direction,
// 0x3002 command, 0x3003 state, 0x3004 abort reason).
const PAT_CIRCLE: u8 = 0;
const PAT_BX: u8 = 1;
const PAT_PROBE: u8 = 7;
const CMD_ARM: u8 = 1;
const CMD_START: u8 = 2;
const CMD_STOP: u8 = 3;
const CMD_ABORT: u8 = 4;
const CMD_CLEAR: u8 = 5;
const CMD_RESET: u8 = 6;
const ST_IDLE: u8 = 0;
const ST_ARMED: u8 = 1;
const ST_RUNNING: u8 = 2;
const ST_DONE: u8 = 3;
const ST_ABORTED: u8 = 4;
const REASON_COMMAND: u8 = 1;
const REASON_UNOBSERVABLE: u8 = 4;

// Status word bits (0x2102) and live-value validity bits (0x2103: bit k-1 = 0x2100:k).
const STATUS_RUNNING: u16 = 1 << 9;
const STATUS_LIVE_VALID: u16 = 1 << 12;
const LIVE_DL: u16 = 1 << 0;
const LIVE_ECC_U: u16 = 1 << 4;
const LIVE_ECC_V: u16 = 1 << 5;
const LIVE_R0: u16 = 1 << 6;
const LIVE_TEMP: u16 = 1 << 7;
/// The live fit's u (u_ecc_u, u_ecc_v, u_r0: 0x2100:12–14).
const LIVE_FIT_U: u16 = 1 << 11 | 1 << 12 | 1 << 13;

/// Forward model of the circle run: the ball bar (nominal length = radius 150 mm) about a socket
/// at the origin of the XY plane, the machine's trajectory off-centre by E_UM and longer by R0_UM,
/// so that ΔL(θ) = r0 + e_u cos θ + e_v sin θ (the limaçon of seed 002 §3.5 / ISO 230-4 about
/// the socket).
const RADIUS_MM: f64 = 150.0;
const E_UM: [f64; 2] = [12.5, -7.25];
const R0_UM: f64 = 3.0;
/// Samples per revolution of the model circle.
const STEPS: usize = 720;

fn fresh_app() -> App {
    App::new(Config::default(), [16; MAX_AXES])
}

struct Bench {
    node: CanOpenNode,
    app: App,
    /// Number of the next sample.
    seq: u32,
    now_us: u64,
    sent: Vec<CanFrame>,
}

impl Bench {
    /// A node that has booted (boot-up consumed) and is pre-operational.
    fn new() -> Self {
        let mut b = Self::unbooted();
        b.poll();
        assert_eq!(b.take(), vec![frame(HEARTBEAT, &[0x00])]);
        b
    }
    fn unbooted() -> Self {
        Self {
            node: CanOpenNode::new(NODE, 0x1234_5678),
            app: fresh_app(),
            seq: 1000,
            now_us: 0,
            sent: Vec::new(),
        }
    }
    fn rx(&mut self, id: u16, data: &[u8]) {
        let f = frame(id, data);
        let sent = &mut self.sent;
        self.node
            .on_frame(&f, &mut self.app, self.now_us, &mut |f| sent.push(f));
    }
    fn poll(&mut self) {
        let sent = &mut self.sent;
        self.node
            .poll(self.now_us, &self.app, &mut |f| sent.push(f));
    }
    /// A new sample's flags for the EMCY producer.
    fn sample(&mut self, flags: SampleFlags) {
        let sent = &mut self.sent;
        self.node
            .on_sample(flags, self.now_us, &mut |f| sent.push(f));
    }
    /// Feeds one sample to the application (numbered in sequence).
    fn feed(&mut self, mut s: Sample) {
        s.seq = self.seq;
        s.t_us = 1_000_000 + u64::from(self.seq) * 1000;
        self.seq += 1;
        self.app.on_sample(&s, &mut ());
    }
    fn take(&mut self) -> Vec<CanFrame> {
        std::mem::take(&mut self.sent)
    }
    fn advance_ms(&mut self, ms: u64) {
        self.now_us += ms * 1000;
    }
    /// Sends an SDO request and returns the single response payload.
    fn sdo(&mut self, req: [u8; 8]) -> [u8; 8] {
        self.rx(SDO_RX, &req);
        let out = self.take();
        assert_eq!(out.len(), 1, "one SDO response expected, got {out:?}");
        assert_eq!(out[0].id, SDO_TX);
        assert_eq!(
            out[0].len, 8,
            "SDO responses are 8 bytes (CiA 301 §7.2.4.3)"
        );
        out[0].data
    }
    fn nmt(&mut self, cs: u8, node: u8) {
        self.rx(0x000, &[cs, node])
    }
    /// Upload (expedited or segmented); returns the data bytes (per the size indicated) or the
    /// abort code.
    fn upload(&mut self, index: u16, sub: u8) -> Result<Vec<u8>, u32> {
        let r = self.sdo(req(0x40, index, sub, [0; 4]));
        check_mux(&r, index, sub);
        match r[0] {
            0x80 => Err(abort_code(&r)),
            b if b & 0xE3 == 0x43 => Ok(r[4..8 - usize::from((b >> 2) & 3)].to_vec()),
            0x41 => {
                let size = u32::from_le_bytes(r[4..8].try_into().unwrap()) as usize;
                let mut data = Vec::new();
                let mut t = 0u8;
                loop {
                    let s = self.sdo([0x60 | t << 4, 0, 0, 0, 0, 0, 0, 0]);
                    assert_eq!(s[0] >> 5, 0, "scs 0 = upload segment response");
                    assert_eq!((s[0] >> 4) & 1, t, "toggle echoed");
                    let n = 7 - usize::from((s[0] >> 1) & 7);
                    data.extend_from_slice(&s[1..1 + n]);
                    t ^= 1;
                    if s[0] & 1 == 1 {
                        break;
                    }
                }
                assert_eq!(data.len(), size, "indicated size = transferred size");
                Ok(data)
            }
            b => panic!("unexpected upload response {b:#04x}"),
        }
    }
    /// A VISIBLE_STRING object as text.
    fn text(&mut self, index: u16) -> String {
        String::from_utf8(self.upload(index, 0).unwrap()).unwrap()
    }
    /// Expedited download of `data` (1–4 bytes, size indicated): Ok or the abort code. An
    /// aborted write leaves the application as it was (CiA 301 §7.2.4: nothing of a refused
    /// transfer is applied).
    fn download(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), u32> {
        let n = 4 - data.len() as u8;
        let mut d = [0u8; 4];
        d[..data.len()].copy_from_slice(data);
        let before = state(&self.app);
        self.rx(SDO_RX, &req(0x23 | n << 2, index, sub, d));
        let out = self.take();
        assert_eq!(out.len(), 1);
        let r = out[0].data;
        check_mux(&r, index, sub);
        match r[0] {
            0x60 => Ok(()),
            0x80 => {
                assert_eq!(
                    state(&self.app),
                    before,
                    "an aborted write changes nothing in the application"
                );
                Err(abort_code(&r))
            }
            b => panic!("unexpected download response {b:#04x}"),
        }
    }
    fn write_f32(&mut self, index: u16, sub: u8, v: f32) -> Result<(), u32> {
        self.download(index, sub, &v.to_le_bytes())
    }
    fn read_u32(&mut self, index: u16, sub: u8) -> u32 {
        let d = self.upload(index, sub).unwrap();
        assert!(d.len() <= 4);
        let mut b = [0u8; 4];
        b[..d.len()].copy_from_slice(&d);
        u32::from_le_bytes(b)
    }
    fn read_f32(&mut self, index: u16, sub: u8) -> f32 {
        let d = self.upload(index, sub).unwrap();
        f32::from_le_bytes(d.try_into().expect("REAL32 is 4 bytes"))
    }
    fn command(&mut self, code: u8) -> Result<(), u32> {
        self.download(0x3002, 0, &[code])
    }
    /// The jobs the last commands left run to their end (the firmware's worker).
    fn run_jobs(&mut self) {
        ballpod_host::run_jobs(&mut self.app);
    }
    fn session_state(&mut self) -> u8 {
        let d = self.upload(0x3003, 0).unwrap();
        assert_eq!(d.len(), 1, "UNSIGNED8");
        d[0]
    }
    fn start(&mut self) {
        self.nmt(0x01, NODE);
        assert_eq!(self.node.state(), NmtState::Operational);
    }
    /// Writes the circle's geometry over SDO (pre-operational): centre at the origin of XY,
    /// radius 150 mm.
    fn set_circle_geometry(&mut self) {
        for name in ["circle_centre_x", "circle_centre_y", "circle_centre_z"] {
            self.write_f32(obj(name), 0, 0.0).unwrap();
        }
        self.write_f32(obj("circle_radius"), 0, RADIUS_MM as f32)
            .unwrap();
    }
    /// Arms and starts a CIRCLE run and feeds one whole revolution of the forward model (CCW),
    /// leaving the run running.
    fn run_circle(&mut self) {
        self.set_circle_geometry();
        self.download(0x3000, 0, &[PAT_CIRCLE]).unwrap();
        self.command(CMD_ARM).unwrap();
        self.command(CMD_START).unwrap();
        for k in 0..=STEPS {
            self.feed(circle_sample(k));
        }
        assert_eq!(self.app.session(), SessionState::Running);
    }
}

/// Sample k of the forward model's revolution (θ = 2πk/STEPS, CCW from +X).
fn circle_sample(k: usize) -> Sample {
    let th = 2.0 * std::f64::consts::PI * k as f64 / STEPS as f64;
    linear_circle_sample(th, RADIUS_MM, E_UM, R0_UM)
}

fn frame(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::new(id, data).unwrap()
}

fn req(b0: u8, index: u16, sub: u8, d: [u8; 4]) -> [u8; 8] {
    let i = index.to_le_bytes();
    [b0, i[0], i[1], sub, d[0], d[1], d[2], d[3]]
}

fn check_mux(r: &[u8; 8], index: u16, sub: u8) {
    assert_eq!(
        u16::from_le_bytes([r[1], r[2]]),
        index,
        "multiplexer index in {r:02x?}"
    );
    assert_eq!(r[3], sub, "multiplexer sub-index in {r:02x?}");
}

fn abort_code(r: &[u8; 8]) -> u32 {
    assert_eq!(r[0], 0x80, "abort transfer cs");
    u32::from_le_bytes(r[4..8].try_into().unwrap())
}

fn field_index(name: &str) -> u16 {
    FIELDS
        .iter()
        .position(|f| f.name == name)
        .unwrap_or_else(|| panic!("no field {name}")) as u16
}

/// The configuration object of field `name` (`od::config_index` of its row; the layout is
/// checked against the EDS in canopen_eds.rs).
fn obj(name: &str) -> u16 {
    ballpod::protocol::canopen::od::config_index(usize::from(field_index(name)))
}

/// Sub-index of a result in 0x4000–0x4002 (k + 1 for the k-th entry of the catalogue).
fn result_sub(name: &str) -> u8 {
    ResultInfo::all().position(|r| r.name == name).unwrap() as u8 + 1
}

fn close(got: f32, want: f64, tol: f64, what: &str) {
    assert!(
        (f64::from(got) - want).abs() <= tol,
        "{what}: {got} vs {want} ± {tol}"
    );
}

// ---------------------------------------------------------------------------------------------
// NMT and heartbeat (CiA 301 §7.2.8, §7.3.2)
// ---------------------------------------------------------------------------------------------

#[test]
fn boot_up_then_heartbeat_every_period_with_state_byte() {
    let mut b = Bench::new();
    assert_eq!(b.node.state(), NmtState::PreOperational);
    b.advance_ms(999);
    b.poll();
    assert!(b.take().is_empty(), "no heartbeat before 1000 ms");
    b.advance_ms(1);
    b.poll();
    assert_eq!(
        b.take(),
        vec![frame(HEARTBEAT, &[0x7F])],
        "pre-operational = 0x7F"
    );
    b.start();
    b.advance_ms(1000);
    b.poll();
    assert_eq!(
        b.take(),
        vec![frame(HEARTBEAT, &[0x05])],
        "operational = 0x05"
    );
    b.nmt(0x02, NODE);
    b.advance_ms(1000);
    b.poll();
    assert_eq!(b.take(), vec![frame(HEARTBEAT, &[0x04])], "stopped = 0x04");
}

/// A shell polls every millisecond, each poll a little late by a latency that varies (the
/// turn in front of it): every heartbeat leaves at the poll nearest its place on the 1000 ms
/// grid, so the gaps between them differ from 1000 ms by no more than the latencies do — not
/// by a whole poll interval, as when a heartbeat goes out only at or after its due time and
/// the grid was set by a poll later than the one that finds it due.
#[test]
fn heartbeats_keep_their_period_to_the_polls_latency_not_to_a_poll_interval() {
    let mut b = Bench::new();
    // the producer time written at 150 µs: the grid is 150 µs + k s
    b.now_us = 150;
    b.download(0x1017, 0, &0u16.to_le_bytes()).unwrap();
    b.download(0x1017, 0, &1000u16.to_le_bytes()).unwrap();
    // latencies of a shell's 1 ms polls, µs: 0…300
    let latency = |k: u64| (k * 37) % 301;
    let mut times = Vec::new();
    for k in 1..10_000u64 {
        b.now_us = k * 1000 + latency(k);
        b.poll();
        if b.take().iter().any(|f| f.id == HEARTBEAT) {
            times.push(b.now_us);
        }
    }
    assert_eq!(times.len(), 9, "one a second: {times:?}");
    let gaps: Vec<i64> = times
        .windows(2)
        .map(|w| w[1] as i64 - w[0] as i64)
        .collect();
    for g in &gaps {
        assert!((g - 1_000_000).abs() <= 300, "gap {g} µs: {gaps:?}");
    }
}

#[test]
fn heartbeat_time_written_by_sdo_takes_effect_and_zero_disables() {
    let mut b = Bench::new();
    b.download(0x1017, 0, &100u16.to_le_bytes()).unwrap();
    b.advance_ms(100);
    b.poll();
    assert_eq!(b.take(), vec![frame(HEARTBEAT, &[0x7F])]);
    b.download(0x1017, 0, &0u16.to_le_bytes()).unwrap();
    b.advance_ms(5000);
    b.poll();
    assert!(b.take().is_empty());
}

#[test]
fn nmt_commands_for_this_node_or_all_change_state_others_are_ignored() {
    let mut b = Bench::new();
    b.nmt(0x01, NODE + 1);
    assert_eq!(
        b.node.state(),
        NmtState::PreOperational,
        "addressed to another node"
    );
    b.nmt(0x01, 0);
    assert_eq!(b.node.state(), NmtState::Operational, "node 0 = all nodes");
    b.nmt(0x80, NODE);
    assert_eq!(b.node.state(), NmtState::PreOperational);
    b.nmt(0x02, NODE);
    assert_eq!(b.node.state(), NmtState::Stopped);
    // In stopped the SDO server is silent (CiA 301 table 86).
    b.rx(SDO_RX, &req(0x40, 0x1000, 0, [0; 4]));
    assert!(b.take().is_empty());
    b.nmt(0x01, NODE);
    assert_eq!(b.node.state(), NmtState::Operational);
}

#[test]
fn malformed_or_unknown_nmt_frames_change_nothing() {
    let mut b = Bench::new();
    b.rx(0x000, &[0x01]);
    b.rx(0x000, &[0x01, NODE, 0]);
    b.rx(0x000, &[0x55, NODE]);
    assert_eq!(b.node.state(), NmtState::PreOperational);
    assert_eq!(b.node.stats().frames_malformed, 3);
    assert!(b.take().is_empty());
}

#[test]
fn unknown_cob_ids_are_ignored_and_counted() {
    let mut b = Bench::new();
    let before = state(&b.app);
    for id in [0x123u16, 0x601, 0x7FF, 0x200 + NODE as u16] {
        b.rx(id, &[1, 2, 3, 4, 5, 6, 7, 8]);
    }
    assert!(b.take().is_empty());
    assert_eq!(state(&b.app), before);
    assert_eq!(b.node.stats().frames_ignored, 4);
}

#[test]
fn reset_communication_restores_parameters_and_sends_boot_up_but_keeps_the_application() {
    let mut b = Bench::new();
    b.download(0x1017, 0, &250u16.to_le_bytes()).unwrap();
    // A PROBE run needs no geometry: arm one.
    b.download(0x3000, 0, &[PAT_PROBE]).unwrap();
    b.command(CMD_ARM).unwrap();
    b.start();
    b.nmt(0x82, NODE);
    assert_eq!(b.take(), vec![frame(HEARTBEAT, &[0x00])], "boot-up");
    assert_eq!(b.node.state(), NmtState::PreOperational);
    assert_eq!(b.read_u32(0x1017, 0), 1000, "0x1017 back to its default");
    // CiA 301 §7.3.2.2.1: reset communication leaves the application alone.
    assert_eq!(b.session_state(), ST_ARMED);
    assert_eq!(b.app.session(), SessionState::Armed);
}

#[test]
fn reset_node_resets_the_application_and_takes_the_new_node_id() {
    let mut b = Bench::new();
    // can_node_id is UNSIGNED8: one byte.
    b.download(obj("can_node_id"), 0, &[42]).unwrap();
    assert_eq!(b.app.config().can_node_id, 42);
    assert_eq!(b.node.node_id(), NODE, "the node-ID changes only at reset");
    b.download(0x3000, 0, &[PAT_PROBE]).unwrap();
    b.command(CMD_ARM).unwrap();
    b.command(CMD_START).unwrap();
    assert_eq!(b.app.session(), SessionState::Running);
    b.nmt(0x81, NODE);
    assert_eq!(b.take(), vec![frame(0x700 + 42, &[0x00])]);
    assert_eq!(b.node.node_id(), 42);
    // The application was reset: the run is gone, the state is IDLE with no abort reason,
    // the configuration stays.
    assert_eq!(b.app.session(), SessionState::Idle);
    assert_eq!(b.app.abort_reason(), None);
    assert_eq!(b.app.config().can_node_id, 42);
}

// ---------------------------------------------------------------------------------------------
// SDO (CiA 301 §7.2.4)
// ---------------------------------------------------------------------------------------------

#[test]
fn expedited_upload_layouts() {
    let mut b = Bench::new();
    // UNSIGNED32 → n = 0: 0x43; UNSIGNED16 → n = 2: 0x4B; UNSIGNED8 → n = 3: 0x4F.
    let r = b.sdo(req(0x40, 0x1018, 4, [0; 4]));
    assert_eq!(r, [0x43, 0x18, 0x10, 0x04, 0x78, 0x56, 0x34, 0x12]);
    let r = b.sdo(req(0x40, 0x1017, 0, [0; 4]));
    assert_eq!(r, [0x4B, 0x17, 0x10, 0x00, 0xE8, 0x03, 0, 0]);
    let r = b.sdo(req(0x40, 0x1018, 0, [0; 4]));
    assert_eq!(r, [0x4F, 0x18, 0x10, 0x00, 4, 0, 0, 0]);
    // The SDO server's own COB-IDs (0x1200).
    assert_eq!(b.read_u32(0x1200, 1), 0x600 + u32::from(NODE));
    assert_eq!(b.read_u32(0x1200, 2), 0x580 + u32::from(NODE));
}

#[test]
fn segmented_upload_of_names_and_versions() {
    let mut b = Bench::new();
    let r = b.sdo(req(0x40, 0x1008, 0, [0; 4]));
    assert_eq!(r[0], 0x41, "segmented, size indicated");
    let name = b"ballpod measurement pod";
    assert_eq!(
        u32::from_le_bytes(r[4..8].try_into().unwrap()),
        name.len() as u32
    );
    // First segment: toggle 0, 7 bytes, not last → byte 0 = 0x00.
    let s = b.sdo([0x60, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(s[0], 0x00);
    assert_eq!(&s[1..8], &name[..7]);
    assert_eq!(b.upload(0x1008, 0).unwrap(), name);
    // the release and the commit (scpi_protocol.rs asks git for it), as *IDN?'s version
    let sw = String::from_utf8(b.upload(0x100A, 0).unwrap()).unwrap();
    assert_eq!(sw, format!("ballpod {}", ballpod::FIRMWARE_VERSION));
    assert!(sw.starts_with(concat!("ballpod ", env!("CARGO_PKG_VERSION"), "+")));
    let hw = b.upload(0x1009, 0).unwrap();
    assert!(hw.len() > 4);
}

#[test]
fn upload_toggle_error_aborts() {
    let mut b = Bench::new();
    b.sdo(req(0x40, 0x1008, 0, [0; 4]));
    let r = b.sdo([0x70, 0, 0, 0, 0, 0, 0, 0]);
    check_mux(&r, 0x1008, 0);
    assert_eq!(abort_code(&r), TOGGLE);
    // The transfer is gone: a further segment request is a protocol error.
    let r = b.sdo([0x60, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(abort_code(&r), BAD_CS);
}

#[test]
fn expedited_config_write_in_pre_operational_goes_through_config() {
    let mut b = Bench::new();
    let idx = obj("bar_length");
    assert_eq!(b.write_f32(idx, 0, 300.0), Ok(()));
    assert_eq!(b.app.config().bar_length_mm, 300.0);
    assert_eq!(b.upload(idx, 0).unwrap(), 300.0f32.to_le_bytes());
}

#[test]
fn indexed_config_fields_are_arrays() {
    let mut b = Bench::new();
    let idx = obj("axis_counts");
    assert_eq!(b.upload(idx, 0).unwrap(), [5], "sub 0 = number of inputs");
    b.write_f32(idx, 3, 2500.0).unwrap();
    assert_eq!(b.app.config().axes[2].counts_per_unit, 2500.0);
    assert_eq!(b.write_f32(idx, 6, 2500.0), Err(NO_SUB));
    let poly = obj("lvdt_poly");
    b.write_f32(poly, 2, 1990.5).unwrap();
    assert_eq!(b.app.config().lvdt_poly_um[1], 1990.5);
}

#[test]
fn integer_config_objects_are_unsigned_types_of_their_width() {
    // CiA 301 §7.1.6: UNSIGNED8 is one byte, UNSIGNED16 two, UNSIGNED32 four, little-endian;
    // the defaults of Config::default() (node-ID 16, 20 samples per period, 2 ms debounce).
    let mut b = Bench::new();
    let node = obj("can_node_id");
    let spp = obj("samples_per_period");
    let debounce = obj("probe_debounce");
    let r = b.sdo(req(0x40, node, 0, [0; 4]));
    assert_eq!(r[0], 0x4F, "expedited, 1 byte (n = 3)");
    assert_eq!(b.upload(node, 0).unwrap(), [16]);
    let r = b.sdo(req(0x40, spp, 0, [0; 4]));
    assert_eq!(r[0], 0x4B, "expedited, 2 bytes (n = 2)");
    assert_eq!(b.upload(spp, 0).unwrap(), 20u16.to_le_bytes());
    assert_eq!(b.upload(debounce, 0).unwrap(), 2000u32.to_le_bytes());
    // A code field is an UNSIGNED8 code too (circle_plane 0 = XY).
    assert_eq!(b.upload(obj("circle_plane"), 0).unwrap(), [0]);
    // Writes must have the type's length.
    assert_eq!(b.download(node, 0, &[42, 0, 0, 0]), Err(LENGTH));
    assert_eq!(b.download(node, 0, &[42, 0]), Err(LENGTH));
    assert_eq!(b.download(spp, 0, &[32]), Err(LENGTH));
    assert_eq!(b.download(spp, 0, &32.0f32.to_le_bytes()), Err(LENGTH));
    assert_eq!(b.download(debounce, 0, &[1, 0]), Err(LENGTH));
    // Ranges of the table: node-ID 1…127, samples per period 20 (the excitation table).
    assert_eq!(b.download(node, 0, &[0]), Err(TOO_LOW));
    assert_eq!(b.download(node, 0, &[128]), Err(TOO_HIGH));
    assert_eq!(b.download(spp, 0, &19u16.to_le_bytes()), Err(TOO_LOW));
    assert_eq!(b.download(spp, 0, &21u16.to_le_bytes()), Err(TOO_HIGH));
    assert_eq!(
        b.download(debounce, 0, &100_001u32.to_le_bytes()),
        Err(TOO_HIGH)
    );
    assert_eq!(b.download(obj("circle_plane"), 0, &[3]), Err(TOO_HIGH));
    b.download(node, 0, &[127]).unwrap();
    b.download(spp, 0, &20u16.to_le_bytes()).unwrap();
    b.download(debounce, 0, &0u32.to_le_bytes()).unwrap();
    b.download(obj("circle_plane"), 0, &[2]).unwrap();
    let c = b.app.config();
    assert_eq!(c.can_node_id, 127);
    assert_eq!(c.samples_per_period, 20);
    assert_eq!(c.probe_debounce_us, 0);
    assert_eq!(c.setup.circle_plane, ballpod::config::CirclePlane::ZX);
    assert_eq!(b.upload(spp, 0).unwrap(), 20u16.to_le_bytes());
}

#[test]
fn set_up_lengths_read_nan_until_written_and_cannot_be_written_nan() {
    let mut b = Bench::new();
    for name in [
        "circle_radius",
        "circle_centre_x",
        "s002_l_b",
        "ssm_socket_z",
        "ts_tool_z",
    ] {
        assert!(b.read_f32(obj(name), 0).is_nan(), "{name} not set");
    }
    let r = obj("circle_radius");
    b.write_f32(r, 0, 99.5).unwrap();
    assert_eq!(b.read_f32(r, 0), 99.5);
    assert_eq!(b.app.config().setup.circle_radius_mm, 99.5);
    assert_eq!(b.write_f32(r, 0, f32::NAN), Err(INVALID));
    assert_eq!(b.write_f32(r, 0, 0.5), Err(TOO_LOW));
    assert_eq!(b.write_f32(r, 0, 2000.5), Err(TOO_HIGH));
    assert_eq!(b.read_f32(r, 0), 99.5);
}

#[test]
fn segmented_download_applies_only_at_the_last_segment() {
    let mut b = Bench::new();
    let idx = obj("bar_length");
    let v = 222.5f32.to_le_bytes();
    // Initiate: ccs 1, e 0, s 1 → 0x21, size 4.
    let r = b.sdo(req(0x21, idx, 0, 4u32.to_le_bytes()));
    assert_eq!(r, req(0x60, idx, 0, [0; 4]));
    assert_eq!(b.app.config().bar_length_mm, 150.0);
    // Segment: toggle 0, n = 7 − 4 = 3 unused, c = 1 → 0b000_0_011_1 = 0x07.
    b.rx(SDO_RX, &[0x07, v[0], v[1], v[2], v[3], 0, 0, 0]);
    assert_eq!(b.take(), vec![frame(SDO_TX, &[0x20, 0, 0, 0, 0, 0, 0, 0])]);
    assert_eq!(b.app.config().bar_length_mm, 222.5);
}

#[test]
fn segmented_download_over_two_segments_and_toggle_error() {
    let mut b = Bench::new();
    let idx = obj("bar_length");
    let v = 333.0f32.to_le_bytes();
    // Size not indicated (0x20); two segments of 2 bytes.
    b.sdo(req(0x20, idx, 0, [0; 4]));
    let r = b.sdo([0x0A, v[0], v[1], 0, 0, 0, 0, 0]); // t0, n = 5, c 0
    assert_eq!(r[0], 0x20);
    assert_eq!(b.app.config().bar_length_mm, 150.0, "not before the last");
    let r = b.sdo([0x1B, v[2], v[3], 0, 0, 0, 0, 0]); // t1, n = 5, c 1
    assert_eq!(r[0], 0x30, "toggle echoed");
    assert_eq!(b.app.config().bar_length_mm, 333.0);

    let before = state(&b.app);
    b.sdo(req(0x21, idx, 0, 4u32.to_le_bytes()));
    let r = b.sdo([0x1A, v[0], v[1], 0, 0, 0, 0, 0]); // toggle 1 first: wrong
    check_mux(&r, idx, 0);
    assert_eq!(abort_code(&r), TOGGLE);
    assert_eq!(state(&b.app), before);
}

#[test]
fn segment_timeout_aborts_and_writes_nothing() {
    let mut b = Bench::new();
    let idx = obj("bar_length");
    let before = state(&b.app);
    b.sdo(req(0x21, idx, 0, 4u32.to_le_bytes()));
    b.sdo([0x0A, 0, 0, 0, 0, 0, 0, 0]);
    b.advance_ms(999);
    b.poll();
    assert!(b.take().is_empty());
    b.advance_ms(2);
    b.poll();
    let out: Vec<_> = b.take().into_iter().filter(|f| f.id != HEARTBEAT).collect();
    assert_eq!(out.len(), 1);
    assert_eq!(out[0].id, SDO_TX);
    check_mux(&out[0].data, idx, 0);
    assert_eq!(abort_code(&out[0].data), TIMEOUT);
    let r = b.sdo([0x1B, 0x10, 0x43, 0, 0, 0, 0, 0]);
    assert_eq!(abort_code(&r), BAD_CS);
    assert_eq!(state(&b.app), before);
}

#[test]
fn out_of_range_config_values_abort_with_range_codes_and_change_nothing() {
    let mut b = Bench::new();
    let idx = obj("bar_length");
    let before = state(&b.app);
    assert_eq!(b.write_f32(idx, 0, 601.0), Err(TOO_HIGH));
    assert_eq!(b.write_f32(idx, 0, 49.0), Err(TOO_LOW));
    assert_eq!(b.write_f32(idx, 0, f32::NAN), Err(INVALID));
    assert_eq!(b.write_f32(idx, 0, f32::INFINITY), Err(TOO_HIGH));
    assert_eq!(b.write_f32(idx, 0, f32::NEG_INFINITY), Err(TOO_LOW));
    assert_eq!(state(&b.app), before);
    // Excitation 20 kHz / 1 kHz = 20 periods a sample, more than the ADC ring's 5: a
    // cross-field rule; 5 kHz samples, then a 10 kHz excitation (2 periods) pass.
    let exc = obj("excitation");
    assert_eq!(b.write_f32(exc, 0, 20000.0), Err(INCOMPATIBLE));
    assert_eq!(state(&b.app), before);
    b.write_f32(obj("sample_rate"), 0, 5000.0).unwrap();
    b.write_f32(exc, 0, 10000.0).unwrap();
    assert_eq!(
        (b.app.config().excitation_hz, b.app.config().sample_rate_hz),
        (10000.0, 5000.0)
    );
    let after_rate = state(&b.app);
    // Enumerated fields (0x2040 lvdt_input, 0x2041 can_bitrate, 0x2042 axis_name,
    // 0x2043 axis_reversed).
    assert_eq!(b.download(0x2040, 0, &[2]), Err(TOO_HIGH));
    assert_eq!(b.download(0x2041, 0, &[4]), Err(TOO_HIGH));
    assert_eq!(b.download(0x2042, 1, &[7]), Err(TOO_HIGH));
    assert_eq!(
        b.download(0x2042, 1, &[2]),
        Err(INCOMPATIBLE),
        "Y is input 2's"
    );
    assert_eq!(
        b.download(0x2043, 1, &[2]),
        Err(INVALID),
        "BOOLEAN is 0 or 1"
    );
    assert_eq!(state(&b.app), after_rate);
    // and the accepted ones land in the configuration
    b.download(0x2040, 0, &[1]).unwrap();
    b.download(0x2041, 0, &[3]).unwrap();
    b.download(0x2042, 5, &[4]).unwrap();
    b.download(0x2043, 2, &[1]).unwrap();
    let c = b.app.config();
    assert_eq!(c.lvdt_input, ballpod::config::LvdtInput::DcConditioner);
    assert_eq!(c.can_bitrate.bits_per_s(), 1_000_000);
    assert_eq!(c.axes[4].name, ballpod::config::AxisName::A);
    assert!(c.axes[1].reversed);
}

#[test]
fn config_writes_only_in_pre_operational() {
    let mut b = Bench::new();
    b.start();
    let idx = obj("bar_length");
    let before = state(&b.app);
    assert_eq!(b.write_f32(idx, 0, 200.0), Err(WRONG_STATE));
    assert_eq!(b.download(0x2040, 0, &[1]), Err(WRONG_STATE));
    assert_eq!(b.download(obj("can_node_id"), 0, &[20]), Err(WRONG_STATE));
    assert_eq!(state(&b.app), before);
    // Reading is fine in operational.
    assert_eq!(b.upload(idx, 0).unwrap(), 150.0f32.to_le_bytes());
}

#[test]
fn access_and_addressing_aborts() {
    let mut b = Bench::new();
    assert_eq!(b.download(0x1000, 0, &[0, 0, 0, 0]), Err(READ_ONLY));
    assert_eq!(b.download(0x2100, 1, &[0, 0, 0, 0]), Err(READ_ONLY));
    assert_eq!(b.download(0x3003, 0, &[0]), Err(READ_ONLY));
    assert_eq!(b.upload(0x3002, 0), Err(WRITE_ONLY));
    assert_eq!(b.upload(0x2FFF, 0), Err(NO_OBJECT));
    assert_eq!(b.upload(0x6000, 0), Err(NO_OBJECT));
    assert_eq!(b.upload(0x1018, 5), Err(NO_SUB));
    assert_eq!(b.upload(0x1000, 1), Err(NO_SUB));
    assert_eq!(b.upload(0x1800, 4), Err(NO_SUB), "reserved sub-index");
    // Length: 2 bytes to a REAL32, 4 bytes to an UNSIGNED16.
    let idx = obj("bar_length");
    assert_eq!(b.download(idx, 0, &[0, 0]), Err(LENGTH));
    assert_eq!(b.download(0x1017, 0, &[0, 0, 0, 0]), Err(LENGTH));
    let r = b.sdo(req(0x21, idx, 0, 8u32.to_le_bytes()));
    assert_eq!(abort_code(&r), LENGTH, "segmented, indicated size ≠ 4");
}

#[test]
fn segmented_download_longer_than_the_object_aborts() {
    let mut b = Bench::new();
    let idx = obj("bar_length");
    b.sdo(req(0x20, idx, 0, [0; 4]));
    let r = b.sdo([0x00, 1, 2, 3, 4, 5, 6, 7]);
    assert_eq!(abort_code(&r), LENGTH);
    // Too short at the last segment.
    b.sdo(req(0x20, idx, 0, [0; 4]));
    let r = b.sdo([0x0D, 1, 0, 0, 0, 0, 0, 0]); // n = 6 unused, c = 1: 1 byte
    assert_eq!(abort_code(&r), LENGTH);
    assert_eq!(state(&b.app), state(&fresh_app()));
}

#[test]
fn malformed_and_unsupported_sdo_requests() {
    let mut b = Bench::new();
    // A request shorter than 8 bytes.
    b.rx(SDO_RX, &[0x40, 0x00, 0x10]);
    let out = b.take();
    assert_eq!(out.len(), 1);
    assert_eq!(abort_code(&out[0].data), BAD_CS);
    // Block download (ccs 6), block upload (ccs 5), ccs 7.
    for b0 in [0xC0u8, 0xA0, 0xE0] {
        let r = b.sdo(req(b0, 0x1008, 0, [0; 4]));
        assert_eq!(abort_code(&r), BAD_CS, "cs {b0:#04x}");
    }
    // A download segment without a transfer.
    let r = b.sdo([0x00, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(abort_code(&r), BAD_CS);
    assert_eq!(state(&b.app), state(&fresh_app()));
}

#[test]
fn client_abort_ends_the_transfer_silently() {
    let mut b = Bench::new();
    b.sdo(req(0x40, 0x1008, 0, [0; 4]));
    b.rx(SDO_RX, &req(0x80, 0x1008, 0, 0x0504_0000u32.to_le_bytes()));
    assert!(b.take().is_empty());
    let r = b.sdo([0x60, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(abort_code(&r), BAD_CS);
}

#[test]
fn store_and_restore_need_their_signatures() {
    // CiA 301 §7.5.2.13/14: "save" = 0x65766173, "load" = 0x64616F6C; bit 0 of sub 1 = the
    // device saves on command.
    let mut b = Bench::new();
    assert_eq!(b.read_u32(0x1010, 1) & 1, 1, "saves on command");
    assert_eq!(b.read_u32(0x1011, 1) & 1, 1, "restores on command");
    assert_eq!(b.download(0x1010, 1, b"SAVE"), Err(CANNOT_STORE));
    assert_eq!(b.app.take_settings_request(), None);
    assert_eq!(b.download(0x1010, 1, b"save"), Ok(()));
    assert_eq!(b.app.take_settings_request(), Some(SettingsRequest::Store));
    assert_eq!(b.download(0x1011, 1, b"save"), Err(CANNOT_STORE));
    assert_eq!(b.app.take_settings_request(), None);
    assert_eq!(b.download(0x1011, 1, b"load"), Ok(()));
    assert_eq!(
        b.app.take_settings_request(),
        Some(SettingsRequest::RestoreDefaults)
    );
    // not while a run is armed (the flash work would stall the sampling): 0x0800 0022, as
    // SCPI's *SAV gets -221 — one rule, the application's
    b.download(0x3000, 0, &[PAT_PROBE]).unwrap();
    b.command(CMD_ARM).unwrap();
    assert_eq!(b.app.session(), SessionState::Armed);
    assert_eq!(b.download(0x1010, 1, b"save"), Err(WRONG_STATE));
    assert_eq!(b.download(0x1011, 1, b"load"), Err(WRONG_STATE));
    assert_eq!(b.app.take_settings_request(), None);
}

// ---------------------------------------------------------------------------------------------
// Session control (0x3000–0x3007): the application accepts or refuses, a refusal is aborted
// with 0x0800 0022 and 0x3006 says why
// ---------------------------------------------------------------------------------------------

#[test]
fn session_control_by_sdo() {
    let mut b = Bench::new();
    b.download(0x3000, 0, &[PAT_BX]).unwrap();
    b.download(0x3001, 0, &[1]).unwrap();
    assert_eq!(
        (b.app.pattern(), b.app.direction()),
        (Pattern::Bx, Direction::Cw)
    );
    assert_eq!(b.upload(0x3000, 0).unwrap(), [PAT_BX]);
    assert_eq!(b.upload(0x3001, 0).unwrap(), [1]);
    assert_eq!(b.download(0x3000, 0, &[8]), Err(TOO_HIGH));
    assert_eq!(b.download(0x3001, 0, &[2]), Err(TOO_HIGH));
    assert_eq!(b.command(0), Err(TOO_LOW));
    assert_eq!(b.command(9), Err(TOO_HIGH));
    assert_eq!(b.command(CMD_START), Err(WRONG_STATE), "start while idle");
    assert_eq!(b.text(0x3006), "START needs ARMED");
    assert_eq!(b.session_state(), ST_IDLE);

    // CIRCLE with its geometry written over SDO: arm, start, stop.
    b.download(0x3000, 0, &[PAT_CIRCLE]).unwrap();
    b.set_circle_geometry();
    b.command(CMD_ARM).unwrap();
    assert_eq!(b.session_state(), ST_ARMED);
    assert_eq!(b.download(0x3000, 0, &[PAT_BX]), Err(WRONG_STATE));
    assert_eq!(b.text(0x3006), "not while a run is armed or running");
    assert_eq!(b.download(0x3001, 0, &[0]), Err(WRONG_STATE));
    assert_eq!(b.command(CMD_ARM), Err(WRONG_STATE));
    assert_eq!(b.command(CMD_STOP), Err(WRONG_STATE));
    assert_eq!(b.command(CMD_CLEAR), Err(WRONG_STATE));
    b.command(CMD_START).unwrap();
    assert_eq!(b.session_state(), ST_RUNNING);
    assert_eq!(b.command(CMD_START), Err(WRONG_STATE));
    // Stopped without a single sample: the run has no results and is aborted as not
    // observable (0x3004 code 4).
    b.command(CMD_STOP).unwrap();
    assert_eq!(b.session_state(), ST_ABORTED);
    assert_eq!(b.upload(0x3004, 0).unwrap(), [REASON_UNOBSERVABLE]);
    assert_eq!(b.command(CMD_ABORT), Err(WRONG_STATE));
    assert_eq!(b.text(0x3006), "ABORT needs ARMED or RUNNING");

    // Session commands also work in operational (only configuration is pre-operational only).
    b.start();
    b.command(CMD_ARM).unwrap();
    assert_eq!(b.session_state(), ST_ARMED);
    assert_eq!(b.upload(0x3004, 0).unwrap(), [0], "no reason while armed");
    b.command(CMD_ABORT).unwrap();
    assert_eq!(b.session_state(), ST_ABORTED);
    assert_eq!(b.upload(0x3004, 0).unwrap(), [REASON_COMMAND]);
    b.command(CMD_CLEAR).unwrap();
    b.command(CMD_RESET).unwrap();
    assert_eq!(b.session_state(), ST_IDLE);
    assert_eq!(b.upload(0x3004, 0).unwrap(), [0]);
}

#[test]
fn a_pattern_armed_without_its_geometry_is_refused_naming_the_field() {
    let mut b = Bench::new();
    // CIRCLE needs the centre's in-plane coordinates and the radius (set-up fields, not set by
    // default).
    assert_eq!(b.command(CMD_ARM), Err(WRONG_STATE));
    assert_eq!(b.text(0x3006), "circle_centre_x not set");
    b.write_f32(obj("circle_centre_x"), 0, 0.0).unwrap();
    assert_eq!(b.command(CMD_ARM), Err(WRONG_STATE));
    assert_eq!(b.text(0x3006), "circle_centre_y not set");
    b.write_f32(obj("circle_centre_y"), 0, 0.0).unwrap();
    assert_eq!(b.command(CMD_ARM), Err(WRONG_STATE));
    assert_eq!(b.text(0x3006), "circle_radius not set");
    assert_eq!(b.session_state(), ST_IDLE);
    b.write_f32(obj("circle_radius"), 0, 150.0).unwrap();
    b.command(CMD_ARM).unwrap();
    assert_eq!(b.session_state(), ST_ARMED);
    b.command(CMD_ABORT).unwrap();
    // A seed 002 step needs the Table 4.3 quantities: L_B first.
    b.download(0x3000, 0, &[PAT_BX]).unwrap();
    assert_eq!(b.command(CMD_ARM), Err(WRONG_STATE));
    assert_eq!(b.text(0x3006), "s002_l_b not set");
    assert_eq!(b.session_state(), ST_ABORTED);
    // The procedure note is empty while no procedure step had anything to say.
    assert_eq!(b.text(0x3007), "");
}

#[test]
fn a_config_write_while_running_is_refused_by_both_protocols_the_same_way() {
    let mut b = Bench::new();
    b.run_circle();
    let before = state(&b.app);
    let config_before = format!("{:?}", b.app.config());
    // CANopen (pre-operational, so only the application's rule applies).
    assert_eq!(b.write_f32(obj("bar_length"), 0, 200.0), Err(WRONG_STATE));
    assert_eq!(b.text(0x3006), "not while a run is armed or running");
    assert_eq!(b.download(obj("can_node_id"), 0, &[20]), Err(WRONG_STATE));
    assert_eq!(b.download(0x2042, 1, &[4]), Err(WRONG_STATE));
    assert_eq!(state(&b.app), before);
    // SCPI on the same application.
    let mut scpi = ScpiServer::new();
    let log = SampleLog::<4>::new();
    let mut out = Vec::new();
    scpi.feed(
        b"CONF:UNL;:CONF:BAR_LENGTH 200;:CONF:AXIS1:NAME A;:SYST:ERR?;ERR?;ERR?\n",
        &mut b.app,
        &log,
        &mut |r: &[u8]| out.extend_from_slice(r),
    );
    assert_eq!(
        String::from_utf8(out).unwrap(),
        "-221,\"Settings conflict;not while a run is armed or running\";\
         -221,\"Settings conflict;not while a run is armed or running\";0,\"No error\"\n"
    );
    assert_eq!(format!("{:?}", b.app.config()), config_before);
    assert_eq!(b.session_state(), ST_RUNNING);
}

#[test]
fn a_refusal_over_scpi_is_the_same_text_in_0x3006() {
    let mut b = Bench::new();
    let mut scpi = ScpiServer::new();
    let log = SampleLog::<4>::new();
    let mut out = Vec::new();
    scpi.feed(
        b"SESS:PATT CR2;ARM;:SYST:ERR?\n",
        &mut b.app,
        &log,
        &mut |r: &[u8]| out.extend_from_slice(r),
    );
    assert_eq!(
        String::from_utf8(out).unwrap(),
        "-221,\"Settings conflict;s002_l_b not set\"\n"
    );
    assert_eq!(b.upload(0x3000, 0).unwrap(), [5], "CR2 = code 5");
    assert_eq!(b.text(0x3006), "s002_l_b not set");
}

// ---------------------------------------------------------------------------------------------
// Results (0x4000–0x4002): "no data available" until valid
// ---------------------------------------------------------------------------------------------

#[test]
fn results_read_only_when_valid() {
    let mut b = Bench::new();
    let n = ResultInfo::all().count();
    assert_eq!(n, 131);
    for index in [0x4000u16, 0x4001, 0x4002] {
        assert_eq!(b.upload(index, 0).unwrap(), [n as u8], "{index:04X}:0");
        assert_eq!(b.upload(index, n as u8 + 1), Err(NO_SUB));
    }
    // Nothing computed: every value and uncertainty aborts "no data", every flag reads FALSE.
    for k in 1..=n as u8 {
        assert_eq!(b.upload(0x4000, k), Err(NO_DATA), "4000:{k}");
        assert_eq!(b.upload(0x4001, k), Err(NO_DATA), "4001:{k}");
        assert_eq!(b.upload(0x4002, k).unwrap(), [0], "BOOLEAN FALSE");
    }
    // A complete CCW circle of the forward model: the run's fit is valid.
    b.run_circle();
    b.command(CMD_STOP).unwrap();
    assert_eq!(b.session_state(), ST_DONE);
    // the run's fit is a job's (status bit 6 COMPUTING): no data until it ends
    assert_eq!(b.upload(0x4000, result_sub("ecc_u")), Err(NO_DATA));
    b.run_jobs();
    for (name, want) in [("ecc_u", E_UM[0]), ("ecc_v", E_UM[1]), ("r0", R0_UM)] {
        let k = result_sub(name);
        assert_eq!(b.upload(0x4002, k).unwrap(), [1], "{name} valid");
        close(b.read_f32(0x4000, k), want, 1e-3, name);
        let u = b.read_f32(0x4001, k);
        assert!(u.is_finite() && u >= 0.0, "{name} u = {u}");
    }
    // The model is an exact limaçon: the residuals are rounding only.
    close(
        b.read_f32(0x4000, result_sub("residual_rms")),
        0.0,
        1e-3,
        "rms",
    );
    close(b.read_f32(0x4000, result_sub("arc")), 360.0, 0.01, "arc");
    // Bi-directional results need a CW run too; the seed 002 ones a procedure.
    for name in [
        "G_bidir", "H", "G_cw", "e_BX_x", "dx_BT", "ssm_ex", "sphere_x",
    ] {
        let k = result_sub(name);
        assert_eq!(b.upload(0x4000, k), Err(NO_DATA), "{name}");
        assert_eq!(b.upload(0x4001, k), Err(NO_DATA), "{name}");
        assert_eq!(b.upload(0x4002, k).unwrap(), [0], "{name}");
    }
    // CLEAR forgets them.
    b.command(CMD_CLEAR).unwrap();
    assert_eq!(b.upload(0x4000, result_sub("ecc_u")), Err(NO_DATA));
    assert_eq!(b.upload(0x4002, result_sub("ecc_u")).unwrap(), [0]);
}

#[test]
fn touch_points_of_a_probe_run() {
    let mut b = Bench::new();
    let max = ballpod::app::probe::MAX_TOUCHES as u8;
    assert_eq!(b.upload(0x3008, 0).unwrap(), [0]);
    assert_eq!(b.upload(0x3009, 0).unwrap(), [max]);
    assert_eq!(b.upload(0x3009, 1), Err(NO_DATA));
    b.download(0x3000, 0, &[PAT_PROBE]).unwrap();
    b.command(CMD_ARM).unwrap();
    b.command(CMD_START).unwrap();
    let points = [
        [10.0f32, 20.0, -5.0],
        [10.5, 19.25, -5.125],
        [9.75, 20.5, -4.5],
    ];
    for (k, p) in points.iter().enumerate() {
        b.feed(Sample {
            temp_c: 20.0,
            ..Sample::default()
        });
        let t = Touch {
            t_us: 5_000_000 + k as u64 * 1000,
            axes: [p[0], p[1], p[2], 0.0, 0.0],
        };
        b.app.on_recorded_touch(&t, &mut ());
    }
    assert_eq!(b.upload(0x3008, 0).unwrap(), [3]);
    for (k, p) in points.iter().enumerate() {
        for (axis, index) in [0x3009u16, 0x300A, 0x300B].into_iter().enumerate() {
            assert_eq!(
                b.read_f32(index, k as u8 + 1),
                p[axis],
                "touch {k} axis {axis}"
            );
        }
    }
    assert_eq!(b.upload(0x3009, 4), Err(NO_DATA));
    assert_eq!(b.upload(0x300B, max + 1), Err(NO_SUB));
}

// ---------------------------------------------------------------------------------------------
// Live values (0x2100–0x2103): NaN while invalid, with the validity bit clear
// ---------------------------------------------------------------------------------------------

#[test]
fn invalid_live_values_read_nan_with_their_valid_bit_clear() {
    let mut b = Bench::new();
    assert_eq!(b.upload(0x2100, 0).unwrap(), [14]);
    for k in 1..=14 {
        assert!(b.read_f32(0x2100, k).is_nan(), "2100:{k} before any sample");
    }
    assert_eq!(b.upload(0x2103, 0).unwrap(), [0, 0], "UNSIGNED16 mask");
    // An idle sample: ΔL and the temperature are valid, the fits are not.
    b.feed(Sample {
        delta_l_um: 1.5,
        temp_c: 20.25,
        ..Sample::default()
    });
    assert_eq!(b.read_f32(0x2100, 1), 1.5);
    assert_eq!(b.read_f32(0x2100, 8), 20.25);
    for k in (2..=7).chain(9..=14) {
        assert!(b.read_f32(0x2100, k).is_nan(), "2100:{k}");
    }
    assert_eq!(b.read_u32(0x2103, 0), u32::from(LIVE_DL | LIVE_TEMP));
    assert_eq!(b.read_u32(0x2101, 0), b.seq - 1, "sample counter");
    // The LVDT open: ΔL invalid, NaN, bit 0 clear; a thermistor fault: the temperature too.
    b.feed(Sample {
        delta_l_um: 0.0,
        temp_c: 20.25,
        flags: SampleFlags::LVDT_OPEN,
        ..Sample::default()
    });
    assert!(b.read_f32(0x2100, 1).is_nan());
    assert_eq!(b.read_u32(0x2103, 0), u32::from(LIVE_TEMP));
    b.feed(Sample {
        delta_l_um: -2.0,
        temp_c: 20.0,
        flags: SampleFlags::TEMPERATURE_FAULT,
        ..Sample::default()
    });
    assert_eq!(b.read_f32(0x2100, 1), -2.0);
    assert!(b.read_f32(0x2100, 8).is_nan());
    assert_eq!(b.read_u32(0x2103, 0), u32::from(LIVE_DL));
    // A running circle: e and r0 become valid once the minimum arc (300° by default) is
    // turned; the SSM components stay invalid.
    b.set_circle_geometry();
    b.command(CMD_ARM).unwrap();
    b.command(CMD_START).unwrap();
    for k in 0..=STEPS / 2 {
        b.feed(circle_sample(k));
    }
    assert!(
        b.read_f32(0x2100, 5).is_nan(),
        "half a turn: e not observable"
    );
    assert_eq!(b.read_u32(0x2103, 0) as u16 & LIVE_ECC_U, 0);
    for k in STEPS / 2 + 1..=STEPS {
        b.feed(circle_sample(k));
    }
    // the fit and, refreshed every 32 samples since it became observable, its u
    assert_eq!(
        b.read_u32(0x2103, 0) as u16,
        LIVE_DL | LIVE_ECC_U | LIVE_ECC_V | LIVE_R0 | LIVE_TEMP | LIVE_FIT_U
    );
    close(b.read_f32(0x2100, 5), E_UM[0], 1e-3, "e_u");
    close(b.read_f32(0x2100, 6), E_UM[1], 1e-3, "e_v");
    close(b.read_f32(0x2100, 7), R0_UM, 1e-3, "r0");
    for k in 12..=14 {
        let u = b.read_f32(0x2100, k);
        assert!(u.is_finite() && u >= 0.0, "2100:{k} = {u}");
    }
    for k in (2..=4).chain(9..=11) {
        assert!(b.read_f32(0x2100, k).is_nan(), "SSM 2100:{k}");
    }
}

// ---------------------------------------------------------------------------------------------
// SYNC and TPDOs (CiA 301 §7.2.2, §7.2.5, §7.5.2.35–38)
// ---------------------------------------------------------------------------------------------

fn cat(parts: &[&[u8]]) -> Vec<u8> {
    parts.concat()
}

fn f32_at(p: &[u8], at: usize) -> f32 {
    f32::from_le_bytes(p[at..at + 4].try_into().unwrap())
}

#[test]
fn default_tpdos_on_sync_carry_the_live_values() {
    let mut b = Bench::new();
    b.run_circle();
    b.rx(0x080, &[]);
    assert!(b.take().is_empty(), "no PDO in pre-operational");
    b.start();
    b.rx(0x080, &[]);
    let out = b.take();
    let n = u16::from(NODE);
    assert_eq!(out.len(), 3, "TPDO1–3 enabled, TPDO4 not: {out:?}");
    // TPDO1: ΔL of the last sample (REAL32) + its sample counter (UNSIGNED32).
    let last = circle_sample(STEPS);
    assert_eq!(out[0].id, 0x180 + n);
    assert_eq!(
        out[0].payload(),
        cat(&[&last.delta_l_um.to_le_bytes(), &(b.seq - 1).to_le_bytes()])
    );
    // TPDO2: e_u, e_v of the running fit.
    assert_eq!(out[1].id, 0x280 + n);
    assert_eq!(out[1].len, 8);
    close(f32_at(out[1].payload(), 0), E_UM[0], 1e-3, "TPDO2 e_u");
    close(f32_at(out[1].payload(), 4), E_UM[1], 1e-3, "TPDO2 e_v");
    // TPDO3: r0 + status word (running, live valid) + live-valid mask.
    assert_eq!(out[2].id, 0x380 + n);
    let p = out[2].payload();
    assert_eq!(p.len(), 8);
    close(f32_at(p, 0), R0_UM, 1e-3, "TPDO3 r0");
    assert_eq!(
        &p[4..6],
        &(STATUS_RUNNING | STATUS_LIVE_VALID).to_le_bytes()
    );
    assert_eq!(
        &p[6..8],
        &(LIVE_DL | LIVE_ECC_U | LIVE_ECC_V | LIVE_R0 | LIVE_TEMP | LIVE_FIT_U).to_le_bytes()
    );
    // The same values by SDO.
    let tpdo2 = out[1].payload().to_vec();
    let tpdo3 = out[2].payload().to_vec();
    assert_eq!(b.upload(0x2100, 1).unwrap(), last.delta_l_um.to_le_bytes());
    assert_eq!(b.read_u32(0x2101, 0), b.seq - 1);
    assert_eq!(b.upload(0x2100, 5).unwrap(), &tpdo2[0..4]);
    assert_eq!(b.upload(0x2100, 6).unwrap(), &tpdo2[4..8]);
    assert_eq!(b.upload(0x2100, 7).unwrap(), &tpdo3[0..4]);
    assert_eq!(b.upload(0x2102, 0).unwrap(), &tpdo3[4..6]);
    assert_eq!(b.upload(0x2103, 0).unwrap(), &tpdo3[6..8]);
}

#[test]
fn sync_with_counter_byte_is_accepted_longer_is_ignored() {
    let mut b = Bench::new();
    b.start();
    b.rx(0x080, &[7]);
    assert_eq!(b.take().len(), 3);
    b.rx(0x080, &[7, 8]);
    assert!(b.take().is_empty());
    assert_eq!(b.node.stats().frames_malformed, 1);
}

#[test]
fn transmission_type_n_sends_on_every_nth_sync() {
    let mut b = Bench::new();
    b.download(0x1800, 2, &[3]).unwrap();
    b.download(0x1801, 1, &(0x8000_0280u32 + u32::from(NODE)).to_le_bytes())
        .unwrap();
    b.download(0x1802, 1, &(0x8000_0380u32 + u32::from(NODE)).to_le_bytes())
        .unwrap();
    b.start();
    let mut sent_at = Vec::new();
    for k in 1..=9 {
        b.rx(0x080, &[]);
        if !b.take().is_empty() {
            sent_at.push(k);
        }
    }
    assert_eq!(sent_at, vec![3, 6, 9]);
    for t in [0u8, 241, 252, 253] {
        assert_eq!(b.download(0x1800, 2, &[t]), Err(INVALID), "type {t}");
    }
}

#[test]
fn remapping_follows_the_cia301_procedure() {
    let mut b = Bench::new();
    let cob = 0x180 + u32::from(NODE);
    // Mapping cannot change while the PDO is valid.
    assert_eq!(b.download(0x1A00, 0, &[0]), Err(UNSUPPORTED_ACCESS));
    // The COB-ID cannot change while valid.
    assert_eq!(b.download(0x1800, 1, &0x1A5u32.to_le_bytes()), Err(INVALID));
    // 1. invalidate, 2. sub 0 = 0, 3. entries, 4. sub 0 = n, 5. validate.
    b.download(0x1800, 1, &(cob | 0x8000_0000).to_le_bytes())
        .unwrap();
    assert_eq!(
        b.download(0x1A00, 1, &0x2101_0020u32.to_le_bytes()),
        Err(UNSUPPORTED_ACCESS),
        "sub 0 still ≠ 0"
    );
    b.download(0x1A00, 0, &[0]).unwrap();
    assert_eq!(
        b.download(0x1A00, 1, &0x2000_0020u32.to_le_bytes()),
        Err(NOT_MAPPABLE),
        "config"
    );
    assert_eq!(
        b.download(0x1A00, 1, &0x2101_0010u32.to_le_bytes()),
        Err(NOT_MAPPABLE),
        "16 of 32 bits"
    );
    assert_eq!(
        b.download(0x1A00, 1, &0x2FFF_0020u32.to_le_bytes()),
        Err(NOT_MAPPABLE),
        "no object"
    );
    assert_eq!(
        b.download(0x1A00, 1, &0x3006_0020u32.to_le_bytes()),
        Err(NOT_MAPPABLE),
        "a string"
    );
    b.download(0x1A00, 1, &0x2101_0020u32.to_le_bytes())
        .unwrap();
    b.download(0x1A00, 2, &0x2102_0010u32.to_le_bytes())
        .unwrap();
    b.download(0x1A00, 3, &0x2100_0120u32.to_le_bytes())
        .unwrap();
    assert_eq!(b.download(0x1A00, 0, &[3]), Err(PDO_LENGTH), "80 bits > 64");
    assert_eq!(b.download(0x1A00, 0, &[9]), Err(TOO_HIGH));
    b.download(0x1A00, 0, &[2]).unwrap();
    b.download(0x1800, 1, &cob.to_le_bytes()).unwrap();
    b.run_circle();
    b.start();
    b.rx(0x080, &[]);
    let out = b.take();
    assert_eq!(out[0].id, cob as u16);
    assert_eq!(
        out[0].payload(),
        cat(&[
            &(b.seq - 1).to_le_bytes(),
            &(STATUS_RUNNING | STATUS_LIVE_VALID).to_le_bytes()
        ])
    );
}

#[test]
fn event_timer_tpdo_with_type_254() {
    let mut b = Bench::new();
    // Disable TPDO1–3 and use TPDO4 (SSM E_x, E_y) event-driven every 100 ms.
    for k in 0..3u16 {
        let cob = [0x180u32, 0x280, 0x380][usize::from(k)] + u32::from(NODE);
        b.download(0x1800 + k, 1, &(cob | 0x8000_0000).to_le_bytes())
            .unwrap();
    }
    b.download(0x1803, 2, &[254]).unwrap();
    b.download(0x1803, 5, &100u16.to_le_bytes()).unwrap();
    b.download(0x1803, 1, &(0x480 + u32::from(NODE)).to_le_bytes())
        .unwrap();
    b.download(0x1017, 0, &0u16.to_le_bytes()).unwrap();
    // A circle run: the SSM components are not observable, so TPDO4 carries NaNs.
    b.run_circle();
    b.start();
    let mut times = Vec::new();
    for ms in 1..=350 {
        b.advance_ms(1);
        b.poll();
        for f in b.take() {
            assert_eq!(f.id, 0x480 + u16::from(NODE));
            assert_eq!(f.len, 8);
            assert!(f32_at(f.payload(), 0).is_nan(), "E_x invalid");
            assert!(f32_at(f.payload(), 4).is_nan(), "E_y invalid");
            times.push(ms);
        }
    }
    assert_eq!(times, vec![100, 200, 300]);
    b.rx(0x080, &[]);
    assert!(b.take().is_empty(), "type 254 ignores SYNC");
}

// ---------------------------------------------------------------------------------------------
// EMCY (CiA 301 §7.2.7) and the error register / pre-defined error field
// ---------------------------------------------------------------------------------------------

#[test]
fn new_fault_sends_one_emcy_and_sets_the_error_register() {
    let mut b = Bench::new();
    let emcy = 0x080 + u16::from(NODE);
    b.sample(SampleFlags::NONE);
    assert!(b.take().is_empty());
    b.sample(SampleFlags::LVDT_OPEN);
    let out = b.take();
    assert_eq!(out.len(), 1);
    assert_eq!(out[0].id, emcy);
    assert_eq!(out[0].len, 8);
    // Error code 0x5001 (0x50xx: device hardware) little-endian, then the error register with
    // bit 0 (generic) set.
    assert_eq!(&out[0].data[..2], &[0x01, 0x50]);
    assert_eq!(out[0].data[2] & 0x01, 0x01);
    assert_eq!(b.upload(0x1001, 0).unwrap(), [out[0].data[2]]);
    assert_eq!(b.upload(0x1003, 0).unwrap(), [1]);
    assert_eq!(b.read_u32(0x1003, 1) & 0xFFFF, 0x5001);
    // Persisting fault: no repeat.
    b.advance_ms(500);
    b.sample(SampleFlags::LVDT_OPEN);
    b.poll();
    assert!(b.take().iter().all(|f| f.id != emcy));
    // Cleared: "error reset" (code 0x0000) with the error register cleared.
    b.sample(SampleFlags::NONE);
    let out: Vec<_> = b.take().into_iter().filter(|f| f.id == emcy).collect();
    assert_eq!(out.len(), 1);
    assert_eq!(&out[0].data[..3], &[0, 0, 0]);
    assert_eq!(b.upload(0x1001, 0).unwrap(), [0]);
    // Writing 0 to 0x1003:0 clears the history; anything else is refused.
    assert_eq!(b.download(0x1003, 0, &[1]), Err(TOO_HIGH));
    b.download(0x1003, 0, &[0]).unwrap();
    assert_eq!(b.upload(0x1003, 0).unwrap(), [0]);
}

#[test]
fn emcy_respects_the_inhibit_time_and_reports_every_fault() {
    let mut b = Bench::new();
    let emcy = 0x080 + u16::from(NODE);
    b.sample(SampleFlags::OVERRUN);
    b.sample(SampleFlags::LVDT_OVER_RANGE.with(SampleFlags::OVERRUN));
    let n = b.take().iter().filter(|f| f.id == emcy).count();
    assert_eq!(n, 1, "second fault waits for the 100 ms inhibit time");
    b.advance_ms(100);
    b.poll();
    let out: Vec<_> = b.take().into_iter().filter(|f| f.id == emcy).collect();
    assert_eq!(out.len(), 1);
    assert_eq!(&out[0].data[..2], &[0x02, 0x50], "LVDT over-range 0x5002");
}

#[test]
fn no_emcy_in_stopped() {
    let mut b = Bench::new();
    b.nmt(0x02, NODE);
    b.sample(SampleFlags::LVDT_OPEN);
    assert!(b.take().is_empty());
    assert_ne!(
        b.node.error_register(),
        0,
        "the register still shows the fault"
    );
}

/// Issue 7: the reason of the previous reset (panic, watchdog) is reported once after boot-up:
/// EMCY 0x6000 "software, generic" (CiA 301 table 21) with the reason in byte 3, and the
/// code in the error history 0x1003.
#[test]
fn a_panic_found_at_boot_is_reported_by_one_emcy_after_boot_up() {
    let mut b = Bench::unbooted();
    b.node.report_boot_error(0x6000, 1);
    b.poll();
    assert_eq!(
        b.take(),
        vec![
            frame(HEARTBEAT, &[0x00]),
            // code 0x6000 LE, error register bit 0 (generic), byte 3 = 1 (panic), no faults
            frame(0x080 + NODE as u16, &[0x00, 0x60, 0x01, 0x01, 0, 0, 0, 0]),
        ]
    );
    assert_eq!(b.upload(0x1003, 0).unwrap(), [1]);
    assert_eq!(b.read_u32(0x1003, 1) & 0xFFFF, 0x6000);
    // Reported once: a reset communication boots again without it.
    b.rx(0x000, &[0x82, NODE]);
    assert_eq!(b.take(), vec![frame(HEARTBEAT, &[0x00])]);
}

/// A healthy AC block of LVDT ratio 0.1 (ΔL is not what these tests look at).
fn healthy_block() -> ballpod::acquisition::lvdt::BlockReading {
    ballpod::acquisition::lvdt::BlockReading::Ac(Ok(ballpod::acquisition::lvdt::LvdtReading {
        ratio: 0.1,
        signal_level: 1000.0,
        iq_a: [0.0; 2],
        clipped: false,
    }))
}

impl Bench {
    /// One sample through the acquisition with the hardware encoder counters `raw` (16-bit).
    fn raw_sample(&mut self, raw: [u32; MAX_AXES]) -> Sample {
        self.seq += 1;
        let t = 1_000_000 + u64::from(self.seq) * 1000;
        self.app.on_raw_sample(t, healthy_block(), raw, 0, &mut ())
    }
}

#[test]
fn axes_are_referenced_over_sdo_where_they_stand_and_count_on_from_there() {
    // Forward model of a 16-bit quadrature counter: position = reference + (counts moved,
    // through the wrap) / counts_per_unit, negated for a reversed input (defaults: 10 000
    // counts per mm or degree; inputs X Y Z B C).
    let mut b = Bench::new();
    let axis = 0x300C;
    // before the first reading there is no count to reference
    assert_eq!(b.write_f32(axis, 1, 100.0), Err(WRONG_STATE));
    assert!(
        b.text(0x3006).contains("not read yet"),
        "{}",
        b.text(0x3006)
    );
    let raw0 = [65_000, 12, 40_000, 7, 0];
    let s = b.raw_sample(raw0);
    assert_eq!(
        s.axes[0], 0.0,
        "unreferenced: counts from the first reading"
    );
    // X at 100 mm, B at −30°, in pre-operational and in operational alike
    b.write_f32(axis, 1, 100.0).unwrap();
    b.start();
    b.write_f32(axis, 4, -30.0).unwrap();
    assert_eq!(b.read_f32(axis, 1), 100.0);
    assert_eq!(b.read_f32(axis, 4), -30.0);
    // X moves +1234 counts through the wrap, B −500 counts through zero
    let s = b.raw_sample([(65_000 + 1_234) % 65_536, 12, 40_000, 65_536 - 493, 0]);
    let expect = |reference: f64, counts: f64| (reference + counts / 10_000.0) as f32;
    assert_eq!(s.axes[0], expect(100.0, 1_234.0));
    assert_eq!(s.axes[3], expect(-30.0, -500.0));
    assert_eq!(b.read_f32(axis, 1), expect(100.0, 1_234.0));
    // the bounds of the object (±10 000 mm or degrees, the EDS's limits) and NaN
    b.write_f32(axis, 2, 10_000.0).unwrap();
    b.write_f32(axis, 2, -10_000.0).unwrap();
    assert_eq!(b.read_f32(axis, 2), -10_000.0);
    assert_eq!(b.write_f32(axis, 2, 10_000.5), Err(TOO_HIGH));
    assert_eq!(b.write_f32(axis, 2, -10_000.5), Err(TOO_LOW));
    assert_eq!(b.write_f32(axis, 2, f32::NAN), Err(INVALID));
    assert_eq!(b.download(axis, 6, &1.0f32.to_le_bytes()), Err(NO_SUB));
    // not while a run is armed or running
    b.download(0x3000, 0, &[PAT_PROBE]).unwrap();
    b.command(CMD_ARM).unwrap();
    assert_eq!(b.write_f32(axis, 1, 0.0), Err(WRONG_STATE));
    assert_eq!(b.text(0x3006), "not while a run is armed or running");
    b.command(CMD_ABORT).unwrap();
    // a reversed input counts down in the positive direction
    b.nmt(0x80, NODE); // pre-operational: configuration
    b.download(0x2043, 2, &[1]).unwrap();
    b.write_f32(axis, 2, 50.0).unwrap();
    let s = b.raw_sample([(65_000 + 1_234) % 65_536, 12 + 250, 40_000, 65_536 - 493, 0]);
    assert_eq!(s.axes[1], expect(50.0, -250.0));
}

#[test]
fn referencing_an_axis_forgets_the_runs_measured_in_the_old_coordinates() {
    let mut b = Bench::new();
    b.raw_sample([0; MAX_AXES]);
    b.run_circle();
    b.command(CMD_STOP).unwrap();
    b.run_jobs();
    let ecc_u = result_sub("ecc_u");
    assert_eq!(b.read_u32(0x4002, ecc_u), 1, "the run's result is valid");
    b.write_f32(0x300C, 1, 0.0).unwrap();
    assert_eq!(b.upload(0x4000, ecc_u), Err(NO_DATA), "as after command 5");
}

/// The controller's acceptance filters (`CanOpenNode::accepted_ids`) against the node's own
/// handling of every standard COB-ID: a frame whose ID is not in the list is one the node
/// ignores (nothing sent, counted in `frames_ignored`), and each listed ID is one a frame
/// reaches — in pre-operational and operational, after the SYNC COB-ID moves (0x1005), and
/// with no node-ID (LSS only).
#[test]
fn the_acceptance_filters_pass_every_frame_the_node_consumes() {
    // NMT start, an empty SYNC, an SDO upload of 0x1000, an LSS switch-state-global, a few
    // other shapes
    let payloads: [&[u8]; 6] = [
        &[0x01, 0],
        &[],
        &[0x40, 0x00, 0x10, 0, 0, 0, 0, 0],
        &[0x04, 0x01, 0, 0, 0, 0, 0, 0],
        &[0x80, NODE],
        &[0xFF; 8],
    ];
    for setup in ["pre-operational", "operational", "sync 0x0A0", "no node-ID"] {
        let mut b = Bench::new();
        match setup {
            "operational" => b.nmt(0x01, NODE),
            "sync 0x0A0" => b.download(0x1005, 0, &0xA0u32.to_le_bytes()).unwrap(),
            "no node-ID" => {
                b.node = CanOpenNode::new(255, 1);
                b.poll();
            }
            _ => {}
        }
        b.take();
        let ids = b.node.accepted_ids();
        let expected_sync = if setup == "sync 0x0A0" { 0x0A0 } else { 0x080 };
        let expected_sdo = (setup != "no node-ID").then_some(SDO_RX);
        assert_eq!(
            ids,
            [Some(0x000), Some(expected_sync), expected_sdo, Some(0x7E5)],
            "{setup}"
        );
        for id in 0..0x800u16 {
            let listed = ids.contains(&Some(id));
            let mut reached = false;
            for p in payloads {
                let (mut node, mut app) = (b.node, b.app.clone());
                let ignored = node.stats().frames_ignored;
                let mut out = Vec::new();
                node.on_frame(&frame(id, p), &mut app, 0, &mut |f| out.push(f));
                let was_ignored = node.stats().frames_ignored == ignored + 1;
                if !listed {
                    assert!(was_ignored && out.is_empty(), "{setup}: {id:#05x} {p:?}");
                }
                reached |= !was_ignored;
            }
            if listed && setup != "no node-ID" {
                assert!(reached, "{setup}: {id:#05x} listed but never consumed");
            }
        }
    }
}

/// Received frames the controller lost: EMCY 0x8110 (CAN overrun) with the communication bit
/// in its error register (CiA 301 table 21), at most one per inhibit time (0x1015) and none
/// while bus-off; a loss not reported yet is reported when the shell calls again.
#[test]
fn lost_frames_are_reported_as_emcy_8110_once_per_inhibit_time() {
    let mut b = Bench::new();
    // 0x1015 inhibit time, 100 µs units: 10 ms
    b.download(0x1015, 0, &100u16.to_le_bytes()).unwrap();
    let lost = |b: &mut Bench| {
        let sent = &mut b.sent;
        b.node.on_rx_lost(b.now_us, &mut |f| sent.push(f))
    };
    assert!(lost(&mut b));
    let out = b.take();
    assert_eq!(out.len(), 1);
    assert_eq!(out[0].id, 0x80 + u16::from(NODE));
    assert_eq!(out[0].data[..2], 0x8110u16.to_le_bytes());
    assert_eq!(
        out[0].data[2] & 0x11,
        0x11,
        "generic and communication bits"
    );
    // within the inhibit time: not now
    b.advance_ms(5);
    assert!(!lost(&mut b));
    assert!(b.take().is_empty());
    b.advance_ms(6);
    assert!(lost(&mut b));
    assert_eq!(b.take().len(), 1);
    // bus-off: nothing can be sent
    b.advance_ms(20);
    let sent = &mut b.sent;
    b.node.on_bus_state(
        ballpod::protocol::canopen::BusState::BusOff,
        b.now_us,
        &mut |f| sent.push(f),
    );
    b.take();
    assert!(!lost(&mut b));
    assert!(b.take().is_empty());
}
