//! Firmware safety: the independent watchdog fed only when every task has checked in, the
//! panic handler that leaves its reason in retained RAM, and the report of both at the next
//! boot (defmt log, CANopen EMCY 0x6000, SCPI `SYSTem:ERRor?` -300).
//!
//! - **Watchdog**: IWDG (LSI clock, runs even if the main clocks fail) with [`WATCHDOG_TIMEOUT_US`].
//!   Every task calls [`check_in`] as it goes round its loop — compute per sample, LVDT per
//!   block, thermistor per reading, CAN, USB and the worker at least every [`CHECK_IN_MS`] even
//!   when they have nothing to do, the worker's running job by its deadline
//!   ([`super::worker::job_alive`]); the board's watchdog task ([`watch`], at the acquisition's
//!   priority, above every computation) pets the dog every [`PET_PERIOD_MS`] only if all of
//!   [`Task::ALL`] checked in since its last look. A stuck task, a stopped acquisition (no LVDT blocks), a
//!   starved executor or a job past its deadline therefore resets the MCU; the next boot
//!   finds the IWDG reset flag (RCC_CSR.IWDGRSTF, RM0440 §7.4.30) and reports it.
//!
//!   The timeout against the LSI's tolerance: the IWDG counts the LSI, 32 kHz nominal and
//!   29.5–34 kHz over voltage and temperature (STM32G474 datasheet, LSI characteristics), so
//!   the nominal 500 ms expire after 471–542 ms. A look that finds a task missing leaves the
//!   dog unpetted and is counted (`WATCHDOG_MISSES`); the next look, 400 ms after the last pet,
//!   is still inside the shortest timeout, so a task missing at one look only is survived,
//!   and one missing at two looks in a row resets the pod 471–542 ms after the last pet. A task
//!   that checks in at least every [`PET_PERIOD_MS`] (200 ms) is never missing.
//! - **Panic**: [`panic`] writes `file:line: message` (at most [`PANIC_TEXT_BYTES`] bytes) and a
//!   magic word into a `.uninit` static that the startup code does not zero, logs it over defmt
//!   and resets. The next boot takes it out ([`take_reset_report`]) and clears the magic.
//! - **HardFault**: [`HardFault`] leaves `HardFault at PC 0x…, LR 0x…, CFSR 0x…` the same way
//!   (its own magic) and resets: a fault is reported with the instruction that took it, not as
//!   the watchdog reset it would otherwise end in. A fault inside the handler locks the core
//!   up; the G474 does not reset on a lockup, the watchdog does (reported as one).
//! - **NMI** (the STM32 board's `settings::NonMaskableInt`): a double ECC error at the settings
//!   pages is let through (the read that met it fails, its slot is unreadable); any other NMI
//!   is recorded as `NMI, FLASH_ECCR 0x…` the same way ([`record_fault_and_reset`]).

use core::cell::UnsafeCell;
use core::mem::MaybeUninit;
use core::sync::atomic::{AtomicU32, Ordering};

use embassy_time::Timer;

use super::Overruns;

/// Watchdog timeout, µs (nominal: 471–542 ms with the LSI's tolerance, module doc).
pub const WATCHDOG_TIMEOUT_US: u32 = 500_000;
/// How often the watchdog task looks at the check-ins, ms: twice the thermistor's 100 ms
/// period, so every look finds its check-in; two looks fit in the timeout.
pub const PET_PERIOD_MS: u64 = 200;
/// Bytes of panic text kept in retained RAM.
pub const PANIC_TEXT_BYTES: usize = 120;

/// Longest a waiting task (CAN, USB) goes without checking in, ms.
pub const CHECK_IN_MS: u64 = 50;

/// The tasks the watchdog waits for (bit k of [`CHECK_INS`] = task k).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Task {
    /// The application task (per sample).
    Compute = 0,
    /// LVDT demodulation (per block).
    Lvdt = 1,
    /// Thermistor (per reading).
    Thermistor = 2,
    /// CAN (per frame, or every [`CHECK_IN_MS`]).
    Can = 3,
    /// USB (every [`CHECK_IN_MS`]).
    Usb = 4,
    /// The worker (every [`CHECK_IN_MS`] while it waits; a job by its deadline).
    Worker = 5,
}

impl Task {
    /// Every task the watchdog waits for.
    pub const ALL: [Task; 6] = [
        Task::Compute,
        Task::Lvdt,
        Task::Thermistor,
        Task::Can,
        Task::Usb,
        Task::Worker,
    ];
    /// All their bits.
    const ALL_BITS: u32 = (1 << Task::ALL.len()) - 1;
}

