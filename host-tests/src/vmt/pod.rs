//! The pod's peripherals in virtual time: the ball bar's LVDT secondaries as 12-bit ADC blocks
//! (through [`crate::lvdt_model`]), the encoders as 16-bit hardware counters, the bar
//! thermistor as an ADC code. Each sample goes through the core's
//! `ballpod::acquisition::lvdt::demodulate` and `Acquisition::sample`, as on the board.
//!
//! Fault injection ([`SensorFaults`], [`Pod::lose_samples`], [`Pod::thermistor_code`],
//! [`Pod::probe_edge`], [`Pod::set_probe_seated`]) makes the peripherals misbehave the way the
//! hardware does: an open LVDT coil, a core beyond its stroke, a ball that left its socket, an
//! encoder glitch, ADC blocks lost to a queue overrun, a thermistor open or shorted, probe
//! contact bounce.

use ballpod::acquisition::probe::TriggerOutcome;
use ballpod::acquisition::thermal::{ThermistorFault, bar_expansion_um};
use ballpod::acquisition::{Acquisition, MAX_AXES, Sample};
use ballpod::config::Config;
use serde::{Deserialize, Serialize};

use super::lvdt_channel::LvdtChannel;
use crate::rng::Rng;

/// Instrument faults and noise of the simulated pod.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Instrument {
    /// Bar (LVDT) noise σ per sample, µm (white, added to the core displacement).
    pub bar_noise_um: f64,
    /// ADC noise σ per ADC sample, counts.
    pub adc_noise_counts: f64,
    /// Bar temperature, °C (the LVDT sees the bar body's expansion, the pod corrects it).
    pub bar_temp_c: f64,
    /// Quadratic LVDT non-linearity: the LVDT reads x + k·x², k in 1/µm.
    pub lvdt_nonlinearity_per_um: f64,
    /// Sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Bar temperature change during a run, °C per minute from `bar_temp_c` at the pod's
    /// start (the thermistor follows: its code is fed to the acquisition every 100 ms).
    pub bar_temp_drift_c_per_min: f64,
    /// The thermistor is not in contact with the bar (a fault): it keeps reading `bar_temp_c`
    /// while the bar drifts, so the pod does not correct the drift.
    pub thermistor_detached: bool,
    /// Touch-trigger probe pre-travel, µm: the stylus travels this far past contact before the
    /// probe switches (the latched point lies this much inside the surface).
    pub probe_pretravel_um: f64,
    /// Touch-trigger probe repeatability σ, µm (along the approach, per touch).
    pub probe_repeatability_um: f64,
    /// Contact-bounce edges after each trigger (within the debounce time).
    pub probe_bounces: u32,
}

impl Default for Instrument {
    fn default() -> Self {
        Self {
            bar_noise_um: 0.2,
            adc_noise_counts: 0.5,
            bar_temp_c: 20.5,
            lvdt_nonlinearity_per_um: 0.0,
            sample_rate_hz: 1000.0,
            bar_temp_drift_c_per_min: 0.0,
            thermistor_detached: false,
            probe_pretravel_um: 0.0,
            probe_repeatability_um: 0.0,
            probe_bounces: 0,
        }
    }
}

/// LVDT core displacement of an over-range fault, µm: beyond the default calibration's stroke
/// (ratio 0.55 × 2000 µm = 1100 µm), so the demodulated ratio is out of range.
pub const OVER_RANGE_UM: f64 = 1600.0;

/// Sensor faults on the next samples (set the fields; each counts down as samples are made).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SensorFaults {
    /// Samples left with the LVDT coil open: the secondaries carry only ADC noise.
    pub lvdt_open_samples: u32,
    /// Samples left with the LVDT core beyond its stroke ([`OVER_RANGE_UM`]).
    pub lvdt_over_range_samples: u32,
    /// Change of the bar length from now on, µm (a ball that left its socket and sits beside it).
    pub bar_offset_um: f64,
    /// Counts added to encoder 1's hardware counter on the next sample only (a spike of
    /// miscounted edges; the following read is right again).
    pub encoder_glitch_counts: i64,
}

