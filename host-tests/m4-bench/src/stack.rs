//! Stack high-water mark by painting: fill the free stack below the caller's frame with a
//! pattern, run a path, then find the deepest word that no longer holds the pattern.

use core::ptr;

const PAINT: u32 = 0xC0DE_F00D;
/// Bytes painted below the caller's stack pointer (more than any path here uses).
const PAINT_BYTES: usize = 64 * 1024;
/// Bytes left untouched just below the stack pointer (the painting function's own frame; a path using less reads as 64).
const GUARD: usize = 64;

/// The caller's stack pointer (the reference the depth is measured from).
#[inline(always)]
pub fn sp() -> usize {
    cortex_m::register::msp::read() as usize
}

/// Paints `PAINT_BYTES` below `top − GUARD`; returns the lowest painted address.
#[inline(never)]
pub fn paint(top: usize) -> usize {
    let hi = (top - GUARD) & !3;
    let lo = hi - PAINT_BYTES;
    let mut a = lo;
    while a < hi {
        // SAFETY: addresses below the current stack pointer of this single-threaded program are
        // free stack (the mps2-an386 RAM is 4 MiB; 16 KiB below the frame is well inside it).
        unsafe { ptr::write_volatile(a as *mut u32, PAINT) };
        a += 4;
    }
    lo
}

/// Bytes of stack used below `top` since [`paint`] returned `lo`.
#[inline(never)]
pub fn used(top: usize, lo: usize) -> usize {
    let mut a = lo;
    // SAFETY: reads of the painted region, which is ordinary RAM.
    while a < top && unsafe { ptr::read_volatile(a as *const u32) } == PAINT {
        a += 4;
    }
    top - a
}
