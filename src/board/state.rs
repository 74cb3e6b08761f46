//! The queues between the I/O tasks and the application task. The application task owns the
//! pod ([`ballpod::app::App`], the CANopen node, the SCPI server, the log and the stream); the
//! CAN and USB tasks only move frames and bytes through these bounded queues. A producer that
//! finds a queue full drops the item and counts it (never silently).

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;
use embassy_sync::pipe::Pipe;
use embassy_sync::signal::Signal;

use ballpod::protocol::canopen::{BusState, CanFrame};

use super::Overruns;

/// Frames received on the bus, for the application task.
pub static CAN_RX: Channel<CriticalSectionRawMutex, CanFrame, 16> = Channel::new();
/// Received frames (or bus-state changes) dropped because the application task had not taken
/// the previous ones.
pub static CAN_RX_OVERRUNS: Overruns = Overruns::new();
/// Frames the CANopen node sends, for the CAN task.
pub static CAN_TX: Channel<CriticalSectionRawMutex, CanFrame, 16> = Channel::new();
/// Frames the node produced that did not fit the transmit queue.
pub static CAN_TX_OVERRUNS: Overruns = Overruns::new();
/// Frames the CAN task gave up on: the controller's transmit buffers stayed full for
/// [`super::can::TX_WAIT_MS`] (no other node acknowledges: the FDCAN retries for ever), or a
/// queued frame was replaced by a higher-priority one.
pub static CAN_TX_DROPPED: Overruns = Overruns::new();
/// The controller's fault-confinement states in the order they came (the CAN task reads FDCAN
/// `PSR` and its interrupt's counts, so a bus-off that recovered between two looks is still
/// one entry and its recovery another).
pub static CAN_BUS: Channel<CriticalSectionRawMutex, BusState, 4> = Channel::new();
/// Received frames the CAN controller lost (its FIFO or the driver's buffer full), counted in
/// the interrupt.
pub static CAN_RX_LOST: Overruns = Overruns::new();
/// The COB-IDs the CANopen node consumes now (`CanOpenNode::accepted_ids`), for the
/// controller's acceptance filters: application task → CAN task, on a change.
pub static CAN_FILTERS: Signal<CriticalSectionRawMutex, [Option<u16>; 4]> = Signal::new();
/// The bit rate an LSS master activated, once its switch delay has passed (the application
/// task's node → the CAN task, which switches the controller).
pub static CAN_BIT_RATE: Signal<CriticalSectionRawMutex, ballpod::config::CanBitrate> =
    Signal::new();

/// Bytes of one USB packet.
pub const PACKET: usize = 64;

/// What the USB task tells the application task.
#[derive(Clone, Copy, Debug)]
pub enum UsbEvent {
    /// Bytes received on the command port (`len` of `data`).
    Bytes {
        /// The packet.
        data: [u8; PACKET],
        /// Bytes used.
        len: usize,
    },
    /// The command port's host went away (DTR dropped or a write failed).
    CommandClosed,
    /// A host opened the stream port (DTR set): the stream starts writing.
    StreamOpened,
    /// The stream port's host went away.
    StreamClosed,
}

/// USB events, for the application task (the STM32 board's USB task waits for room: flow
/// control; the emulated board's drops and counts, as its UART cannot hold the host back).
pub static USB_RX: Channel<CriticalSectionRawMutex, UsbEvent, 8> = Channel::new();
/// USB events dropped because the application task had not taken the previous ones.
pub static USB_RX_OVERRUNS: Overruns = Overruns::new();
/// SCPI responses and log downloads, for the command port.
pub static USB_TX: Pipe<CriticalSectionRawMutex, 2048> = Pipe::new();
/// Response bytes dropped because the command port's host did not read them.
pub static USB_TX_OVERRUNS: Overruns = Overruns::new();
/// The sample stream's text, for the stream port (the stream counts what did not fit).
pub static STREAM_TX: Pipe<CriticalSectionRawMutex, 2048> = Pipe::new();

/// Writes all of `bytes` into `pipe` without waiting, or as much as there is room for: the
/// pipe's ring takes a write up to its end only, so one `try_write` can take less than the
/// room it has. Returns the bytes written.
pub fn write_all_now<const N: usize>(
    pipe: &Pipe<CriticalSectionRawMutex, N>,
    bytes: &[u8],
) -> usize {
    let mut done = 0;
    while let Some(rest) = bytes.get(done..).filter(|r| !r.is_empty()) {
        match pipe.try_write(rest) {
            Ok(n) if n > 0 => done += n,
            _ => break,
        }
    }
    done
}
