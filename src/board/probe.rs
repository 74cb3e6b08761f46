//! Touch-trigger probe on PB4 / EXTI line 4. The interrupt latches every encoder counter and
//! the time at the edge and queues them; the compute task applies the core's debounce and
//! re-seat lock-out.

use embassy_stm32::exti::{ExtiInput, TriggerEdge};
use embassy_stm32::gpio::Pull;
use embassy_stm32::interrupt::typelevel::{EXTI4, Handler};
use embassy_stm32::mode::Blocking;
use embassy_stm32::{Peri, pac, peripherals};

use super::probe_queue::ProbeEdge;

/// EXTI line 4 interrupt: latch, clear, queue.
pub struct ProbeEdgeIsr;

impl Handler<EXTI4> for ProbeEdgeIsr {
    unsafe fn on_interrupt() {
        let raw = super::encoders::latched_counts();
        let t_us = embassy_time::Instant::now().as_micros();
        if pac::EXTI.pr(0).read().0 & (1 << 4) != 0 {
            pac::EXTI.pr(0).write_value(pac::exti::regs::Lines(1 << 4));
            super::probe_queue::queue(ProbeEdge { t_us, raw });
        }
    }
}

/// The probe's contact input (PB4).
pub type ProbeInput = ExtiInput<'static, Blocking>;

/// The stylus is seated (at rest): the NC contact to ground with pull-up reads low.
pub fn seated(input: &ProbeInput) -> bool {
    input.is_low()
}

/// Configures PB4 with pull-up and a rising-edge interrupt (NC probe contact opening).
pub fn input(
    pin: Peri<'static, peripherals::PB4>,
    ch: Peri<'static, peripherals::EXTI4>,
) -> ExtiInput<'static, Blocking> {
    ExtiInput::new_blocking(pin, ch, Pull::Up, TriggerEdge::Rising)
}
