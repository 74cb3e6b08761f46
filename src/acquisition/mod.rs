//! Acquisition: raw sensor readings → calibrated, validated [`Sample`]s (DESIGN §5).
//!
//! - [`lvdt`]: ratiometric synchronous demodulation, DC-input mode, calibration polynomial;
//! - [`projection`]: the demodulation's per-sample projection (M4 DSP kernel, portable twin);
//! - [`encoder`]: hardware counter → exact 64-bit count → mm / degrees, glitch detection;
//! - [`probe`]: touch-trigger latch, debounce, re-seat lock-out;
//! - [`thermal`]: thermistor → °C, bar expansion correction;
//! - [`rings`]: the two secondaries' DMA rings realigned together after an overrun;
//! - [`pipeline`]: all of the above → one flagged [`Sample`] per sample period;
//! - [`sample`]: the sample and its validity flags.

pub mod encoder;
pub mod lvdt;
pub mod pipeline;
pub mod probe;
pub mod projection;
pub mod rings;
pub mod sample;
pub mod thermal;

pub use pipeline::{Acquisition, AcquisitionCounters, periods_lost};
pub use sample::{MAX_AXES, Sample, SampleFlags};
