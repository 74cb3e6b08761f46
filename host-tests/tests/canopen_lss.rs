//! LSS slave (CiA 305 v3.0) edge cases the python `canopen` master does not reach
//! (`clients/test_canopen_lss.py` is the interoperability test): the request and answer bytes
//! are written out from CiA 305's frame layouts, not taken from the implementation.
use ballpod::app::{App, Command, SettingsRequest};
use ballpod::config::{CanBitrate, Config};
use ballpod::protocol::canopen::{CanFrame, CanOpenNode, NmtState, od};

const SERIAL: u32 = 0x1234_5678;
const MASTER: u16 = 0x7E5;
const SLAVE: u16 = 0x7E4;

struct Bus {
    app: App,
    node: CanOpenNode,
    now_us: u64,
}

impl Bus {
    fn new(node_id: u8) -> Self {
        let config = Config {
            can_node_id: node_id,
            ..Config::default()
        };
        let mut b = Self {
            app: App::new(config, [16; 5]),
            node: CanOpenNode::new(node_id, SERIAL),
            now_us: 0,
        };
        b.poll(0);
        b
    }
    /// The master's request (8 bytes: cs, then data); the frames the node answered.
    fn lss(&mut self, req: [u8; 8]) -> Vec<CanFrame> {
        let mut out = Vec::new();
        let f = CanFrame::new(MASTER, &req).unwrap();
        self.node
            .on_frame(&f, &mut self.app, self.now_us, &mut |f| out.push(f));
        out
    }
    fn poll(&mut self, dt_us: u64) -> Vec<CanFrame> {
        self.now_us += dt_us;
        let mut out = Vec::new();
        self.node.poll(self.now_us, &self.app, &mut |f| out.push(f));
        out
    }
}

fn req(cs: u8, v: u32) -> [u8; 8] {
    let b = v.to_le_bytes();
    [cs, b[0], b[1], b[2], b[3], 0, 0, 0]
}

fn answer(frames: &[CanFrame]) -> Option<[u8; 8]> {
    match frames {
        [f] if f.id == SLAVE && f.len == 8 => Some(f.data),
        [] => None,
        _ => panic!("one LSS answer expected: {frames:?}"),
    }
}

const ADDRESS: [u32; 4] = [od::VENDOR_ID, od::PRODUCT_CODE, od::REVISION, SERIAL];

fn select(bus: &mut Bus) {
    for (k, v) in ADDRESS.iter().enumerate() {
        let a = answer(&bus.lss(req(0x40 + k as u8, *v)));
        assert_eq!(a.map(|a| a[0]), (k == 3).then_some(0x44));
    }
}

#[test]
fn selective_switch_takes_the_address_in_order_only() {
    let mut bus = Bus::new(16);
    // serial before the rest, or a wrong part in between: no switch
    assert_eq!(answer(&bus.lss(req(0x43, SERIAL))), None);
    for (k, v) in ADDRESS.iter().enumerate().take(2) {
        bus.lss(req(0x40 + k as u8, *v));
    }
    bus.lss(req(0x42, od::REVISION + 1));
    assert_eq!(answer(&bus.lss(req(0x43, SERIAL))), None);
    assert_eq!(answer(&bus.lss(req(0x5E, 0))), None, "still waiting");
    select(&mut bus);
    assert_eq!(
        answer(&bus.lss(req(0x5E, 0))),
        Some([0x5E, 16, 0, 0, 0, 0, 0, 0])
    );
}

#[test]
fn identify_remote_slave_matches_ranges_of_revision_and_serial() {
    let mut bus = Bus::new(16);
    let ask = |bus: &mut Bus, rev: (u32, u32), ser: (u32, u32)| {
        let mut last = Vec::new();
        for (cs, v) in [
            (0x46, od::VENDOR_ID),
            (0x47, od::PRODUCT_CODE),
            (0x48, rev.0),
            (0x49, rev.1),
            (0x4A, ser.0),
            (0x4B, ser.1),
        ] {
            last = bus.lss(req(cs, v));
        }
        answer(&last).map(|a| a[0])
    };
    assert_eq!(ask(&mut bus, (0, u32::MAX), (SERIAL, SERIAL)), Some(0x4F));
    assert_eq!(
        ask(&mut bus, (od::REVISION + 1, u32::MAX), (0, u32::MAX)),
        None
    );
    assert_eq!(ask(&mut bus, (0, u32::MAX), (SERIAL + 1, u32::MAX)), None);
    assert_eq!(ask(&mut bus, (0, u32::MAX), (0, SERIAL - 1)), None);
}

#[test]
fn store_is_refused_during_a_run_with_error_2_and_changes_nothing() {
    let mut bus = Bus::new(16);
    for name in ["circle_centre_x", "circle_centre_y", "circle_centre_z"] {
        let f = Config::field_by_name(name).unwrap();
        bus.app.set_field(f, 0.0).unwrap();
    }
    let radius = f64::from(bus.app.config().bar_length_mm);
    let f = Config::field_by_name("circle_radius").unwrap();
    bus.app.set_field(f, radius).unwrap();
    bus.app.execute(Command::Arm).unwrap();
    select(&mut bus);
    assert_eq!(
        answer(&bus.lss(req(0x11, 42))),
        Some([0x11, 0, 0, 0, 0, 0, 0, 0])
    );
    // CiA 305: store answers error 2, "storage media access error"
    assert_eq!(
        answer(&bus.lss(req(0x17, 0))),
        Some([0x17, 2, 0, 0, 0, 0, 0, 0])
    );
    assert_eq!(bus.app.config().can_node_id, 16);
    assert_eq!(bus.app.take_settings_request(), None);
    bus.app.execute(Command::Abort).unwrap();
    assert_eq!(
        answer(&bus.lss(req(0x17, 0))),
        Some([0x17, 0, 0, 0, 0, 0, 0, 0])
    );
    assert_eq!(bus.app.config().can_node_id, 42);
    assert_eq!(
        bus.app.take_settings_request(),
        Some(SettingsRequest::Store)
    );
}

