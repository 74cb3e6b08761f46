//! Instruction counts of the core's per-sample paths on a Cortex-M4F, under QEMU
//! (`-machine mps2-an386 -cpu cortex-m4 -icount shift=10`): every instruction takes 1024 ns of
//! virtual time, SysTick runs on the 25 MHz CPU clock, so it advances 25.6 ticks per
//! instruction and `round(ticks / 25.6)` is the exact instruction count between two reads
//! (`../shared/spec/embedded-toolchain.md` §4). Run with `cargo bench-m4`; prints a Markdown
//! table and exits through semihosting.
//!
//! Every path runs on the same realistic data (see [`data`]) twice: the core's code, and the
//! naive baseline of [`naive`] (nalgebra, a dynamic solve per sample). Beside each figure: the
//! FLOP count of the path, counted by hand from the code (derivation in the comment at each
//! row), the instructions per FLOP, the naive figure and the ratio, and the issue-6 target.
//! Then the longest interrupt-masked section of each of the firmware's queues ([`masked`]), the
//! stack high-water mark of each path (stack painting, [`stack`]) and the bytes of each
//! estimator's state.
//!
//! Counts are instructions, not cycles (no wait states; VDIV/VSQRT take 14 cycles on silicon).
#![no_std]
#![no_main]

mod data;
mod masked;
mod naive;
mod stack;

use core::hint::black_box;

use cortex_m::peripheral::{SYST, syst::SystClkSource};
use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hprintln};

use core::sync::atomic::{AtomicU32, Ordering};

use ballpod::acquisition::lvdt::{
    BlockReading, ExcitationTable, LvdtReading, demodulate, demodulate_watched,
};
use ballpod::acquisition::projection::{Q14Sums, RailTest, add_periods, add_periods_portable};
use ballpod::acquisition::{Acquisition, MAX_AXES, Sample};
use ballpod::app::bc_ballbar::{Procedure, Setup};
use ballpod::app::log::{LOG_CAPACITY, SampleLog};
use ballpod::app::{App, Command, Direction as RunDirection, Pattern, Recorder, RunMeta};
use ballpod::config::Config;
use ballpod::identify::lsq::GivensLsq;
use ballpod::metrology::bar_budget::BarBudget;
use ballpod::metrology::circle_fit::CircleEstimate;
use ballpod::metrology::circle_fit::{CircleFit, CircleFitConfig};
use ballpod::metrology::iso230_4::{CircularTest, Direction, SpikeCapture};
use ballpod::metrology::pattern::{ArcGeometry, Plane, Sensitivity};
use ballpod::metrology::ssm::SsmGeometry;
use ballpod::metrology::ssm::streaming::{StreamingConfig, StreamingSsm};
use ballpod::pod::{Block, BootReport, Pod};
use ballpod::protocol::canopen::CanOpenNode;
use ballpod::protocol::scpi::ScpiServer;
use ballpod::protocol::stream::{FIRMWARE_RING_BYTES, SampleStream};
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::pipe::Pipe;

/// SysTick ticks per 10 instructions (25.6 per instruction).
pub(crate) const TICKS_PER_10_INSN: u32 = 256;

#[inline(always)]
pub(crate) fn now() -> u32 {
    // SAFETY: a read of the SysTick current-value register, which has no side effects.
    0x00FF_FFFF - unsafe { (*SYST::PTR).cvr.read() }
}

/// SysTick wraps (every 2^24 ticks = 655 360 instructions), for [`measure_long`].
static WRAPS: AtomicU32 = AtomicU32::new(0);

#[cortex_m_rt::exception]
fn SysTick() {
    WRAPS.fetch_add(1, Ordering::Relaxed);
}

/// Runs `f` (which may take billions of instructions) and returns its result and the
/// instructions it took, counting the SysTick wraps (the wrap interrupt's own few dozen
/// instructions per 655 360 are included: < 0.01 %).
fn measure_long<R>(f: impl FnOnce() -> R) -> (R, u64) {
    let w0 = WRAPS.load(Ordering::Relaxed);
    let t0 = now();
    let r = black_box(f());
    let t1 = now();
    let w1 = WRAPS.load(Ordering::Relaxed);
    let ticks = (u64::from(w1.wrapping_sub(w0)) << 24) + u64::from(t1) - u64::from(t0);
    (
        r,
        (ticks * 10 + u64::from(TICKS_PER_10_INSN) / 2) / u64::from(TICKS_PER_10_INSN),
    )
}

/// An application armed and started on `pattern` with a set-up matching [`data`]'s circle
/// about the socket, the encoders homed at the first sample. The circle's minimum arc is 10°
/// so that the live fit solves from the start (the worst case of every sample).
fn started_app(pattern: Pattern, first: &Sample) -> App {
    let mut app = App::new(Config::default(), [16; MAX_AXES]);
    let _ = app.configure(|c| {
        c.bar_length_mm = data::BAR_MM;
        let s = &mut c.setup;
        s.circle_centre_mm = data::SOCKET_MM;
        s.circle_radius_mm = data::BAR_MM;
        s.circle_min_arc_deg = 10.0;
        s.ssm_socket_mm = data::SOCKET_MM;
        Setup::thesis_table_4_3().to_config(s);
        // the C circle of the data about the socket
        s.s002_origin_mm = data::SOCKET_MM;
    });
    let _ = app.set_pattern(pattern);
    let _ = app.execute(Command::Arm);
    app.reference_axes(raw_counts(first), first.axes.map(f64::from));
    let _ = app.execute(Command::Start);
    app
}

