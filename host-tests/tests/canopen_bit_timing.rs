//! The FDCAN nominal bit timing of every offered CAN bit rate (`protocol::canopen::bit_timing`)
//! against the definition bit rate = kernel clock / (prescaler × (1 + seg1 + seg2)), the
//! FDCAN `NBTP` field ranges (RM0440 §44.4.6) and the CiA 301 sample point, and against an
//! independent exhaustive search; the 42.5 MHz clock the firmware used before has no exact
//! 1 Mbit/s timing (the boot loop of issue 13).
use ballpod::config::CanBitrate;
use ballpod::protocol::canopen::bit_timing::{FDCAN_KERNEL_HZ, bit_timing};

const ALL: [CanBitrate; 4] = [
    CanBitrate::K125,
    CanBitrate::K250,
    CanBitrate::K500,
    CanBitrate::M1,
];

/// Every (prescaler, quanta per bit) of the FDCAN that gives `bitrate` exactly from `clock`.
fn exact(clock: u64, bitrate: u64) -> Vec<(u64, u64)> {
    let mut out = Vec::new();
    for prescaler in 1..=512u64 {
        for quanta in 4..=385u64 {
            if prescaler * quanta * bitrate == clock {
                out.push((prescaler, quanta));
            }
        }
    }
    out
}

#[test]
fn every_offered_bit_rate_is_exact_at_the_kernel_clock() {
    assert_eq!(FDCAN_KERNEL_HZ, 24_000_000, "the NUCLEO-G474RE's HSE");
    for b in ALL {
        let t = b.timing();
        let rate = u64::from(b.bits_per_s());
        let bit = u64::from(t.prescaler) * u64::from(t.quanta());
        assert_eq!(
            u64::from(FDCAN_KERNEL_HZ),
            bit * rate,
            "{b:?}: {t:?} gives {} bit/s",
            f64::from(FDCAN_KERNEL_HZ) / bit as f64
        );
        // NBTP ranges: NBRP 1…512, NTSEG1 2…256, NTSEG2 1…128, NSJW 1…128 (≤ NTSEG2)
        assert!((1..=512).contains(&t.prescaler), "{t:?}");
        assert!(t.seg1 >= 2 && t.seg2 >= 1 && t.seg2 <= 128, "{t:?}");
        assert!(
            t.sync_jump_width >= 1 && t.sync_jump_width <= t.seg2,
            "{t:?}"
        );
        // sample point at 87.5 % (CiA 301 §7.3.2), within one quantum
        let sample = f64::from(1 + u32::from(t.seg1)) / f64::from(t.quanta());
        assert!(
            (sample - 0.875).abs() <= 1.0 / f64::from(t.quanta()),
            "{b:?}: sample point {sample}"
        );
        // at least 8 quanta per bit (resynchronisation resolution), and a timing the exhaustive
        // search also finds
        assert!(t.quanta() >= 8);
        assert!(
            exact(u64::from(FDCAN_KERNEL_HZ), rate)
                .contains(&(u64::from(t.prescaler), u64::from(t.quanta())))
        );
        assert_eq!(bit_timing(FDCAN_KERNEL_HZ, b.bits_per_s()), Some(t));
    }
}

#[test]
fn the_old_42_5_mhz_clock_has_no_exact_1_mbit_timing() {
    let clock = 42_500_000u32;
    assert!(exact(u64::from(clock), 1_000_000).is_empty());
    assert_eq!(bit_timing(clock, 1_000_000), None);
    // the lower rates did divide it
    for rate in [125_000u32, 250_000, 500_000] {
        let t = bit_timing(clock, rate).expect("exact");
        assert_eq!(
            u64::from(clock),
            u64::from(t.prescaler) * u64::from(t.quanta()) * u64::from(rate)
        );
    }
    assert_eq!(bit_timing(clock, 0), None);
}
