//! Validation of a whole configuration: every value in its row's range, then the rules across
//! fields (node-ID, whole excitation periods per sample, one input per axis name, the encoder
//! counters' reach); and the checked ways to change a configuration.

use super::table::{by_name, check, info};
use super::{
    AxisName, COUNTER_READS_PER_SAMPLE, Config, ConfigError, ENCODER_COUNTER_BITS, FIELDS, Field,
    FieldInfo, GLITCH_MARGIN, MAX_PERIODS_PER_SAMPLE,
};

/// An encoder input's count step between two counter reads against what the extension follows
/// ([`Config::counter_reach`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CounterReach {
    /// Counts between two reads at [`GLITCH_MARGIN`] × the maximum speed.
    pub counts_per_read: f64,
    /// The largest step the extension follows, counts (2^(bits − 1) − 1).
    pub max_counts_per_read: f64,
}

impl Config {
    /// Unit, range and name of a field.
    pub fn field_info(field: Field) -> Option<&'static FieldInfo> {
        info(field)
    }

    /// The field called `name` (as in [`FIELDS`]; `lvdt_poly`, `axis_counts` and
    /// `axis_max_speed` take the element as a suffix: `lvdt_poly2`, `axis_counts1`…), or `None`.
    pub fn field_by_name(name: &str) -> Option<Field> {
        by_name(name)
    }

    /// Excitation periods in one pod sample, `excitation_hz / sample_rate_hz` (a whole number
    /// 1…[`MAX_PERIODS_PER_SAMPLE`] in a valid configuration).
    pub fn periods_per_sample(&self) -> f64 {
        f64::from(self.excitation_hz) / f64::from(self.sample_rate_hz)
    }

    /// Validates every field; the first violation is returned.
    pub fn validate(&self) -> Result<(), ConfigError> {
        for row in FIELDS {
            for f in row.fields() {
                check(f, self.field_value(f).unwrap_or(f64::NAN))?;
            }
        }
        // a node-ID is 1–127, or 255 for none (CiA 305's "unconfigured")
        if (128..=254).contains(&self.can_node_id) {
            return Err(ConfigError::OutOfRange {
                field: Field::CanNodeId,
                value: f64::from(self.can_node_id),
                min: 1.0,
                max: 127.0,
            });
        }
        // a sample is a whole number of excitation periods that fits the ADC ring
        let periods = self.periods_per_sample();
        let max = f64::from(MAX_PERIODS_PER_SAMPLE);
        if !(periods >= 1.0 && periods <= max && periods == libm::trunc(periods)) {
            return Err(ConfigError::OutOfRange {
                field: Field::PeriodsPerSample,
                value: periods,
                min: 1.0,
                max,
            });
        }
        for (i, a) in (0u8..).zip(self.axes.iter()) {
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
        self.check_counter_reach()
    }

    /// The counter-reach rule alone ([`Config::counter_reach`] of every input that reads an
    /// axis), the first input beyond it named.
    pub fn check_counter_reach(&self) -> Result<(), ConfigError> {
        for (i, a) in (0u8..).zip(self.axes.iter()) {
            let reach = self.counter_reach(usize::from(i));
            if a.name != AxisName::Unused && !(reach.counts_per_read <= reach.max_counts_per_read) {
                return Err(ConfigError::OutOfRange {
                    field: Field::AxisCounterReach(i),
                    value: reach.counts_per_read,
                    min: 0.0,
                    max: reach.max_counts_per_read,
                });
            }
        }
        Ok(())
    }

    /// Encoder input `i`'s counts between two reads of its hardware counter at
    /// [`GLITCH_MARGIN`] × its maximum speed, and the most the count extension follows: the
    /// difference of two reads is taken modulo 2^bits as signed, so a step must stay below
    /// 2^(bits − 1) ([`ENCODER_COUNTER_BITS`], [`COUNTER_READS_PER_SAMPLE`]). A step the pod
    /// flags as a glitch is then one it measured. (Unknown input: 0 of 0.)
    pub fn counter_reach(&self, i: usize) -> CounterReach {
        let (Some(a), Some(bits)) = (self.axes.get(i), ENCODER_COUNTER_BITS.get(i)) else {
            return CounterReach::default();
        };
        let reads_per_s = f64::from(self.sample_rate_hz) * f64::from(COUNTER_READS_PER_SAMPLE);
        CounterReach {
            counts_per_read: GLITCH_MARGIN * f64::from(a.max_speed_per_s) * a.counts_per_unit
                / reads_per_s,
            max_counts_per_read: (1u64 << (bits.saturating_sub(1) & 63)) as f64 - 1.0,
        }
    }

    /// True for the fields stored as integers (a written value must be a whole number).
    pub fn is_integer_field(f: Field) -> bool {
        info(f).is_some_and(FieldInfo::is_integer)
    }

    /// Checks `v` for field `f` as a write would see it (range, whole number for an integer
    /// field, a known code for a code field, NaN only for a field that may be not set) without
    /// changing anything.
    pub fn check_write(f: Field, v: f64) -> Result<(), ConfigError> {
        check(f, v)?;
        if Self::is_integer_field(f) && v != libm::trunc(v) {
            let (min, max) = info(f).map_or((0.0, 0.0), |i| (i.min, i.max));
            return Err(ConfigError::OutOfRange {
                field: f,
                value: v,
                min,
                max,
            });
        }
        Ok(())
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

    /// Sets field `f` to `v` if the value is acceptable ([`check_write`](Self::check_write))
    /// and the whole configuration stays valid; otherwise nothing changes.
    pub fn set(&mut self, f: Field, v: f64) -> Result<(), ConfigError> {
        Self::check_write(f, v)?;
        self.try_update(|c| c.set_field(f, v))
    }
}
