//! USB FS device (PA11/PA12) with one CDC-ACM interface. Until the SCPI layer lands it answers
//! `*IDN?`; other lines get an SCPI-style error line.

use embassy_futures::join::join;
use embassy_stm32::peripherals::USB;
use embassy_stm32::usb::Driver;
use embassy_usb::Builder;
use embassy_usb::class::cdc_acm::{CdcAcmClass, State};
use static_cell::StaticCell;

/// The pod's USB identity (pid.codes test VID/PID until an allocation exists).
const VID: u16 = 0x1209;
const PID: u16 = 0x0001;
/// `*IDN?` answer: manufacturer, model, serial, firmware version (IEEE 488.2 §10.14).
const IDN: &[u8] = concat!("ballpod,pod,0,", env!("CARGO_PKG_VERSION"), "\n").as_bytes();

/// Runs the USB device and the command line.
#[embassy_executor::task]
pub async fn usb_task(driver: Driver<'static, USB>) {
    let mut config = embassy_usb::Config::new(VID, PID);
    config.manufacturer = Some("ballpod");
    config.product = Some("ballpod measurement pod");
    config.serial_number = Some("0");
    config.max_packet_size_0 = 64;

    static CONFIG_DESC: StaticCell<[u8; 256]> = StaticCell::new();
    static BOS_DESC: StaticCell<[u8; 256]> = StaticCell::new();
    static CONTROL_BUF: StaticCell<[u8; 64]> = StaticCell::new();
    static STATE: StaticCell<State> = StaticCell::new();
    let mut builder = Builder::new(
        driver,
        config,
        CONFIG_DESC.init([0; 256]),
        BOS_DESC.init([0; 256]),
        &mut [],
        CONTROL_BUF.init([0; 64]),
    );
    let mut class = CdcAcmClass::new(&mut builder, STATE.init(State::new()), 64);
    let mut usb = builder.build();

    let lines = async {
        let mut line = [0u8; 64];
        let mut len = 0usize;
        let mut overlong = false;
        loop {
            class.wait_connection().await;
            let mut buf = [0u8; 64];
            while let Ok(n) = class.read_packet(&mut buf).await {
                for &c in buf.iter().take(n) {
                    if c == b'\n' || c == b'\r' {
                        if len > 0 || overlong {
                            let reply: &[u8] = match (overlong, line.get(..len)) {
                                (false, Some(b"*IDN?")) => IDN,
                                (true, _) => b"ERR -223,\"Too much data\"\n",
                                _ => b"ERR -113,\"Undefined header\"\n",
                            };
                            let _ = class.write_packet(reply).await;
                        }
                        len = 0;
                        overlong = false;
                    } else if let Some(slot) = line.get_mut(len) {
                        *slot = c;
                        len += 1;
                    } else {
                        // An over-long line is rejected whole; the next line parses normally.
                        overlong = true;
                    }
                }
            }
        }
    };
    join(usb.run(), lines).await;
}
