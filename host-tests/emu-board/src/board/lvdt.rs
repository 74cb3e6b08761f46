//! The emulated ADC: the sample clock (the dual timer at the configured sample rate) takes the
//! harness's next block record at each tick — the STM32's block latch: the counters and the
//! time at the block's centre — and pends the probe interrupt for a record's edge; the LVDT
//! task then runs the STM32 board's path from a block ready onward (`block::BlockPath`) on the
//! record's codes. No record at a tick (the harness is behind): the period is lost, and the
//! gap in the latched times counts it, as a DMA ring overrun does on the pod.
//!
//! QEMU delivers a timer's interrupt late when it wakes late from the firmware's idle (its
//! `sleep=on` follows real time) and then once for several periods; a real ADC and its DMA do
//! not wait for an interrupt. So a tick takes every period elapsed since the last one, each
//! with its own time on the sample clock's grid: the block path sees the periods the ADC
//! converted, and a period is lost only where the harness had no record.

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

/// A block taken at a tick: the record's number, the time of the tick.
#[derive(Clone, Copy)]
struct Tick {
    record: u32,
    t_us: u64,
}

/// Sample clock → LVDT task (a late tick's periods wait here: 64 ms at 1 kHz, 6.4 ms at 10
/// kHz; a full queue loses the period).
static TICKS: Channel<CriticalSectionRawMutex, Tick, TICKS_HELD> = Channel::new();
/// Periods the tick queue holds; a tick takes at most this many (a QEMU wake-up later than
/// that loses the rest; at 8, a wake-up 17 ms late lost 9 periods of an idle pod).
const TICKS_HELD: usize = 64;
/// The record the next tick takes.
static NEXT: AtomicU32 = AtomicU32::new(0);
/// The sample period, µs.
static PERIOD_US: AtomicU32 = AtomicU32::new(1000);
/// The grid time of the last period taken, µs (0: none yet).
static LAST_T_US: critical_section::Mutex<core::cell::Cell<u64>> =
    critical_section::Mutex::new(core::cell::Cell::new(0));

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
    NEXT.store(
        shared::region().written.load(Ordering::Acquire),
        Ordering::Relaxed,
    );
}

/// The sample clock's tick (priority 1): every period elapsed since the last tick (module
/// doc), each with the next record if the harness wrote it.
pub extern "C" fn block_latch() {
    // SAFETY: the dual timer's interrupt clear.
    unsafe { write_volatile((DUAL + INTCLR) as *mut u32, 1) };
    let now = embassy_time::Instant::now().as_micros();
    let period = u64::from(PERIOD_US.load(Ordering::Relaxed));
    let last = critical_section::with(|cs| LAST_T_US.borrow(cs).get());
    let periods = if last == 0 {
        1
    } else {
        (now.saturating_sub(last) + period / 2) / period
    };
    let mut t_us = if last == 0 { now } else { last };
    for _ in 0..periods.min(TICKS_HELD as u64) {
        if last != 0 {
            t_us += period;
        }
        take(t_us);
        if last == 0 {
            break;
        }
    }
    critical_section::with(|cs| LAST_T_US.borrow(cs).set(t_us));
}

/// One period at `t_us`: the next record, if written, to the LVDT task.
fn take(t_us: u64) {
    let r = shared::region();
    let k = NEXT.load(Ordering::Relaxed);
    if r.written.load(Ordering::Acquire).wrapping_sub(k) as i32 <= 0 {
        // not there: this period is lost (the next block's time shows the gap)
        return;
    }
    NEXT.store(k.wrapping_add(1), Ordering::Relaxed);
    let rec = shared::record(k);
    super::probe::level_from(k);
    if rec.edge != 0 {
        super::probe::EDGE_RECORD.store(k, Ordering::Relaxed);
        NVIC::pend(hw::PROBE);
    }
    if TICKS.try_send(Tick { record: k, t_us }).is_err() {
        super::block::ADC_BLOCKS_LOST.count();
    }
}

/// Runs the path from a block ready onward on each tick's record. `len` is the block length
/// (`block::block_len`), `period_us` the sample period.
#[embassy_executor::task]
pub async fn lvdt_task(len: usize, period_us: u32) {
    let mut path = BlockPath::new(period_us);
    let len = len.min(BLOCK_MAX);
    loop {
        super::safety::check_in(super::safety::Task::Lvdt);
        let tick = TICKS.receive().await;
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
