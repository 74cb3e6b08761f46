//! Bad input on the bus (issue 5, "Bad input"): random and malformed frames never panic the
//! node, never leave an invalid configuration, and change the configuration only through a
//! complete SDO download in pre-operational that the application accepted (the node answered
//! it with a download response, not an abort). Every SDO request gets exactly one 8-byte
//! response (CiA 301 §7.2.4: confirmed service) unless it is a client abort.
use ballpod::acquisition::MAX_AXES;
use ballpod::app::App;
use ballpod::config::{Config, FIELDS};
use ballpod::protocol::canopen::{CanFrame, CanOpenNode, NmtState};
use ballpod_host::rng::Rng;

const NODE: u8 = 16;

/// The configuration object of field `name` (`od::config_index` of its row of
/// `config::FIELDS`; the layout is checked against the EDS in canopen_eds.rs).
fn obj(name: &str) -> u16 {
    ballpod::protocol::canopen::od::config_index(
        FIELDS.iter().position(|f| f.name == name).unwrap(),
    )
}

/// The configuration, compared as text (a set-up field that is not set is NaN, which `==`
/// would never find equal to itself).
fn config_text(app: &App) -> String {
    format!("{:?}", app.config())
}

#[test]
fn random_frames_never_half_apply() {
    let mut rng = Rng::new(5);
    let mut node = CanOpenNode::new(NODE, 0);
    let mut app = App::new(Config::default(), [16; MAX_AXES]);
    let mut now_us = 0u64;
    node.poll(now_us, &app, &mut |_| {});
    // Indices the random requests aim at: real objects (so that writes get far) and others.
    // Configuration objects of every type: REAL32, UNSIGNED8 / 16 / 32, code fields, set-up
    // fields, an ARRAY, and the enumerated objects 0x2040–0x2043.
    let targets: [u16; 20] = [
        0x1003,
        0x1005,
        0x1017,
        0x1800,
        0x1A00,
        obj("bar_length"),
        obj("lvdt_poly"),
        obj("samples_per_period"),
        obj("can_node_id"),
        obj("probe_debounce"),
        obj("circle_plane"),
        obj("circle_radius"),
        obj("ts_machine"),
        0x2040,
        0x2041,
        0x2042,
        0x2043,
        0x3000,
        0x3002,
        0x5FFF,
    ];
    let mut accepted_config_writes = 0;
    let mut node_id_changes = 0;
    for _ in 0..200_000 {
        // A written can_node_id takes effect at the next reset: address the node it is now.
        let id_now = node.node_id();
        let sdo_rx = 0x600 + u16::from(id_now);
        let sdo_tx = 0x580 + u16::from(id_now);
        now_us += rng.next_u64() % 3000;
        let r = rng.next_u64();
        let mut data = rng.next_u64().to_le_bytes();
        let id = match r % 8 {
            0 => 0x000,
            1 => 0x080,
            2 => (r >> 8) as u16 & 0x7FF,
            _ => sdo_rx,
        };
        if id == sdo_rx && r & 0x100 != 0 {
            let t = targets[(r >> 16) as usize % targets.len()].to_le_bytes();
            data[1] = t[0];
            data[2] = t[1];
            data[3] = (r >> 24) as u8 % 6;
        }
        if id == 0x000 && r & 0x200 != 0 {
            // Keep the node mostly pre-operational so that configuration writes can land.
            data[0] = [0x80, 0x80, 0x80, 0x01, 0x02, 0x82][(r >> 12) as usize % 6];
            data[1] = id_now;
        }
        let len = if r & 0x400 != 0 {
            (r >> 32) as usize % 9
        } else {
            8
        };
        let frame = CanFrame::new(id, &data[..len.min(if id == 0 { 2 } else { 8 })]).unwrap();
        let before = config_text(&app);
        let state = node.state();
        let mut out = Vec::new();
        node.on_frame(&frame, &mut app, now_us, &mut |f| out.push(f));
        let answers: Vec<CanFrame> = out.iter().copied().filter(|f| f.id == sdo_tx).collect();
        node.poll(now_us, &app, &mut |f| out.push(f));
        app.config()
            .validate()
            .expect("the configuration is always valid");
        if config_text(&app) != before {
            assert_eq!(id, sdo_rx, "only an SDO download writes: {frame:?}");
            assert_eq!(
                state,
                NmtState::PreOperational,
                "config changes only in pre-op"
            );
            // The request that completed the download was answered with an initiate
            // download response (scs 3) or a download segment response (scs 1), never with
            // an abort (scs 4).
            assert_eq!(answers.len(), 1, "{answers:?}");
            let scs = answers[0].data[0] >> 5;
            assert!(
                scs == 3 || scs == 1,
                "a configuration change answered {:02x?}",
                answers[0].data
            );
            accepted_config_writes += 1;
        }
        if id == sdo_rx && state.sdo_allowed() {
            let responses: Vec<_> = out.iter().filter(|f| f.id == sdo_tx).collect();
            let client_abort = frame.len == 8 && frame.data[0] >> 5 == 4;
            assert!(responses.len() <= 2, "{responses:?}"); // response + possible timeout abort
            if !client_abort {
                assert!(!responses.is_empty(), "request {frame:?} unanswered");
            }
            assert!(responses.iter().all(|f| f.len == 8));
        }
        if node.node_id() != id_now {
            // only a reset (NMT 0x81 / 0x82) takes the configuration's node-ID
            assert_eq!(id, 0x000, "{frame:?}");
            assert!(matches!(frame.data[0], 0x81 | 0x82), "{frame:?}");
            assert_eq!(node.node_id(), app.config().can_node_id);
            node_id_changes += 1;
        }
    }
    assert!(
        accepted_config_writes > 0,
        "the test reached the write path"
    );
    assert!(node_id_changes > 0, "the test reached a node-ID change");
}

