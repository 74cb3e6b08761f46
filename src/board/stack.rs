//! The stack's high-water mark: cortex-m-rt paints the stack with `0xCCCC_CCCC` before `main`
//! (feature `paint-stack`) and flip-link puts it at the bottom of RAM (`_stack_end` …
//! `_stack_start`), so the deepest use is the lowest word that no longer holds the paint. Both
//! boards' diagnostics read it.

unsafe extern "C" {
    /// Lowest stack address (flip-link: the start of RAM).
    static _stack_end: u32;
    /// Highest stack address (the initial stack pointer).
    static _stack_start: u32;
}

/// Deepest stack use since boot, bytes: from the bottom of the stack up to the first word that
/// lost the paint. Scans the unused part (≈ 4 cycles a word): call it seldom.
pub fn stack_high_water_bytes() -> u32 {
    let lo = core::ptr::addr_of!(_stack_end) as usize;
    let hi = core::ptr::addr_of!(_stack_start) as usize;
    let mut a = lo;
    // SAFETY: reads of the stack region between the linker's two symbols (ordinary RAM, 4-byte
    // aligned, below the live stack pointer or holding live frames: reads never disturb them).
    while a < hi && unsafe { core::ptr::read_volatile(a as *const u32) } == 0xCCCC_CCCC {
        a += 4;
    }
    (hi - a) as u32
}
