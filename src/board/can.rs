//! FDCAN1 on PB8/PB9 at the configured bit rate, driving the core's CANopen slave
//! (`ballpod::protocol::canopen`): received frames go to the node, its frames go out, its
//! session commands go to the compute task. The node is polled every millisecond (heartbeat,
//! event-timer TPDOs, SDO timeout) and told about each new sample (EMCY on new faults).
//! Bus-off is watched and counted; the controller recovers automatically.

use core::sync::atomic::{AtomicU32, Ordering};

use embassy_futures::select::{Either, select};
use embassy_stm32::can::enums::BusErrorMode;
use embassy_stm32::can::{Can, CanConfigurator, OperatingMode, frame::Frame};
use embassy_stm32::{Peri, peripherals};
use embassy_time::{Duration, Instant, Ticker};
use embedded_can::Id;

use ballpod::acquisition::SampleFlags;
use ballpod::protocol::canopen::{CanFrame, CanOpenNode};

use super::{Irqs, Overruns, state};

/// Frames received since boot.
pub static RX_FRAMES: AtomicU32 = AtomicU32::new(0);
/// Times the controller was found bus-off.
pub static BUS_OFF_EVENTS: AtomicU32 = AtomicU32::new(0);
/// Frames the node produced that did not fit the transmit batch (never expected: the node
/// bounds its output per call below the batch size).
pub static TX_BATCH_OVERRUNS: Overruns = Overruns::new();

/// Frames per batch: the node emits at most 4 per received frame and 7 per poll.
const TX_BATCH: usize = 8;

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
    let mut was_bus_off = false;
    let mut last_counter = None;
    loop {
        let mut batch: heapless::Vec<CanFrame, TX_BATCH> = heapless::Vec::new();
        let mut out = |f: CanFrame| {
            if batch.push(f).is_err() {
                TX_BATCH_OVERRUNS.count();
            }
        };
        let now = Instant::now().as_micros();
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
        let bus_off = matches!(can.properties().bus_error_mode(), BusErrorMode::BusOff);
        if bus_off && !was_bus_off {
            BUS_OFF_EVENTS.fetch_add(1, Ordering::Relaxed);
            defmt::warn!("CAN bus-off");
        }
        was_bus_off = bus_off;
    }
}
