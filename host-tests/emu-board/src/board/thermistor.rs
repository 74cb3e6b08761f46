//! The bar thermistor: the code in a block record (every 100 ms), queued for the application
//! task as the STM32's ADC3 task queues its reading.

use core::sync::atomic::Ordering;

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;

use super::{Overruns, shared};

/// Thermistor ADC codes for the application task.
pub static CODES: Channel<CriticalSectionRawMutex, u16, 2> = Channel::new();
/// Readings dropped because the application task had not taken the previous ones.
pub static CODE_QUEUE_OVERRUNS: Overruns = Overruns::new();

/// Looks at the records taken every 10 ms and queues the thermistor codes among them.
#[embassy_executor::task]
pub async fn thermistor_task() {
    let mut seen = shared::region().taken.load(Ordering::Acquire);
    loop {
        super::safety::check_in(super::safety::Task::Thermistor);
        embassy_time::Timer::after_millis(10).await;
        let taken = shared::region().taken.load(Ordering::Acquire);
        while seen != taken {
            let code = shared::record(seen).thermistor;
            if code != u32::MAX && CODES.try_send(code as u16).is_err() {
                CODE_QUEUE_OVERRUNS.count();
            }
            seen = seen.wrapping_add(1);
        }
    }
}
