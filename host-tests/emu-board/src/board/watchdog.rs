//! The CMSDK watchdog (0x40008000, the mps2's system clock) as the STM32's IWDG: it expires
//! [`WATCHDOG_TIMEOUT_US`] after the last pet and raises the NMI, whose handler notes the
//! expiry in RAM the start-up code leaves alone and resets the machine (SYSRESETREQ), so the
//! next boot knows a watchdog reset. Its own reset, at a second expiry, stays enabled behind
//! that (a core locked up in the NMI is still reset).
//!
//! One expiry is not the firmware's: QEMU stalled on the host. While the firmware sleeps,
//! emulated time follows real time (`-icount sleep=on`), so a stall of QEMU's process jumps
//! emulated time at once, past every timer — the sample clock's and the watchdog's alike —
//! with no instruction run in between: the pod never stops for that long. The NMI excuses an
//! expiry that came so: the core asleep in thread mode's WFI ([`load::asleep`]), the sample
//! clock — the board's highest-priority periodic interrupt — quiet for [`QUIET_US`] or more,
//! and ticking since the last expiry excused; it then re-arms the watchdog and counts it
//! ([`Figure::WatchdogStallsExcused`]). A firmware fault is never all three: a task that holds
//! the CPU keeps it awake, a task that waits for ever leaves the sample clock ticking, and a
//! stopped sample clock is excused once. A stall that ends two timeouts or more after the last
//! pet (one of 0.8 s or more) met the watchdog's own reset: not excused.
//!
//! [`load::asleep`]: super::load::asleep
//! [`Figure::WatchdogStallsExcused`]: super::shared::Figure::WatchdogStallsExcused

use core::ptr::{read_volatile, write_volatile};
use core::sync::atomic::{AtomicU32, Ordering};

use super::safety::{self, WATCHDOG_TIMEOUT_US};
use super::shared::{Figure, add_figure};

const BASE: usize = 0x4000_8000;
const LOAD: usize = 0x00;
const CONTROL: usize = 0x08;
const INTCLR: usize = 0x0C;
const LOCK: usize = 0xC00;
const UNLOCK: u32 = 0x1ACC_E551;
/// Interrupt (NMI) and reset enabled.
const CONTROL_ON: u32 = 0b11;

/// How long the sample clock must have been quiet for an expiry to be a stall of QEMU, µs: a
/// hundred periods at 1 kHz. Its interrupt (priority 1) runs within microseconds of each
/// period while the core sleeps or works; a stall that expires the watchdog is at least
/// 300 ms (the timeout less the 200 ms between pets).
const QUIET_US: u32 = 100_000;

/// "WDOG" in the retained word: the watchdog expired and the NMI reset the machine.
const FIRED: u32 = 0x474F_4457;

struct Retained(core::cell::UnsafeCell<u32>);
// SAFETY: written by the NMI handler, read and cleared once at boot.
unsafe impl Sync for Retained {}

#[unsafe(link_section = ".uninit.ballpod_watchdog")]
static NOTE: Retained = Retained(core::cell::UnsafeCell::new(0));

/// The sample clock's tick count at the last expiry excused (0: none yet).
static EXCUSED_AT_TICK: AtomicU32 = AtomicU32::new(0);

fn wr(reg: usize, v: u32) {
    // SAFETY: a register of the CMSDK watchdog (mps2-an386 memory map).
    unsafe { write_volatile((BASE + reg) as *mut u32, v) }
}

fn note(v: u32) {
    // SAFETY: see `Retained`.
    unsafe { write_volatile(NOTE.0.get(), v) };
}

/// Whether the last reset was the watchdog's; clears the note. Call once at boot.
pub fn take_reset_flag() -> bool {
    // SAFETY: see `Retained`.
    let fired = unsafe { read_volatile(NOTE.0.get()) } == FIRED;
    note(0);
    fired
}

/// The time base's counter at the last pet ([`super::time::counter`]).
static PETTED_AT: AtomicU32 = AtomicU32::new(0);

/// Reloads the count (and clears the expiry's interrupt).
fn pet() {
    wr(LOCK, UNLOCK);
    wr(INTCLR, 1);
    wr(LOCK, 0);
    PETTED_AT.store(super::time::counter(), Ordering::Relaxed);
}

/// Starts the watchdog and pets it while every task checks in ([`safety::watch`]).
#[embassy_executor::task]
pub async fn watchdog_task() {
    wr(LOCK, UNLOCK);
    wr(LOAD, WATCHDOG_TIMEOUT_US * super::time::PER_US as u32);
    wr(CONTROL, CONTROL_ON);
    wr(LOCK, 0);
    PETTED_AT.store(super::time::counter(), Ordering::Relaxed);
    safety::watch(pet).await
}

/// The watchdog's expiry: a stall of QEMU on the host is excused (module doc), anything else
/// resets the machine as the IWDG would.
#[cortex_m_rt::exception]
unsafe fn NonMaskableInt() {
    // noted first: if the watchdog's own reset is under way, the next boot knows it
    note(FIRED);
    let unpetted_us =
        super::time::counter_gap_us(PETTED_AT.load(Ordering::Relaxed), super::time::counter());
    if let Some((ticks, quiet_us)) = super::lvdt::ticks_and_quiet_us()
        && unpetted_us < 2 * WATCHDOG_TIMEOUT_US
        && super::load::asleep()
        && quiet_us >= QUIET_US
        && ticks != EXCUSED_AT_TICK.load(Ordering::Relaxed)
    {
        EXCUSED_AT_TICK.store(ticks, Ordering::Relaxed);
        pet();
        note(0);
        add_figure(Figure::WatchdogStallsExcused, 1);
        return;
    }
    cortex_m::peripheral::SCB::sys_reset()
}
