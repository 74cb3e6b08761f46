//! The way into the STM32G474's ROM bootloader (ST's system memory: USB DFU, AN2606) from the
//! running firmware, for a field update with `dfu-util` (book: Hardware, "Updating the
//! firmware"). `SYSTem:BOOTloader` (`App::request_bootloader`) → the application task lets the
//! answer out and calls [`restart_into`]: a mark in retained RAM, a system reset. The next boot
//! calls [`enter_if_asked`] first, before anything is set up (clocks at their reset values, no
//! interrupt enabled, the watchdog not started), which clears the mark and enters the system
//! memory (`system_memory::enter`). Going through a reset rather than jumping at once leaves
//! every peripheral as the bootloader expects it.
//!
//! The emulated board builds this file as it is; its `system_memory` counts the entry (QEMU's
//! mps2 has no ST bootloader) and boots on.

use core::cell::UnsafeCell;
use core::mem::MaybeUninit;

use super::safety::Retained;

/// The mark: "BOOT LOAD".
const MARK: u32 = 0xB007_10AD;

/// Written by `restart_into` (interrupts disabled, the reset follows), read and cleared by
/// `enter_if_asked` at boot before any task or interrupt runs.
#[unsafe(link_section = ".uninit.ballpod_bootloader")]
static ASKED: Retained<u32> = Retained(UnsafeCell::new(MaybeUninit::uninit()));

/// Marks retained RAM and resets: the next boot enters the ROM bootloader.
pub fn restart_into() -> ! {
    cortex_m::interrupt::disable();
    // SAFETY: see `Retained`.
    unsafe { ASKED.0.get().cast::<u32>().write_volatile(MARK) };
    cortex_m::peripheral::SCB::sys_reset()
}

/// First thing in `main`: enters the ROM bootloader if the last run asked for it (the mark is
/// cleared first, so the boot after the bootloader is an ordinary one).
pub fn enter_if_asked() {
    // SAFETY: see `Retained` (any bit pattern is a valid u32: power-on leaves noise).
    let asked = unsafe { ASKED.0.get().cast::<u32>().read_volatile() } == MARK;
    // SAFETY: as above.
    unsafe { ASKED.0.get().cast::<u32>().write_volatile(0) };
    if asked {
        super::system_memory::enter();
    }
}
