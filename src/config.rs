//! The pod's configuration: every field with its unit, default for the reference hardware
//! (NUCLEO-G474RE, a 150 mm steel ball bar, 0.1 µm encoders) and validated range, plus a
//! versioned binary encoding with CRC-32 (persistence to flash comes later).
//!
//! Changes go through [`Config::try_update`]: the closure edits a copy, the copy is validated
//! as a whole, and only a valid copy replaces the configuration — a bad value changes nothing
//! and the error names the field and its allowed range.
//!
//! The encoding is hand-written (little-endian, fixed layout) rather than serde + postcard: it is
//! ~150 lines, needs no derive machinery in the flash image, and its layout is the one the
//! settings slots and the CAN/USB configuration objects document.

use crate::acquisition::MAX_AXES;

/// Names of the axes the encoder inputs can be assigned to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum AxisName {
    /// Input not used.
    Unused = 0,
    /// Linear X, mm.
    X = 1,
    /// Linear Y, mm.
    Y = 2,
    /// Linear Z, mm.
    Z = 3,
    /// Rotary A (about X), degrees.
    A = 4,
    /// Rotary B (about Y), degrees.
    B = 5,
    /// Rotary C (about Z), degrees.
    C = 6,
}

impl AxisName {
    /// From its encoded byte.
    pub const fn from_u8(v: u8) -> Option<Self> {
        Some(match v {
            0 => Self::Unused,
            1 => Self::X,
            2 => Self::Y,
            3 => Self::Z,
            4 => Self::A,
            5 => Self::B,
            6 => Self::C,
            _ => return None,
        })
    }
    /// True for the rotary axes (positions in degrees); linear axes are in mm.
    pub const fn is_rotary(self) -> bool {
        matches!(self, Self::A | Self::B | Self::C)
    }
    /// The axis letter (`-` when unused).
    pub const fn letter(self) -> char {
        match self {
            Self::Unused => '-',
            Self::X => 'X',
            Self::Y => 'Y',
            Self::Z => 'Z',
            Self::A => 'A',
            Self::B => 'B',
            Self::C => 'C',
        }
    }
}

/// How the LVDT is read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum LvdtInput {
    /// The pod excites the primary and demodulates both secondaries (ratiometric).
    AcRatiometric = 0,
    /// An external conditioner delivers a DC voltage proportional to position.
    DcConditioner = 1,
}

/// CAN bit rates the pod supports, bit/s.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum CanBitrate {
    /// 125 kbit/s.
    K125 = 0,
    /// 250 kbit/s.
    K250 = 1,
    /// 500 kbit/s (default).
    K500 = 2,
    /// 1 Mbit/s.
    M1 = 3,
}

impl CanBitrate {
    /// Bit rate in bit/s.
    pub const fn bits_per_s(self) -> u32 {
        match self {
            Self::K125 => 125_000,
            Self::K250 => 250_000,
            Self::K500 => 500_000,
            Self::M1 => 1_000_000,
        }
    }
    /// From its encoded byte.
    pub const fn from_u8(v: u8) -> Option<Self> {
        Some(match v {
            0 => Self::K125,
            1 => Self::K250,
            2 => Self::K500,
            3 => Self::M1,
            _ => return None,
        })
    }
}

/// One encoder input.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisConfig {
    /// Which machine axis this input reads.
    pub name: AxisName,
    /// Counts per mm (linear) or per degree (rotary), after ×4 quadrature decoding.
    pub counts_per_unit: f64,
    /// Counting direction: true if the counter counts down in the axis' positive direction.
    pub reversed: bool,
    /// Fastest plausible axis speed, mm/s or °/s: larger count steps are quadrature glitches.
    pub max_speed_per_s: f32,
}

