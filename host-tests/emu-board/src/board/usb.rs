//! The USB device's two ports as UARTs (QEMU's serial 1 and 2, TCP ports): the command port's
//! received bytes go to the application task's SCPI server in packets (`state::USB_RX`), its
//! responses and log downloads come back through `state::USB_TX`; the sample stream's text
//! goes out of `state::STREAM_TX`. QEMU's UARTs have no DTR: the stream port counts as open
//! from boot (a client connecting gets what is written from then on; bytes written while none
//! is connected are dropped by QEMU).

use embassy_futures::join::join3;
use embassy_futures::select::{Either, select};

use super::safety::{self, Task};
use super::state::{self, PACKET, UsbEvent};
use super::uart::{UART1, UART2};

fn event(e: UsbEvent) {
    if state::USB_RX.try_send(e).is_err() {
        state::USB_RX_OVERRUNS.count();
    }
}

/// Runs both ports.
#[embassy_executor::task]
pub async fn usb_task() {
    event(UsbEvent::StreamOpened);
    let receive = async {
        let mut data = [0u8; PACKET];
        loop {
            let mut len = UART1.rx.read(&mut data).await;
            // a USB frame's worth: what arrives within 1 ms, up to a packet (QEMU hands the
            // UART a byte at a time; one event a byte would fill the application task's
            // 8-event queue with 8 bytes, where the STM32 board's holds 8 packets)
            let frame_end = embassy_time::Instant::now() + embassy_time::Duration::from_millis(1);
            while let Some(rest) = data.get_mut(len..).filter(|r| !r.is_empty()) {
                match select(UART1.rx.read(rest), embassy_time::Timer::at(frame_end)).await {
                    Either::First(n) => len += n,
                    Either::Second(()) => break,
                }
            }
            event(UsbEvent::Bytes { data, len });
        }
    };
    let respond = async {
        let mut buf = [0u8; PACKET];
        loop {
            let n = state::USB_TX.read(&mut buf).await;
            UART1.write_all(buf.get(..n).unwrap_or(&[])).await;
        }
    };
    let samples = async {
        let mut buf = [0u8; PACKET];
        loop {
            let n = state::STREAM_TX.read(&mut buf).await;
            UART2.write_all(buf.get(..n).unwrap_or(&[])).await;
        }
    };
    let alive = async {
        loop {
            safety::check_in(Task::Usb);
            embassy_time::Timer::after_millis(safety::CHECK_IN_MS).await;
        }
    };
    embassy_futures::join::join(join3(receive, respond, samples), alive).await;
}
