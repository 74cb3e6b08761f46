//! The STM32's independent watchdog (IWDG, LSI clock: it runs even if the main clocks fail)
//! and its reset flag; what it waits for is `safety`'s.

use embassy_stm32::peripherals::IWDG;
use embassy_stm32::wdg::IndependentWatchdog;

use super::safety::{self, WATCHDOG_TIMEOUT_US};

/// Starts the watchdog and pets it while every task checks in ([`safety::watch`]).
#[embassy_executor::task]
pub async fn watchdog_task(iwdg: embassy_stm32::Peri<'static, IWDG>) {
    let mut dog = IndependentWatchdog::new(iwdg, WATCHDOG_TIMEOUT_US);
    dog.unleash();
    safety::watch(|| dog.pet()).await
}

/// Whether the last reset was the watchdog's (RCC_CSR.IWDGRSTF, RM0440 §7.4.30); clears the
/// reset flags. Call once at boot.
pub fn take_reset_flag() -> bool {
    let rcc = embassy_stm32::pac::RCC;
    let watchdog = rcc.csr().read().iwdgrstf();
    rcc.csr().modify(|w| w.set_rmvf(true));
    watchdog
}
