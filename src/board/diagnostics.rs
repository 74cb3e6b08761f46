//! What the board measures about itself, for the device counters (`ballpod::app::device`,
//! SCPI `SYSTem:COUNt?`, CANopen 0x2110):
//!
//! - **Longest interrupt-masked section.** `masked_cs.rs` is the firmware's critical-section
//!   implementation (the one embassy's queues, the time driver and defmt use; it replaces
//!   cortex-m's `critical-section-single-core`, which it otherwise equals): the outermost
//!   section reads the DWT cycle counter (170 MHz) on entry and exit and keeps the maximum.
//! - **Stack high-water mark.** cortex-m-rt paints the stack with `0xCCCC_CCCC` before `main`
//!   (feature `paint-stack`); flip-link puts the stack at the bottom of RAM
//!   (`_stack_end` = 0x2000_0000 … `_stack_start`), so the deepest use is the lowest word that
//!   no longer holds the paint. An overflow runs into the reserved region below RAM and faults
//!   (a lock-up, which the watchdog resets) instead of overwriting statics.
//! - **Excitation DMA underrun.** DAC1 SR.DMAUDR1 (RM0440 §22.4.8): the DMA did not deliver the
//!   next sine value in time and the DAC stopped requesting: the excitation stalls, the LVDT
//!   secondaries lose their carrier and the core flags the samples LVDT open. Counted here so
//!   the reason is known.

use ballpod::app::{DeviceCounter, DeviceCounters};
use cortex_m::peripheral::DWT;
use embassy_stm32::pac;

use super::Overruns;

/// Core clock, Hz (main.rs: 24 MHz HSE / 6 × 85 / 2).
pub const SYSCLK_HZ: u32 = 170_000_000;

/// Excitation DMA underruns seen.
pub static DAC_UNDERRUNS: Overruns = Overruns::new();

#[path = "masked_cs.rs"]
mod masked_cs;

/// The clock of the masked-section probe: the DWT cycle counter (170 MHz, 32 bits).
fn masked_clock() -> u32 {
    DWT::cycle_count()
}
/// The probe clock's width.
const MASKED_CLOCK_MASK: u32 = u32::MAX;

/// Starts the DWT cycle counter the masked-section probe reads. Call once at boot.
pub fn start_cycle_counter() {
    // SAFETY: only DCB.DEMCR.TRCENA and DWT.CTRL.CYCCNTENA are written, before any task runs;
    // nothing else in the firmware uses the DCB or the DWT.
    let mut cp = unsafe { cortex_m::Peripherals::steal() };
    cp.DCB.enable_trace();
    cp.DWT.enable_cycle_counter();
}

#[path = "stack.rs"]
mod stack;
use stack::stack_high_water_bytes;

/// Counts an excitation DMA underrun (and clears the flag so the next one is seen).
fn check_dac_underrun() {
    let sr = pac::DAC1.sr();
    if sr.read().dmaudr(0) {
        sr.write(|w| w.set_dmaudr(0, true));
        DAC_UNDERRUNS.count();
        defmt::error!("excitation DAC DMA underrun");
    }
}

/// Every device counter the board keeps, for the application's table (the pod adds its own:
/// `Pod::set_device_counters`).
pub fn device_counters() -> DeviceCounters {
    use DeviceCounter as C;
    check_dac_underrun();
    let masked_ns = u64::from(masked_cs::max()) * 1_000_000_000 / u64::from(SYSCLK_HZ);
    let mut c = super::overruns::queue_counters();
    for (k, v) in [
        (C::DacUnderruns, DAC_UNDERRUNS.get()),
        (
            C::MaskedMaxNs,
            u32::try_from(masked_ns).unwrap_or(u32::MAX - 1),
        ),
        (C::StackHighWaterBytes, stack_high_water_bytes()),
        (C::CanBusOffEntries, super::can::BUS_OFF_ENTRIES.get()),
        (
            C::CanErrorPassiveEntries,
            super::can::ERROR_PASSIVE_ENTRIES.get(),
        ),
    ] {
        c.set(k, v);
    }
    c
}
