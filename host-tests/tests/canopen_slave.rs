//! CANopen slave: NMT, heartbeat, SDO, SYNC/TPDO and EMCY checked against the frame layouts and
//! abort codes of CiA 301 (v4.2.0). Expected bytes are written out from the standard's tables,
//! not taken from the implementation.
use ballpod::acquisition::SampleFlags;
use ballpod::config::Config;
use ballpod::protocol::canopen::{CanFrame, CanOpenNode, NmtState};
use ballpod::protocol::pod::{
    Direction, Pattern, PodModel, ResultEntry, SessionCommand, SessionState, StatusWord,
};

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

struct Bench {
    node: CanOpenNode,
    pod: PodModel,
    now_us: u64,
    sent: Vec<CanFrame>,
}

impl Bench {
    /// A node that has booted (boot-up consumed) and is pre-operational.
    fn new() -> Self {
        let mut b = Self {
            node: CanOpenNode::new(NODE, 0x1234_5678),
            pod: PodModel::default(),
            now_us: 0,
            sent: Vec::new(),
        };
        b.poll();
        assert_eq!(b.take(), vec![frame(HEARTBEAT, &[0x00])]);
        b
    }
    fn rx(&mut self, id: u16, data: &[u8]) -> Option<SessionCommand> {
        let f = frame(id, data);
        let sent = &mut self.sent;
        self.node
            .on_frame(&f, &mut self.pod, self.now_us, &mut |f| sent.push(f))
    }
    fn poll(&mut self) {
        let sent = &mut self.sent;
        self.node
            .poll(self.now_us, &self.pod, &mut |f| sent.push(f));
    }
    fn sample(&mut self, flags: SampleFlags) {
        let sent = &mut self.sent;
        self.node
            .on_sample(flags, self.now_us, &mut |f| sent.push(f));
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
    fn nmt(&mut self, cs: u8, node: u8) -> Option<SessionCommand> {
        self.rx(0x000, &[cs, node])
    }
    /// Expedited upload; returns the data bytes (per the size indicated) or the abort code.
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
    /// Expedited download of `data` (1–4 bytes, size indicated): Ok or the abort code.
    fn download(
        &mut self,
        index: u16,
        sub: u8,
        data: &[u8],
    ) -> Result<Option<SessionCommand>, u32> {
        let n = 4 - data.len() as u8;
        let mut d = [0u8; 4];
        d[..data.len()].copy_from_slice(data);
        let f = frame(SDO_RX, &req(0x23 | n << 2, index, sub, d));
        let sent = &mut self.sent;
        let cmd = self
            .node
            .on_frame(&f, &mut self.pod, self.now_us, &mut |f| sent.push(f));
        let out = self.take();
        assert_eq!(out.len(), 1);
        let r = out[0].data;
        check_mux(&r, index, sub);
        match r[0] {
            0x60 => Ok(cmd),
            0x80 => {
                assert_eq!(
                    cmd, None,
                    "an aborted write asks nothing of the application"
                );
                Err(abort_code(&r))
            }
            b => panic!("unexpected download response {b:#04x}"),
        }
    }
    fn write_f32(&mut self, index: u16, sub: u8, v: f32) -> Result<Option<SessionCommand>, u32> {
        self.download(index, sub, &v.to_le_bytes())
    }
    fn read_u32(&mut self, index: u16, sub: u8) -> u32 {
        let d = self.upload(index, sub).unwrap();
        let mut b = [0u8; 4];
        b[..d.len()].copy_from_slice(&d);
        u32::from_le_bytes(b)
    }
    fn start(&mut self) {
        self.nmt(0x01, NODE);
        assert_eq!(self.node.state(), NmtState::Operational);
    }
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
    let before = b.pod;
    for id in [0x123u16, 0x601, 0x7FF, 0x200 + NODE as u16] {
        b.rx(id, &[1, 2, 3, 4, 5, 6, 7, 8]);
    }
    assert!(b.take().is_empty());
    assert_eq!(b.pod, before);
    assert_eq!(b.node.stats().frames_ignored, 4);
}

#[test]
fn reset_communication_restores_parameters_and_sends_boot_up() {
    let mut b = Bench::new();
    b.download(0x1017, 0, &250u16.to_le_bytes()).unwrap();
    b.start();
    assert_eq!(b.nmt(0x82, NODE), None);
    assert_eq!(b.take(), vec![frame(HEARTBEAT, &[0x00])], "boot-up");
    assert_eq!(b.node.state(), NmtState::PreOperational);
    assert_eq!(b.read_u32(0x1017, 0), 1000, "0x1017 back to its default");
}

#[test]
fn reset_node_asks_the_application_to_reset_and_takes_the_new_node_id() {
    let mut b = Bench::new();
    b.write_f32(0x2000 + field_index("can_node_id"), 0, 42.0)
        .unwrap();
    assert_eq!(b.node.node_id(), NODE, "the node-ID changes only at reset");
    assert_eq!(b.nmt(0x81, NODE), Some(SessionCommand::Reset));
    assert_eq!(b.take(), vec![frame(0x700 + 42, &[0x00])]);
    assert_eq!(b.node.node_id(), 42);
}

// ---------------------------------------------------------------------------------------------
// SDO (CiA 301 §7.2.4)
// ---------------------------------------------------------------------------------------------

fn field_index(name: &str) -> u16 {
    ballpod::config::FIELDS
        .iter()
        .position(|f| f.name == name)
        .unwrap() as u16
}

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
    let sw = b.upload(0x100A, 0).unwrap();
    assert!(
        String::from_utf8(sw)
            .unwrap()
            .contains(env!("CARGO_PKG_VERSION"))
    );
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
    let idx = 0x2000 + field_index("bar_length");
    assert_eq!(
        b.write_f32(idx, 0, 300.0),
        Ok(Some(SessionCommand::ConfigChanged))
    );
    assert_eq!(b.pod.config.bar_length_mm, 300.0);
    assert_eq!(b.upload(idx, 0).unwrap(), 300.0f32.to_le_bytes());
}

