//! FDCAN1 on PB8/PB9 at the configured bit rate: boot-up message and heartbeat of CANopen node
//! `can_node_id` (CiA 301 §7.2.8.3: COB-ID 0x700 + node). The CANopen slave itself arrives with
//! the protocol layer; received frames are counted, bus-off is watched and counted.

use core::sync::atomic::{AtomicU32, Ordering};

use embassy_futures::select::{Either, select};
use embassy_stm32::can::enums::BusErrorMode;
use embassy_stm32::can::{Can, CanConfigurator, OperatingMode, frame::Frame};
use embassy_stm32::{Peri, peripherals};
use embassy_time::{Duration, Ticker};

use super::Irqs;

/// Frames received since boot.
pub static RX_FRAMES: AtomicU32 = AtomicU32::new(0);
/// Times the controller was found bus-off (it recovers automatically).
pub static BUS_OFF_EVENTS: AtomicU32 = AtomicU32::new(0);

/// NMT state byte of a pre-operational node in the heartbeat.
const NMT_PRE_OPERATIONAL: u8 = 0x7F;

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

/// Boot-up, then a heartbeat every second; counts received frames and bus-off events.
#[embassy_executor::task]
pub async fn can_task(mut can: Can<'static>, node_id: u8) {
    let cob = 0x700 + u16::from(node_id);
    if let Ok(boot) = Frame::new_standard(cob, &[0x00]) {
        let _ = can.write(&boot).await;
    }
    let mut ticker = Ticker::every(Duration::from_millis(1000));
    let mut was_bus_off = false;
    loop {
        match select(can.read(), ticker.next()).await {
            Either::First(Ok(_env)) => {
                RX_FRAMES.fetch_add(1, Ordering::Relaxed);
            }
            Either::First(Err(_)) => {}
            Either::Second(()) => {
                if let Ok(hb) = Frame::new_standard(cob, &[NMT_PRE_OPERATIONAL]) {
                    let _ = can.write(&hb).await;
                }
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