/// The pod's configuration (see the module doc; fields listed with unit, default and range in
/// [`FIELDS`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config {
    /// Calibrated ball-bar length at 20 °C, mm.
    pub bar_length_mm: f32,
    /// Bar thermal expansion coefficient, µm/m/K (ppm/K).
    pub bar_cte_ppm_per_k: f32,
    /// LVDT input mode.
    pub lvdt_input: LvdtInput,
    /// LVDT calibration polynomial, µm per ratio^k (k = 0…3): `x = Σ c_k r^k`.
    pub lvdt_poly_um: [f32; 4],
    /// Largest |ratio| inside the calibrated stroke (beyond: over-range).
    pub lvdt_max_abs_ratio: f32,
    /// Smallest healthy LVDT signal level, ADC counts (AC) or volts (DC); below: open.
    pub lvdt_min_signal: f32,
    /// DC mode: conditioner output at the LVDT null, V.
    pub lvdt_dc_zero_v: f32,
    /// DC mode: conditioner output change for ratio 1, V.
    pub lvdt_dc_span_v: f32,
    /// LVDT excitation frequency, Hz.
    pub excitation_hz: f32,
    /// ADC samples per excitation period (the DAC table length).
    pub samples_per_period: u16,
    /// Pod sample rate (ΔL + axes), Hz.
    pub sample_rate_hz: f32,
    /// Encoder inputs 1…5.
    pub axes: [AxisConfig; MAX_AXES],
    /// Thermistor resistance at 25 °C, Ω.
    pub thermistor_r25_ohm: f32,
    /// Thermistor β constant, K.
    pub thermistor_beta_k: f32,
    /// Divider's fixed resistor, Ω.
    pub thermistor_r_fixed_ohm: f32,
    /// Probe debounce window, µs.
    pub probe_debounce_us: u32,
    /// Time the probe must read seated before it re-arms, µs.
    pub probe_reseat_us: u32,
    /// CANopen node id (1…127).
    pub can_node_id: u8,
    /// CAN bit rate.
    pub can_bitrate: CanBitrate,
}

/// A field that can be out of range (named in [`ConfigError`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Field {
    /// [`Config::bar_length_mm`].
    BarLengthMm,
    /// [`Config::bar_cte_ppm_per_k`].
    BarCtePpmPerK,
    /// [`Config::lvdt_poly_um`] coefficient k.
    LvdtPolyUm(u8),
    /// [`Config::lvdt_max_abs_ratio`].
    LvdtMaxAbsRatio,
    /// [`Config::lvdt_min_signal`].
    LvdtMinSignal,
    /// [`Config::lvdt_dc_zero_v`].
    LvdtDcZeroV,
    /// [`Config::lvdt_dc_span_v`].
    LvdtDcSpanV,
    /// [`Config::excitation_hz`].
    ExcitationHz,
    /// [`Config::samples_per_period`].
    SamplesPerPeriod,
    /// [`Config::sample_rate_hz`].
    SampleRateHz,
    /// [`AxisConfig::counts_per_unit`] of input i.
    AxisCountsPerUnit(u8),
    /// [`AxisConfig::max_speed_per_s`] of input i.
    AxisMaxSpeed(u8),
    /// [`Config::thermistor_r25_ohm`].
    ThermistorR25Ohm,
    /// [`Config::thermistor_beta_k`].
    ThermistorBetaK,
    /// [`Config::thermistor_r_fixed_ohm`].
    ThermistorRFixedOhm,
    /// [`Config::probe_debounce_us`].
    ProbeDebounceUs,
    /// [`Config::probe_reseat_us`].
    ProbeReseatUs,
    /// [`Config::can_node_id`].
    CanNodeId,
    /// The LVDT sample rate (excitation × samples per period) exceeds what the ADCs can do.
    AdcRate,
    /// An axis name is used by two inputs.
    AxisNameDuplicate(u8),
}

/// Unit, allowed range and default of a numeric field.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldInfo {
    /// The field.
    pub field: Field,
    /// Its name as users see it (SCPI / docs).
    pub name: &'static str,
    /// Its unit.
    pub unit: &'static str,
    /// Smallest allowed value (inclusive).
    pub min: f64,
    /// Largest allowed value (inclusive).
    pub max: f64,
}

