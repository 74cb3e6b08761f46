//! Acquisition: raw sensor readings → calibrated, validated [`Sample`]s.

pub mod sample;

pub use sample::{MAX_AXES, Sample, SampleFlags};
