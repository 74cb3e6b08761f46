//! Five quadrature encoders on timers in encoder mode (×4 decoding). The hardware counters are
//! read as 16 bits (TIM5 is 32-bit but is read like the others so one extension width
//! serves); the core extends them to 64 bits.

use embassy_stm32::timer::qei::{self, Qei};
use embassy_stm32::{Peri, pac, peripherals};

use ballpod::acquisition::MAX_AXES;

/// Width of every hardware counter as the core sees it.
pub const COUNTER_BITS: [u32; MAX_AXES] = [16; MAX_AXES];

/// The five timers in encoder mode, in axis-input order.
type QeiSet = (
    Qei<'static, peripherals::TIM1>,
    Qei<'static, peripherals::TIM3>,
    Qei<'static, peripherals::TIM4>,
    Qei<'static, peripherals::TIM8>,
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
        Peri<'static, peripherals::TIM8>,
        Peri<'static, peripherals::PC6>,
        Peri<'static, peripherals::PC7>,
    ),
    /// Encoder 5.
    pub e5: (
        Peri<'static, peripherals::TIM5>,
        Peri<'static, peripherals::PB2>,
        Peri<'static, peripherals::PC12>,
    ),
}

impl Encoders {
    /// Puts the five timers in encoder mode (both edges of both channels: ×4).
    pub fn new(p: EncoderPeripherals) -> Self {
        let c = qei::Config::default;
        Self {
            _qei: (
                Qei::new(p.e1.0, p.e1.1, p.e1.2, c()),
                Qei::new(p.e2.0, p.e2.1, p.e2.2, c()),
                Qei::new(p.e3.0, p.e3.1, p.e3.2, c()),
                Qei::new(p.e4.0, p.e4.1, p.e4.2, c()),
                Qei::new(p.e5.0, p.e5.1, p.e5.2, c()),
            ),
        }
    }
}

/// The five hardware counters, low 16 bits, read straight from the timer registers (also
/// called from the probe interrupt to latch the touch point).
#[inline(always)]
pub fn raw_counts() -> [u32; MAX_AXES] {
    [
        u32::from(pac::TIM1.cnt().read().cnt()),
        u32::from(pac::TIM3.cnt().read().cnt()),
        u32::from(pac::TIM4.cnt().read().cnt()),
        u32::from(pac::TIM8.cnt().read().cnt()),
        pac::TIM5.cnt().read() & 0xFFFF,
    ]
}
