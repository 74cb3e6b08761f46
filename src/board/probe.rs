//! Touch-trigger probe on PB4 / EXTI line 4. The interrupt latches every encoder counter and
//! the time at the edge and queues them; the compute task applies the core's debounce and
//! re-seat lock-out.

use embassy_stm32::exti::{ExtiInput, TriggerEdge};
use embassy_stm32::gpio::Pull;
use embassy_stm32::interrupt::typelevel::{EXTI4, Handler};
use embassy_stm32::mode::Blocking;
use embassy_stm32::{Peri, pac, peripherals};
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;

use ballpod::acquisition::MAX_AXES;

use super::Overruns;

/// A probe edge as latched in the interrupt.
#[derive(Clone, Copy)]
pub struct ProbeEdge {
    /// Time of the edge, µs since boot.
    pub t_us: u64,
    /// The hardware encoder counters at the edge.
    pub raw: [u32; MAX_AXES],
}

/// Probe interrupt → compute task.
pub static EDGES: Channel<CriticalSectionRawMutex, ProbeEdge, 8> = Channel::new();
/// Edges dropped because the queue was full.
pub static PROBE_QUEUE_OVERRUNS: Overruns = Overruns::new();

/// EXTI line 4 interrupt: latch, clear, queue.
pub struct ProbeEdgeIsr;

impl Handler<EXTI4> for ProbeEdgeIsr {
    unsafe fn on_interrupt() {
        let raw = super::encoders::raw_counts();
        let t_us = embassy_time::Instant::now().as_micros();
        if pac::EXTI.pr(0).read().0 & (1 << 4) != 0 {
            pac::EXTI.pr(0).write_value(pac::exti::regs::Lines(1 << 4));
            if EDGES.try_send(ProbeEdge { t_us, raw }).is_err() {
                PROBE_QUEUE_OVERRUNS.count();
            }
        }
    }
}

/// Configures PB4 with pull-up and a rising-edge interrupt (NC probe contact opening).
pub fn input(
    pin: Peri<'static, peripherals::PB4>,
    ch: Peri<'static, peripherals::EXTI4>,
) -> ExtiInput<'static, Blocking> {
    ExtiInput::new_blocking(pin, ch, Pull::Up, TriggerEdge::Rising)
}
