//! The firmware's critical-section implementation, which times every outermost
//! interrupt-masked section: PRIMASK saved, interrupts masked, the clock read on entry and exit
//! of the outermost section, the maximum kept. Otherwise it is cortex-m's
//! `critical-section-single-core`. The including module supplies the clock,
//! `super::masked_clock()` (a free-running counter) and `super::MASKED_CLOCK_MASK` (its width):
//! the firmware the DWT cycle counter (`board::diagnostics`), the QEMU bench SysTick
//! (`host-tests/m4-bench/src/masked.rs`, which includes this file to measure this very code).

use core::sync::atomic::{AtomicU32, Ordering, compiler_fence};

/// Clock count at the entry of the current outermost section.
static SINCE: AtomicU32 = AtomicU32::new(0);
/// Longest outermost section so far, clock counts.
static MAX: AtomicU32 = AtomicU32::new(0);

struct MeasuredCriticalSection;
critical_section::set_impl!(MeasuredCriticalSection);

// SAFETY: single core: masking interrupts with PRIMASK excludes every other context; the
// restore state is PRIMASK as it was, so nested sections restore correctly. The statics are
// touched only with interrupts masked.
unsafe impl critical_section::Impl for MeasuredCriticalSection {
    unsafe fn acquire() -> critical_section::RawRestoreState {
        let was = cortex_m::register::primask::read_raw();
        cortex_m::interrupt::disable();
        if was & 1 == 0 {
            // interrupts were on: an outermost section starts
            SINCE.store(super::masked_clock(), Ordering::Relaxed);
            // the section's own accesses stay after the clock read
            compiler_fence(Ordering::SeqCst);
        }
        was
    }

    unsafe fn release(was: critical_section::RawRestoreState) {
        if was & 1 == 0 {
            compiler_fence(Ordering::SeqCst);
            let d = super::masked_clock().wrapping_sub(SINCE.load(Ordering::Relaxed))
                & super::MASKED_CLOCK_MASK;
            if d > MAX.load(Ordering::Relaxed) {
                MAX.store(d, Ordering::Relaxed);
            }
        }
        // SAFETY: restores the PRIMASK this section found.
        unsafe { cortex_m::register::primask::write_raw(was) };
    }
}

/// The longest outermost masked section so far, clock counts.
#[allow(dead_code)] // the firmware reads it, the bench takes it
pub fn max() -> u32 {
    MAX.load(Ordering::Relaxed)
}

/// The longest outermost masked section since the last call, clock counts; starts anew.
#[allow(dead_code)]
pub fn take_max() -> u32 {
    MAX.swap(0, Ordering::Relaxed)
}
