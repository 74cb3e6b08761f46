//! Bad input on the bus (issue 5, "Bad input"): random and malformed frames never panic the
//! node, never leave an invalid configuration, and change the configuration only through a
//! complete, accepted SDO download that hands `ConfigChanged` to the application. Every SDO
//! request gets exactly one 8-byte response (CiA 301 §7.2.4: confirmed service) unless it is a
//! client abort.
use ballpod::protocol::canopen::{CanFrame, CanOpenNode, NmtState};
use ballpod::protocol::pod::{PodModel, SessionCommand};
use ballpod_host::rng::Rng;

const NODE: u8 = 16;

#[test]
fn random_frames_never_half_apply() {
    let mut rng = Rng::new(5);
    let mut node = CanOpenNode::new(NODE, 0);
    let mut pod = PodModel::default();
    let mut now_us = 0u64;
    node.poll(now_us, &pod, &mut |_| {});
    // Indices the random requests aim at: real objects (so that writes get far) and others.
    let targets: [u16; 12] = [
        0x1003, 0x1005, 0x1017, 0x1800, 0x1A00, 0x2000, 0x2002, 0x2008, 0x2022, 0x3000, 0x3002,
        0x5FFF,
    ];
    let mut accepted_config_writes = 0;
    for _ in 0..200_000 {
        now_us += rng.next_u64() % 3000;
        let r = rng.next_u64();
        let mut data = rng.next_u64().to_le_bytes();
        let id = match r % 8 {
            0 => 0x000,
            1 => 0x080,
            2 => (r >> 8) as u16 & 0x7FF,
            _ => 0x600 + u16::from(NODE),
        };
        if id == 0x600 + u16::from(NODE) && r & 0x100 != 0 {
            let t = targets[(r >> 16) as usize % targets.len()].to_le_bytes();
            data[1] = t[0];
            data[2] = t[1];
            data[3] = (r >> 24) as u8 % 6;
        }
        if id == 0x000 && r & 0x200 != 0 {
            // Keep the node mostly pre-operational so that configuration writes can land.
            data[0] = [0x80, 0x80, 0x80, 0x01, 0x02, 0x82][(r >> 12) as usize % 6];
            data[1] = NODE;
        }
        let len = if r & 0x400 != 0 {
            (r >> 32) as usize % 9
        } else {
            8
        };
        let frame = CanFrame::new(id, &data[..len.min(if id == 0 { 2 } else { 8 })]).unwrap();
        let before = pod.config;
        let state = node.state();
        let mut out = Vec::new();
        let cmd = node.on_frame(&frame, &mut pod, now_us, &mut |f| out.push(f));
        node.poll(now_us, &pod, &mut |f| out.push(f));
        pod.config
            .validate()
            .expect("the configuration is always valid");
        if pod.config != before {
            assert_eq!(cmd, Some(SessionCommand::ConfigChanged));
            assert_eq!(
                state,
                NmtState::PreOperational,
                "config changes only in pre-op"
            );
            accepted_config_writes += 1;
        }
        if id == 0x600 + u16::from(NODE) && state.sdo_allowed() {
            let responses: Vec<_> = out
                .iter()
                .filter(|f| f.id == 0x580 + u16::from(NODE))
                .collect();
            let client_abort = frame.len == 8 && frame.data[0] >> 5 == 4;
            assert!(responses.len() <= 2, "{responses:?}"); // response + possible timeout abort
            if !client_abort {
                assert!(!responses.is_empty(), "request {frame:?} unanswered");
            }
            assert!(responses.iter().all(|f| f.len == 8));
        }
    }
    assert!(
        accepted_config_writes > 0,
        "the test reached the write path"
    );
}

#[test]
fn frames_before_boot_up_are_ignored() {
    let mut node = CanOpenNode::new(NODE, 0);
    let mut pod = PodModel::default();
    let mut out = Vec::new();
    let f = CanFrame::new(0x000, &[0x01, NODE]).unwrap();
    node.on_frame(&f, &mut pod, 0, &mut |f| out.push(f));
    assert_eq!(node.state(), NmtState::Initialising);
    assert!(out.is_empty());
    node.poll(0, &pod, &mut |f| out.push(f));
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