/// Largest ADC conversion rate used for the LVDT, samples/s per ADC (the G474 ADC does 4 MS/s;
/// we keep DMA and CPU load low).
pub const MAX_ADC_RATE_HZ: f64 = 500_000.0;

/// The numeric fields with unit and range (the single table that validation, documentation and
/// the protocol layers share).
pub const FIELDS: &[FieldInfo] = &[
    FieldInfo {
        field: Field::BarLengthMm,
        name: "bar_length",
        unit: "mm",
        min: 50.0,
        max: 600.0,
    },
    FieldInfo {
        field: Field::BarCtePpmPerK,
        name: "bar_cte",
        unit: "ppm/K",
        min: -5.0,
        max: 30.0,
    },
    FieldInfo {
        field: Field::LvdtPolyUm(0),
        name: "lvdt_poly",
        unit: "um",
        min: -1.0e5,
        max: 1.0e5,
    },
    FieldInfo {
        field: Field::LvdtMaxAbsRatio,
        name: "lvdt_max_ratio",
        unit: "1",
        min: 0.01,
        max: 1.0,
    },
    FieldInfo {
        field: Field::LvdtMinSignal,
        name: "lvdt_min_signal",
        unit: "counts or V",
        min: 1.0e-3,
        max: 4095.0,
    },
    FieldInfo {
        field: Field::LvdtDcZeroV,
        name: "lvdt_dc_zero",
        unit: "V",
        min: -10.0,
        max: 10.0,
    },
    FieldInfo {
        field: Field::LvdtDcSpanV,
        name: "lvdt_dc_span",
        unit: "V",
        min: 0.01,
        max: 20.0,
    },
    FieldInfo {
        field: Field::ExcitationHz,
        name: "excitation",
        unit: "Hz",
        min: 1000.0,
        max: 20000.0,
    },
    FieldInfo {
        field: Field::SamplesPerPeriod,
        name: "samples_per_period",
        unit: "1",
        min: 8.0,
        max: 64.0,
    },
    FieldInfo {
        field: Field::SampleRateHz,
        name: "sample_rate",
        unit: "Hz",
        min: 10.0,
        max: 10000.0,
    },
    FieldInfo {
        field: Field::AxisCountsPerUnit(0),
        name: "axis_counts",
        unit: "counts/mm or counts/deg",
        min: 0.1,
        max: 1.0e8,
    },
    FieldInfo {
        field: Field::AxisMaxSpeed(0),
        name: "axis_max_speed",
        unit: "mm/s or deg/s",
        min: 1.0,
        max: 10000.0,
    },
    FieldInfo {
        field: Field::ThermistorR25Ohm,
        name: "ntc_r25",
        unit: "ohm",
        min: 100.0,
        max: 1.0e6,
    },
    FieldInfo {
        field: Field::ThermistorBetaK,
        name: "ntc_beta",
        unit: "K",
        min: 1000.0,
        max: 10000.0,
    },
    FieldInfo {
        field: Field::ThermistorRFixedOhm,
        name: "ntc_r_fixed",
        unit: "ohm",
        min: 100.0,
        max: 1.0e6,
    },
    FieldInfo {
        field: Field::ProbeDebounceUs,
        name: "probe_debounce",
        unit: "us",
        min: 0.0,
        max: 100_000.0,
    },
    FieldInfo {
        field: Field::ProbeReseatUs,
        name: "probe_reseat",
        unit: "us",
        min: 0.0,
        max: 5_000_000.0,
    },
    FieldInfo {
        field: Field::CanNodeId,
        name: "can_node_id",
        unit: "1",
        min: 1.0,
        max: 127.0,
    },
];