/// The encoder counters (16-bit, 10 000 counts/mm) of a sample's positions.
fn raw_counts(s: &Sample) -> [u32; MAX_AXES] {
    s.axes
        .map(|p| (libm::round(f64::from(p) * 10_000.0) as i64).rem_euclid(1 << 16) as u32)
}

/// The SSM pipeline again in its steady state at the measuring feed (F1000, 0.0064° per
/// sample: the window's reference direction moves every ~35 samples, not every sample as on
/// the fast circle): the first 2 N samples fill the window, the next N are measured.
/// Instructions per sample. Out of line, so that its arrays do not change `main`'s frame (the
/// stack rows are measured below it).
#[inline(never)]
fn ssm_pipeline_at_feed(
    parts: &mut PodParts,
    a: &[u16; BLOCK],
    b: &[u16; BLOCK],
    table: &ExcitationTable<P>,
    empty: u32,
) -> (f32, f32) {
    let mut app = started_app(Pattern::Ssm, &data::circle_samples_at_feed(0)[0]);
    let mut growing = f32::NAN;
    for batch in 0..2 {
        let warm_up = data::circle_samples_at_feed(batch * data::N);
        if batch == 0 {
            // the run's first W samples: the window grows (the live E's u every 4 samples)
            let (first, rest) = warm_up.split_at(W.min(warm_up.len()));
            growing = pipeline_per_sample(&mut app, parts, first, a, b, table, empty);
            pipeline_per_sample(&mut app, parts, rest, a, b, table, empty);
        } else {
            pipeline_per_sample(&mut app, parts, &warm_up, a, b, table, empty);
        }
    }
    let measured = data::circle_samples_at_feed(2 * data::N);
    (
        growing,
        pipeline_per_sample(&mut app, parts, &measured, a, b, table, empty),
    )
}

/// The firmware's USB stream pipe (`board::state::STREAM_TX`).
static STREAM_PIPE: Pipe<CriticalSectionRawMutex, 2048> = Pipe::new();

/// The pod's parts beside its application, as the firmware keeps them (the log's and the
/// stream ring's sizes are the firmware's: `board/compute.rs`).
struct PodParts {
    node: CanOpenNode,
    scpi: ScpiServer,
    log: SampleLog<LOG_CAPACITY>,
    stream: SampleStream<FIRMWARE_RING_BYTES>,
}