#[test]
fn indexed_config_fields_are_arrays() {
    let mut b = Bench::new();
    let idx = 0x2000 + field_index("axis_counts");
    assert_eq!(b.upload(idx, 0).unwrap(), [5], "sub 0 = number of inputs");
    b.write_f32(idx, 3, 2500.0).unwrap();
    assert_eq!(b.pod.config.axes[2].counts_per_unit, 2500.0);
    assert_eq!(b.write_f32(idx, 6, 2500.0), Err(NO_SUB));
    let poly = 0x2000 + field_index("lvdt_poly");
    b.write_f32(poly, 2, 1990.5).unwrap();
    assert_eq!(b.pod.config.lvdt_poly_um[1], 1990.5);
}

#[test]
fn segmented_download_applies_only_at_the_last_segment() {
    let mut b = Bench::new();
    let idx = 0x2000 + field_index("bar_length");
    let v = 222.5f32.to_le_bytes();
    // Initiate: ccs 1, e 0, s 1 → 0x21, size 4.
    let r = b.sdo(req(0x21, idx, 0, 4u32.to_le_bytes()));
    assert_eq!(r, req(0x60, idx, 0, [0; 4]));
    assert_eq!(b.pod.config.bar_length_mm, 150.0);
    // Segment: toggle 0, n = 7 − 4 = 3 unused, c = 1 → 0b000_0_011_1 = 0x07.
    let f = frame(SDO_RX, &[0x07, v[0], v[1], v[2], v[3], 0, 0, 0]);
    let sent = &mut b.sent;
    let cmd = b.node.on_frame(&f, &mut b.pod, 0, &mut |f| sent.push(f));
    assert_eq!(b.take(), vec![frame(SDO_TX, &[0x20, 0, 0, 0, 0, 0, 0, 0])]);
    assert_eq!(cmd, Some(SessionCommand::ConfigChanged));
    assert_eq!(b.pod.config.bar_length_mm, 222.5);
}

