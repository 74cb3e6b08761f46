//! FDCAN1 on PB8/PB9 at the configured bit rate, driving the core's CANopen slave
//! (`ballpod::protocol::canopen`): received frames go to the node, its frames go out, its
//! session commands go to the compute task. The node is polled every millisecond (heartbeat,
//! event-timer TPDOs, SDO timeout) and told about each new sample (EMCY on new faults).
//! The controller's error state (error active / passive / bus-off, FDCAN `PSR`) goes to the
//! node before each step: EMCY 0x8120 on error passive, nothing sent while bus-off (the node
//! counts what it dropped), EMCY 0x8140 and the heartbeat on recovery. The controller recovers
//! from bus-off by itself (embassy-stm32's `automatic_bus_off_recovery`, on by default: the
//! IT0 interrupt clears `CCCR.INIT` and the FDCAN waits for 128 × 11 recessive bits).

use core::sync::atomic::{AtomicU32, Ordering};

use embassy_futures::select::{Either, select};
use embassy_stm32::can::enums::BusErrorMode;
use embassy_stm32::can::{Can, CanConfigurator, OperatingMode, frame::Frame};
use embassy_stm32::{Peri, peripherals};
use embassy_time::{Duration, Instant, Ticker};
use embedded_can::Id;

use ballpod::acquisition::SampleFlags;
use ballpod::protocol::canopen::{BusState, CanFrame, CanOpenNode};

use super::{Irqs, Overruns, state};

/// Frames received since boot.
pub static RX_FRAMES: AtomicU32 = AtomicU32::new(0);
/// Frames the node produced that did not fit the transmit batch (never expected: the node
/// bounds its output per call below the batch size).
pub static TX_BATCH_OVERRUNS: Overruns = Overruns::new();

/// Frames per batch: the node emits at most 5 per received frame or 7 per poll, plus 2 on a
/// change of the bus state.
const TX_BATCH: usize = 10;

/// Configures FDCAN1 and starts it in normal mode.
pub fn start(
    fdcan: Peri<'static, peripherals::FDCAN1>,
    rx: Peri<'static, peripherals::PB8>,
    tx: Peri<'static, peripherals::PB9>,
    bitrate: u32,
) -> Can<'static> {
    let mut cc = CanConfigurator::new(fdcan, rx, tx, Irqs);
    cc.set_bitrate(bitrate);
    cc.start(OperatingMode::NormalOperationMode)
}

/// The core's view of the controller's fault-confinement state.
fn bus_state(mode: BusErrorMode) -> BusState {
    match mode {
        BusErrorMode::ErrorActive => BusState::ErrorActive,
        BusErrorMode::ErrorPassive => BusState::ErrorPassive,
        BusErrorMode::BusOff => BusState::BusOff,
    }
}

fn to_core(frame: &Frame) -> Option<CanFrame> {
    // The slave uses 11-bit data frames only; RTR and 29-bit frames are not for it.
    match frame.id() {
        Id::Standard(id) if !frame.header().rtr() => CanFrame::new(id.as_raw(), frame.data()),
        _ => None,
    }
}

/// Runs the CANopen slave on FDCAN1.
#[embassy_executor::task]
pub async fn can_task(
    mut can: Can<'static>,
    node_id: u8,
    serial: u32,
    boot_error: Option<(u16, u8)>,
) {
    let mut node = CanOpenNode::new(node_id, serial);
    if let Some((code, reason)) = boot_error {
        // The previous run's panic / watchdog reset: one EMCY after boot-up.
        node.report_boot_error(code, reason);
    }
    let mut ticker = Ticker::every(Duration::from_millis(1));
    let mut last_counter = None;
    loop {
        let mut batch: heapless::Vec<CanFrame, TX_BATCH> = heapless::Vec::new();
        let mut out = |f: CanFrame| {
            if batch.push(f).is_err() {
                TX_BATCH_OVERRUNS.count();
            }
        };
        let now = Instant::now().as_micros();
        let bus = bus_state(can.properties().bus_error_mode());
        if bus != node.bus_state() {
            defmt::warn!("CAN bus state {}", bus as u8);
        }
        // While bus-off the node sends nothing, so no write below waits for a free mailbox.
        node.on_bus_state(bus, now, &mut out);
        match select(can.read(), ticker.next()).await {
            Either::First(Ok(env)) => {
                RX_FRAMES.fetch_add(1, Ordering::Relaxed);
                if let Some(frame) = to_core(&env.frame) {
                    let cmd = state::with_pod(|pod| {
                        let cmd = node.on_frame(&frame, pod, now, &mut out);
                        if let Some(c) = cmd {
                            pod.apply(c);
                        }
                        cmd
                    });
                    if let Some(Some(c)) = cmd {
                        state::submit(c);
                    }
                }
            }
            Either::First(Err(_)) => {}
            Either::Second(()) => {
                let sample = state::with_pod(|pod| {
                    node.poll(now, pod, &mut out);
                    (pod.live.sample_counter, pod.live.status.0)
                });
                if let Some((counter, status)) = sample
                    && last_counter != Some(counter)
                {
                    last_counter = Some(counter);
                    let flags =
                        SampleFlags(status & ballpod::protocol::pod::StatusWord::SAMPLE_FLAGS_MASK);
                    node.on_sample(flags, now, &mut out);
                }
            }
        }
        for f in &batch {
            if let Ok(frame) = Frame::new_standard(f.id, f.payload()) {
                let _ = can.write(&frame).await;
            }
        }
    }
}
