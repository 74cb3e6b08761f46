//! CAN nominal bit timing of the FDCAN for the offered bit rates, computed at compile time.
//!
//! The FDCAN kernel clock is the NUCLEO-G474RE's 24 MHz HSE crystal ([`FDCAN_KERNEL_HZ`];
//! `src/main.rs` selects it): 24 MHz divides into 125, 250, 500 kbit/s and 1 Mbit/s with
//! 24 time quanta per bit, so every offered rate is exact (from a 42.5 MHz PLL output,
//! 1 Mbit/s has none, and embassy's `set_bitrate` would unwrap a failed calculation).
//! [`CanBitrate`] is the only way
//! a bit rate enters the configuration, and the build fails if one of its values has no exact
//! timing at the kernel clock — so no stored or written configuration can ask for a rate the
//! hardware cannot realise.
//!
//! The rule (CiA 301 §7.3.2 / CiA 601 recommend a sample point at 87.5 %): the most time
//! quanta per bit from 25 down to 8 that divide the clock exactly, phase segment 2 = an eighth
//! of them (rounded, at least 1), synchronisation jump width = phase segment 2.

use crate::config::CanBitrate;

/// FDCAN kernel clock, Hz (HSE, RCC `FDCANSEL` = HSE).
pub const FDCAN_KERNEL_HZ: u32 = 24_000_000;

/// One nominal bit timing (FDCAN `NBTP`, the values themselves, not minus one).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BitTiming {
    /// Clock prescaler (1…512): one time quantum = prescaler / kernel clock.
    pub prescaler: u16,
    /// Time segment before the sample point, propagation + phase 1 (1…256 tq).
    pub seg1: u8,
    /// Phase segment 2, after the sample point (1…128 tq).
    pub seg2: u8,
    /// Synchronisation jump width (1…128 tq, ≤ seg2).
    pub sync_jump_width: u8,
}

impl BitTiming {
    /// Time quanta per bit (the synchronisation segment included).
    pub const fn quanta(&self) -> u32 {
        1 + self.seg1 as u32 + self.seg2 as u32
    }
}

/// The exact nominal timing of `bitrate` (bit/s) from a kernel clock of `kernel_hz`, or `None`
/// if no prescaler and 8…25 quanta per bit give it exactly.
pub const fn bit_timing(kernel_hz: u32, bitrate: u32) -> Option<BitTiming> {
    if bitrate == 0 {
        return None;
    }
    let mut quanta = 25u32;
    while quanta >= 8 {
        let per_bit = bitrate as u64 * quanta as u64;
        if (kernel_hz as u64).is_multiple_of(per_bit) {
            let prescaler = kernel_hz as u64 / per_bit;
            if prescaler >= 1 && prescaler <= 512 {
                let seg2 = (quanta + 4) / 8;
                let seg1 = quanta - 1 - seg2;
                return Some(BitTiming {
                    prescaler: prescaler as u16,
                    seg1: seg1 as u8,
                    seg2: seg2 as u8,
                    sync_jump_width: seg2 as u8,
                });
            }
        }
        quanta -= 1;
    }
    None
}

/// The timings of [`CanBitrate`] in its discriminant order, evaluated at compile time: a value
/// without an exact timing at [`FDCAN_KERNEL_HZ`] fails the build.
// Evaluated at compile time: an index out of bounds is a build error, not a panic.
#[allow(clippy::indexing_slicing)]
const TIMINGS: [BitTiming; 4] = {
    let rates = [
        CanBitrate::K125,
        CanBitrate::K250,
        CanBitrate::K500,
        CanBitrate::M1,
    ];
    let mut out = [BitTiming {
        prescaler: 1,
        seg1: 1,
        seg2: 1,
        sync_jump_width: 1,
    }; 4];
    let mut i = 0;
    while i < rates.len() {
        out[rates[i] as usize] = match bit_timing(FDCAN_KERNEL_HZ, rates[i].bits_per_s()) {
            Some(t) => t,
            // const evaluation: this is a build error, never a run-time panic
            None => panic!("a CanBitrate without an exact timing at FDCAN_KERNEL_HZ"),
        };
        i += 1;
    }
    out
};

impl CanBitrate {
    /// Its nominal bit timing at [`FDCAN_KERNEL_HZ`] (exact: checked at compile time).
    pub const fn timing(self) -> BitTiming {
        let [k125, k250, k500, m1] = TIMINGS;
        match self {
            Self::K125 => k125,
            Self::K250 => k250,
            Self::K500 => k500,
            Self::M1 => m1,
        }
    }
}
