//! The CANopen slave on a sequence of arbitrary frames, time steps and CAN error states.
//! Invariants: no panic; the configuration is always valid; it changes only together with
//! `ConfigChanged`, and only in pre-operational; every output frame has an 11-bit id and ≤ 8 bytes;
//! nothing is sent while bus-off.
#![no_main]

use arbitrary::{Arbitrary, Unstructured};
use ballpod::acquisition::SampleFlags;
use ballpod::protocol::canopen::{BusState, CanFrame, CanOpenNode, NmtState};
use ballpod::protocol::pod::{PodModel, SessionCommand};
use libfuzzer_sys::fuzz_target;

/// One step of the bus: a frame, elapsed time, or a new sample with flags.
#[derive(Arbitrary, Debug)]
enum Step {
    Frame {
        id: u16,
        len: u8,
        data: [u8; 8],
    },
    /// An SDO request to this node (most interesting frames; steers the fuzzer there).
    Sdo {
        data: [u8; 8],
    },
    /// NMT to this node or broadcast.
    Nmt {
        cs: u8,
        broadcast: bool,
    },
    Wait {
        us: u16,
    },
    Sample {
        flags: u16,
    },
    /// The controller's error state (0 active, 1 passive, else bus-off).
    Bus {
        state: u8,
    },
}

const NODE: u8 = 16;

fuzz_target!(|data: &[u8]| {
    let mut u = Unstructured::new(data);
    let mut node = CanOpenNode::new(NODE, 0x1234_5678);
    let mut pod = PodModel::default();
    let mut now_us = 0u64;
    let bus_off = std::cell::Cell::new(false);
    let check = |f: CanFrame| {
        assert!(f.id <= 0x7FF && f.len <= 8, "bad output frame {f:?}");
        assert!(!bus_off.get(), "frame sent while bus-off: {f:?}");
    };
    node.poll(now_us, &pod, &mut { check });
    while !u.is_empty() {
        let Ok(step) = Step::arbitrary(&mut u) else {
            break;
        };
        let frame = match step {
            Step::Frame { id, len, data } => {
                CanFrame::new(id & 0x7FF, &data[..usize::from(len % 9)])
            }
            Step::Sdo { data } => CanFrame::new(0x600 + u16::from(NODE), &data),
            Step::Nmt { cs, broadcast } => {
                CanFrame::new(0x000, &[cs, if broadcast { 0 } else { NODE }])
            }
            Step::Wait { us } => {
                now_us += u64::from(us) * 16;
                node.poll(now_us, &pod, &mut { check });
                None
            }
            Step::Sample { flags } => {
                node.on_sample(SampleFlags(flags), now_us, &mut { check });
                None
            }
            Step::Bus { state } => {
                let state = match state {
                    0 => BusState::ErrorActive,
                    1 => BusState::ErrorPassive,
                    _ => BusState::BusOff,
                };
                bus_off.set(state == BusState::BusOff);
                node.on_bus_state(state, now_us, &mut { check });
                None
            }
        };
        let Some(frame) = frame else { continue };
        let before = pod.config;
        let state = node.state();
        let cmd = node.on_frame(&frame, &mut pod, now_us, &mut { check });
        assert!(pod.config.validate().is_ok(), "invalid configuration");
        if pod.config != before {
            assert_eq!(cmd, Some(SessionCommand::ConfigChanged));
            assert_eq!(state, NmtState::PreOperational);
        }
        if let Some(c) = cmd {
            pod.apply(c);
        }
    }
});
