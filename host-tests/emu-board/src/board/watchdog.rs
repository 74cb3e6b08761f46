//! The CMSDK watchdog (0x40008000, the mps2's system clock): its first expiry raises the NMI,
//! whose handler notes it in RAM the start-up code leaves alone; the second resets the
//! machine. So the timeout is twice the load, and the next boot knows a watchdog reset.

use core::ptr::write_volatile;

use super::safety::{self, WATCHDOG_TIMEOUT_US};

const BASE: usize = 0x4000_8000;
const LOAD: usize = 0x00;
const CONTROL: usize = 0x08;
const INTCLR: usize = 0x0C;
const LOCK: usize = 0xC00;
const UNLOCK: u32 = 0x1ACC_E551;
/// Interrupt (NMI) and reset enabled.
const CONTROL_ON: u32 = 0b11;

/// "WDOG" in the retained word: the NMI saw the first expiry.
const FIRED: u32 = 0x474F_4457;

struct Retained(core::cell::UnsafeCell<u32>);
// SAFETY: written by the NMI handler, read and cleared once at boot.
unsafe impl Sync for Retained {}

#[unsafe(link_section = ".uninit.ballpod_watchdog")]
static NOTE: Retained = Retained(core::cell::UnsafeCell::new(0));

fn wr(reg: usize, v: u32) {
    // SAFETY: a register of the CMSDK watchdog (mps2-an386 memory map).
    unsafe { write_volatile((BASE + reg) as *mut u32, v) }
}

/// Whether the last reset was the watchdog's; clears the note. Call once at boot.
pub fn take_reset_flag() -> bool {
    // SAFETY: see `Retained`.
    let fired = unsafe { core::ptr::read_volatile(NOTE.0.get()) } == FIRED;
    // SAFETY: as above.
    unsafe { write_volatile(NOTE.0.get(), 0) };
    fired
}

/// Starts the watchdog (each expiry half the timeout) and pets it while every task checks in
/// ([`safety::watch`]).
#[embassy_executor::task]
pub async fn watchdog_task() {
    wr(LOCK, UNLOCK);
    wr(LOAD, WATCHDOG_TIMEOUT_US / 2 * 25);
    wr(CONTROL, CONTROL_ON);
    wr(LOCK, 0);
    safety::watch(|| {
        wr(LOCK, UNLOCK);
        wr(INTCLR, 1);
        wr(LOCK, 0);
        // petted in time: a first expiry since was survived, not a reset
        // SAFETY: see `Retained`.
        unsafe { write_volatile(NOTE.0.get(), 0) };
    })
    .await
}

/// The watchdog's first expiry.
#[cortex_m_rt::exception]
unsafe fn NonMaskableInt() {
    // SAFETY: see `Retained`.
    unsafe { write_volatile(NOTE.0.get(), FIRED) };
}