/// Why a configuration was rejected.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ConfigError {
    /// A value outside its allowed range (or not finite).
    OutOfRange {
        /// The field.
        field: Field,
        /// The rejected value.
        value: f64,
        /// Smallest allowed value.
        min: f64,
        /// Largest allowed value.
        max: f64,
    },
    /// Two inputs name the same axis (the field names the second input).
    Duplicate {
        /// The field.
        field: Field,
    },
    /// Encoded bytes too short or too long for this version.
    BadLength {
        /// Bytes given.
        len: usize,
        /// Bytes expected.
        expected: usize,
    },
    /// The encoding does not start with the magic `BPOD`.
    BadMagic,
    /// An encoding version this firmware does not read.
    UnsupportedVersion(u16),
    /// The CRC does not match (corrupt or torn write).
    BadCrc {
        /// CRC stored in the bytes.
        stored: u32,
        /// CRC computed over them.
        computed: u32,
    },
    /// An enum byte with no meaning (axis name, input mode, bit rate); the byte offset is given.
    BadEnum {
        /// Offset of the byte in the encoding.
        offset: usize,
    },
}

impl Default for Config {
    fn default() -> Self {
        let lin = |name| AxisConfig {
            name,
            counts_per_unit: 10_000.0,
            reversed: false,
            max_speed_per_s: 1000.0,
        };
        let rot = |name| AxisConfig {
            name,
            counts_per_unit: 10_000.0,
            reversed: false,
            max_speed_per_s: 3600.0,
        };
        Self {
            bar_length_mm: 150.0,
            bar_cte_ppm_per_k: 11.5,
            lvdt_input: LvdtInput::AcRatiometric,
            // ±1 mm stroke at ratio ±0.5 (a typical half-bridge LVDT); calibrated per bar.
            lvdt_poly_um: [0.0, 2000.0, 0.0, 0.0],
            lvdt_max_abs_ratio: 0.55,
            lvdt_min_signal: 200.0,
            lvdt_dc_zero_v: 0.0,
            lvdt_dc_span_v: 10.0,
            excitation_hz: 5000.0,
            samples_per_period: 20,
            sample_rate_hz: 1000.0,
            axes: [
                lin(AxisName::X),
                lin(AxisName::Y),
                lin(AxisName::Z),
                rot(AxisName::B),
                rot(AxisName::C),
            ],
            thermistor_r25_ohm: 10_000.0,
            thermistor_beta_k: 3950.0,
            thermistor_r_fixed_ohm: 10_000.0,
            probe_debounce_us: 2_000,
            probe_reseat_us: 50_000,
            can_node_id: 16,
            can_bitrate: CanBitrate::K500,
        }
    }
}

fn info(field: Field) -> Option<&'static FieldInfo> {
    // Indexed fields share the entry of index 0.
    let key = match field {
        Field::LvdtPolyUm(_) => Field::LvdtPolyUm(0),
        Field::AxisCountsPerUnit(_) => Field::AxisCountsPerUnit(0),
        Field::AxisMaxSpeed(_) => Field::AxisMaxSpeed(0),
        f => f,
    };
    FIELDS.iter().find(|i| i.field == key)
}

/// Checks an `f32` field: the limits are rounded to `f32` first, so that a limit such as 0.01,
/// which has no exact binary value, can itself be written (0.01f32 < 0.01f64).
fn check_f32(field: Field, value: f32) -> Result<(), ConfigError> {
    let (min, max) = info(field).map_or((f64::NEG_INFINITY, f64::INFINITY), |i| (i.min, i.max));
    let (min32, max32) = (min as f32, max as f32);
    if value.is_finite() && value >= min32 && value <= max32 {
        Ok(())
    } else {
        Err(ConfigError::OutOfRange {
            field,
            value: f64::from(value),
            min,
            max,
        })
    }
}