/// The simulated pod: configuration, acquisition pipeline and sensor models.
pub struct Pod {
    /// The pod's configuration (bar length set by the set-up).
    pub config: Config,
    acq: Acquisition,
    lvdt: LvdtChannel,
    inst: Instrument,
    rng: Rng,
    t_us: u64,
    /// Faults on the next samples.
    pub faults: SensorFaults,
    /// Items lost upstream so far (the queues' overrun counter the acquisition reads).
    lost_total: u32,
    /// A probe trigger was accepted since the last sample.
    probe_event: bool,
    /// The probe stylus is seated (the input level polled each sample).
    probe_seated: bool,
    /// The encoder positions of the last sample, mm / degrees.
    last_axes: [f64; MAX_AXES],
    /// The thermistor ADC code of the bar temperature.
    good_code: u16,
}

/// Encoder counts per mm or degree of the default configuration.
fn counts_per_unit(cfg: &Config, axis: usize) -> f64 {
    cfg.axes.get(axis).map(|a| a.counts_per_unit).unwrap_or(1.0)
}

impl Pod {
    /// A pod with a bar of `bar_length_mm`, the instrument `inst` and noise seed `seed`.
    pub fn new(bar_length_mm: f64, inst: &Instrument, seed: u64) -> Self {
        let config = Config {
            bar_length_mm: bar_length_mm as f32,
            sample_rate_hz: inst.sample_rate_hz as f32,
            ..Config::default()
        };
        let mut acq = Acquisition::new(&config, [16; MAX_AXES]);
        let r = f64::from(config.thermistor_r25_ohm)
            * (f64::from(config.thermistor_beta_k)
                * (1.0 / (inst.bar_temp_c + 273.15) - 1.0 / 298.15))
                .exp();
        let code = (4095.0 * r / (r + f64::from(config.thermistor_r_fixed_ohm))).round() as u16;
        // a fault here shows up as TEMPERATURE_FAULT flags on the samples
        let _ = acq.update_temperature(code);
        let good_code = code;
        Self {
            config,
            acq,
            lvdt: LvdtChannel::new(&config),
            inst: *inst,
            rng: Rng::new(seed),
            t_us: 0,
            faults: SensorFaults::default(),
            lost_total: 0,
            probe_event: false,
            probe_seated: true,
            last_axes: [0.0; MAX_AXES],
            good_code,
        }
    }

    fn raw(&self, axes: &[f64; MAX_AXES]) -> [u32; MAX_AXES] {
        let mut raw = [0u32; MAX_AXES];
        for (i, (r, p)) in raw.iter_mut().zip(axes).enumerate() {
            let c = (p * counts_per_unit(&self.config, i)).round() as i64;
            *r = c.rem_euclid(1 << 16) as u32;
        }
        raw
    }

    /// Homes the encoders at `axes` (mm / degrees) before a run: the counters start there.
    pub fn reference(&mut self, axes: &[f64; MAX_AXES]) {
        let q: [f64; MAX_AXES] = std::array::from_fn(|i| {
            (axes[i] * counts_per_unit(&self.config, i)).round() / counts_per_unit(&self.config, i)
        });
        let raw = self.raw(axes);
        self.acq.reference_axes(raw, q);
    }

    /// One sample: the true bar-length deviation `dl_um` (ball distance − L_B, µm) and the axis
    /// positions `axes` the encoders read (mm / degrees). Advances virtual time by one period.
    pub fn sample(&mut self, dl_um: f64, axes: &[f64; MAX_AXES]) -> Sample {
        let temp_c = self.bar_temp_now_c();
        if self.inst.bar_temp_drift_c_per_min != 0.0
            && !self.inst.thermistor_detached
            && self.t_us.is_multiple_of(100_000)
        {
            // the thermistor task's read every 100 ms
            let code = self.thermistor_code_of(temp_c);
            let _ = self.acq.update_temperature(code);
        }
        let expansion = f64::from(bar_expansion_um(
            self.config.bar_length_mm,
            self.config.bar_cte_ppm_per_k,
            temp_c as f32,
        ));
        let f = &mut self.faults;
        let mut x =
            dl_um + f.bar_offset_um - expansion + self.inst.bar_noise_um * self.rng.normal();
        x += self.inst.lvdt_nonlinearity_per_um * x * x;
        let mut lvdt = self.lvdt.model;
        if f.lvdt_open_samples > 0 {
            f.lvdt_open_samples -= 1;
            lvdt.amplitude_sum = 0.0;
        } else if f.lvdt_over_range_samples > 0 {
            f.lvdt_over_range_samples -= 1;
            x = OVER_RANGE_UM;
        }
        let reading = self
            .lvdt
            .read_with(&lvdt, x, self.inst.adc_noise_counts, &mut self.rng);
        let glitch = std::mem::take(&mut f.encoder_glitch_counts);
        let mut raw = self.raw(axes);
        if glitch != 0 {
            raw[0] = (i64::from(raw[0]) + glitch).rem_euclid(1 << 16) as u32;
        }
        self.acq.probe.poll(self.t_us, self.probe_seated);
        let probe_event = std::mem::take(&mut self.probe_event);
        let s = self
            .acq
            .sample(self.t_us, reading, raw, self.lost_total, probe_event);
        self.last_axes = *axes;
        self.t_us += self.period_us();
        s
    }

