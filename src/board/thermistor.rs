//! Bar thermistor on PB0 / ADC3 IN12, read at 10 Hz and queued for the compute task.

use embassy_stm32::adc::{Adc, AdcConfig, SampleTime};
use embassy_stm32::{Peri, peripherals};
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;
use embassy_time::{Duration, Ticker};

use super::Overruns;

/// Thermistor ADC codes → compute task.
pub static CODES: Channel<CriticalSectionRawMutex, u16, 2> = Channel::new();
/// Readings dropped because the compute task had not taken the previous ones (harmless: a
/// newer reading follows, but counted like every other loss).
pub static CODE_QUEUE_OVERRUNS: Overruns = Overruns::new();

/// Reads the thermistor divider every 100 ms (long sample time: high source impedance).
#[embassy_executor::task]
pub async fn thermistor_task(
    adc: Peri<'static, peripherals::ADC3>,
    mut pin: Peri<'static, peripherals::PB0>,
) {
    let mut adc = Adc::new(adc, AdcConfig::default());
    let mut ticker = Ticker::every(Duration::from_millis(100));
    loop {
        super::safety::check_in(super::safety::Task::Thermistor);
        let code = adc.blocking_read(&mut pin, SampleTime::CYCLES640_5);
        if CODES.try_send(code).is_err() {
            CODE_QUEUE_OVERRUNS.count();
        }
        ticker.next().await;
    }
}