/// Instructions per sample of the whole live pipeline over `samples`, as the firmware's
/// application task runs it for one block with a reader on the stream port: one LVDT block's
/// demodulation, `Pod::on_block` (the application, the log and the stream's record, the CANopen
/// node) and `Pod::end_of_turn` (one USB packet of the stream out).
fn pipeline_per_sample(
    app: &mut App,
    parts: &mut PodParts,
    samples: &[Sample],
    a: &[u16; BLOCK],
    b: &[u16; BLOCK],
    table: &ExcitationTable<P>,
    empty: u32,
) -> f32 {
    let PodParts {
        node,
        scpi,
        log,
        stream,
    } = parts;
    // each pattern on an empty ring, as a pod's first run (the previous pattern's run never
    // ended: its records would stay ahead of this run's 2 kB header)
    stream.drain(usize::MAX, &mut |_| {});
    let mut pod = Pod::boot(app, node, scpi, log, stream, 1, &BootReport::default());
    let mut packet = [0u8; 64];
    let mut pipe = [0u8; 64];
    if !pod.stream.enabled() {
        pod.stream_reader(true);
    }
    // a new run's start reaches the recorders; its header leaves the ring (all but the last
    // part packet, which the run's first samples fill)
    while {
        pod.end_of_turn(
            &mut (),
            &mut packet,
            &mut || 0,
            &mut |_| {},
            64,
            &mut |_| {},
        );
        pod.stream.pending() >= packet.len()
    } {}
    let mut total = 0u32;
    for s in samples {
        let raw = raw_counts(s);
        let (_, n) = measure(|| {
            let r = demodulate_watched(
                black_box(&a[..]),
                black_box(&b[..]),
                black_box(table),
                false,
            );
            let block = Block {
                t_us: s.t_us,
                reading: BlockReading::Ac(r),
                raw,
                lost_total: 0,
                probe_seated: true,
            };
            pod.on_block(&block, s.t_us, &mut (), &mut |f| {
                black_box(f);
            });
            // the stream's bytes into the USB stream pipe, as the firmware's shell writes them
            // (`board::state::write_all_now`; the USB task's read is not the pod's)
            pod.end_of_turn(&mut (), &mut packet, &mut || 0, &mut |_| {}, 64, &mut |b| {
                let mut done = 0;
                while let Some(rest) = b.get(done..).filter(|r| !r.is_empty()) {
                    match STREAM_PIPE.try_write(rest) {
                        Ok(n) if n > 0 => done += n,
                        _ => break,
                    }
                }
            });
        });
        total += n.saturating_sub(empty);
        // the USB task's side: the pipe emptied (not the pod's work)
        while STREAM_PIPE.try_read(&mut pipe).is_ok() {}
    }
    assert_eq!(
        pod.stream.dropped_lines(),
        0,
        "the stream kept every record"
    );
    total as f32 / samples.len() as f32
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

/// Bins of the ISO 230-4 test (1°), window of the streaming SSM: the sizes the tests use.
const BINS: usize = 360;
const W: usize = 256;
/// Excitation period and block length of the LVDT path (20 samples per period, 5 periods).
const P: usize = 20;
const BLOCK: usize = 100;

/// One channel's block of ADC codes, word-aligned like the pod's DMA buffers.
#[repr(C, align(4))]
struct Codes([u16; BLOCK]);

/// Instructions per unit of a path and what it is compared with.
struct Row {
    name: &'static str,
    unit: &'static str,
    insns_per_unit: f32,
    /// Hand-counted FLOP per unit (0: not counted, e.g. a per-test path).
    flops_per_unit: u32,
    /// The naive baseline on the same data, instructions per unit.
    naive_per_unit: Option<f32>,
    /// Target: at most this many instructions per unit …
    max_insns: Option<f32>,
    /// … and at least this ratio naive / core.
    min_ratio: Option<f32>,
}

impl Row {
    /// A row with no naive baseline and no target.
    fn plain(
        name: &'static str,
        unit: &'static str,
        insns_per_unit: f32,
        flops_per_unit: u32,
    ) -> Self {
        Self {
            name,
            unit,
            insns_per_unit,
            flops_per_unit,
            naive_per_unit: None,
            max_insns: None,
            min_ratio: None,
        }
    }

    /// A whole-live-pipeline row: instructions per sample against the 3 000 target (issue 41:
    /// what the pod does per sample with a reader on the stream port).
    fn pipeline(name: &'static str, insns_per_sample: f32) -> Self {
        Self {
            max_insns: Some(3000.0),
            ..Self::plain(name, "sample", insns_per_sample, 0)
        }
    }
}

fn print(r: &Row) {
    let ipf = if r.flops_per_unit > 0 {
        r.insns_per_unit / r.flops_per_unit as f32
    } else {
        f32::NAN
    };
    let (naive, ratio) = match r.naive_per_unit {
        Some(n) => (n, n / r.insns_per_unit),
        None => (f32::NAN, f32::NAN),
    };
    let mut verdict = heapless_str();
    if let Some(max) = r.max_insns {
        if r.insns_per_unit <= max {
            push(&mut verdict, format_args!("≤ {max:.0}: met"));
        } else {
            push(
                &mut verdict,
                format_args!("≤ {max:.0}: MISSED by {:.1}", r.insns_per_unit - max),
            );
        }
    }
    if let Some(min) = r.min_ratio {
        if ratio >= min {
            push(&mut verdict, format_args!("; ≥ {min:.0}× naive: met"));
        } else {
            push(
                &mut verdict,
                format_args!("; ≥ {min:.0}× naive: MISSED ({ratio:.2}×)"),
            );
        }
    }
    let mut cols = heapless_str();
    if r.flops_per_unit > 0 {
        push(&mut cols, format_args!("{} | {ipf:.2}", r.flops_per_unit));
    } else {
        push(&mut cols, format_args!("— | —"));
    }
    if r.naive_per_unit.is_some() {
        push(&mut cols, format_args!(" | {naive:.1} | {ratio:.2}"));
    } else {
        push(&mut cols, format_args!(" | — | —"));
    }
    hprintln!(
        "| {} | {} | {:.2} | {} | {} |",
        r.name,
        r.unit,
        r.insns_per_unit,
        cols.as_str(),
        verdict.as_str()
    );
}

/// A small fixed text buffer for the verdict column (no allocator here).
struct Text {
    buf: [u8; 96],
    len: usize,
}
impl Text {
    fn as_str(&self) -> &str {
        self.buf
            .get(..self.len)
            .and_then(|b| core::str::from_utf8(b).ok())
            .unwrap_or("")
    }
}
impl core::fmt::Write for Text {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        let end = self.len + s.len();
        let dst = self.buf.get_mut(self.len..end).ok_or(core::fmt::Error)?;
        dst.copy_from_slice(s.as_bytes());
        self.len = end;
        Ok(())
    }
}
fn heapless_str() -> Text {
    Text {
        buf: [0; 96],
        len: 0,
    }
}
fn push(t: &mut Text, a: core::fmt::Arguments) {
    let _ = core::fmt::write(t, a);
}