/// Checks one value against its table range.
fn check(field: Field, value: f64) -> Result<(), ConfigError> {
    let (min, max) = info(field).map_or((f64::NEG_INFINITY, f64::INFINITY), |i| (i.min, i.max));
    if value.is_finite() && value >= min && value <= max {
        Ok(())
    } else {
        Err(ConfigError::OutOfRange {
            field,
            value,
            min,
            max,
        })
    }
}

impl Config {
    /// Unit, range and name of a field.
    pub fn field_info(field: Field) -> Option<&'static FieldInfo> {
        info(field)
    }

    /// Validates every field; the first violation is returned.
    pub fn validate(&self) -> Result<(), ConfigError> {
        check_f32(Field::BarLengthMm, self.bar_length_mm)?;
        check_f32(Field::BarCtePpmPerK, self.bar_cte_ppm_per_k)?;
        for (k, &c) in (0u8..).zip(self.lvdt_poly_um.iter()) {
            check_f32(Field::LvdtPolyUm(k), c)?;
        }
        check_f32(Field::LvdtMaxAbsRatio, self.lvdt_max_abs_ratio)?;
        check_f32(Field::LvdtMinSignal, self.lvdt_min_signal)?;
        check_f32(Field::LvdtDcZeroV, self.lvdt_dc_zero_v)?;
        check_f32(Field::LvdtDcSpanV, self.lvdt_dc_span_v)?;
        check_f32(Field::ExcitationHz, self.excitation_hz)?;
        check(Field::SamplesPerPeriod, f64::from(self.samples_per_period))?;
        let adc_rate = f64::from(self.excitation_hz) * f64::from(self.samples_per_period);
        if adc_rate > MAX_ADC_RATE_HZ {
            return Err(ConfigError::OutOfRange {
                field: Field::AdcRate,
                value: adc_rate,
                min: 0.0,
                max: MAX_ADC_RATE_HZ,
            });
        }
        check_f32(Field::SampleRateHz, self.sample_rate_hz)?;
        for (i, a) in (0u8..).zip(self.axes.iter()) {
            check(Field::AxisCountsPerUnit(i), a.counts_per_unit)?;
            check_f32(Field::AxisMaxSpeed(i), a.max_speed_per_s)?;
            let dup = a.name != AxisName::Unused
                && self
                    .axes
                    .iter()
                    .take(usize::from(i))
                    .any(|b| b.name == a.name);
            if dup {
                return Err(ConfigError::Duplicate {
                    field: Field::AxisNameDuplicate(i),
                });
            }
        }
        check_f32(Field::ThermistorR25Ohm, self.thermistor_r25_ohm)?;
        check_f32(Field::ThermistorBetaK, self.thermistor_beta_k)?;
        check_f32(Field::ThermistorRFixedOhm, self.thermistor_r_fixed_ohm)?;
        check(Field::ProbeDebounceUs, f64::from(self.probe_debounce_us))?;
        check(Field::ProbeReseatUs, f64::from(self.probe_reseat_us))?;
        check(Field::CanNodeId, f64::from(self.can_node_id))?;
        Ok(())
    }

    /// A numeric field's value as `f64` in its unit (`None` for [`Field`]s with no storage).
    /// The one accessor the protocol layers (CANopen objects, SCPI `CONFigure`) share.
    pub fn field_value(&self, f: Field) -> Option<f64> {
        let axis = |i: u8| self.axes.get(usize::from(i));
        Some(match f {
            Field::BarLengthMm => f64::from(self.bar_length_mm),
            Field::BarCtePpmPerK => f64::from(self.bar_cte_ppm_per_k),
            Field::LvdtPolyUm(k) => f64::from(*self.lvdt_poly_um.get(usize::from(k))?),
            Field::LvdtMaxAbsRatio => f64::from(self.lvdt_max_abs_ratio),
            Field::LvdtMinSignal => f64::from(self.lvdt_min_signal),
            Field::LvdtDcZeroV => f64::from(self.lvdt_dc_zero_v),
            Field::LvdtDcSpanV => f64::from(self.lvdt_dc_span_v),
            Field::ExcitationHz => f64::from(self.excitation_hz),
            Field::SamplesPerPeriod => f64::from(self.samples_per_period),
            Field::SampleRateHz => f64::from(self.sample_rate_hz),
            Field::AxisCountsPerUnit(i) => axis(i)?.counts_per_unit,
            Field::AxisMaxSpeed(i) => f64::from(axis(i)?.max_speed_per_s),
            Field::ThermistorR25Ohm => f64::from(self.thermistor_r25_ohm),
            Field::ThermistorBetaK => f64::from(self.thermistor_beta_k),
            Field::ThermistorRFixedOhm => f64::from(self.thermistor_r_fixed_ohm),
            Field::ProbeDebounceUs => f64::from(self.probe_debounce_us),
            Field::ProbeReseatUs => f64::from(self.probe_reseat_us),
            Field::CanNodeId => f64::from(self.can_node_id),
            Field::AdcRate | Field::AxisNameDuplicate(_) => return None,
        })
    }

    /// True for the fields stored as integers (a written value is rounded to the nearest).
    pub const fn is_integer_field(f: Field) -> bool {
        matches!(
            f,
            Field::SamplesPerPeriod
                | Field::ProbeDebounceUs
                | Field::ProbeReseatUs
                | Field::CanNodeId
        )
    }

    /// Sets a numeric field from `v` in its unit: `f32` fields take the nearest `f32`, integer
    /// fields the nearest integer (saturating), `counts_per_unit` the `f64` as is. No range
    /// check here: use it inside [`Config::try_update`], which validates the result (the `f32`
    /// limits are compared rounded to `f32`, so every value the table allows can be set).
    pub fn set_field(&mut self, f: Field, v: f64) {
        let x = v as f32;
        let int = libm::round(v);
        match f {
            Field::BarLengthMm => self.bar_length_mm = x,
            Field::BarCtePpmPerK => self.bar_cte_ppm_per_k = x,
            Field::LvdtPolyUm(k) => {
                if let Some(p) = self.lvdt_poly_um.get_mut(usize::from(k)) {
                    *p = x;
                }
            }
            Field::LvdtMaxAbsRatio => self.lvdt_max_abs_ratio = x,
            Field::LvdtMinSignal => self.lvdt_min_signal = x,
            Field::LvdtDcZeroV => self.lvdt_dc_zero_v = x,
            Field::LvdtDcSpanV => self.lvdt_dc_span_v = x,
            Field::ExcitationHz => self.excitation_hz = x,
            Field::SamplesPerPeriod => self.samples_per_period = int as u16,
            Field::SampleRateHz => self.sample_rate_hz = x,
            Field::AxisCountsPerUnit(i) => {
                if let Some(a) = self.axes.get_mut(usize::from(i)) {
                    a.counts_per_unit = v;
                }
            }
            Field::AxisMaxSpeed(i) => {
                if let Some(a) = self.axes.get_mut(usize::from(i)) {
                    a.max_speed_per_s = x;
                }
            }
            Field::ThermistorR25Ohm => self.thermistor_r25_ohm = x,
            Field::ThermistorBetaK => self.thermistor_beta_k = x,
            Field::ThermistorRFixedOhm => self.thermistor_r_fixed_ohm = x,
            Field::ProbeDebounceUs => self.probe_debounce_us = int as u32,
            Field::ProbeReseatUs => self.probe_reseat_us = int as u32,
            Field::CanNodeId => self.can_node_id = int as u8,
            Field::AdcRate | Field::AxisNameDuplicate(_) => {}
        }
    }

    /// Applies `edit` to a copy and keeps it only if the whole copy is valid; on error the
    /// configuration is unchanged.
    pub fn try_update(&mut self, edit: impl FnOnce(&mut Config)) -> Result<(), ConfigError> {
        let mut next = *self;
        edit(&mut next);
        next.validate()?;
        *self = next;
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// Binary encoding
// ---------------------------------------------------------------------------------------------

/// Magic at the start of an encoded configuration.
pub const MAGIC: [u8; 4] = *b"BPOD";
/// Current encoding version.
pub const ENCODING_VERSION: u16 = 1;
/// Bytes of one encoded axis: name u8, reversed u8, counts_per_unit f64, max_speed f32.
const AXIS_BYTES: usize = 1 + 1 + 8 + 4;
/// Payload bytes of version 1 (see [`Config::encode`] for the layout).
const PAYLOAD_V1: usize =
    4 * 2 + 1 + 4 * 4 + 4 * 4 + 4 + 2 + 4 + MAX_AXES * AXIS_BYTES + 4 * 3 + 4 * 2 + 1 + 1;
/// Total encoded size: magic, version u16, payload length u16, payload, CRC-32.
pub const ENCODED_LEN: usize = 4 + 2 + 2 + PAYLOAD_V1 + 4;

/// Little-endian writer over a fixed buffer (never writes past its end).
struct Writer<'a> {
    buf: &'a mut [u8],
    pos: usize,
}

