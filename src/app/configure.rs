//! Changing the configuration: validated as a whole, between runs only; the acquisition follows
//! at once, the [`AT_RESET`](crate::config::AT_RESET) fields at the next reset (the rule:
//! [`crate::config`]).

use super::AxisMap;
use super::{App, CommandError};
use crate::config::{Config, Field};

impl App {
    /// Changes the configuration (not while a run is armed or running): `edit` works on a copy,
    /// which replaces the configuration only if it is valid. The acquisition follows at once,
    /// keeping the axis references, sample counter, temperature and counters.
    pub fn configure(&mut self, edit: impl FnOnce(&mut Config)) -> Result<(), CommandError> {
        if !self.idle() {
            return self.refuse(CommandError::Busy);
        }
        let mut next = self.config;
        if let Err(e) = next.try_update(edit) {
            return self.refuse(CommandError::Config(e));
        }
        // until the reset the counters are read at the sample rate the pod runs with: the
        // counter-reach rule holds there too
        if let Err(e) = self.running(next).check_counter_reach() {
            return self.refuse(CommandError::Config(e));
        }
        self.apply_config(next);
        Ok(())
    }

    /// Sets one numeric field ([`Config::set`]: range, whole numbers, codes) — the common case
    /// of [`configure`](Self::configure).
    pub fn set_field(&mut self, f: Field, v: f64) -> Result<(), CommandError> {
        if let Err(e) = Config::check_write(f, v) {
            return self.refuse(CommandError::Config(e));
        }
        self.configure(|c| c.set_field(f, v))
    }

    pub(super) fn apply_config(&mut self, next: Config) {
        if next.lvdt_input != self.config.lvdt_input {
            self.lvdt_input_change = Some(next.lvdt_input);
        }
        self.config = next;
        let running = self.running_config();
        self.acq.reconfigure(&running, self.counter_bits);
        self.axes = AxisMap::new(&next);
        self.update_status();
    }

    /// True when an [`AT_RESET`](crate::config::AT_RESET) field differs from the value the pod
    /// runs with (status word bit 14).
    pub fn reset_pending(&self) -> bool {
        let c = &self.config;
        (c.excitation_hz, c.samples_per_period, c.sample_rate_hz) != self.boot
    }

    /// The configuration the pod runs with: [`config`](Self::config) with the
    /// [`AT_RESET`](crate::config::AT_RESET) fields as they were at start.
    pub fn running_config(&self) -> Config {
        self.running(self.config)
    }

    /// `config` with the [`AT_RESET`](crate::config::AT_RESET) fields the pod started with.
    pub(super) fn running(&self, config: Config) -> Config {
        let (excitation_hz, samples_per_period, sample_rate_hz) = self.boot;
        Config {
            excitation_hz,
            samples_per_period,
            sample_rate_hz,
            ..config
        }
    }
}
