//! The CMSDK APB UARTs of the mps2-an386 (QEMU hands each to a TCP port: `-serial tcp:…`):
//! received bytes go by interrupt into a pipe a task reads; a task writes bytes, waiting for
//! the transmit interrupt only while the transmitter is full. QEMU's UART has no baud-rate
//! timing and no modem lines: the firmware cannot tell whether a client is connected.

use core::ptr::{read_volatile, write_volatile};

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::pipe::Pipe;
use embassy_sync::signal::Signal;

use super::Overruns;

const DATA: usize = 0x00;
const STATE: usize = 0x04;
const CTRL: usize = 0x08;
const INTSTATUS: usize = 0x0C;
const BAUDDIV: usize = 0x10;

const STATE_TXFULL: u32 = 1 << 0;
const STATE_RXFULL: u32 = 1 << 1;
const CTRL_TXEN: u32 = 1 << 0;
const CTRL_RXEN: u32 = 1 << 1;
const CTRL_TXINTEN: u32 = 1 << 2;
const CTRL_RXINTEN: u32 = 1 << 3;
const INT_TX: u32 = 1 << 0;
const INT_RX: u32 = 1 << 1;

/// Bytes a port's receive pipe holds (the task empties it every few hundred µs).
pub const RX_BYTES: usize = 512;

/// One UART: its registers, its transmit interrupt, its receive pipe.
pub struct Uart {
    base: usize,
    /// Received bytes, for the port's task.
    pub rx: Pipe<CriticalSectionRawMutex, RX_BYTES>,
    /// Bytes the receive pipe had no room for.
    pub rx_overruns: Overruns,
    tx_ready: Signal<CriticalSectionRawMutex, ()>,
}

/// UART0: SLCAN (the CAN bus).
pub static UART0: Uart = Uart::new(0x4000_4000);
/// UART1: the SCPI command port.
pub static UART1: Uart = Uart::new(0x4000_5000);
/// UART2: the sample stream.
pub static UART2: Uart = Uart::new(0x4000_6000);

impl Uart {
    const fn new(base: usize) -> Self {
        Self {
            base,
            rx: Pipe::new(),
            rx_overruns: Overruns::new(),
            tx_ready: Signal::new(),
        }
    }

    fn read(&self, reg: usize) -> u32 {
        // SAFETY: a register of this UART (mps2-an386 memory map).
        unsafe { read_volatile((self.base + reg) as *const u32) }
    }

    fn write(&self, reg: usize, v: u32) {
        // SAFETY: as above.
        unsafe { write_volatile((self.base + reg) as *mut u32, v) }
    }

    /// Enables transmitter, receiver and the receive interrupt (QEMU ignores the baud rate;
    /// a divider of 16 or more is a valid one).
    pub fn start(&self) {
        self.write(BAUDDIV, 16);
        self.write(CTRL, CTRL_TXEN | CTRL_RXEN | CTRL_RXINTEN);
    }

    /// The receive interrupt: every byte waiting into the pipe. The interrupt is cleared
    /// before the data register is read: a byte that arrives after the last read raises it
    /// again (cleared after, it would be lost with the UART full for ever).
    fn on_rx(&self) {
        loop {
            self.write(INTSTATUS, INT_RX);
            if self.read(STATE) & STATE_RXFULL == 0 {
                break;
            }
            let b = self.read(DATA) as u8;
            if self.rx.try_write(&[b]).is_err() {
                self.rx_overruns.count();
            }
        }
    }

    /// The transmit interrupt: the transmitter has room again.
    fn on_tx(&self) {
        self.write(INTSTATUS, INT_TX);
        self.write(CTRL, self.read(CTRL) & !CTRL_TXINTEN);
        self.tx_ready.signal(());
    }

    /// Writes `bytes`, waiting while the transmitter is full.
    pub async fn write_all(&self, bytes: &[u8]) {
        for &b in bytes {
            while self.read(STATE) & STATE_TXFULL != 0 {
                self.tx_ready.reset();
                critical_section::with(|_| {
                    self.write(CTRL, self.read(CTRL) | CTRL_TXINTEN);
                });
                if self.read(STATE) & STATE_TXFULL != 0 {
                    self.tx_ready.wait().await;
                }
            }
            self.write(DATA, u32::from(b));
        }
    }
}

/// UART0 receive interrupt.
pub extern "C" fn uart0_rx() {
    UART0.on_rx();
}
/// UART0 transmit interrupt.
pub extern "C" fn uart0_tx() {
    UART0.on_tx();
}
/// UART1 receive interrupt.
pub extern "C" fn uart1_rx() {
    UART1.on_rx();
}
/// UART1 transmit interrupt.
pub extern "C" fn uart1_tx() {
    UART1.on_tx();
}
/// UART2 receive interrupt.
pub extern "C" fn uart2_rx() {
    UART2.on_rx();
}
/// UART2 transmit interrupt.
pub extern "C" fn uart2_tx() {
    UART2.on_tx();
}