#[test]
fn segmented_download_over_two_segments_and_toggle_error() {
    let mut b = Bench::new();
    let idx = 0x2000 + field_index("bar_length");
    let v = 333.0f32.to_le_bytes();
    // Size not indicated (0x20); two segments of 2 bytes.
    b.sdo(req(0x20, idx, 0, [0; 4]));
    let r = b.sdo([0x0A, v[0], v[1], 0, 0, 0, 0, 0]); // t0, n = 5, c 0
    assert_eq!(r[0], 0x20);
    let r = b.sdo([0x1B, v[2], v[3], 0, 0, 0, 0, 0]); // t1, n = 5, c 1
    assert_eq!(r[0], 0x30, "toggle echoed");
    assert_eq!(b.pod.config.bar_length_mm, 333.0);

    let before = b.pod;
    b.sdo(req(0x21, idx, 0, 4u32.to_le_bytes()));
    let r = b.sdo([0x1A, v[0], v[1], 0, 0, 0, 0, 0]); // toggle 1 first: wrong
    check_mux(&r, idx, 0);
    assert_eq!(abort_code(&r), TOGGLE);
    assert_eq!(b.pod, before);
}

#[test]
fn segment_timeout_aborts_and_writes_nothing() {
    let mut b = Bench::new();
    let idx = 0x2000 + field_index("bar_length");
    let before = b.pod;
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
    assert_eq!(b.pod, before);
}

#[test]
fn out_of_range_config_values_abort_with_range_codes_and_change_nothing() {
    let mut b = Bench::new();
    let idx = 0x2000 + field_index("bar_length");
    let before = b.pod;
    assert_eq!(b.write_f32(idx, 0, 601.0), Err(TOO_HIGH));
    assert_eq!(b.write_f32(idx, 0, 49.0), Err(TOO_LOW));
    assert_eq!(b.write_f32(idx, 0, f32::NAN), Err(INVALID));
    assert_eq!(b.write_f32(idx, 0, f32::INFINITY), Err(TOO_HIGH));
    let spp = 0x2000 + field_index("samples_per_period");
    assert_eq!(b.write_f32(spp, 0, 10.5), Err(INVALID), "integer field");
    // Excitation 20 kHz × 64 samples = 1.28 MS/s > 500 kS/s: a cross-field rule.
    b.write_f32(spp, 0, 64.0).unwrap();
    let after_spp = b.pod;
    let exc = 0x2000 + field_index("excitation");
    assert_eq!(b.write_f32(exc, 0, 20000.0), Err(INCOMPATIBLE));
    assert_eq!(b.pod, after_spp);
    b.pod = before;
    // Enumerated fields.
    assert_eq!(b.download(0x2021, 0, &[4]), Err(TOO_HIGH));
    assert_eq!(
        b.download(0x2022, 1, &[2]),
        Err(INCOMPATIBLE),
        "Y is input 2's"
    );
    assert_eq!(
        b.download(0x2023, 1, &[2]),
        Err(INVALID),
        "BOOLEAN is 0 or 1"
    );
    assert_eq!(b.pod, before);
}

#[test]
fn config_writes_only_in_pre_operational() {
    let mut b = Bench::new();
    b.start();
    let idx = 0x2000 + field_index("bar_length");
    let before = b.pod;
    assert_eq!(b.write_f32(idx, 0, 200.0), Err(WRONG_STATE));
    assert_eq!(b.download(0x2020, 0, &[1]), Err(WRONG_STATE));
    assert_eq!(b.pod, before);
    // Reading is fine in operational.
    assert_eq!(b.upload(idx, 0).unwrap(), 150.0f32.to_le_bytes());
}

