//! The mps2-an386's interrupt numbers, priorities and vector table (QEMU `hw/arm/mps2.c`:
//! UART n at 0x40004000 + …, RX interrupt 0/2/4, TX one more; CMSDK timers 0 and 1 at
//! 0x40000000 / 0x40001000, interrupts 8 and 9; the dual timer at 0x40002000, interrupt 10).
//! No device crate exists for it: the vector table is written here.

use cortex_m::interrupt::InterruptNumber;
use cortex_m::peripheral::NVIC;

/// An interrupt line of the NVIC.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Irq(pub u16);

// SAFETY: every number below is a line of the mps2-an386's NVIC (32 lines).
unsafe impl InterruptNumber for Irq {
    fn number(self) -> u16 {
        self.0
    }
}

/// UART0 (SLCAN) receive and transmit.
pub const UART0_RX: Irq = Irq(0);
/// UART0 transmit.
pub const UART0_TX: Irq = Irq(1);
/// UART1 (SCPI) receive.
pub const UART1_RX: Irq = Irq(2);
/// UART1 transmit.
pub const UART1_TX: Irq = Irq(3);
/// UART2 (sample stream) receive.
pub const UART2_RX: Irq = Irq(4);
/// UART2 transmit.
pub const UART2_TX: Irq = Irq(5);
/// Timer 0: the time base's wrap.
pub const TIMER0: Irq = Irq(8);
/// Timer 1: the time driver's alarm.
pub const TIMER1: Irq = Irq(9);
/// The dual timer: the sample clock (the block latch).
pub const DUALTIMER: Irq = Irq(10);
/// The probe edge (pended by the block latch for a record's edge; the STM32's EXTI4).
pub const PROBE: Irq = Irq(24);
/// The I/O executor (the STM32's UART4).
pub const EXEC_IO: Irq = Irq(25);
/// The pod executor (the STM32's UART5).
pub const EXEC_POD: Irq = Irq(26);

/// NVIC priorities in the top three bits (the least an M4 implements), as the STM32 board's
/// levels 0–4.
pub const fn prio(level: u8) -> u8 {
    level << 5
}

/// Sets every line's priority and enables the peripherals' lines (the executors enable
/// their own when started).
pub fn set_priorities() {
    // SAFETY: priorities are set before the interrupts are enabled (boot, one context).
    let mut nvic = unsafe { cortex_m::Peripherals::steal() }.NVIC;
    let table = [
        (PROBE, 0),
        (DUALTIMER, 1),
        (UART0_RX, 2),
        (UART0_TX, 2),
        (UART1_RX, 2),
        (UART1_TX, 2),
        (UART2_RX, 2),
        (UART2_TX, 2),
        (TIMER0, 2),
        (TIMER1, 2),
        (EXEC_IO, 3),
        (EXEC_POD, 4),
    ];
    for (irq, level) in table {
        // SAFETY: changing a priority can break a priority-based critical section; none is
        // in use yet (boot).
        unsafe { nvic.set_priority(irq, prio(level)) };
    }
    for (irq, _) in table.iter().take(10) {
        // SAFETY: their handlers are in the vector table below.
        unsafe { NVIC::unmask(*irq) };
    }
}

unsafe extern "C" {
    fn DefaultHandler();
}

/// A vector table entry.
pub type Vector = unsafe extern "C" fn();

/// The device interrupts (cortex-m-rt's `device` feature takes this table as it is).
#[unsafe(link_section = ".vector_table.interrupts")]
#[unsafe(no_mangle)]
pub static __INTERRUPTS: [Vector; 32] = {
    let mut v: [Vector; 32] = [DefaultHandler; 32];
    v[0] = super::uart::uart0_rx;
    v[1] = super::uart::uart0_tx;
    v[2] = super::uart::uart1_rx;
    v[3] = super::uart::uart1_tx;
    v[4] = super::uart::uart2_rx;
    v[5] = super::uart::uart2_tx;
    v[8] = super::time::timer0;
    v[9] = super::time::timer1;
    v[10] = super::lvdt::block_latch;
    v[24] = super::probe::probe_edge;
    v[25] = crate::exec_io;
    v[26] = crate::exec_pod;
    v
};
