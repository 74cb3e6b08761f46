//! The CAN bus as SLCAN on UART0 (QEMU's serial 0, a TCP port): the emulated board is its own
//! SLCAN adapter. Received `t…` lines are frames for the application task (`state::CAN_RX`),
//! the frames its CANopen node sends go out as `t…` lines (`state::CAN_TX`); the adapter's
//! commands (`O`, `C`, `Sn`, `V`, …) are answered CR, a bad line BEL. The codec is the core's
//! (`ballpod::protocol::slcan`), the one `sim --serve` speaks.

use embassy_futures::select::{Either, select};

use ballpod::protocol::slcan::{LineSplitter, SlcanPort};

use super::safety::{self, Task};
use super::state;
use super::uart::UART0;

/// Moves SLCAN lines and frames between UART0 and the application task.
#[embassy_executor::task]
pub async fn can_task() {
    let mut lines = LineSplitter::default();
    let mut port = SlcanPort::default();
    let mut buf = [0u8; 64];
    let mut out: heapless::Vec<u8, 512> = heapless::Vec::new();
    loop {
        safety::check_in(Task::Can);
        let tick = embassy_time::Timer::after_millis(safety::CHECK_IN_MS);
        match select(
            select(UART0.rx.read(&mut buf), state::CAN_TX.receive()),
            tick,
        )
        .await
        {
            Either::First(Either::First(n)) => {
                out.clear();
                lines.push(buf.get(..n).unwrap_or(&[]), &mut |line| {
                    let frame = port.on_line(line, &mut |r: &[u8]| {
                        // (a 64-byte read answers at most 64 lines of 1–6 bytes)
                        let _ = out.extend_from_slice(r);
                    });
                    if let Some(f) = frame
                        && state::CAN_RX.try_send(f).is_err()
                    {
                        state::CAN_RX_OVERRUNS.count();
                    }
                });
                UART0.write_all(&out).await;
            }
            Either::First(Either::Second(frame)) => {
                if port.is_open() {
                    UART0.write_all(&SlcanPort::frame_line(&frame)).await;
                }
            }
            Either::Second(()) => {}
        }
    }
}
