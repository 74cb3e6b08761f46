//! embassy-time's driver on the CMSDK timers (25 MHz, the mps2's system clock): timer 0 counts
//! down from 2³² − 1 for ever and its wrap extends it to 64 bits; timer 1 is the alarm for the
//! next expiry of the timer queue. One tick = 1 µs (the firmware's `tick-hz-1_000_000`).

use core::cell::{Cell, RefCell};
use core::ptr::{read_volatile, write_volatile};
use core::task::Waker;

use critical_section::Mutex;
use embassy_time_driver::Driver;
use embassy_time_queue_utils::Queue;

const TIMER0: usize = 0x4000_0000;
const TIMER1: usize = 0x4000_1000;
const CTRL: usize = 0x00;
const VALUE: usize = 0x04;
const RELOAD: usize = 0x08;
const INTSTATUS: usize = 0x0C;
const CTRL_EN: u32 = 1 << 0;
const CTRL_IRQEN: u32 = 1 << 3;

/// Clock ticks per µs of the mps2's system clock (25 MHz), which the CMSDK timers and the
/// watchdog count.
pub const PER_US: u64 = 25;

fn rd(base: usize, reg: usize) -> u32 {
    // SAFETY: a register of a CMSDK timer (mps2-an386 memory map).
    unsafe { read_volatile((base + reg) as *const u32) }
}

fn wr(base: usize, reg: usize, v: u32) {
    // SAFETY: as above.
    unsafe { write_volatile((base + reg) as *mut u32, v) }
}

struct TimerDriver {
    /// Timer 0's wraps (each 2³² ticks).
    wraps: Mutex<Cell<u32>>,
    queue: Mutex<RefCell<Queue>>,
}

embassy_time_driver::time_driver_impl!(static DRIVER: TimerDriver = TimerDriver {
    wraps: Mutex::new(Cell::new(0)),
    queue: Mutex::new(RefCell::new(Queue::new())),
});

/// Starts the time base (before any task runs).
pub fn start() {
    wr(TIMER0, CTRL, 0);
    wr(TIMER0, RELOAD, u32::MAX);
    wr(TIMER0, VALUE, u32::MAX);
    wr(TIMER0, CTRL, CTRL_EN | CTRL_IRQEN);
    wr(TIMER1, CTRL, 0);
}

impl TimerDriver {
    /// Timer clock ticks since start.
    fn ticks(&self) -> u64 {
        critical_section::with(|cs| {
            let mut wraps = self.wraps.borrow(cs).get();
            let value = rd(TIMER0, VALUE);
            // a wrap whose interrupt has not run yet (masked here): count it, unless the
            // value read was from before it
            if rd(TIMER0, INTSTATUS) & 1 != 0 && value > u32::MAX / 2 {
                wraps = wraps.wrapping_add(1);
            }
            (u64::from(wraps) << 32) | u64::from(u32::MAX - value)
        })
    }

    /// Arms the alarm for `at` µs; false if that time has passed already.
    fn set_alarm(&self, at: u64) -> bool {
        wr(TIMER1, CTRL, 0);
        wr(TIMER1, INTSTATUS, 1);
        if at == u64::MAX {
            return true;
        }
        let now = self.ticks();
        let at_ticks = at.saturating_mul(PER_US);
        if at_ticks <= now {
            return false;
        }
        let delta = (at_ticks - now).min(u64::from(u32::MAX - 1)) as u32;
        wr(TIMER1, RELOAD, u32::MAX);
        wr(TIMER1, VALUE, delta.max(1));
        wr(TIMER1, CTRL, CTRL_EN | CTRL_IRQEN);
        true
    }

    fn on_alarm(&self) {
        critical_section::with(|cs| {
            let mut q = self.queue.borrow(cs).borrow_mut();
            let mut next = q.next_expiration(self.now());
            while !self.set_alarm(next) {
                next = q.next_expiration(self.now());
            }
        });
    }
}

impl Driver for TimerDriver {
    fn now(&self) -> u64 {
        // ticks / 25 without a 64-bit division (a library call of ~100 instructions, several
        // a sample period: the STM32's time driver counts µs itself): with ticks = w·2³² + l
        // and 2³² = 25 · 171 798 691 + 21, µs = w · 171 798 691 + (w · 21 + l mod 25) / 25 +
        // l / 25 (the middle term in u32 for 1 100 years of wraps)
        let t = self.ticks();
        let (w, l) = ((t >> 32) as u32, t as u32);
        const Q: u64 = (1u64 << 32) / PER_US;
        const R: u32 = ((1u64 << 32) % PER_US) as u32;
        let per_us = PER_US as u32;
        u64::from(w) * Q
            + u64::from((w.wrapping_mul(R) + l % per_us) / per_us)
            + u64::from(l / per_us)
    }

    fn schedule_wake(&self, at: u64, waker: &Waker) {
        critical_section::with(|cs| {
            let mut q = self.queue.borrow(cs).borrow_mut();
            if q.schedule_wake(at, waker) {
                let mut next = q.next_expiration(self.now());
                while !self.set_alarm(next) {
                    next = q.next_expiration(self.now());
                }
            }
        });
    }
}

/// Timer 0's wrap.
pub extern "C" fn timer0() {
    critical_section::with(|cs| {
        wr(TIMER0, INTSTATUS, 1);
        let w = DRIVER.wraps.borrow(cs);
        w.set(w.get().wrapping_add(1));
    });
}

/// Timer 1: the alarm.
pub extern "C" fn timer1() {
    wr(TIMER1, INTSTATUS, 1);
    DRIVER.on_alarm();
}

/// The time base's counter as it is: 25 MHz, counting down, a wrap every 171.8 s. Read
/// without a critical section, for the NMI (the watchdog's expiry): the clock ticks from one
/// reading to a later one are `earlier.wrapping_sub(later)`, right for gaps under 171 s.
pub fn counter() -> u32 {
    rd(TIMER0, VALUE)
}

/// µs between two [`counter`] readings, `earlier` then `later`.
pub fn counter_gap_us(earlier: u32, later: u32) -> u32 {
    earlier.wrapping_sub(later) / PER_US as u32
}
