//! The pod's configuration: every field with its unit, default for the reference hardware
//! (NUCLEO-G474RE, a 150 mm steel ball bar, 0.1 µm encoders), validated range and the moment
//! it takes effect, plus a versioned binary encoding with CRC-32 (persisted by
//! [`crate::settings`]). The test set-up ([`TestSetup`]: circle, seed 002, SSM, two-step and
//! probe geometry and their uncertainty budgets) is part of it, so it travels with the
//! configuration over both protocols and survives a reset.
//!
//! # Responsibilities
//!
//! - `fields`: every field declared once, one row each (wire name, storage, unit, range,
//!   default, encoding version, when it takes effect, meaning); `declare` derives the rest.
//! - `kinds`: the coded kinds (axis names, LVDT input, bit rates, plane, machine, trigger).
//! - `defaults`: the uncertainty budget's defaults and why each.
//! - `table`: the field table's row type, lookup by name, the range check.
//! - `rules`: validation of a whole configuration (ranges and the rules across fields).
//! - `encoding`: the versioned binary layout and the migration of older versions.
//!
//! # When a written value takes effect
//!
//! One rule, stated per field in its row ([`TakesEffect`], shown in the book's configuration
//! reference): a change is accepted only while no run is armed or running (the pod refuses it
//! with *busy* otherwise), so a run is measured with one configuration from ARM to its end.
//! Then
//!
//! - **next sample** — the acquisition (LVDT, encoders, thermistor, probe): [`App::configure`]
//!   hands the new configuration to the acquisition at once, keeping axis references, the
//!   sample counter, the temperature and the counters;
//! - **next run** — the test set-up and the uncertainty budget: read when a run is armed (or a
//!   procedure's step begins) and frozen with it;
//! - **reset** — [`AT_RESET`]: the sample clock, the excitation table and the ADC rings are
//!   set up at boot; written values are kept, saved and reported pending (status word bit 14);
//! - **reset communication** — the CANopen node-ID (NMT reset communication or a reset).
//!
//! Changes go through [`Config::try_update`]: the closure edits a copy, the copy is validated
//! as a whole, and only a valid copy replaces the configuration — a bad value changes nothing
//! and the error names the field and its allowed range.
//!
//! # Adding a field
//!
//! One row at the end of `fields` with the next encoding version: the member and its
//! default, the [`Field`] variant, the [`FIELDS`] row (and so its CANopen object, SCPI name,
//! EDS entry and reference row), get and set, validation and the encoding follow. The host test
//! `config_one_row` builds the crate with one more row and checks that they do.
//!
//! [`App::configure`]: ../app/struct.App.html#method.configure

#[macro_use]
mod declare;
mod defaults;
mod encoding;
mod fields;
mod kinds;
mod rules;
mod table;

pub use defaults::*;
pub use encoding::{ENCODED_LEN, ENCODED_LENS, ENCODING_VERSION, MAGIC, OLDEST_ENCODING_VERSION};
pub use fields::{AxisConfig, Config, Field, TestSetup};
pub use kinds::{AxisName, CanBitrate, CirclePlane, LvdtInput, RunTrigger, TwoStepMachine};
pub use rules::CounterReach;
use table::family;
pub use table::{FIELDS, FieldInfo, FieldType, is_set, required, required3};

/// Number of encoder axes the pod reads (X, Y, Z and two rotary axes; DESIGN §1).
pub const MAX_AXES: usize = 5;

/// Points of the excitation table per period: the pod's DAC table and the demodulation's (the
/// firmware builds both at compile time), so `samples_per_period` can only be this.
pub const EXCITATION_POINTS: u16 = 20;
/// Width of each encoder input's hardware counter, bits, in input order: TIM1, TIM3, TIM4
/// (16 bits), TIM2 and TIM5 (32 bits) on the NUCLEO-G474RE — the rotary axes' default inputs
/// (4 and 5) are the wide ones. The configuration's rule ([`Config::counter_reach`]) holds every
/// board to these, so a configuration the pod takes is one the real counters follow.
pub const ENCODER_COUNTER_BITS: [u32; MAX_AXES] = [16, 16, 16, 32, 32];
/// Times a sample the board reads the hardware counters and extends them to 64 bits (the block
/// latch at each half block: `board::lvdt::BlockLatchIsr`).
pub const COUNTER_READS_PER_SAMPLE: u32 = 2;
/// Margin on the plausible count step between two samples: a step beyond this many times the
/// step at the axis' maximum speed is a quadrature glitch (flagged, counted).
pub const GLITCH_MARGIN: f64 = 2.0;
/// Most excitation periods in one pod sample: the ADC DMA ring holds one block of
/// [`EXCITATION_POINTS`] × this samples per channel (RAM budget).
pub const MAX_PERIODS_PER_SAMPLE: u32 = 5;
/// Largest |coordinate| of a set-up position or an axis reference, mm (degrees for a rotary
/// axis's reference).
pub const POS_MM: f64 = 10_000.0;

/// When a written value takes effect (the module doc states the rule).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TakesEffect {
    /// At the next sample (the acquisition follows at once).
    NextSample,
    /// When the next run is armed (test set-up, uncertainty budget).
    NextRun,
    /// At the next reset (reported pending until then).
    Reset,
    /// At the next NMT reset communication (or reset).
    ResetCommunication,
}

impl TakesEffect {
    /// How the book's reference says it.
    pub const fn as_str(self) -> &'static str {
        match self {
            Self::NextSample => "next sample",
            Self::NextRun => "next run",
            Self::Reset => "reset",
            Self::ResetCommunication => "reset communication",
        }
    }
}

/// The fields the pod applies at its next reset ([`TakesEffect::Reset`]; the sample clock, the
/// excitation table and the ADC rings are set up at boot): written values are kept and read
/// back, saved with `*SAV` / 0x1010, and reported pending (status word bit 14) until then.
pub const AT_RESET: [Field; 3] = table::fields_taking_effect(TakesEffect::Reset);

/// Why a configuration was rejected.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ConfigError {
    /// A value outside its allowed range (or not finite, or NaN where the field must be set).
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

impl Default for TestSetup {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl Default for Config {
    fn default() -> Self {
        Self::DEFAULT
    }
}