    /// The bar's true temperature now, °C (`bar_temp_c` plus the drift since the pod started).
    pub fn bar_temp_now_c(&self) -> f64 {
        self.inst.bar_temp_c + self.inst.bar_temp_drift_c_per_min * self.t_us as f64 / 60e6
    }

    /// The thermistor ADC code (12-bit) of a bar at `temp_c` (°C): the β equation and the
    /// divider of the configuration.
    pub fn thermistor_code_of(&self, temp_c: f64) -> u16 {
        let c = &self.config;
        let r = f64::from(c.thermistor_r25_ohm)
            * (f64::from(c.thermistor_beta_k) * (1.0 / (temp_c + 273.15) - 1.0 / 298.15)).exp();
        (4095.0 * r / (r + f64::from(c.thermistor_r_fixed_ohm))).round() as u16
    }

    fn period_us(&self) -> u64 {
        (1e6 / self.inst.sample_rate_hz).round() as u64
    }

    /// The next `n` sample periods' ADC blocks are lost upstream (a queue overrun): virtual time
    /// advances, the overrun counter grows by `n`, and the next sample carries `OVERRUN`.
    pub fn lose_samples(&mut self, n: u32) {
        self.lost_total = self.lost_total.wrapping_add(n);
        self.t_us += self.period_us() * u64::from(n);
    }

    /// Feeds a thermistor ADC code (12-bit; 0 = shorted, 4095 = open) to the acquisition, as
    /// the thermistor task does every 100 ms.
    pub fn thermistor_code(&mut self, code: u16) -> Result<f32, ThermistorFault> {
        self.acq.update_temperature(code)
    }

    /// The thermistor ADC code of the bar's true temperature.
    pub fn thermistor_good_code(&self) -> u16 {
        self.good_code
    }

    /// A probe trigger edge now, the encoders latched at the last sample's positions; an
    /// accepted touch flags the next sample `PROBE_EVENT`.
    pub fn probe_edge(&mut self) -> TriggerOutcome {
        let raw = self.raw(&self.last_axes);
        let o = self.acq.probe_trigger(self.t_us, raw);
        if matches!(o, TriggerOutcome::Accepted(_)) {
            self.probe_event = true;
        }
        o
    }

    /// A probe trigger edge between samples, the encoders latched at `axes` (mm / degrees:
    /// where the machine is at the edge — the EXTI interrupt latches the counters there, not
    /// at the last sample); an accepted touch flags the next sample `PROBE_EVENT`.
    pub fn probe_edge_at(&mut self, axes: &[f64; MAX_AXES]) -> TriggerOutcome {
        let raw = self.raw(axes);
        let o = self.acq.probe_trigger(self.t_us, raw);
        if matches!(o, TriggerOutcome::Accepted(_)) {
            self.probe_event = true;
        }
        o
    }

    /// The positions (mm / degrees) of a latch's counts, as the pod converts them.
    pub fn latch_positions(
        &self,
        latch: &ballpod::acquisition::probe::ProbeLatch,
    ) -> [f32; MAX_AXES] {
        self.acq.positions(&latch.counts)
    }

    /// The probe stylus level from the next sample on (`true` = seated, at rest).
    pub fn set_probe_seated(&mut self, seated: bool) {
        self.probe_seated = seated;
    }

    /// The probe debouncer's counters: (accepted, bounces, not re-seated).
    pub fn probe_counts(&self) -> (u32, u32, u32) {
        let p = &self.acq.probe;
        (p.accepted, p.bounces, p.not_reseated)
    }

    /// Virtual time of the next sample, µs.
    pub fn t_us(&self) -> u64 {
        self.t_us
    }

    /// What the acquisition flagged or lost so far.
    pub fn counters(&self) -> ballpod::acquisition::AcquisitionCounters {
        self.acq.counters
    }
}