impl Writer<'_> {
    fn put(&mut self, bytes: &[u8]) {
        if let Some(dst) = self.buf.get_mut(self.pos..self.pos + bytes.len()) {
            dst.copy_from_slice(bytes);
        }
        self.pos += bytes.len();
    }
}

/// Little-endian reader (returns zeros past the end; lengths are checked before reading).
struct Reader<'a> {
    buf: &'a [u8],
    pos: usize,
}

impl Reader<'_> {
    fn take<const K: usize>(&mut self) -> [u8; K] {
        let mut out = [0u8; K];
        if let Some(src) = self.buf.get(self.pos..self.pos + K) {
            out.copy_from_slice(src);
        }
        self.pos += K;
        out
    }
    fn f32(&mut self) -> f32 {
        f32::from_le_bytes(self.take())
    }
    fn f64(&mut self) -> f64 {
        f64::from_le_bytes(self.take())
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }
    fn u16(&mut self) -> u16 {
        u16::from_le_bytes(self.take())
    }
    fn u8(&mut self) -> u8 {
        self.take::<1>()[0]
    }
}

impl Config {
    /// Encodes into `out` (which must hold [`ENCODED_LEN`] bytes; returns the bytes written or
    /// `BadLength`). Layout: `"BPOD"`, version u16, payload length u16, payload (fields in
    /// declaration order, little-endian, enums as u8, bools as 0/1), CRC-32/ISO-HDLC of
    /// everything before it.
    pub fn encode(&self, out: &mut [u8]) -> Result<usize, ConfigError> {
        if out.len() < ENCODED_LEN {
            return Err(ConfigError::BadLength {
                len: out.len(),
                expected: ENCODED_LEN,
            });
        }
        let mut w = Writer { buf: out, pos: 0 };
        w.put(&MAGIC);
        w.put(&ENCODING_VERSION.to_le_bytes());
        w.put(&(PAYLOAD_V1 as u16).to_le_bytes());
        w.put(&self.bar_length_mm.to_le_bytes());
        w.put(&self.bar_cte_ppm_per_k.to_le_bytes());
        w.put(&[self.lvdt_input as u8]);
        for c in self.lvdt_poly_um {
            w.put(&c.to_le_bytes());
        }
        for v in [
            self.lvdt_max_abs_ratio,
            self.lvdt_min_signal,
            self.lvdt_dc_zero_v,
            self.lvdt_dc_span_v,
        ] {
            w.put(&v.to_le_bytes());
        }
        w.put(&self.excitation_hz.to_le_bytes());
        w.put(&self.samples_per_period.to_le_bytes());
        w.put(&self.sample_rate_hz.to_le_bytes());
        for a in &self.axes {
            w.put(&[a.name as u8, u8::from(a.reversed)]);
            w.put(&a.counts_per_unit.to_le_bytes());
            w.put(&a.max_speed_per_s.to_le_bytes());
        }
        for v in [
            self.thermistor_r25_ohm,
            self.thermistor_beta_k,
            self.thermistor_r_fixed_ohm,
        ] {
            w.put(&v.to_le_bytes());
        }
        w.put(&self.probe_debounce_us.to_le_bytes());
        w.put(&self.probe_reseat_us.to_le_bytes());
        w.put(&[self.can_node_id, self.can_bitrate as u8]);
        let crc_end = w.pos;
        let crc = out.get(..crc_end).map_or(0, crate::num::crc32);
        let mut w = Writer {
            buf: out,
            pos: crc_end,
        };
        w.put(&crc.to_le_bytes());
        Ok(w.pos)
    }