#[test]
fn access_and_addressing_aborts() {
    let mut b = Bench::new();
    assert_eq!(b.download(0x1000, 0, &[0, 0, 0, 0]), Err(READ_ONLY));
    assert_eq!(b.download(0x2100, 1, &[0, 0, 0, 0]), Err(READ_ONLY));
    assert_eq!(b.upload(0x3002, 0), Err(WRITE_ONLY));
    assert_eq!(b.upload(0x2FFF, 0), Err(NO_OBJECT));
    assert_eq!(b.upload(0x6000, 0), Err(NO_OBJECT));
    assert_eq!(b.upload(0x1018, 5), Err(NO_SUB));
    assert_eq!(b.upload(0x1000, 1), Err(NO_SUB));
    assert_eq!(b.upload(0x1800, 4), Err(NO_SUB), "reserved sub-index");
    // Length: 2 bytes to a REAL32, 4 bytes to an UNSIGNED16.
    let idx = 0x2000 + field_index("bar_length");
    assert_eq!(b.download(idx, 0, &[0, 0]), Err(LENGTH));
    assert_eq!(b.download(0x1017, 0, &[0, 0, 0, 0]), Err(LENGTH));
    let r = b.sdo(req(0x21, idx, 0, 8u32.to_le_bytes()));
    assert_eq!(abort_code(&r), LENGTH, "segmented, indicated size ≠ 4");
}

#[test]
fn segmented_download_longer_than_the_object_aborts() {
    let mut b = Bench::new();
    let idx = 0x2000 + field_index("bar_length");
    b.sdo(req(0x20, idx, 0, [0; 4]));
    let r = b.sdo([0x00, 1, 2, 3, 4, 5, 6, 7]);
    assert_eq!(abort_code(&r), LENGTH);
    // Too short at the last segment.
    b.sdo(req(0x20, idx, 0, [0; 4]));
    let r = b.sdo([0x0D, 1, 0, 0, 0, 0, 0, 0]); // n = 6 unused, c = 1: 1 byte
    assert_eq!(abort_code(&r), LENGTH);
    assert_eq!(b.pod.config, Config::default());
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
    assert_eq!(b.pod, PodModel::default());
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
    let mut b = Bench::new();
    assert_eq!(b.read_u32(0x1010, 1) & 1, 1, "saves on command");
    assert_eq!(
        b.download(0x1010, 1, b"save"),
        Ok(Some(SessionCommand::StoreSettings))
    );
    assert_eq!(b.download(0x1010, 1, b"SAVE"), Err(CANNOT_STORE));
    assert_eq!(
        b.download(0x1011, 1, b"load"),
        Ok(Some(SessionCommand::RestoreDefaults))
    );
    assert_eq!(b.download(0x1011, 1, b"save"), Err(CANNOT_STORE));
}

#[test]
fn session_control_by_sdo() {
    let mut b = Bench::new();
    b.download(0x3000, 0, &[Pattern::Bx as u8]).unwrap();
    b.download(0x3001, 0, &[1]).unwrap();
    assert_eq!(b.download(0x3000, 0, &[8]), Err(TOO_HIGH));
    assert_eq!(
        b.download(0x3002, 0, &[2]),
        Err(WRONG_STATE),
        "start while idle"
    );
    assert_eq!(b.download(0x3002, 0, &[0]), Err(TOO_LOW));
    assert_eq!(b.download(0x3002, 0, &[5]), Err(TOO_HIGH));
    assert_eq!(
        b.download(0x3002, 0, &[1]),
        Ok(Some(SessionCommand::Arm {
            pattern: Pattern::Bx,
            direction: Direction::Cw
        }))
    );
    b.pod.session = SessionState::Armed;
    assert_eq!(
        b.download(0x3000, 0, &[0]),
        Err(WRONG_STATE),
        "pattern while armed"
    );
    assert_eq!(b.download(0x3002, 0, &[2]), Ok(Some(SessionCommand::Start)));
    b.pod.session = SessionState::Running;
    assert_eq!(b.upload(0x3003, 0).unwrap(), [2]);
    assert_eq!(b.download(0x3002, 0, &[3]), Ok(Some(SessionCommand::Stop)));
    assert_eq!(b.download(0x3002, 0, &[4]), Ok(Some(SessionCommand::Abort)));
    // Session commands also work in operational (only configuration is pre-operational only).
    b.start();
    assert_eq!(b.download(0x3002, 0, &[3]), Ok(Some(SessionCommand::Stop)));
}

