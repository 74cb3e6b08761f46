//! The emulated ADC: the sample clock (the dual timer at the configured sample rate) takes the
//! harness's next block record at each tick — the STM32's block latch: the counters and the
//! time at the block's centre — and pends the probe interrupt for a record's edge; the LVDT
//! task then runs the STM32 board's path from a block ready onward (`block::BlockPath`) on the
//! record's codes. No record at a tick (the harness, on the host beside QEMU, is behind): the
//! period is owed and delivered with its own time once the record is there (below).
//!
//! QEMU delivers a timer's interrupt late when it wakes late from the firmware's idle (its
//! `sleep=on` follows real time) and then once for several periods; a real ADC and its DMA do
//! not wait for an interrupt. So a tick takes every period elapsed since the last one, each
//! with its own time on the sample clock's grid: the block path sees the periods the ADC
//! converted. A period is lost where the firmware did not take the previous ones (the tick
//! queue is full, as the STM32's DMA ring overruns) or the harness stayed far behind.

use core::ptr::{read_volatile, write_volatile};
use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::NVIC;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;

use super::block::{BLOCK_MAX, BlockPath};
use super::{hw, shared};

const DUAL: usize = 0x4000_2000;
const LOAD: usize = 0x00;
const CONTROL: usize = 0x08;
const INTCLR: usize = 0x0C;
/// Timer enable, periodic, interrupt enable, 32-bit.
const CONTROL_RUN: u32 = (1 << 7) | (1 << 6) | (1 << 5) | (1 << 1);

/// A block taken at a tick: the record's number, the period's time on the sample grid.
#[derive(Clone, Copy)]
struct Tick {
    record: u32,
    t_us: u64,
}

/// Sample clock → LVDT task (64 ms at 1 kHz, 6.4 ms at 10 kHz).
static TICKS: Channel<CriticalSectionRawMutex, Tick, TICKS_HELD> = Channel::new();
/// A tick delivered nothing (the harness is behind): wakes the LVDT task to check in.
static STARVED: embassy_sync::signal::Signal<CriticalSectionRawMutex, ()> =
    embassy_sync::signal::Signal::new();
/// Periods the tick queue holds.
const TICKS_HELD: usize = 64;
/// Time owed before the oldest period is given up as lost, µs (the harness keeps 48 ms of
/// records ahead; on a loaded host QEMU has been seen to stall for 260 ms).
const OWED_MAX_US: u64 = 1_000_000;
/// Owed periods go with every second tick besides the tick's own: the firmware catches up at
/// 1.5 times the sample rate (a stall's periods all at once would be a burst no ADC makes, and
/// would overrun the block queue at 10 kHz).
const CATCH_UP_EVERY: u32 = 2;
/// Ticks since the last owed period went.
static SINCE_CATCH_UP: AtomicU32 = AtomicU32::new(0);
/// The sample clock's latest late tick: when it came and how late, µs (QEMU stalled on the
/// host and its timers fired late in emulated time; 0, 0: none yet).
static LAST_STALL: critical_section::Mutex<core::cell::Cell<(u64, u32)>> =
    critical_section::Mutex::new(core::cell::Cell::new((0, 0)));

/// When the sample clock's latest late tick came and how late it was, µs. A stall of QEMU on
/// the host delays every emulated timer alike: the CAN adapter leaves out the heartbeat gaps
/// it made late (`can::BusFigures`).
pub fn last_stall() -> (u64, u32) {
    critical_section::with(|cs| LAST_STALL.borrow(cs).get())
}
/// The time base's counter at the sample clock's latest tick ([`super::time::counter`]).
static TICKED_AT: AtomicU32 = AtomicU32::new(0);
/// Ticks of the sample clock since boot (0: none yet).
static TICKS_SEEN: AtomicU32 = AtomicU32::new(0);