#[test]
fn bit_timing_outside_table_0_or_unsupported_is_error_1() {
    let mut bus = Bus::new(16);
    select(&mut bus);
    for (table, index) in [(1, 2), (0, 1), (0, 5), (0, 6), (0, 9)] {
        let a = answer(&bus.lss([0x13, table, index, 0, 0, 0, 0, 0]));
        assert_eq!(
            a,
            Some([0x13, 1, 0, 0, 0, 0, 0, 0]),
            "table {table} index {index}"
        );
    }
    // nothing pending: activate does nothing
    bus.lss([0x15, 10, 0, 0, 0, 0, 0, 0]);
    assert_eq!(bus.node.take_bit_rate_switch(u64::MAX), None);
}

#[test]
fn activate_bit_timing_switches_after_the_delay_and_the_node_is_silent_for_twice_it() {
    let mut bus = Bus::new(16);
    bus.poll(500_000); // half-way to the first heartbeat (1 s after boot-up)
    select(&mut bus);
    assert_eq!(
        answer(&bus.lss([0x13, 0, 0, 0, 0, 0, 0, 0])),
        Some([0x13, 0, 0, 0, 0, 0, 0, 0])
    );
    bus.lss([0x15, 0xF4, 0x01, 0, 0, 0, 0, 0]); // 500 ms
    let t0 = bus.now_us;
    assert_eq!(bus.node.take_bit_rate_switch(t0 + 499_999), None);
    assert_eq!(
        bus.node.take_bit_rate_switch(t0 + 500_000),
        Some(CanBitrate::M1)
    );
    assert_eq!(
        bus.node.take_bit_rate_switch(t0 + 500_000),
        None,
        "taken once"
    );
    // the heartbeat (1 s after boot-up) falls in the silence (0.5–1.5 s): held and counted,
    // then it resumes
    let mut sent = Vec::new();
    for _ in 0..999 {
        sent.extend(bus.poll(1000));
    }
    assert!(sent.is_empty(), "{sent:?}");
    let held = bus.node.stats().frames_dropped_bit_rate_switch;
    assert!(held >= 1);
    let after: Vec<_> = (0..1100).flat_map(|_| bus.poll(1000)).collect();
    assert!(after.iter().any(|f| f.id == 0x710), "the heartbeat resumes");
}

#[test]
fn a_node_without_node_id_sends_nothing_until_lss_gives_it_one() {
    let mut bus = Bus::new(0xFF);
    let quiet: Vec<_> = (0..3000).flat_map(|_| bus.poll(1000)).collect();
    assert!(quiet.is_empty(), "{quiet:?}");
    assert_eq!(bus.node.state(), NmtState::Initialising);
    // NMT and SDO to any node are not for it
    let mut out = Vec::new();
    for f in [
        CanFrame::new(0x000, &[0x01, 0]).unwrap(),
        CanFrame::new(0x67F, &[0x40, 0x00, 0x10, 0, 0, 0, 0, 0]).unwrap(),
    ] {
        bus.node
            .on_frame(&f, &mut bus.app, bus.now_us, &mut |f| out.push(f));
    }
    assert!(out.is_empty());
    // identify non-configured: answered (cs 0x50)
    assert_eq!(answer(&bus.lss(req(0x4C, 0))).map(|a| a[0]), Some(0x50));
    // switch global to configuration, node-ID 7, back to waiting: boot-up on 7
    assert_eq!(answer(&bus.lss(req(0x04, 1))), None);
    assert_eq!(
        answer(&bus.lss(req(0x11, 7))),
        Some([0x11, 0, 0, 0, 0, 0, 0, 0])
    );
    let boot = bus.lss(req(0x04, 0));
    assert_eq!(boot.len(), 1);
    assert_eq!((boot[0].id, boot[0].payload()), (0x707, &[0u8][..]));
    assert_eq!(bus.node.node_id(), 7);
    assert_eq!(bus.node.state(), NmtState::PreOperational);
    assert_eq!(answer(&bus.lss(req(0x4C, 0))), None, "configured now");
}

#[test]
fn fastscan_bisects_the_address_of_a_node_without_node_id() {
    let mut bus = Bus::new(0xFF);
    // the master's algorithm (CiA 305 §3.7.7): confirm, then per part from the top bit down
    let mut scan = |id: u32, bit: u8, sub: u8, next: u8| {
        let b = id.to_le_bytes();
        answer(&bus.lss([0x51, b[0], b[1], b[2], b[3], bit, sub, next])).is_some()
    };
    assert!(scan(0, 0x80, 0, 0));
    let mut found = [0u32; 4];
    for sub in 0..4u8 {
        for bit in (0..32u8).rev() {
            if !scan(found[sub as usize], bit, sub, sub) {
                found[sub as usize] |= 1 << bit;
            }
        }
        assert!(scan(found[sub as usize], 0, sub, (sub + 1) % 4));
    }
    assert_eq!(found, ADDRESS);
    // the last step switched it to configuration: it answers inquire
    assert_eq!(
        answer(&bus.lss(req(0x5E, 0))),
        Some([0x5E, 0xFF, 0, 0, 0, 0, 0, 0])
    );
}
