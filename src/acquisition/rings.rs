//! The two secondaries' ADC rings after an overrun: both are cleared at one DMA position, so
//! their halves stay the same conversions (ADC1 and ADC2 convert on the same TIM6 edge). A
//! ring cleared on its own restarts at the next half-ring boundary after *its* overrun; the
//! other one, cleared when the task next finds it lapped, can restart a half ring later and
//! pair every later half of A with the next half of B — a secondary half a block late, unflagged.

/// One DMA ring as the realignment sees it (the board's `RingBufferedAdc` and its channel).
pub trait DmaRing {
    /// Transfers left before the ring's end (the DMA channel's NDTR).
    fn remaining(&mut self) -> u16;
    /// Drops what is unread: the ring's read position becomes the DMA's position now (and reads
    /// restart at the next half-ring boundary).
    fn clear(&mut self);
}

/// Attempts [`realign`] makes before it gives up (each takes well under a conversion: a
/// conversion lands in at most a few of them).
pub const REALIGN_TRIES: u32 = 16;

/// Clears both rings at one DMA position: both channels' positions are read, the rings cleared
/// and the positions read again; only if all four agree were both cleared at the same position
/// (a transfer between the reads, or an interrupt that delays the second clear past one, shows
/// as a changed position, and it is tried again). True once aligned; false if no attempt of
/// [`REALIGN_TRIES`] found the two channels at one position (a stopped ADC: the rings are left
/// cleared, and the board says so).
pub fn realign(a: &mut impl DmaRing, b: &mut impl DmaRing) -> bool {
    for _ in 0..REALIGN_TRIES {
        let before = (a.remaining(), b.remaining());
        if before.0 != before.1 {
            continue;
        }
        a.clear();
        b.clear();
        if (a.remaining(), b.remaining()) == before {
            return true;
        }
    }
    false
}
