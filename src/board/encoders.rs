//! Five quadrature encoders on timers in encoder mode (×4 decoding): TIM1, TIM3, TIM4 count
//! 16 bits, TIM2 and TIM5 (encoders 4 and 5, the rotary axes by default) 32 bits
//! ([`ballpod::config::ENCODER_COUNTER_BITS`]). Every read goes through [`latched_counts`],
//! which extends each counter to 64 bits ([`CounterLatch`]); the block latch reads them at each
//! half block whatever else runs, so the extension keeps up with the axes while the
//! application computes.

use core::cell::RefCell;

use embassy_stm32::timer::qei::{self, Qei};
use embassy_stm32::{Peri, pac, peripherals};

use ballpod::acquisition::MAX_AXES;
use ballpod::acquisition::encoder::{CounterLatch, LATCHED_COUNTER_BITS};
use ballpod::config::ENCODER_COUNTER_BITS;

/// Width of every counter as the core sees it: the low 32 bits of [`latched_counts`].
pub const COUNTER_BITS: [u32; MAX_AXES] = LATCHED_COUNTER_BITS;

/// The extension of the five counters, advanced by every read.
static LATCH: critical_section::Mutex<RefCell<CounterLatch>> =
    critical_section::Mutex::new(RefCell::new(CounterLatch::new(ENCODER_COUNTER_BITS)));

/// The five timers in encoder mode, in axis-input order.
type QeiSet = (
    Qei<'static, peripherals::TIM1>,
    Qei<'static, peripherals::TIM3>,
    Qei<'static, peripherals::TIM4>,
    Qei<'static, peripherals::TIM2>,
    Qei<'static, peripherals::TIM5>,
);

/// The five encoder interfaces (kept alive: dropping one would release its pins).
pub struct Encoders {
    _qei: QeiSet,
}

/// The timers and pins of the five encoders.
pub struct EncoderPeripherals {
    /// Encoder 1.
    pub e1: (
        Peri<'static, peripherals::TIM1>,
        Peri<'static, peripherals::PA8>,
        Peri<'static, peripherals::PA9>,
    ),
    /// Encoder 2.
    pub e2: (
        Peri<'static, peripherals::TIM3>,
        Peri<'static, peripherals::PA6>,
        Peri<'static, peripherals::PA7>,
    ),
    /// Encoder 3.
    pub e3: (
        Peri<'static, peripherals::TIM4>,
        Peri<'static, peripherals::PB6>,
        Peri<'static, peripherals::PB7>,
    ),
    /// Encoder 4.
    pub e4: (
        Peri<'static, peripherals::TIM2>,
        Peri<'static, peripherals::PA15>,
        Peri<'static, peripherals::PB3>,
    ),
    /// Encoder 5.
    pub e5: (
        Peri<'static, peripherals::TIM5>,
        Peri<'static, peripherals::PB2>,
        Peri<'static, peripherals::PC12>,
    ),
}

impl Encoders {
    /// Puts the five timers in encoder mode (both edges of both channels: ×4), the 32-bit
    /// ones over their whole range.
    pub fn new(p: EncoderPeripherals) -> Self {
        let c = qei::Config::default;
        let qei = (
            Qei::new(p.e1.0, p.e1.1, p.e1.2, c()),
            Qei::new(p.e2.0, p.e2.1, p.e2.2, c()),
            Qei::new(p.e3.0, p.e3.1, p.e3.2, c()),
            Qei::new(p.e4.0, p.e4.1, p.e4.2, c()),
            Qei::new(p.e5.0, p.e5.1, p.e5.2, c()),
        );
        // embassy's encoder mode sets a 16-bit auto-reload (0xFFFF): a 32-bit timer would
        // wrap at 2^16 where the extension expects 2^32
        for tim in [pac::TIM2, pac::TIM5] {
            tim.arr().write_value(u32::MAX);
        }
        Self { _qei: qei }
    }
}

/// The five hardware counters, straight from the timer registers: 16 bits from TIM1, TIM3,
/// TIM4, 32 from TIM2 and TIM5.
#[inline(always)]
fn raw_counts() -> [u32; MAX_AXES] {
    [
        u32::from(pac::TIM1.cnt().read().cnt()),
        u32::from(pac::TIM3.cnt().read().cnt()),
        u32::from(pac::TIM4.cnt().read().cnt()),
        pac::TIM2.cnt().read(),
        pac::TIM5.cnt().read(),
    ]
}

/// Reads the five counters and advances their extension; returns the extended counts' low 32
/// bits ([`COUNTER_BITS`]). Called by the block latch at each half block, by the probe's
/// interrupt at a touch, and by the LVDT task when it resynchronises; the read and the step
/// are one masked section (≈ 0.5 µs), so two callers never interleave.
#[inline(always)]
pub fn latched_counts() -> [u32; MAX_AXES] {
    critical_section::with(|cs| LATCH.borrow_ref_mut(cs).read(raw_counts()))
}
