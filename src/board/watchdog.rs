//! The STM32's independent watchdog (IWDG, LSI clock: it runs even if the main clocks fail)
//! and the reset flags; what it waits for is `safety`'s.

use embassy_stm32::peripherals::IWDG;
use embassy_stm32::wdg::IndependentWatchdog;

use ballpod::boot::ResetCause;

use super::safety::{self, WATCHDOG_TIMEOUT_US};

/// The running watchdog.
pub type Dog = IndependentWatchdog<'static, IWDG>;

/// Starts the watchdog, frozen while a debugger halts the core (DBGMCU_APB1FZR1.DBG_IWDG_STOP,
/// RM0440, debug support: a breakpoint does not reset the pod). Call at boot before the flash is
/// read, so a boot that hangs there is reset.
pub fn start(iwdg: embassy_stm32::Peri<'static, IWDG>) -> Dog {
    embassy_stm32::pac::DBGMCU
        .apb1lfzr()
        .modify(|w| w.set_iwdg(true));
    let mut dog = IndependentWatchdog::new(iwdg, WATCHDOG_TIMEOUT_US);
    dog.unleash();
    dog
}

/// Pets the watchdog while every task checks in ([`safety::watch`]).
#[embassy_executor::task]
pub async fn watchdog_task(mut dog: Dog) {
    safety::watch(|| dog.pet()).await
}

/// Why the MCU last reset (RCC_CSR's flags, RM0440 §7.4.30); clears the flags. Call once at
/// boot.
pub fn take_reset_cause() -> ResetCause {
    let rcc = embassy_stm32::pac::RCC;
    let cause = ResetCause::from_rcc_csr(rcc.csr().read().0);
    rcc.csr().modify(|w| w.set_rmvf(true));
    cause
}
