//! The pod's peripherals in virtual time: the ball bar's LVDT secondaries as 12-bit ADC blocks
//! (through [`crate::lvdt_model`]), the encoders as 16-bit hardware counters, the bar
//! thermistor as an ADC code. Each sample goes through the core's
//! `ballpod::acquisition::lvdt::demodulate` and `Acquisition::sample`, as on the board.

use ballpod::acquisition::lvdt::{ExcitationTable, demodulate};
use ballpod::acquisition::thermal::bar_expansion_um;
use ballpod::acquisition::{Acquisition, MAX_AXES, Sample};
use ballpod::config::Config;
use serde::{Deserialize, Serialize};

use crate::lvdt_model::LvdtModel;
use crate::rng::Rng;

/// ADC samples per excitation period (the default configuration's DAC table).
const P: usize = 20;

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
}

impl Default for Instrument {
    fn default() -> Self {
        Self {
            bar_noise_um: 0.2,
            adc_noise_counts: 0.5,
            bar_temp_c: 20.5,
            lvdt_nonlinearity_per_um: 0.0,
            sample_rate_hz: 1000.0,
        }
    }
}

/// The simulated pod: configuration, acquisition pipeline and sensor models.
pub struct Pod {
    /// The pod's configuration (bar length set by the set-up).
    pub config: Config,
    acq: Acquisition,
    table: ExcitationTable<P>,
    lvdt: LvdtModel,
    periods: usize,
    inst: Instrument,
    rng: Rng,
    t_us: u64,
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
        let periods =
            (f64::from(config.excitation_hz) / f64::from(config.sample_rate_hz)).round() as usize;
        Self {
            config,
            acq,
            table: ExcitationTable::<P>::new(),
            lvdt: LvdtModel::default(),
            periods: periods.max(1),
            inst: *inst,
            rng: Rng::new(seed),
            t_us: 0,
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
        let expansion = f64::from(bar_expansion_um(
            self.config.bar_length_mm,
            self.config.bar_cte_ppm_per_k,
            self.inst.bar_temp_c as f32,
        ));
        let mut x = dl_um - expansion + self.inst.bar_noise_um * self.rng.normal();
        x += self.inst.lvdt_nonlinearity_per_um * x * x;
        let (a, b) = self.lvdt.block_adc(
            x,
            P,
            self.periods,
            self.inst.adc_noise_counts,
            &mut self.rng,
        );
        let reading = demodulate(&a, &b, &self.table);
        let raw = self.raw(axes);
        let s = self.acq.sample(self.t_us, reading, raw, 0, false);
        self.t_us += (1e6 / self.inst.sample_rate_hz).round() as u64;
        s
    }

    /// What the acquisition flagged or lost so far.
    pub fn counters(&self) -> ballpod::acquisition::AcquisitionCounters {
        self.acq.counters
    }
}
