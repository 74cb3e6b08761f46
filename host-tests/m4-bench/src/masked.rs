//! Interrupt-masked time of the firmware's shared queues, measured: this bench's
//! critical-section implementation is the firmware's own file (`src/board/masked_cs.rs`:
//! PRIMASK saved, interrupts masked, the outermost section timed), with SysTick instruction
//! counts as its clock in place of the DWT cycle counter. Each queue below has the firmware's
//! element type (or one of the same size) and depth, and goes through the operations the
//! firmware does on it, empty and full; the table gives the longest outermost masked section of
//! each, in instructions (≈ cycles: at 170 MHz, 170 per µs). No core function runs masked (the
//! application is owned by one task).

use core::cell::Cell;

use ballpod::acquisition::MAX_AXES;
use ballpod::acquisition::lvdt::{BlockReading, DemodError};
use ballpod::protocol::canopen::{BusState, CanFrame};
use cortex_m_semihosting::hprintln;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;
use embassy_sync::pipe::Pipe;
use embassy_sync::signal::Signal;

#[path = "../../../src/board/masked_cs.rs"]
mod masked_cs;

/// The probe's clock here: SysTick, counting up (25.6 ticks per instruction, 24 bits).
fn masked_clock() -> u32 {
    crate::now()
}
/// SysTick's width.
const MASKED_CLOCK_MASK: u32 = 0x00FF_FFFF;

/// The longest section since the last call, instructions; resets it.
fn take_max() -> u32 {
    let t = masked_cs::take_max();
    (t * 10 + crate::TICKS_PER_10_INSN / 2) / crate::TICKS_PER_10_INSN
}

/// The LVDT block queue's element (`board::lvdt::LvdtBlock`: time, latched counts, reading).
type Block = (u64, [u32; MAX_AXES], BlockReading);
/// The probe edge queue's element (`board::probe::ProbeEdge`).
type Edge = (u64, [u32; MAX_AXES]);
/// One slot of the block latch's history (`board::lvdt::LATCHES`: event number, time, counts).
type Latch = (u32, u64, [u32; MAX_AXES]);

static BLOCKS: Channel<CriticalSectionRawMutex, Block, 64> = Channel::new();
static EDGES: Channel<CriticalSectionRawMutex, Edge, 8> = Channel::new();
static CODES: Channel<CriticalSectionRawMutex, u16, 2> = Channel::new();
static CAN_RX: Channel<CriticalSectionRawMutex, CanFrame, 16> = Channel::new();
static USB_TX: Pipe<CriticalSectionRawMutex, 2048> = Pipe::new();
static BUS: Signal<CriticalSectionRawMutex, BusState> = Signal::new();
static LATCHES: critical_section::Mutex<[Cell<Latch>; 4]> =
    critical_section::Mutex::new([const { Cell::new((0, 0, [0; MAX_AXES])) }; 4]);

/// Runs `ops` and prints the longest masked section they took (the printing itself, which
/// semihosting does inside a critical section, is not counted).
fn row(name: &str, ops: impl FnOnce()) {
    let _ = take_max();
    ops();
    let insns = take_max();
    hprintln!("| {} | {} |", name, insns);
}

/// Runs every queue operation of the firmware, empty to full and back, and prints the table.
pub fn report() {
    hprintln!();
    hprintln!("| interrupt-masked section (firmware queue, its depth) | longest, insns |");
    hprintln!("|---|---|");
    row("LVDT block queue (64): try_send, try_receive", || {
        let block: Block = (
            1,
            [2; MAX_AXES],
            BlockReading::Ac(Err(DemodError::ModeChanged)),
        );
        for _ in 0..66 {
            let _ = BLOCKS.try_send(block);
        }
        while BLOCKS.try_receive().is_ok() {}
    });
    row("probe edge queue (8): try_send, try_receive", || {
        for _ in 0..10 {
            let _ = EDGES.try_send((3, [4; MAX_AXES]));
        }
        while EDGES.try_receive().is_ok() {}
    });
    row("thermistor code queue (2): try_send, try_receive", || {
        for _ in 0..3 {
            let _ = CODES.try_send(2048);
        }
        while CODES.try_receive().is_ok() {}
    });
    row("CAN frame queue (16): try_send, try_receive", || {
        if let Some(f) = CanFrame::new(0x601, &[0x40, 0x00, 0x20, 0, 0, 0, 0, 0]) {
            for _ in 0..18 {
                let _ = CAN_RX.try_send(f);
            }
        }
        while CAN_RX.try_receive().is_ok() {}
    });
    row(
        "USB byte pipe (2048): try_write / try_read of a 64-byte packet",
        || {
            let packet = [b'x'; 64];
            let mut buf = [0u8; 64];
            for _ in 0..40 {
                let _ = USB_TX.try_write(&packet);
            }
            while USB_TX.try_read(&mut buf).is_ok() {}
        },
    );
    row("CAN bus-state signal: signal, try_take", || {
        BUS.signal(BusState::BusOff);
        let _ = BUS.try_take();
    });
    row(
        "block latch history: one slot set (interrupt), one got (task)",
        || {
            for k in 0..8u32 {
                critical_section::with(|cs| {
                    if let Some(c) = LATCHES.borrow(cs).get(k as usize % 4) {
                        c.set(core::hint::black_box((k, 5, [6; MAX_AXES])));
                    }
                });
                core::hint::black_box(critical_section::with(|cs| {
                    LATCHES.borrow(cs).get(k as usize % 4).map(Cell::get)
                }));
            }
        },
    );
}