/// The ticks of the sample clock so far and the µs since the latest, if it has ticked: the
/// watchdog's NMI tells by them a stall of QEMU on the host from one of the firmware
/// (`watchdog`). Read from the NMI: two words, no critical section (a tick between the two
/// reads makes the gap read one period short).
pub fn ticks_and_quiet_us() -> Option<(u32, u32)> {
    let seen = TICKS_SEEN.load(Ordering::Acquire);
    let at = TICKED_AT.load(Ordering::Relaxed);
    (seen != 0).then(|| {
        (
            seen,
            super::time::counter_gap_us(at, super::time::counter()),
        )
    })
}
/// The record the next period takes.
static NEXT: AtomicU32 = AtomicU32::new(0);
/// The sample period, µs.
static PERIOD_US: AtomicU32 = AtomicU32::new(1000);
/// The sample grid: the time of the next period to deliver and of the next to fall due, µs
/// (0, 0: the clock has not ticked yet). Between them, the periods owed.
static GRID: critical_section::Mutex<core::cell::Cell<(u64, u64)>> =
    critical_section::Mutex::new(core::cell::Cell::new((0, 0)));

/// Starts the sample clock at `period_us`.
pub fn start(period_us: u32) {
    let reg = |r: usize| (DUAL + r) as *mut u32;
    // SAFETY: the dual timer's first timer (mps2-an386 memory map).
    unsafe {
        write_volatile(reg(CONTROL), 0);
        write_volatile(reg(LOAD), period_us.saturating_mul(25));
        write_volatile(reg(CONTROL), CONTROL_RUN);
    }
    PERIOD_US.store(period_us.max(1), Ordering::Relaxed);
    // after a reset, on from the first record the last boot did not finish: the harness keeps
    // its lead from there, so it waits for nothing the firmware does not take
    NEXT.store(
        shared::region().taken.load(Ordering::Acquire),
        Ordering::Relaxed,
    );
}

/// The sample clock's tick (priority 1). Each period falls due at its time on the sample grid
/// and goes to the LVDT task with its record and that time. A tick on time has one period due;
/// a tick QEMU delivers late (it stalled on the host: its `sleep=on` then jumps emulated time)
/// has several, which a real ADC would have converted and interrupted for at their own times.
/// Those, and a period whose record the harness (on the host beside QEMU) has not written yet,
/// are owed: delivered, with their own times, as their records appear and the tick queue has
/// room, one with every [`CATCH_UP_EVERY`]th tick besides its own
/// ([`Figure::PeriodsDeliveredLate`](shared::Figure)). Lost, as on the pod, is a period
/// on time that finds the queue full (the firmware's LVDT task is [`TICKS_HELD`] periods
/// behind), and a period owed longer than [`OWED_MAX_US`]: the next block's time shows the gap.
pub extern "C" fn block_latch() {
    // SAFETY: the dual timer's interrupt clear.
    unsafe { write_volatile((DUAL + INTCLR) as *mut u32, 1) };
    TICKED_AT.store(super::time::counter(), Ordering::Relaxed);
    TICKS_SEEN.fetch_add(1, Ordering::Release);
    let now = embassy_time::Instant::now().as_micros();
    let period = u64::from(PERIOD_US.load(Ordering::Relaxed));
    let (mut next_t, mut due_t) = critical_section::with(|cs| GRID.borrow(cs).get());
    if due_t == 0 {
        (next_t, due_t) = (now, now);
    }
    let carried = (due_t - next_t) / period;
    let mut fell_due = 0u64;
    while due_t <= now + period / 2 {
        due_t += period;
        fell_due += 1;
    }
    if fell_due > 1 {
        // this tick came (fell_due - 1) periods late
        let late_us = u32::try_from((fell_due - 1) * period).unwrap_or(u32::MAX);
        critical_section::with(|cs| LAST_STALL.borrow(cs).set((now, late_us)));
    }
    let mut owed = (due_t - next_t) / period;
    shared::raise_figure(shared::Figure::MostPeriodsOwed, owed as u32);
    let owed_max = (OWED_MAX_US / period).max(1);
    if owed > owed_max {
        // given up (the records stay for the next periods: the machine's motion pauses)
        next_t += (owed - owed_max) * period;
        owed = owed_max;
    }
    let on_time = owed == 1;
    // this tick's own period, and an owed one every `CATCH_UP_EVERY` ticks
    let since = SINCE_CATCH_UP.load(Ordering::Relaxed) + 1;
    let quota = if owed > 1 && since >= CATCH_UP_EVERY {
        2
    } else {
        1
    };
    let mut late = carried.min(owed);
    let mut sent = 0;
    while owed > 0 && sent < quota {
        match take(next_t) {
            Taken::NotWritten => break,
            Taken::NoRoom if !on_time => break,
            Taken::NoRoom => {}
            Taken::Delivered => {
                sent += 1;
                if late > 0 {
                    shared::add_figure(shared::Figure::PeriodsDeliveredLate, 1);
                    late -= 1;
                }
            }
        }
        next_t += period;
        owed -= 1;
    }
    if sent == 0 {
        STARVED.signal(());
    }
    SINCE_CATCH_UP.store(
        if sent > 1 {
            0
        } else {
            since.min(CATCH_UP_EVERY)
        },
        Ordering::Relaxed,
    );
    critical_section::with(|cs| GRID.borrow(cs).set((next_t, due_t)));
}

