//! The calibrated sample: what acquisition hands to metrology, once per sample period.

pub use crate::config::MAX_AXES;

/// Validity flags of one [`Sample`] (a bit set; a hand-written newtype because six constants do
/// not justify a dependency).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct SampleFlags(pub u16);

impl SampleFlags {
    /// No flag set: the sample is fully valid.
    pub const NONE: Self = Self(0);
    /// LVDT position outside the calibrated stroke (or ADC at a rail): ΔL is clamped, not valid.
    pub const LVDT_OVER_RANGE: Self = Self(1 << 0);
    /// LVDT secondaries too weak (open coil, unplugged bar, no excitation): ΔL is not valid.
    pub const LVDT_OPEN: Self = Self(1 << 1);
    /// An encoder reported a quadrature error (a count jump larger than physically possible).
    pub const QUADRATURE_ERROR: Self = Self(1 << 2);
    /// The touch probe triggered during this sample (the latch is reported separately).
    pub const PROBE_EVENT: Self = Self(1 << 3);
    /// One or more samples or ADC blocks were lost just before this one (see the overrun counter).
    pub const OVERRUN: Self = Self(1 << 4);
    /// The bar thermistor is open, shorted or out of range: the expansion correction used the
    /// last good temperature (or 20 °C if there was none).
    pub const TEMPERATURE_FAULT: Self = Self(1 << 5);

    /// Flags that make ΔL unusable for metrology (the sample is skipped and counted).
    pub const INVALID_FOR_METROLOGY: Self =
        Self(Self::LVDT_OVER_RANGE.0 | Self::LVDT_OPEN.0 | Self::QUADRATURE_ERROR.0);

    /// True if every flag of `other` is set in `self`.
    pub const fn contains(self, other: Self) -> bool {
        self.0 & other.0 == other.0
    }
    /// True if any flag of `other` is set in `self`.
    pub const fn intersects(self, other: Self) -> bool {
        self.0 & other.0 != 0
    }
    /// `self` with the flags of `other` added.
    pub const fn with(self, other: Self) -> Self {
        Self(self.0 | other.0)
    }
    /// Adds the flags of `other`.
    pub fn insert(&mut self, other: Self) {
        self.0 |= other.0;
    }
    /// True if metrology may use this sample's ΔL and axis positions.
    pub const fn is_valid_for_metrology(self) -> bool {
        !self.intersects(Self::INVALID_FOR_METROLOGY)
    }
}

/// One calibrated, validated sample of the pod (DESIGN §5).
///
/// Axis positions are `f32` in mm (linear) or degrees (rotary) in machine coordinates: the ulp
/// at 1000 mm is 61 nm, which is ample for the *directions* metrology derives from them; the
/// measured quantity ΔL is a small deviation and keeps nm resolution in `f32` (DESIGN §6).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sample {
    /// Sample number since boot, counting the samples lost upstream too: a gap between two
    /// consecutive samples is the number lost between them (also in the overrun counter).
    pub seq: u32,
    /// Time stamp, µs since boot.
    pub t_us: u64,
    /// Bar-length deviation ΔL in µm: measured length minus calibrated length at 20 °C,
    /// corrected for the bar's thermal expansion (DESIGN §7). Positive = longer.
    pub delta_l_um: f32,
    /// Axis positions, mm (linear axes) or degrees (rotary axes), in configured axis order.
    pub axes: [f32; MAX_AXES],
    /// Bar temperature used for the expansion correction, °C.
    pub temp_c: f32,
    /// Validity flags.
    pub flags: SampleFlags,
}
