//! Bar temperature: NTC thermistor → °C, and the bar's thermal-expansion correction of ΔL.

/// Reference temperature of all lengths, °C (ISO 1).
pub const REFERENCE_TEMP_C: f32 = 20.0;

/// An NTC thermistor in a voltage divider read by a 12-bit ADC: the fixed resistor from the
/// reference voltage to the ADC pin, the thermistor from the pin to ground, so
/// `R_ntc = R_fixed · code / (full_scale − code)`. Temperature from the β equation
/// `1/T = 1/T0 + ln(R/R0)/β` (T in kelvin).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Thermistor {
    /// Thermistor resistance at `t0_c`, Ω.
    pub r0_ohm: f32,
    /// Temperature of `r0_ohm`, °C (usually 25).
    pub t0_c: f32,
    /// β constant, K.
    pub beta_k: f32,
    /// Fixed divider resistor, Ω.
    pub r_fixed_ohm: f32,
    /// Lowest plausible bar temperature, °C (below: a fault).
    pub min_c: f32,
    /// Highest plausible bar temperature, °C (above: a fault).
    pub max_c: f32,
}

/// Why a temperature reading is not usable.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ThermistorFault {
    /// The ADC reads full scale: the thermistor is open (or unplugged).
    Open,
    /// The ADC reads zero: the thermistor is shorted.
    Short,
    /// A temperature outside the plausible range.
    OutOfRange,
}

impl Thermistor {
    /// Temperature in °C of an ADC code (0…`full_scale`).
    pub fn temperature_c(&self, code: u16, full_scale: u16) -> Result<f32, ThermistorFault> {
        if code == 0 {
            return Err(ThermistorFault::Short);
        }
        if code >= full_scale {
            return Err(ThermistorFault::Open);
        }
        let r = self.r_fixed_ohm * f32::from(code) / f32::from(full_scale - code);
        let inv_t = 1.0 / (self.t0_c + 273.15) + libm::logf(r / self.r0_ohm) / self.beta_k;
        let t = 1.0 / inv_t - 273.15;
        if t.is_finite() && (self.min_c..=self.max_c).contains(&t) {
            Ok(t)
        } else {
            Err(ThermistorFault::OutOfRange)
        }
    }
}

/// The bar's thermal correction, µm, to be **added** to the LVDT displacement to obtain ΔL
/// (DESIGN §7).
///
/// The LVDT reads the ball-to-ball distance minus the bar body's length. When the body is at
/// `temp_c` ≠ 20 °C it is longer by `L · CTE · (T − 20 °C)`, so the LVDT reads that much less
/// for the same distance; adding it back refers ΔL to the bar at 20 °C.
/// `bar_length_mm` in mm, `cte_ppm_per_k` in µm/m/K, `temp_c` in °C.
pub fn bar_expansion_um(bar_length_mm: f32, cte_ppm_per_k: f32, temp_c: f32) -> f32 {
    // mm · (µm/m/K) · K = mm · 1e-6 · K⁻¹ · K · 1e3 µm/mm → L[mm]·CTE[ppm/K]·ΔT[K]·1e-3 µm
    bar_length_mm * cte_ppm_per_k * (temp_c - REFERENCE_TEMP_C) * 1e-3
}