/// Instructions of `f` applied to every sample, summed per call (harness overhead subtracted).
#[inline(always)]
fn per_sample(samples: &[Sample], empty: u32, mut f: impl FnMut(&Sample)) -> f32 {
    let mut total = 0u32;
    for s in samples {
        let (_, n) = measure(|| f(black_box(s)));
        total += n.saturating_sub(empty);
    }
    total as f32 / samples.len() as f32
}

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
    cp.SYST.enable_interrupt();
    cp.SYST.enable_counter();

    let (_, empty) = measure(|| ());
    let top = stack::sp();
    let mut stack_rows: [(&str, usize); 20] = [("", 0); 20];
    let mut n_stack = 0;
    let mut record_stack = |name: &'static str, lo: usize| {
        if let Some(r) = stack_rows.get_mut(n_stack) {
            *r = (name, stack::used(top, lo));
            n_stack += 1;
        }
    };

    hprintln!(
        "ballpod per-sample paths on Cortex-M4F (QEMU mps2-an386 -cpu cortex-m4, -icount shift=10)"
    );
    hprintln!(
        "data: {} samples of a CCW circle, L = {} mm, e = ({}, {}) um, noise {} um rms; harness overhead {} insns (subtracted)",
        data::N,
        data::BAR_MM,
        data::E_UM[0],
        data::E_UM[1],
        data::NOISE_UM,
        empty
    );
    hprintln!();
    hprintln!(
        "| path | unit | insns/unit | FLOP/unit | insns/FLOP | naive insns/unit | naive/core | target |"
    );
    hprintln!("|---|---|---|---|---|---|---|---|");

    // ---- LVDT demodulation ------------------------------------------------------------------
    let table = ExcitationTable::<P>::new();
    // word-aligned, as the pod's DMA buffers are (the lean kernel loads codes with LDM)
    let (a, b) = {
        let (a, b) = data::lvdt_block::<P, BLOCK>(&table);
        (Codes(a), Codes(b))
    };
    let (a, b) = (&a.0, &b.0);
    let lo = stack::paint(top);
    let (r, n) = measure(|| demodulate(black_box(&a[..]), black_box(&b[..]), black_box(&table)));
    record_stack("LVDT demodulate (block of 100 × 2)", lo);
    let core_ratio = r.map(|r| r.ratio).unwrap_or(f32::NAN);
    // The DSP kernels and their portable twin on this block and on the block with rail codes
    // (0, 4095, 65535) put in, with and without the rail test: the same sums bit for bit, or
    // the bench fails.
    let kernel_identical = {
        let mut same = true;
        let mut ra = Codes(*a);
        let mut rb = Codes(*b);
        ra.0[7] = 0;
        rb.0[58] = 4095;
        ra.0[91] = 65535;
        for (x, y) in [(a, b), (&ra.0, &rb.0)] {
            for rails in [RailTest::PerCode, RailTest::WatchdogQuiet] {
                let (mut k, mut q) = (Q14Sums::default(), Q14Sums::default());
                add_periods(&mut k, &x[..], &y[..], &table.q14, rails);
                add_periods_portable(&mut q, &x[..], &y[..], &table.q14, rails);
                same &= k == q;
            }
        }
        same
    };
    if !kernel_identical {
        hprintln!("check FAILED: a Q14 DSP kernel and the portable projection differ");
        debug::exit(debug::EXIT_FAILURE);
    }
    let (naive_ratio, nn) = measure(|| naive::lvdt_demodulate(black_box(a), black_box(b), P));
    // FLOP per ADC sample per channel: I += v·sin, Q += v·cos → 2 multiplies + 2 adds = 4 (the
    // textbook synchronous demodulation; the end-of-block magnitude and ratio are amortised
    // over the block and counted in the instructions but not here).
    let per_code = |insns: u32| insns.saturating_sub(empty) as f32 / (BLOCK * 2) as f32;
    let demod_row = |name, insns| Row {
        name,
        unit: "ADC sample·channel",
        insns_per_unit: per_code(insns),
        flops_per_unit: 4,
        naive_per_unit: Some(per_code(nn)),
        max_insns: Some(5.0),
        min_ratio: None,
    };
    print(&demod_row(
        "LVDT demodulation, rail test per code (block 100 × 2 ch)",
        n,
    ));
    // The pod's path when the ADCs' analog watchdogs stayed quiet over the block: the same
    // reading without the per-code rail test, or the bench fails.
    let (rw, nw) = measure(|| {
        demodulate_watched(
            black_box(&a[..]),
            black_box(&b[..]),
            black_box(&table),
            false,
        )
    });
    if rw != r {
        hprintln!("check FAILED: the watched demodulation differs from the per-code one");
        debug::exit(debug::EXIT_FAILURE);
    }
    print(&demod_row(
        "LVDT demodulation, ADC watchdogs quiet (the pod's usual block)",
        nw,
    ));

    // ---- acquisition ------------------------------------------------------------------------
    let cfg = Config::default();
    let mut acq = Acquisition::new(&cfg, [16; MAX_AXES]);
    let reading = LvdtReading {
        ratio: 0.125,
        signal_level: 3000.0,
        iq_a: [0.0; 2],
        clipped: false,
    };
    let mut raw = [1000u32; MAX_AXES];
    let mut total = 0;
    const ACQ_SAMPLES: u32 = 16;
    let lo = stack::paint(top);
    for k in 0..ACQ_SAMPLES {
        raw.iter_mut().for_each(|r| *r = (*r + 37) & 0xFFFF);
        let (_, n) = measure(|| {
            acq.calibrate(
                u64::from(k) * 1000,
                Ok(black_box(reading)),
                black_box(raw),
                0,
                false,
            )
        });
        total += n.saturating_sub(empty);
    }
    record_stack("acquisition sample", lo);
    // FLOP per sample: calibration polynomial (Horner, 3 mul + 3 add = 6), clamp and |r| (3),
    // expansion L·CTE·(T − 20)·1e-3 (1 sub + 3 mul = 4) + ΔL add (1), 5 axes × (int→float,
    // negate-or-not, divide, add offset = 2 FLOP) = 10 → 24.
    print(&Row::plain(
        "acquisition sample (calibration, 5 axes all moving, thermal, flags)",
        "sample",
        total as f32 / ACQ_SAMPLES as f32,
        24,
    ));

    // ---- metrology --------------------------------------------------------------------------
    let samples = data::circle_samples();
    let geometry = ArcGeometry {
        plane: Plane::XY,
        centre_u_mm: data::SOCKET_MM[0],
        centre_v_mm: data::SOCKET_MM[1],
        sensitivity: Sensitivity::Outward,
    };
    let fit_cfg = CircleFitConfig {
        geometry,
        min_arc_deg: 60.0,
    };
    let ssm_cfg = StreamingConfig {
        geometry: SsmGeometry {
            socket_mm: data::SOCKET_MM.map(f64::from),
            bar_length_mm: f64::from(data::BAR_MM),
        },
        radius_mm: data::SSM_RADIUS_MM,
        rotary_tol_deg: 0.001,
    };

    // Circle fit update. FLOP per sample (CircleFit::update_direction + add): direction
    // du, dv (2) + r² (3) + √ (1) + 1/r (1) + n = d·inv (2) = 9; turned angle: sin, cos of the
    // turn (2 × 3 = 6), turn = s·(1 + (1 − c)/3) (4), ψ (1) = 11; y = ΔL − ref (1); products
    // n_u², n_u n_v, n_v², y n_u, y n_v, y² (6); 9 Kahan sums × 4 (36) → 63.
    let mut fit = CircleFit::new(fit_cfg);
    let lo = stack::paint(top);
    let circle = per_sample(&samples, empty, |s| {
        black_box(fit.update(s));
    });
    record_stack("CircleFit::update", lo);
    let mut nfit = naive::NaiveCircle::new(data::SOCKET_MM[0], data::SOCKET_MM[1]);
    let circle_naive = per_sample(&samples, empty, |s| {
        black_box(nfit.update(s));
    });
    print(&Row {
        name: "circle fit update (CircleFit::update)",
        unit: "sample",
        insns_per_unit: circle,
        flops_per_unit: 63,
        naive_per_unit: Some(circle_naive),
        max_insns: None,
        min_ratio: None,
    });

    // Circle fit estimate (per query, f64 soft-float on the M4F). FLOP: 10 moments read back
    // (10 adds), Cholesky 3×3 (3 √, 3 div, 7 mul/sub pairs = 20), solve (2 × 9 = 18), inverse
    // (≈ 30), SSR (6), variances and 3 √ (9), cond (tr A, tr A⁻¹: 4 adds, 1 mul, 1 √ = 6),
    // residual RMS (2), conversions not counted → ≈ 101.
    let lo = stack::paint(top);
    let (est, n) = measure(|| fit.estimate());
    record_stack("CircleFit::estimate", lo);
    print(&Row::plain(
        "circle fit estimate (f64 Cholesky, per query)",
        "query",
        n.saturating_sub(empty) as f32,
        101,
    ));

    // Circle fit live (per sample, f32 on the FPU: CircleFit::live). FLOP: 1 division, 10 sums
    // read (10), means (3), centred 2×2 and right side (5 × 2 = 10), determinant (3), solve
    // (1 division + 6), r0 (4) → ≈ 38.
    let lo = stack::paint(top);
    let (_, n) = measure(|| fit.live());
    record_stack("CircleFit::live", lo);
    print(&Row::plain(
        "circle fit live (f32, every sample)",
        "query",
        n.saturating_sub(empty) as f32,
        38,
    ));

    // ISO 230-4 trackers (CircularTest::update: the circle fit + F extremes + the angle bin).
    // FLOP per sample: circle fit 63; quadrant angle: one division (1), atan polynomial
    // (z² 1, Horner 5 × 2 = 10, ·z 1 = 12), π/2 − (1); bin index scale (1); bin sums
    // ΔL, n_u, n_v (3) → 81.
    let mut iso = CircularTest::<BINS>::new(fit_cfg, data::BAR_MM);
    let lo = stack::paint(top);
    let iso_core = per_sample(&samples, empty, |s| {
        black_box(iso.update(s, Direction::Ccw));
    });
    record_stack("CircularTest::update", lo);
    let mut niso = naive::NaiveIso::<BINS>::new(data::SOCKET_MM[0], data::SOCKET_MM[1]);
    let iso_naive = per_sample(&samples, empty, |s| niso.update(s));
    print(&Row {
        name: "ISO 230-4 trackers incl. circle fit (CircularTest::update)",
        unit: "sample",
        insns_per_unit: iso_core,
        flops_per_unit: 81,
        naive_per_unit: Some(iso_naive),
        max_insns: None,
        min_ratio: None,
    });

    // The ball-bar diagnoses of one direction at the end of its run (the joint fit for each
    // cyclic order 3..=16 on the bin profile, with u and the centre's share at the pod's
    // default `circle_u_centre`): once per run, in the application task.
    let u_centre_um = ballpod::config::U_CENTRE_UM as f32;
    let lo = stack::paint(top);
    let (dg, n) = measure_long(|| iso.diagnostics(Direction::Ccw, u_centre_um));
    record_stack("ISO 230-4 diagnostics (CircularTest::diagnostics)", lo);
    hprintln!(
        "| ISO 230-4 diagnoses of one direction (joint fit per cyclic order + u, f32) | run | {} | — | — | — | — | {:.1} ms at 170 MHz (1 insn/cycle), ok = {} |",
        n,
        n as f64 / 170e3,
        dg.is_ok()
    );
    // One sample's noise from the bin profile (the third differences' median): what the live
    // u of a CIRCLE run takes every app::circle::LIVE_NOISE_EVERY samples.
    let (noise, n) = measure_long(|| iso.noise_um(Direction::Ccw));
    hprintln!(
        "| ISO 230-4 profile noise of one direction (CircularTest::noise_um, the live u's σ) | query | {} | — | — | — | — | every {} samples: {:.1} a sample, σ = {:.3} µm |",
        n,
        ballpod::app::circle::LIVE_NOISE_EVERY,
        n as f64 / f64::from(ballpod::app::circle::LIVE_NOISE_EVERY),
        noise
    );
    // The centre the axis positions traced (its check of the centre's budget), with each live
    // noise refresh and at the run's end.
    let (traced, n) = measure_long(|| iso.traced_centre(Direction::Ccw));
    hprintln!(
        "| ISO 230-4 traced centre of one direction (CircularTest::traced_centre) | query | {} | — | — | — | — | every {} samples: {:.1} a sample, ok = {} |",
        n,
        ballpod::app::circle::LIVE_NOISE_EVERY,
        n as f64 / f64::from(ballpod::app::circle::LIVE_NOISE_EVERY),
        traced.is_ok()
    );
    // The figures of one direction at the end of its run: G and F with their u, from the noise
    // of the bin profile and the bootstrap of its extremes (metrology/extremes.rs), and the
    // centre's shares.
    let lo = stack::paint(top);
    let (fg, n) = measure_long(|| iso.direction_figures(Direction::Ccw, u_centre_um));
    record_stack("ISO 230-4 figures (CircularTest::direction_figures)", lo);
    hprintln!(
        "| ISO 230-4 figures of one direction (G, F and their u: noise + bootstrap of {} copies) | run | {} | — | — | — | — | {:.1} ms at 170 MHz (1 insn/cycle), ok = {} |",
        ballpod::metrology::extremes::REPLICAS,
        n,
        n as f64 / 170e3,
        fg.is_ok_and(|f| f.circular_deviation_g_um.std_uncertainty.is_finite())
    );

    // The run's reversal spikes and oscillations (SpikeCapture::reversals) at its end, in the
    // figures job: a turn from 45° at 1 kHz, 0.01° a sample, crossing 90°, 180°, 270° and 360°
    // with their windows; a 2 µm spike of τ 8 samples at each and a vibration of 1 µm at
    // 0.1 cycle a sample (both named: the heavier path, the spikes fitted twice).
    let mut capture = SpikeCapture::new();
    for i in 0..36_000u32 {
        let deg = 45.0 + 0.01 * i as f32;
        let (s, c) = (libm::sinf(deg.to_radians()), libm::cosf(deg.to_radians()));
        let from_point = (deg % 90.0) * 100.0; // samples since the latest point
        let spike = if deg >= 90.0 {
            2.0 * libm::expf(-from_point / 8.0)
        } else {
            0.0
        };
        let vib = libm::sinf(core::f32::consts::TAU * 0.1 * i as f32);
        capture.update(spike + vib, [c, s], u64::from(i) * 1000);
    }
    let lo = stack::paint(top);
    let (found, n) = measure_long(|| capture.reversals());
    record_stack(
        "reversal spikes and oscillations (SpikeCapture::reversals)",
        lo,
    );
    hprintln!(
        "| reversal spikes and oscillations of one run (SpikeCapture::reversals: four windows) | run | {} | — | — | — | — | {:.1} ms at 170 MHz (1 insn/cycle), ok = {} |",
        n,
        n as f64 / 170e3,
        found.spikes.iter().flatten().count() == 4
            && found.oscillations.is_some_and(|o| o[0].named())
    );

    // Streaming SSM update. FLOP per sample (float): d = P − P0 (3), r² (5), √ (1),
    // y = ΔL + (L − r)·1e3 (3), U_SCALE/r (1), u = d·inv (3), y·Y_SCALE (1), d·P_SCALE (3),
    // rotary test (2), neighbourhood distance of the oldest entry (3 mul + 2 add = 5) → 27;
    // plus the exact integer normal equations, counted as arithmetic like FLOP: entering sample
    // 10 products + 10 adds + 3 centroid adds (23), leaving sample the same (23) → 73.
    let mut ssm = StreamingSsm::<W>::new(ssm_cfg);
    let lo = stack::paint(top);
    let ssm_core = per_sample(&samples, empty, |s| {
        black_box(ssm.update(s));
    });
    record_stack("StreamingSsm::update", lo);
    let mut nssm = naive::NaiveSsm::<W>::new(data::SOCKET_MM, data::BAR_MM, data::SSM_RADIUS_MM);
    let ssm_naive = per_sample(&samples, empty, |s| nssm.update(s));
    print(&Row {
        name: "streaming SSM update (StreamingSsm::update)",
        unit: "sample",
        insns_per_unit: ssm_core,
        flops_per_unit: 73,
        naive_per_unit: Some(ssm_naive),
        max_insns: None,
        min_ratio: None,
    });

    // Streaming SSM estimate (per query, f64): integer sums → f64 (10 mul), eigen-analysis of
    // the 3×3 (closed-form characteristic cubic + eigenvector, ≈ 60), Cholesky + solve +
    // inverse trace (≈ 60), SSR and RMS (5), centroid (6) → ≈ 141.
    let lo = stack::paint(top);
    let (ssm_est, n) = measure(|| ssm.estimate());
    record_stack("StreamingSsm::estimate", lo);
    print(&Row::plain(
        "streaming SSM estimate (f64, per query)",
        "query",
        n.saturating_sub(empty) as f32,
        141,
    ));

    // Streaming SSM live (per sample, f32 on the FPU: StreamingSsm::live). FLOP: 13 sums read
    // (13), means (4), covariances (9 × 2 + 3 × 2 = 24), mean direction and its length (3 + 6),
    // basis (≈ 12), three 3×3 products (27 × 2 = 54), nine dots (9 × 5 = 45), Schur complement
    // and right side (≈ 16), 2×2 eigenvalues (≈ 10), solve (≈ 8), back to x, y, z (15) → ≈ 215.
    let lo = stack::paint(top);
    let (_, n) = measure(|| ssm.live());
    record_stack("StreamingSsm::live", lo);
    print(&Row::plain(
        "streaming SSM live (f32, every sample)",
        "query",
        n.saturating_sub(empty) as f32,
        215,
    ));

    // The whole per-sample metrology path: ISO 230-4 trackers (with the circle fit) + streaming
    // SSM, on fresh estimators. FLOP: 81 + 73 = 154. Naive: the naive tracker (its circle fit
    // solves per sample) + the naive SSM (solves per sample).
    let mut iso = CircularTest::<BINS>::new(fit_cfg, data::BAR_MM);
    let mut ssm2 = StreamingSsm::<W>::new(ssm_cfg);
    let lo = stack::paint(top);
    let whole = per_sample(&samples, empty, |s| {
        black_box(iso.update(s, Direction::Ccw));
        black_box(ssm2.update(s));
    });
    record_stack("whole metrology path", lo);
    let mut niso = naive::NaiveIso::<BINS>::new(data::SOCKET_MM[0], data::SOCKET_MM[1]);
    let mut nssm = naive::NaiveSsm::<W>::new(data::SOCKET_MM, data::BAR_MM, data::SSM_RADIUS_MM);
    let whole_naive = per_sample(&samples, empty, |s| {
        niso.update(s);
        nssm.update(s);
    });
    print(&Row {
        name: "**whole per-sample metrology path** (ISO trackers + circle fit + streaming SSM)",
        unit: "sample",
        insns_per_unit: whole,
        flops_per_unit: 154,
        naive_per_unit: Some(whole_naive),
        max_insns: Some(300.0),
        min_ratio: Some(3.0),
    });

    // ---- the whole live pipeline --------------------------------------------------------------
    // What the firmware's application task does per LVDT block: the block's demodulation, the
    // acquisition sample (calibration, axes, thermal, flags) and `App::on_raw_sample` with the
    // armed pattern's estimators and every live value refreshed (the circle fit solved, the
    // SSM neighbourhood solved), on the circle data.
    let parts = cortex_m::singleton!(: PodParts = PodParts {
        node: CanOpenNode::new(16, 1),
        scpi: ScpiServer::new(),
        log: SampleLog::new(),
        stream: SampleStream::new(),
    })
    .expect("once");
    for (name, pattern) in [
        (
            "**whole live pipeline, CIRCLE** (demodulation + Pod::on_block + Pod::end_of_turn, the stream open)",
            Pattern::Circle,
        ),
        ("**whole live pipeline, seed 002 CR**", Pattern::Cr),
        ("**whole live pipeline, SSM**", Pattern::Ssm),
    ] {
        let mut app = started_app(pattern, &samples[0]);
        let lo = stack::paint(top);
        let per_sample = pipeline_per_sample(&mut app, parts, &samples, a, b, &table, empty);
        record_stack(name, lo);
        print(&Row::pipeline(name, per_sample));
    }
    // a run's start: the stream's header (the run's configuration as text), written into the
    // ring in the application task's turn that starts the run
    {
        let stream = &mut parts.stream;
        stream.drain(usize::MAX, &mut |_| {});
        stream.set_enabled(true);
        let meta = RunMeta {
            run: 1,
            pattern: Pattern::Circle,
            direction: RunDirection::Ccw,
            config: Config::default(),
        };
        let (_, n) = measure(|| stream.begin_run(black_box(&meta)));
        stream.drain(usize::MAX, &mut |_| {});
        print(&Row::plain(
            "sample stream: a run's header (its configuration as text, at the run's start)",
            "run",
            n.saturating_sub(empty) as f32,
            0,
        ));
    }
    let (growing, steady) = ssm_pipeline_at_feed(parts, a, b, &table, empty);
    print(&Row::pipeline(
        "**whole live pipeline, SSM at F1000** (steady state)",
        steady,
    ));
    print(&Row::pipeline(
        "whole live pipeline, SSM at F1000, the window growing (a run's first 256 samples)",
        growing,
    ));

    // ---- identification (per test) ----------------------------------------------------------
    // The seed 002 identification on the pod (model mode with its uncertainty propagation,
    // thesis mode), once per procedure: the thesis's Table 4.4 mean eccentricities as every
    // step's CW and CCW run.
    const T44_MEANS: [[f32; 2]; 5] = [
        [-51.70, -41.67],
        [-9.73, -36.10],
        [-48.00, 25.77],
        [-6.10, -0.27],
        [-57.73, 28.50],
    ];
    let mut procedure = Procedure::new(Setup::thesis_table_4_3());
    for (step, e) in Pattern::SEED002.into_iter().zip(T44_MEANS) {
        for d in [RunDirection::Cw, RunDirection::Ccw] {
            let _ = procedure.record(
                step,
                d,
                CircleEstimate {
                    r0_um: 0.0,
                    e_um: e,
                    u_r0_um: 0.1,
                    u_e_um: [0.1, 0.1],
                    residual_rms_um: 0.2,
                    samples: 30_000,
                    cond: 3.2,
                },
            );
        }
    }
    let lo = stack::paint(top);
    let bar = BarBudget::from_config(&Config::default());
    let (id, n) = measure_long(|| procedure.identify(&bar));
    record_stack("seed 002 identification (Procedure::identify)", lo);
    hprintln!(
        "| seed 002 identification on the pod (model mode + u, thesis mode; f64 soft-float) | procedure | {} | — | — | — | — | {:.2} s at 170 MHz (1 insn/cycle), ok = {} |",
        n,
        n as f64 / 170e6,
        id.is_ok()
    );

    let mut lsq = GivensLsq::<11>::new();
    let row = [1.0, 0.5, -0.25, 2.0, 0.1, -1.5, 0.7, 0.3, -0.9, 1.1, 0.05];
    let lo = stack::paint(top);
    let (_, n) = measure(|| lsq.add_row(black_box(&row), 1.0, 1.0));
    record_stack("GivensLsq::<11>::add_row", lo);
    // FLOP: 11 rotations of a 12-wide row, each √ + 2 div + 4 mul/add per remaining element
    // (≈ 6 × 66 = 396 for the triangle).
    print(&Row::plain(
        "identification Givens row, 11 unknowns (f64 soft-float, per test)",
        "row",
        n.saturating_sub(empty) as f32,
        396,
    ));

    // ---- a log download: the application task's longest pull ---------------------------------
    // The firmware's log (`LOG_CAPACITY` records) filled with the circle's samples, decimated as
    // on the pod; `DATA:LOG?` in pull mode; every pull as the application task makes it (64-byte
    // USB packets): the counting pulls, the header, the CSV. The longest one is how long a
    // download can hold up the task (and so the samples behind it).
    {
        let mut log: SampleLog<LOG_CAPACITY> = SampleLog::new();
        let app = started_app(Pattern::Circle, &samples[0]);
        log.begin_run(app.run_meta());
        for k in 0..6 {
            for s in samples.iter() {
                let mut s = *s;
                s.seq += (k * data::N) as u32;
                log.sample(&s);
            }
        }
        let mut app = app;
        let mut scpi = ScpiServer::new();
        scpi.set_pull_download(true);
        scpi.feed(b"DATA:LOG?\n", &mut app, &log, &mut |_: &[u8]| {});
        let (mut pulls, mut longest, mut total) = (0u32, 0u32, 0u64);
        let mut packet = [0u8; 64];
        while scpi.download_pending() {
            let (_, n) = measure(|| scpi.pull_download(&log, &mut packet));
            let n = n.saturating_sub(empty);
            pulls += 1;
            longest = longest.max(n);
            total += u64::from(n);
        }
        hprintln!();
        hprintln!(
            "| log download (DATA:LOG? of {} records, 64-byte pulls) | pulls | longest pull, insns | all pulls, insns |",
            log.len()
        );
        hprintln!("|---|---|---|---|");
        hprintln!(
            "| counting {} lines a pull, then the header, then the CSV | {} | {} | {} |",
            ballpod::protocol::scpi::COUNT_LINES_PER_PULL,
            pulls,
            longest,
            total
        );
    }

    // ---- interrupt-masked sections of the firmware's queues ----------------------------------
    masked::report();

    // ---- stack and state --------------------------------------------------------------------
    hprintln!();
    hprintln!("| stack high-water mark (painting) | bytes below the caller |");
    hprintln!("|---|---|");
    for (name, bytes) in stack_rows.iter().take(n_stack) {
        hprintln!("| {} | {} |", name, bytes);
    }
    hprintln!();
    hprintln!("| estimator state | bytes |");
    hprintln!("|---|---|");
    hprintln!(
        "| ExcitationTable<{}> | {} |",
        P,
        core::mem::size_of::<ExcitationTable<P>>()
    );
    hprintln!("| Acquisition | {} |", core::mem::size_of::<Acquisition>());
    hprintln!(
        "| App (the whole pod application, incl. its Acquisition) | {} |",
        core::mem::size_of::<App>()
    );
    hprintln!("| CircleFit | {} |", core::mem::size_of::<CircleFit>());
    hprintln!(
        "| CircularTest<{}> (CW + CCW) | {} |",
        BINS,
        core::mem::size_of::<CircularTest<BINS>>()
    );
    hprintln!(
        "| StreamingSsm<{}> | {} |",
        W,
        core::mem::size_of::<StreamingSsm<W>>()
    );
    hprintln!(
        "| GivensLsq<11> | {} |",
        core::mem::size_of::<GivensLsq<11>>()
    );
    hprintln!();
    let e = est.map(|e| e.e_um).unwrap_or([f32::NAN; 2]);
    let se = ssm_est.map(|e| e.solution.e_um).ok();
    hprintln!(
        "check: LVDT ratio core {} naive {} (expect 0.125); Q14 DSP kernels (with and without the rail test) = portable sums bit for bit (clean and railed block): {}",
        core_ratio,
        naive_ratio,
        kernel_identical
    );
    hprintln!(
        "check: circle fit e = ({}, {}) um core, ({}, {}) naive (expect {:?})",
        e[0],
        e[1],
        nfit.x[1],
        nfit.x[2],
        data::E_UM
    );
    hprintln!(
        "check: streaming SSM E = {:?} um core (local 5 mm window), {:?} naive (its LU finds the planar-path matrix singular)",
        se,
        [nssm.e[0], nssm.e[1], nssm.e[2]]
    );
    debug::exit(debug::EXIT_SUCCESS);
    #[allow(clippy::empty_loop)]
    loop {}
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    hprintln!("panic: {}", info);
    debug::exit(debug::EXIT_FAILURE);
    #[allow(clippy::empty_loop)]
    loop {}
}