#[test]
fn frames_before_boot_up_are_ignored() {
    let mut node = CanOpenNode::new(NODE, 0);
    let mut app = App::new(Config::default(), [16; MAX_AXES]);
    let mut out = Vec::new();
    let f = CanFrame::new(0x000, &[0x01, NODE]).unwrap();
    node.on_frame(&f, &mut app, 0, &mut |f| out.push(f));
    assert_eq!(node.state(), NmtState::Initialising);
    assert!(out.is_empty());
    // An SDO write before boot-up is not served either.
    let sdo = 0x2000 + FIELDS.iter().position(|f| f.name == "bar_length").unwrap() as u16;
    let i = sdo.to_le_bytes();
    let v = 300.0f32.to_le_bytes();
    let f = CanFrame::new(
        0x600 + u16::from(NODE),
        &[0x23, i[0], i[1], 0, v[0], v[1], v[2], v[3]],
    )
    .unwrap();
    node.on_frame(&f, &mut app, 0, &mut |f| out.push(f));
    assert!(out.is_empty());
    assert_eq!(app.config().bar_length_mm, 150.0);
    assert_eq!(node.stats().frames_ignored, 2);
    node.poll(0, &app, &mut |f| out.push(f));
    assert_eq!(node.state(), NmtState::PreOperational);
    assert_eq!(
        out,
        vec![CanFrame::new(0x700 + u16::from(NODE), &[0]).unwrap()]
    );
}

#[test]
fn can_frame_rejects_oversize_payloads_and_ids() {
    assert!(
        CanFrame::new(0x800, &[]).is_none(),
        "11-bit identifiers only"
    );
    assert!(
        CanFrame::new(0x100, &[0; 9]).is_none(),
        "classic CAN: at most 8 bytes"
    );
    let f = CanFrame::new(0x7FF, &[1, 2, 3]).unwrap();
    assert_eq!(f.payload(), &[1, 2, 3]);
}
