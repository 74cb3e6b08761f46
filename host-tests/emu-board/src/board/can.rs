//! The CAN bus as SLCAN on UART0 (QEMU's serial 0, a TCP port): the emulated board is its own
//! SLCAN adapter. Received `t…` lines are frames for the application task (`state::CAN_RX`),
//! the frames its CANopen node sends go out as `t…` lines (`state::CAN_TX`); the adapter's
//! commands (`O`, `C`, `Sn`, `V`, …) are answered CR, a bad line BEL. Frames pass while the
//! host's `Sn` bit rate is the controller's (the configured one, or the one an LSS master
//! activated: `state::CAN_BIT_RATE`). The codec is the core's
//! (`ballpod::protocol::slcan`), the one `sim --serve` speaks.
//!
//! As the bus side of the node it measures, in emulated time, what a CAN analyser on the bus
//! would: each SDO request's answer time (its frame received → the answer's frame sent) and
//! the time between heartbeats ([`BusFigures`], in the shared region's figures), leaving out
//! the gaps a stall of QEMU on the host made late (the sample clock's late tick shows it).

use embassy_futures::select::{Either, select};

use ballpod::protocol::slcan::{LineSplitter, SlcanPort};

use ballpod::protocol::canopen::CanFrame;

use super::safety::{self, Task};
use super::shared::{Figure, set_figure};
use super::state;
use super::uart::UART0;

/// Moves SLCAN lines and frames between UART0 and the application task.
#[embassy_executor::task]
pub async fn can_task(bit_rate: ballpod::config::CanBitrate) {
    let mut lines = LineSplitter::default();
    let mut port = SlcanPort::default();
    // the bus runs at the configured bit rate until an LSS master switches it
    port.set_node_bit_rate(bit_rate.bits_per_s());
    let mut buf = [0u8; 64];
    let mut out: heapless::Vec<u8, 512> = heapless::Vec::new();
    let mut figures = BusFigures::resumed();
    loop {
        safety::check_in(Task::Can);
        let tick = embassy_time::Timer::after_millis(safety::CHECK_IN_MS);
        match select(
            select(UART0.rx.read(&mut buf), state::CAN_TX.receive()),
            select(tick, state::CAN_BIT_RATE.wait()),
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
                    if let Some(f) = frame {
                        figures.received(&f);
                        if state::CAN_RX.try_send(f).is_err() {
                            state::CAN_RX_OVERRUNS.count();
                        }
                    }
                });
                UART0.write_all(&out).await;
            }
            Either::First(Either::Second(frame)) => {
                figures.sent(&frame);
                if port.passes() {
                    UART0.write_all(&SlcanPort::frame_line(&frame)).await;
                }
            }
            Either::Second(Either::First(())) => {}
            Either::Second(Either::Second(rate)) => port.set_node_bit_rate(rate.bits_per_s()),
        }
    }
}

/// A late tick of the sample clock this late or later (a QEMU stall on the host) leaves the
/// heartbeat gaps around it out, µs: half the 1 ms granularity of the heartbeat's own tick.
const STALL_LEFT_OUT_US: u32 = 500;
/// ... if the heartbeat went out at most this long after that tick, µs: its due time fell in
/// the stall, and it waited for the tick turn after it (a turn in front, the 1 ms tick).
const STALL_REACH_US: u64 = 3_000;

/// What the bus side measures (emulated time, µs).
#[derive(Default)]
struct BusFigures {
    /// When the SDO request waiting for its answer was received, and the COB-ID of the answer
    /// it waits for.
    sdo_asked: Option<(u64, u16)>,
    sdo_answers: u32,
    sdo_worst_us: u32,
    /// The last heartbeat's time (none since boot or a boot-up frame).
    heartbeat_us: Option<u64>,
    heartbeats: u32,
    gap_min_us: u32,
    gap_max_us: u32,
    /// The last heartbeat came after a late tick of the sample clock (a QEMU stall).
    stalled_before: bool,
    left_out: u32,
}

impl BusFigures {
    /// The figures so far (a reset keeps them: the shared region is the harness's).
    fn resumed() -> Self {
        use super::shared::figure;
        Self {
            sdo_answers: figure(Figure::SdoAnswers),
            sdo_worst_us: figure(Figure::SdoWorstUs),
            heartbeats: figure(Figure::Heartbeats),
            gap_min_us: figure(Figure::HeartbeatGapMinUs),
            gap_max_us: figure(Figure::HeartbeatGapMaxUs),
            left_out: figure(Figure::HeartbeatGapsLeftOut),
            ..Self::default()
        }
    }

    /// A frame from the bus.
    fn received(&mut self, f: &CanFrame) {
        // an SDO request to any node: the pod answers its own (as an analyser pairs them, the
        // latest request waits; one to a node that never answers is replaced by the next)
        if f.id & 0x780 == 0x600 {
            let answer = f.id - 0x600 + 0x580;
            self.sdo_asked = Some((embassy_time::Instant::now().as_micros(), answer));
        }
    }

    /// A frame the node sends.
    fn sent(&mut self, f: &CanFrame) {
        let now = embassy_time::Instant::now().as_micros();
        let us = |t: u64| u32::try_from(now.saturating_sub(t)).unwrap_or(u32::MAX);
        if let Some((t, answer)) = self.sdo_asked
            && f.id == answer
        {
            self.sdo_asked = None;
            self.sdo_answers = self.sdo_answers.wrapping_add(1);
            self.sdo_worst_us = self.sdo_worst_us.max(us(t));
            set_figure(Figure::SdoAnswers, self.sdo_answers);
            set_figure(Figure::SdoWorstUs, self.sdo_worst_us);
        }
        if f.id & 0x780 == 0x700 {
            // a stall of QEMU on the host that ended just before this heartbeat made it late,
            // and so the gap before it long and the gap after it short: both are left out
            let (stall_end, stall_us) = super::lvdt::last_stall();
            let stalled =
                stall_us >= STALL_LEFT_OUT_US && now.saturating_sub(stall_end) <= STALL_REACH_US;
            let stalled_before = core::mem::replace(&mut self.stalled_before, stalled);
            if f.data[0] == 0 {
                // boot-up: the heartbeat starts again
                self.heartbeat_us = None;
                return;
            }
            if self.heartbeat_us.is_some() && (stalled || stalled_before) {
                self.left_out = self.left_out.wrapping_add(1);
                set_figure(Figure::HeartbeatGapsLeftOut, self.left_out);
            } else if let Some(t) = self.heartbeat_us {
                let gap = us(t);
                self.gap_min_us = if self.heartbeats == 0 {
                    gap
                } else {
                    self.gap_min_us.min(gap)
                };
                self.gap_max_us = self.gap_max_us.max(gap);
                self.heartbeats = self.heartbeats.wrapping_add(1);
                set_figure(Figure::Heartbeats, self.heartbeats);
                set_figure(Figure::HeartbeatGapMinUs, self.gap_min_us);
                set_figure(Figure::HeartbeatGapMaxUs, self.gap_max_us);
            }
            self.heartbeat_us = Some(now);
        }
    }
}
