//! The CANopen slave, over the pod's application, on a sequence of arbitrary frames, time
//! steps, samples and CAN error states. Invariants: no panic; the configuration is always
//! valid and changes only in pre-operational; every output frame has an 11-bit id and ≤ 8
//! bytes; nothing is sent while bus-off.
#![no_main]

use arbitrary::{Arbitrary, Unstructured};
use ballpod::acquisition::{MAX_AXES, Sample, SampleFlags};
use ballpod::app::{App, JobSlot};
use ballpod::config::{Config, ENCODED_LEN};
use ballpod::protocol::canopen::{BusState, CanFrame, CanOpenNode, NmtState};
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
        delta_l_um: f32,
        axes: [f32; MAX_AXES],
    },
    /// The controller's error state (0 active, 1 passive, else bus-off).
    Bus {
        state: u8,
    },
}

const NODE: u8 = 16;

/// The configuration's bytes (set-up fields not set are NaN: compared as bits).
fn bytes(c: &Config) -> [u8; ENCODED_LEN] {
    let mut b = [0u8; ENCODED_LEN];
    c.encode(&mut b).expect("a valid configuration encodes");
    b
}

fuzz_target!(|data: &[u8]| {
    let mut u = Unstructured::new(data);
    let mut node = CanOpenNode::new(NODE, 0x1234_5678);
    let mut app = App::new(Config::default(), [16; MAX_AXES]);
    let mut jobs = Box::new(JobSlot::new());
    let mut now_us = 0u64;
    let mut seq = 0u32;
    let bus_off = std::cell::Cell::new(false);
    let check = |f: CanFrame| {
        assert!(f.id <= 0x7FF && f.len <= 8, "bad output frame {f:?}");
        assert!(!bus_off.get(), "frame sent while bus-off: {f:?}");
    };
    node.poll(now_us, &app, &mut { check });
    while !u.is_empty() {
        let Ok(step) = Step::arbitrary(&mut u) else {
            break;
        };
        let frame = match step {
            Step::Frame { id, len, data } => {
                CanFrame::new(id & 0x7FF, &data[..usize::from(len % 9)])
            }
            Step::Sdo { data } => CanFrame::new(0x600 + u16::from(node.node_id()), &data),
            Step::Nmt { cs, broadcast } => {
                CanFrame::new(0x000, &[cs, if broadcast { 0 } else { node.node_id() }])
            }
            Step::Wait { us } => {
                now_us += u64::from(us) * 16;
                node.poll(now_us, &app, &mut { check });
                None
            }
            Step::Sample {
                flags,
                delta_l_um,
                axes,
            } => {
                seq = seq.wrapping_add(1);
                now_us += 1000;
                let s = Sample {
                    seq,
                    t_us: now_us,
                    delta_l_um,
                    axes,
                    temp_c: 20.0,
                    flags: SampleFlags(flags),
                };
                app.on_sample(&s, &mut ());
                node.on_sample(s.flags, now_us, &mut { check });
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
        let before = bytes(app.config());
        let state = node.state();
        node.on_frame(&frame, &mut app, now_us, &mut { check });
        assert!(app.config().validate().is_ok(), "invalid configuration");
        if bytes(app.config()) != before {
            assert_eq!(
                state,
                NmtState::PreOperational,
                "configuration written in {state:?}"
            );
        }
        app.run_jobs(&mut jobs);
    }
});