    /// Decodes and validates an encoding. Every check (length, magic, version, CRC, enum
    /// bytes, ranges) must pass; otherwise the error says which failed and nothing is returned.
    pub fn decode(bytes: &[u8]) -> Result<Config, ConfigError> {
        if bytes.len() != ENCODED_LEN {
            return Err(ConfigError::BadLength {
                len: bytes.len(),
                expected: ENCODED_LEN,
            });
        }
        let mut r = Reader { buf: bytes, pos: 0 };
        if r.take::<4>() != MAGIC {
            return Err(ConfigError::BadMagic);
        }
        let version = r.u16();
        if version != ENCODING_VERSION {
            return Err(ConfigError::UnsupportedVersion(version));
        }
        let payload = usize::from(r.u16());
        if payload != PAYLOAD_V1 {
            return Err(ConfigError::BadLength {
                len: payload,
                expected: PAYLOAD_V1,
            });
        }
        let crc_at = ENCODED_LEN - 4;
        let computed = bytes.get(..crc_at).map_or(0, crate::num::crc32);
        let stored = bytes
            .get(crc_at..)
            .and_then(|s| s.try_into().ok())
            .map_or(0, u32::from_le_bytes);
        if stored != computed {
            return Err(ConfigError::BadCrc { stored, computed });
        }
        let mut c = Config {
            bar_length_mm: r.f32(),
            bar_cte_ppm_per_k: r.f32(),
            ..Config::default()
        };
        let at = r.pos;
        c.lvdt_input = match r.u8() {
            0 => LvdtInput::AcRatiometric,
            1 => LvdtInput::DcConditioner,
            _ => return Err(ConfigError::BadEnum { offset: at }),
        };
        for p in c.lvdt_poly_um.iter_mut() {
            *p = r.f32();
        }
        c.lvdt_max_abs_ratio = r.f32();
        c.lvdt_min_signal = r.f32();
        c.lvdt_dc_zero_v = r.f32();
        c.lvdt_dc_span_v = r.f32();
        c.excitation_hz = r.f32();
        c.samples_per_period = r.u16();
        c.sample_rate_hz = r.f32();
        for a in c.axes.iter_mut() {
            let at = r.pos;
            a.name = AxisName::from_u8(r.u8()).ok_or(ConfigError::BadEnum { offset: at })?;
            a.reversed = match r.u8() {
                0 => false,
                1 => true,
                _ => return Err(ConfigError::BadEnum { offset: at + 1 }),
            };
            a.counts_per_unit = r.f64();
            a.max_speed_per_s = r.f32();
        }
        c.thermistor_r25_ohm = r.f32();
        c.thermistor_beta_k = r.f32();
        c.thermistor_r_fixed_ohm = r.f32();
        c.probe_debounce_us = r.u32();
        c.probe_reseat_us = r.u32();
        c.can_node_id = r.u8();
        let at = r.pos;
        c.can_bitrate = CanBitrate::from_u8(r.u8()).ok_or(ConfigError::BadEnum { offset: at })?;
        c.validate()?;
        Ok(c)
    }
}