/// Tasks that checked in since the watchdog's last look (bit per [`Task`]).
static CHECK_INS: AtomicU32 = AtomicU32::new(0);
/// Looks of the watchdog task that found a task missing (the dog was not petted).
pub static WATCHDOG_MISSES: Overruns = Overruns::new();

/// Called by `task` as it goes round its loop.
pub fn check_in(task: Task) {
    CHECK_INS.fetch_or(1 << task as u32, Ordering::Relaxed);
}

/// Pets the watchdog (`pet`) every [`PET_PERIOD_MS`] while every task checks in; the board's
/// watchdog task runs it once its watchdog is started (`board::watchdog`).
pub async fn watch(mut pet: impl FnMut()) -> ! {
    loop {
        Timer::after_millis(PET_PERIOD_MS).await;
        let mut seen = CHECK_INS.swap(0, Ordering::Relaxed);
        if super::worker::job_alive() {
            // a job is one long computation: its deadline stands for its check-in
            seen |= 1 << Task::Worker as u32;
        }
        if seen & Task::ALL_BITS == Task::ALL_BITS {
            pet();
        } else {
            defmt::warn!(
                "watchdog: tasks not checked in {=u32:b}",
                !seen & Task::ALL_BITS
            );
            WATCHDOG_MISSES.count();
        }
    }
}

/// Magic word of a valid panic record ("PANC").
const PANIC_MAGIC: u32 = 0x434E_4150;
/// Magic word of a valid HardFault record ("HFLT").
const FAULT_MAGIC: u32 = 0x544C_4648;

/// What a panic leaves in retained RAM.
#[derive(Clone, Copy)]
#[repr(C)]
struct PanicRecord {
    magic: u32,
    len: u32,
    text: [u8; PANIC_TEXT_BYTES],
}

/// Retained RAM: in `.uninit`, NOLOAD and not zeroed by cortex-m-rt, a value survives a reset
/// (the panic record here, the ROM bootloader's mark in `rom_bootloader`). Every bit pattern
/// must be a valid `T`: after a power-on the bytes are arbitrary.
pub struct Retained<T>(pub UnsafeCell<MaybeUninit<T>>);
// SAFETY: each static is written only just before a reset (interrupts disabled, nothing runs
// after it) and read at boot before any task or interrupt runs.
unsafe impl<T> Sync for Retained<T> {}

#[unsafe(link_section = ".uninit.ballpod_panic")]
static PANIC_RECORD: Retained<PanicRecord> = Retained(UnsafeCell::new(MaybeUninit::uninit()));

/// A bounded writer into the panic text (drops what does not fit).
struct Bounded<'a> {
    buf: &'a mut [u8; PANIC_TEXT_BYTES],
    len: usize,
}

impl Bounded<'_> {
    /// `v` as eight hexadecimal digits.
    fn push_hex(&mut self, v: u32) {
        const DIGITS: &[u8; 16] = b"0123456789ABCDEF";
        for k in (0..8).rev() {
            let d = DIGITS
                .get(((v >> (4 * k)) & 0xF) as usize)
                .copied()
                .unwrap_or(b'?');
            if let Some(slot) = self.buf.get_mut(self.len) {
                *slot = d;
                self.len += 1;
            }
        }
    }

    fn push(&mut self, s: &str) {
        for &b in s.as_bytes() {
            if let Some(d) = self.buf.get_mut(self.len) {
                // '"' would end the SCPI string response early.
                *d = if b == b'"' { b'\'' } else { b };
                self.len += 1;
            }
        }
    }
}

/// The panic handler (replaces panic-probe): reason to retained RAM and defmt, then reset.
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    cortex_m::interrupt::disable();
    let mut text = [0u8; PANIC_TEXT_BYTES];
    let mut w = Bounded {
        buf: &mut text,
        len: 0,
    };
    // No core::fmt (3 KiB of flash): the location's line by hand, and the message only when it
    // is a plain string (a formatted message's arguments are not kept).
    if let Some(loc) = info.location() {
        w.push("panic at ");
        w.push(loc.file());
        let mut line = ballpod::protocol::scpi::number::Text::<10>::new();
        ballpod::protocol::scpi::number::push_u64(&mut line, u64::from(loc.line()));
        w.push(":");
        w.push(core::str::from_utf8(&line).unwrap_or("?"));
        w.push(": ");
    }
    w.push(info.message().as_str().unwrap_or("(formatted message)"));
    let len = w.len;
    record_and_reset(PANIC_MAGIC, text, len)
}

