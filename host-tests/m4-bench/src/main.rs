//! Instruction counts of the core's per-sample paths on a Cortex-M4F, under QEMU
//! (`-machine mps2-an386 -cpu cortex-m4 -icount shift=10`): every instruction takes 1024 ns of
//! virtual time, SysTick runs on the 25 MHz CPU clock, so it advances 25.6 ticks per
//! instruction and `round(ticks / 25.6)` is the exact instruction count between two reads
//! (`../shared/spec/embedded-toolchain.md` §4). Run with `cargo bench-m4`; prints a Markdown
//! table and exits through semihosting.
//!
//! Counts are instructions, not cycles (no wait states; VDIV/VSQRT take 14 cycles on silicon).
#![no_std]
#![no_main]

use core::hint::black_box;

use cortex_m::peripheral::{SYST, syst::SystClkSource};
use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hprintln};

use ballpod::acquisition::lvdt::{ExcitationTable, LvdtReading, demodulate};
use ballpod::acquisition::{Acquisition, MAX_AXES};
use ballpod::config::Config;
use ballpod::identify::lsq::GivensLsq;

/// SysTick ticks per 10 instructions (25.6 per instruction).
const TICKS_PER_10_INSN: u32 = 256;

#[inline(always)]
fn now() -> u32 {
    // SAFETY: a read of the SysTick current-value register, which has no side effects.
    0x00FF_FFFF - unsafe { (*SYST::PTR).cvr.read() }
}

/// Runs `f` and returns its result and the instructions it took (harness overhead included;
/// subtract the empty measurement).
#[inline(always)]
fn measure<R>(f: impl FnOnce() -> R) -> (R, u32) {
    let t0 = now();
    let r = black_box(f());
    let t1 = now();
    let ticks = t1.wrapping_sub(t0) & 0x00FF_FFFF;
    (r, (ticks * 10 + TICKS_PER_10_INSN / 2) / TICKS_PER_10_INSN)
}

/// One benchmark row: name, work units per call, instructions per call, FLOPs per unit.
struct Row {
    name: &'static str,
    unit: &'static str,
    per_call_units: u32,
    insns: u32,
    flops_per_unit: u32,
}

fn print(row: &Row) {
    let per_unit = row.insns as f32 / row.per_call_units as f32;
    let ratio = if row.flops_per_unit > 0 { per_unit / row.flops_per_unit as f32 } else { 0.0 };
    hprintln!(
        "| {} | {} | {} | {:.2} | {} | {:.2} |",
        row.name,
        row.unit,
        row.insns,
        per_unit,
        row.flops_per_unit,
        ratio
    );
}

const P: usize = 20;
const BLOCK: usize = 100;

#[entry]
fn main() -> ! {
    let Some(mut cp) = cortex_m::Peripherals::take() else {
        debug::exit(debug::EXIT_FAILURE);
        #[allow(clippy::empty_loop)]
        loop {}
    };
    cp.SYST.set_clock_source(SystClkSource::Core);
    cp.SYST.set_reload(0x00FF_FFFF);
    cp.SYST.clear_current();
    cp.SYST.enable_counter();

    // Realistic LVDT block: both secondaries at +250 µm of a 2000 µm/ratio LVDT, 12-bit codes
    // about mid-scale, as the virtual machine tool's model produces them.
    let table = ExcitationTable::<P>::new();
    let mut a = [0u16; BLOCK];
    let mut b = [0u16; BLOCK];
    for (k, (va, vb)) in a.iter_mut().zip(b.iter_mut()).enumerate() {
        let s = table.sin.get(k % P).copied().unwrap_or(0.0);
        *va = (2048.0 + 1500.0 * 1.125 * s + 0.5) as u16;
        *vb = (2048.0 + 1500.0 * 0.875 * s + 0.5) as u16;
    }

    let (_, empty) = measure(|| ());
    hprintln!("ballpod per-sample paths on Cortex-M4F (QEMU mps2-an386, -icount shift=10)");
    hprintln!("harness overhead {} instructions (subtracted)", empty);
    hprintln!("| path | unit | instructions per call | per unit | FLOP per unit | insn/FLOP |");
    hprintln!("|---|---|---|---|---|---|");

    // LVDT demodulation: per ADC sample per channel, 2 FLOP (one multiply-add each for I and Q).
    let (r, n) = measure(|| demodulate(black_box(&a), black_box(&b), black_box(&table)));
    let ratio = r.map(|r| r.ratio).unwrap_or(f32::NAN);
    print(&Row {
        name: "LVDT demodulation (block of 100 × 2 channels)",
        unit: "ADC sample·channel",
        per_call_units: (BLOCK * 2) as u32,
        insns: n.saturating_sub(empty),
        flops_per_unit: 4,
    });

    // Acquisition pipeline: reading → calibrated, flagged sample.
    let cfg = Config::default();
    let mut acq = Acquisition::new(&cfg, [16; MAX_AXES]);
    let reading = LvdtReading { ratio: 0.125, signal_level: 3000.0, phase_deg: 0.0, clipped: false };
    let mut raw = [1000u32; MAX_AXES];
    let mut total = 0;
    const SAMPLES: u32 = 16;
    for k in 0..SAMPLES {
        raw.iter_mut().for_each(|r| *r = (*r + 37) & 0xFFFF);
        let (_, n) = measure(|| acq.sample(u64::from(k) * 1000, Ok(black_box(reading)), black_box(raw), 0, false));
        total += n.saturating_sub(empty);
    }
    print(&Row {
        name: "acquisition sample (calibration, 5 axes, thermal, flags)",
        unit: "sample",
        per_call_units: SAMPLES,
        insns: total,
        flops_per_unit: 30,
    });

    // Identification accumulator (per-test path, f64 soft-float): one 11-unknown row.
    let mut lsq = GivensLsq::<11>::new();
    let row = [1.0, 0.5, -0.25, 2.0, 0.1, -1.5, 0.7, 0.3, -0.9, 1.1, 0.05];
    let (_, n) = measure(|| lsq.add_row(black_box(&row), 1.0, 1.0));
    print(&Row {
        name: "identification Givens row, 11 unknowns (f64 soft-float)",
        unit: "row",
        per_call_units: 1,
        insns: n.saturating_sub(empty),
        flops_per_unit: 6 * 66,
    });

    hprintln!("check: LVDT ratio {} (expect 0.125)", ratio);
    debug::exit(debug::EXIT_SUCCESS);
    #[allow(clippy::empty_loop)]
    loop {}
}

#[panic_handler]
fn panic(_info: &core::panic::PanicInfo) -> ! {
    debug::exit(debug::EXIT_FAILURE);
    #[allow(clippy::empty_loop)]
    loop {}
}
