//! USB FS device (PA11/PA12), composite with two CDC-ACM interfaces: the **command port** (the
//! SCPI server of the application task: received packets go to `state::USB_RX`, responses and
//! log downloads come back through `state::USB_TX`) and the **stream port** (every sample of
//! every run as CSV text, from `state::STREAM_TX`).
//!
//! A port is **open** while a host holds it with DTR set (a terminal, pyserial and PyVISA set
//! it on open), not merely while the device is enumerated: closing the program closes the port
//! (the command port locks the configuration again, a pending download ends; the stream
//! stops). On opening, what an earlier host left unread is cleared. **Flow control**: a
//! received packet waits for room in `state::USB_RX` (the endpoint is not read meanwhile, so
//! the host's next packet is NAKed and retried by its USB stack) — none is dropped. A response
//! goes into `state::USB_TX` piece by piece, each whole or not at all (`compute`).

use core::sync::atomic::{AtomicBool, Ordering};

use embassy_futures::join::join5;
use embassy_futures::select::{Either, select};
use embassy_stm32::peripherals::USB;
use embassy_stm32::usb::Driver;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::signal::Signal;
use embassy_usb::Builder;
use embassy_usb::class::cdc_acm::{CdcAcmClass, State};
use static_cell::StaticCell;

use super::state::{self, PACKET, UsbEvent};

/// The pod's USB identity (pid.codes test VID/PID until an allocation exists).
const VID: u16 = 0x1209;
const PID: u16 = 0x0001;

/// A host holds the command port open (DTR set).
static COMMAND_OPEN: AtomicBool = AtomicBool::new(false);
/// The command port's host closed it (DTR dropped, the cable gone): a write in progress is
/// given up. Reset when a host opens it.
static COMMAND_CLOSED: Signal<CriticalSectionRawMutex, ()> = Signal::new();

/// Hands `e` to the application task, waiting for room (flow control: nothing is dropped).
async fn event(e: UsbEvent) {
    state::USB_RX.send(e).await;
}

/// Runs the USB device and both ports; `serial` is the pod's serial number (as CANopen
/// 0x1018:4 and `*IDN?`), the descriptor's iSerialNumber as eight hex digits.
#[embassy_executor::task]
pub async fn usb_task(driver: Driver<'static, USB>, serial: u32) {
    let mut config = embassy_usb::Config::new(VID, PID);
    config.manufacturer = Some("ballpod");
    config.product = Some("ballpod measurement pod");
    static SERIAL: StaticCell<[u8; 8]> = StaticCell::new();
    // eight ASCII hex digits are UTF-8
    config.serial_number = core::str::from_utf8(SERIAL.init(ballpod::num::hex8(serial))).ok();
    config.max_packet_size_0 = 64;

    static CONFIG_DESC: StaticCell<[u8; 256]> = StaticCell::new();
    static BOS_DESC: StaticCell<[u8; 256]> = StaticCell::new();
    static CONTROL_BUF: StaticCell<[u8; 64]> = StaticCell::new();
    static COMMAND_STATE: StaticCell<State> = StaticCell::new();
    static STREAM_STATE: StaticCell<State> = StaticCell::new();
    let mut builder = Builder::new(
        driver,
        config,
        CONFIG_DESC.init([0; 256]),
        BOS_DESC.init([0; 256]),
        &mut [],
        CONTROL_BUF.init([0; 64]),
    );
    let command = CdcAcmClass::new(
        &mut builder,
        COMMAND_STATE.init(State::new()),
        PACKET as u16,
    );
    let stream = CdcAcmClass::new(&mut builder, STREAM_STATE.init(State::new()), PACKET as u16);
    let mut usb = builder.build();
    let (mut tx, mut rx, command_control) = command.split_with_control();
    let (mut stream_tx, _stream_rx, stream_control) = stream.split_with_control();

    let receive = async {
        loop {
            rx.wait_connection().await;
            while !command_control.dtr() {
                command_control.control_changed().await;
            }
            // a new host: nothing of the last one's answers is left for it
            COMMAND_CLOSED.reset();
            state::USB_TX.clear();
            COMMAND_OPEN.store(true, Ordering::Relaxed);
            let mut data = [0u8; PACKET];
            loop {
                match select(rx.read_packet(&mut data), command_control.control_changed()).await {
                    Either::First(Ok(len)) => event(UsbEvent::Bytes { data, len }).await,
                    Either::Second(()) if command_control.dtr() => {}
                    // the cable is gone or the host closed the port
                    Either::First(Err(_)) | Either::Second(()) => break,
                }
            }
            // configuration writes lock again, a download cut short is reported
            COMMAND_OPEN.store(false, Ordering::Relaxed);
            COMMAND_CLOSED.signal(());
            event(UsbEvent::CommandClosed).await;
        }
    };
    let respond = async {
        let mut buf = [0u8; PACKET];
        loop {
            let n = state::USB_TX.read(&mut buf).await;
            if !COMMAND_OPEN.load(Ordering::Relaxed) {
                // no host holds the port: nobody takes it
                continue;
            }
            // a packet the closed port's host will not take is given up, not kept for the next
            let sent = select(
                tx.write_packet(buf.get(..n).unwrap_or(&[])),
                COMMAND_CLOSED.wait(),
            )
            .await;
            if !matches!(sent, Either::First(Ok(()))) {
                continue;
            }
            // a full last packet is followed by a zero-length one: the host sees the end
            if n == PACKET && state::USB_TX.is_empty() {
                let _ = select(tx.write_packet(&[]), COMMAND_CLOSED.wait()).await;
            }
        }
    };
    let samples = async {
        let mut buf = [0u8; PACKET];
        loop {
            stream_tx.wait_connection().await;
            while !stream_control.dtr() {
                stream_control.control_changed().await;
            }
            state::STREAM_TX.clear();
            event(UsbEvent::StreamOpened).await;
            loop {
                let n = match select(
                    state::STREAM_TX.read(&mut buf),
                    stream_control.control_changed(),
                )
                .await
                {
                    Either::First(n) => n,
                    Either::Second(()) if stream_control.dtr() => continue,
                    Either::Second(()) => break,
                };
                if stream_tx
                    .write_packet(buf.get(..n).unwrap_or(&[]))
                    .await
                    .is_err()
                    || !stream_control.dtr()
                {
                    break;
                }
            }
            event(UsbEvent::StreamClosed).await;
        }
    };
    // the task's futures are polled together: while this one checks in, none of them blocks
    let alive = async {
        loop {
            super::safety::check_in(super::safety::Task::Usb);
            embassy_time::Timer::after_millis(super::safety::CHECK_IN_MS).await;
        }
    };
    join5(usb.run(), receive, respond, samples, alive).await;
}
