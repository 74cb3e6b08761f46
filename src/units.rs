//! The units of the configuration fields ([`crate::config::FIELDS`]) and the results
//! ([`crate::app::ResultInfo::all`]): one name table for SCPI, CANopen, the EDS and the docs. A row
//! holds a one-byte [`Unit`], not a string: about 170 rows, 1 KB less flash.

/// A unit of a configuration field or a result.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Unit {
    /// A number without unit (a ratio, a count, a code).
    One,
    /// Micrometre.
    Um,
    /// Microradian.
    Urad,
    /// Second of arc.
    Arcsec,
    /// Millimetre.
    Mm,
    /// Degree (angle).
    Deg,
    /// Micrometre per metre.
    UmPerM,
    /// Millisecond.
    Ms,
    /// Microsecond.
    Us,
    /// Samples (a count of pod samples).
    Samples,
    /// Hertz.
    Hz,
    /// Kelvin (a temperature difference).
    K,
    /// Volt.
    V,
    /// Ohm.
    Ohm,
    /// Part per million.
    Ppm,
    /// Part per million per kelvin.
    PpmPerK,
    /// Millimetre per minute (a feed).
    MmPerMin,
    /// Millimetre per second.
    MmPerS,
    /// ADC counts (AC LVDT input) or volts (DC input).
    CountsOrV,
    /// Encoder counts per millimetre (linear axis) or per degree (rotary axis).
    CountsPerMmOrDeg,
    /// Millimetre per second (linear axis) or degree per second (rotary axis).
    MmOrDegPerS,
}

impl Unit {
    /// Its name as users see it, ASCII (`um` for µm, `1` for a number without unit).
    pub const fn as_str(self) -> &'static str {
        match self {
            Unit::One => "1",
            Unit::Um => "um",
            Unit::Urad => "urad",
            Unit::Arcsec => "arcsec",
            Unit::Mm => "mm",
            Unit::Deg => "deg",
            Unit::UmPerM => "um/m",
            Unit::Ms => "ms",
            Unit::Us => "us",
            Unit::Samples => "samples",
            Unit::Hz => "Hz",
            Unit::K => "K",
            Unit::V => "V",
            Unit::Ohm => "ohm",
            Unit::Ppm => "ppm",
            Unit::PpmPerK => "ppm/K",
            Unit::MmPerMin => "mm/min",
            Unit::MmPerS => "mm/s",
            Unit::CountsOrV => "counts or V",
            Unit::CountsPerMmOrDeg => "counts/mm or counts/deg",
            Unit::MmOrDegPerS => "mm/s or deg/s",
        }
    }
}