#[test]
fn results_read_only_when_valid() {
    let mut b = Bench::new();
    assert_eq!(b.upload(0x4000, 4), Err(NO_DATA));
    b.pod.results[3] = ResultEntry {
        value: 12.5,
        std_uncertainty: 0.25,
        valid: true,
    };
    assert_eq!(b.upload(0x4000, 4).unwrap(), 12.5f32.to_le_bytes());
    assert_eq!(b.upload(0x4001, 4).unwrap(), 0.25f32.to_le_bytes());
    assert_eq!(b.read_u32(0x4002, 0), 1 << 3);
    assert_eq!(b.upload(0x4000, 0).unwrap(), [16]);
    assert_eq!(b.upload(0x4000, 17), Err(NO_SUB));
}

// ---------------------------------------------------------------------------------------------
// SYNC and TPDOs (CiA 301 §7.2.2, §7.2.5, §7.5.2.35–38)
// ---------------------------------------------------------------------------------------------

fn live_pod(p: &mut PodModel) {
    p.live.delta_l_um = -3.25;
    p.live.sample_counter = 0x0102_0304;
    p.live.ecc_x_um = 1.5;
    p.live.ecc_y_um = -2.0;
    p.live.r0_um = 0.75;
    p.live.ssm_e_um = [4.0, 5.0, 6.0];
    p.live.status = StatusWord(0x0201);
    p.session = SessionState::Running;
}

fn cat(parts: &[&[u8]]) -> Vec<u8> {
    parts.concat()
}

#[test]
fn default_tpdos_on_sync_carry_the_live_values() {
    let mut b = Bench::new();
    live_pod(&mut b.pod);
    b.rx(0x080, &[]);
    assert!(b.take().is_empty(), "no PDO in pre-operational");
    b.start();
    b.rx(0x080, &[]);
    let out = b.take();
    let n = u16::from(NODE);
    assert_eq!(out.len(), 3, "TPDO1–3 enabled, TPDO4 not: {out:?}");
    assert_eq!(out[0].id, 0x180 + n);
    assert_eq!(
        out[0].payload(),
        cat(&[&(-3.25f32).to_le_bytes(), &0x0102_0304u32.to_le_bytes()])
    );
    assert_eq!(out[1].id, 0x280 + n);
    assert_eq!(
        out[1].payload(),
        cat(&[&1.5f32.to_le_bytes(), &(-2.0f32).to_le_bytes()])
    );
    assert_eq!(out[2].id, 0x380 + n);
    assert_eq!(
        out[2].payload(),
        cat(&[&0.75f32.to_le_bytes(), &[0x01, 0x02], &[2], &[0]])
    );
    // The same values by SDO.
    assert_eq!(b.upload(0x2100, 1).unwrap(), (-3.25f32).to_le_bytes());
    assert_eq!(b.read_u32(0x2101, 0), 0x0102_0304);
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
    live_pod(&mut b.pod);
    b.start();
    b.rx(0x080, &[]);
    let out = b.take();
    assert_eq!(out[0].id, cob as u16);
    assert_eq!(out[0].payload(), [0x04, 0x03, 0x02, 0x01, 0x01, 0x02]);
}

#[test]
fn event_timer_tpdo_with_type_254() {
    let mut b = Bench::new();
    // Disable TPDO1–3 and use TPDO4 (E_x, E_y) event-driven every 100 ms.
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
    live_pod(&mut b.pod);
    b.start();
    let mut times = Vec::new();
    for ms in 1..=350 {
        b.advance_ms(1);
        b.poll();
        for f in b.take() {
            assert_eq!(f.id, 0x480 + u16::from(NODE));
            assert_eq!(
                f.payload(),
                cat(&[&4.0f32.to_le_bytes(), &5.0f32.to_le_bytes()])
            );
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
    let mut b = Bench {
        node: CanOpenNode::new(NODE, 0x1234_5678),
        pod: PodModel::default(),
        now_us: 0,
        sent: Vec::new(),
    };
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