/// The record of `magic` with the first `len` bytes of `text` to retained RAM and defmt, then
/// a reset.
fn record_and_reset(magic: u32, text: [u8; PANIC_TEXT_BYTES], len: usize) -> ! {
    let shown = core::str::from_utf8(text.get(..len).unwrap_or(&[])).unwrap_or("?");
    defmt::error!("{}", shown);
    let rec = PanicRecord {
        magic,
        len: len as u32,
        text,
    };
    // SAFETY: see `Retained`; a volatile write so it is not optimised away before the reset.
    unsafe { core::ptr::write_volatile(PANIC_RECORD.0.get().cast::<PanicRecord>(), rec) };
    cortex_m::peripheral::SCB::sys_reset()
}

/// The HardFault handler: where the fault was (the stacked PC and LR) and why (the
/// configurable fault status register CFSR, PM0214) to retained RAM and defmt, then
/// reset.
#[cortex_m_rt::exception]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    cortex_m::interrupt::disable();
    let mut text = [0u8; PANIC_TEXT_BYTES];
    let mut w = Bounded {
        buf: &mut text,
        len: 0,
    };
    // SAFETY: a read of the fault status register, no side effect.
    let cfsr = unsafe { (*cortex_m::peripheral::SCB::PTR).cfsr.read() };
    w.push("HardFault at PC 0x");
    w.push_hex(frame.pc());
    w.push(", LR 0x");
    w.push_hex(frame.lr());
    w.push(", CFSR 0x");
    w.push_hex(cfsr);
    let len = w.len;
    record_and_reset(FAULT_MAGIC, text, len)
}

/// Records `what` followed by `value` in hex (e.g. `NMI, FLASH_ECCR 0x…`) as a fault, like a
/// HardFault, and resets (for the board's other fault handlers).
#[allow(
    dead_code,
    reason = "the STM32 board's NMI handler calls it; the emulated board has none"
)]
pub fn record_fault_and_reset(what: &str, value: u32) -> ! {
    cortex_m::interrupt::disable();
    let mut text = [0u8; PANIC_TEXT_BYTES];
    let mut w = Bounded {
        buf: &mut text,
        len: 0,
    };
    w.push(what);
    w.push_hex(value);
    let len = w.len;
    record_and_reset(FAULT_MAGIC, text, len)
}

/// Why the previous run ended, when its end left a record.
pub enum ResetReport {
    /// A panic, with its text (`panic at file:line: message`).
    Panic(&'static str),
    /// A HardFault, with its text (`HardFault at PC 0x…, LR 0x…, CFSR 0x…`).
    HardFault(&'static str),
}

/// Takes the panic or HardFault record (clearing it). Call once at boot, before the tasks
/// start.
pub fn take_reset_report() -> Option<ResetReport> {
    static TEXT: static_cell::StaticCell<[u8; PANIC_TEXT_BYTES]> = static_cell::StaticCell::new();
    let ptr = PANIC_RECORD.0.get().cast::<PanicRecord>();
    // SAFETY: see `Retained`; after a power-on the bytes are arbitrary but every bit pattern is
    // a valid `PanicRecord` (integers and bytes), and the magic decides whether it is used.
    let rec = unsafe { core::ptr::read_volatile(ptr) };
    if rec.magic == PANIC_MAGIC || rec.magic == FAULT_MAGIC {
        // SAFETY: as above; the magic is cleared so the report is made once.
        unsafe { core::ptr::write_volatile(core::ptr::addr_of_mut!((*ptr).magic), 0) };
        let text = TEXT.try_init(rec.text)?;
        let len = (rec.len as usize).min(PANIC_TEXT_BYTES);
        let bytes = text.get(..len).unwrap_or(&[]);
        // A cut in the middle of a UTF-8 sequence keeps the valid prefix.
        let s = match core::str::from_utf8(bytes) {
            Ok(s) => s,
            Err(e) => {
                core::str::from_utf8(bytes.get(..e.valid_up_to()).unwrap_or(&[])).unwrap_or("")
            }
        };
        return Some(if rec.magic == FAULT_MAGIC {
            ResetReport::HardFault(s)
        } else {
            ResetReport::Panic(s)
        });
    }
    None
}