/// What became of a period.
enum Taken {
    /// Its record went to the LVDT task.
    Delivered,
    /// The tick queue is full.
    NoRoom,
    /// The harness has not written its record yet.
    NotWritten,
}

/// One period at `t_us`: the next record, if written and the queue has room, to the LVDT task.
fn take(t_us: u64) -> Taken {
    let r = shared::region();
    let k = NEXT.load(Ordering::Relaxed);
    if r.written.load(Ordering::Acquire).wrapping_sub(k) as i32 <= 0 {
        return Taken::NotWritten;
    }
    if TICKS.is_full() {
        return Taken::NoRoom;
    }
    NEXT.store(k.wrapping_add(1), Ordering::Relaxed);
    let rec = shared::record(k);
    super::probe::level_from(k);
    if rec.edge != 0 {
        super::probe::EDGE_RECORD.store(k, Ordering::Relaxed);
        NVIC::pend(hw::PROBE);
    }
    // (room checked above; this interrupt is the queue's only sender)
    let _ = TICKS.try_send(Tick { record: k, t_us });
    Taken::Delivered
}

/// Runs the path from a block ready onward on each tick's record. `len` is the block length
/// (`block::block_len`), `period_us` the sample period.
#[embassy_executor::task]
pub async fn lvdt_task(len: usize, period_us: u32) {
    let mut path = BlockPath::new(period_us);
    let len = len.min(BLOCK_MAX);
    loop {
        super::safety::check_in(super::safety::Task::Lvdt);
        // A block, or a tick that had none to deliver (`STARVED`): the watchdog watches that
        // the task runs; on the STM32 a block comes every half period, here the harness on the
        // host can stall (owed periods) and the task would miss a look for want of input.
        let tick = match embassy_futures::select::select(TICKS.receive(), STARVED.wait()).await {
            embassy_futures::select::Either::First(tick) => tick,
            embassy_futures::select::Either::Second(()) => {
                // the harness (this board's ADC) is behind: with no block waiting, the
                // application task has none to go round for — its check-in is the block's,
                // and the ADC that stopped is the host's, not the firmware's (a block waiting
                // and not taken is the application task's: no check-in for it here)
                if super::block::BLOCKS.is_empty() {
                    super::safety::check_in(super::safety::Task::Compute);
                }
                continue;
            }
        };
        let rec = shared::record(tick.record);
        // SAFETY: the record is the harness's until the firmware marks it taken (below): the
        // harness writes at most `RING` records ahead of `taken`.
        let (raw, tripped) = unsafe { (read_volatile(&rec.raw), read_volatile(&rec.tripped) != 0) };
        super::cnc::from_record(rec, tick.t_us);
        // the codes read where they are, as the STM32 board's path reads its DMA ring's half
        // (no copy: the harness leaves the record alone until it is marked taken, below)
        path.on_block(
            rec.a.get(..len).unwrap_or(&[]),
            rec.b.get(..len).unwrap_or(&[]),
            tick.t_us,
            raw.map(|c| c & 0xFFFF),
            tripped,
        );
        shared::region()
            .taken
            .store(tick.record.wrapping_add(1), Ordering::Release);
    }
}
