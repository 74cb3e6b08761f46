//! The simulated pod's sensor model: its peripherals in virtual time. The ball bar's LVDT
//! secondaries become 12-bit ADC blocks (through [`crate::lvdt_model`], demodulated by the core's
//! `ballpod::acquisition::lvdt::demodulate` as the board's LVDT task does), the encoders 16-bit
//! hardware counters, the bar thermistor an ADC code, the touch probe an edge with the counters
//! latched. What a sample period delivers is a [`Readings`]: the application
//! (`ballpod::app::App::on_raw_sample`) does the rest, with its own configuration.
//!
//! Fault injection ([`SensorFaults`], [`Sensors::lose_samples`], the thermistor code and probe
//! level the caller hands the application) makes the peripherals misbehave the way the
//! hardware does: an open LVDT coil, a core beyond its stroke, a ball that left its socket, an
//! encoder glitch, ADC blocks lost to a queue overrun, a thermistor open or shorted, probe
//! contact bounce.

use ballpod::acquisition::MAX_AXES;
use ballpod::acquisition::lvdt::{DemodError, LvdtReading};
use ballpod::acquisition::thermal::bar_expansion_um;
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
    /// Touch-probe lobing across the stylus, µm: the amplitude of the three-lobe (cos 3φ)
    /// harmonic of a kinematic probe's pre-travel, which grows as 1/cos of the direction's
    /// angle from the middle of its lobe (three seats: 1 to 2 times its least, harmonics
    /// 3, 6, 9, … in the ratio 1 : 0.38 : 0.20 : 0.12 …), weighted by sin²θ (θ from the
    /// stylus); [`Instrument::probe_pretravel_at`].
    pub probe_lobing_um: f64,
    /// Orientation of the lobes about the stylus: φ of the least pre-travel, degrees.
    pub probe_lobing_deg: f64,
    /// Touch-probe pre-travel along the stylus less its mean across, µm (weighted by cos²θ).
    pub probe_axial_um: f64,
    /// The bar's calibrated length (`bar_length`) less its true length, µm: a miscalibrated
    /// bar, whose every ΔL reads this much more than the balls' distance less `bar_length`.
    pub bar_calibration_error_um: f64,
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
            probe_lobing_um: 0.0,
            probe_lobing_deg: 0.0,
            probe_axial_um: 0.0,
            bar_calibration_error_um: 0.0,
        }
    }
}

impl Instrument {
    /// The touch probe's pre-travel, µm, for a touch at the surface whose outward normal is
    /// `n` (machine frame, unit), the probe turned by B = `b_deg` about Y (the stylus along −Z
    /// at B = 0): [`Self::probe_pretravel_um`] plus the lobing ([`Self::probe_lobing_um`],
    /// [`Self::probe_axial_um`]) in the probe's frame.
    pub fn probe_pretravel_at(&self, n: [f64; 3], b_deg: f64) -> f64 {
        let (sb, cb) = b_deg.to_radians().sin_cos();
        // the normal in the probe's frame (z up the stylus)
        let (x, y, z) = (cb * n[0] - sb * n[2], n[1], sb * n[0] + cb * n[2]);
        let (sin2, cos2) = (x * x + y * y, z * z);
        // the kinematic lobe 1/cos ψ, ψ within ±60° of the nearest lobe's middle, less its
        // mean (3/π·ln(2 + √3)), scaled by its 3rd harmonic's amplitude (|−0.346| for 1/cos ψ:
        // the least pre-travel at ψ = 0, so this lobe is −cos 3ψ times `probe_lobing_um`)
        let third = 120f64.to_radians();
        let phi = y.atan2(x) - self.probe_lobing_deg.to_radians();
        let psi = (phi + third / 2.0).rem_euclid(third) - third / 2.0;
        let (mean, a3) = (1.257_602_154_8, 0.346_013_313_7);
        let lobe = (1.0 / psi.cos() - mean) / a3;
        self.probe_pretravel_um + self.probe_lobing_um * lobe * sin2 + self.probe_axial_um * cos2
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

/// What one sample period delivers to the application (as the board's tasks hand it over).
#[derive(Clone, Debug)]
pub struct Readings {
    /// Time of the sample, µs.
    pub t_us: u64,
    /// The LVDT block's demodulation.
    pub lvdt: Result<LvdtReading, DemodError>,
    /// The encoders' hardware counters.
    pub raw: [u32; MAX_AXES],
    /// Samples lost upstream so far (the queues' overrun counter).
    pub lost_total: u32,
    /// The thermistor code read this period, if the thermistor task read one (every 100 ms).
    pub thermistor: Option<u16>,
    /// The LVDT block's 12-bit ADC codes, secondary A then B (what the board's ADCs read).
    pub adc: (Vec<u16>, Vec<u16>),
}

/// The sensor model of the simulated pod: the instrument (bar, LVDT, encoders, thermistor,
/// probe) with its noise and faults, in virtual time.
pub struct Sensors {
    /// The configuration the sensors are built for (bar length, calibration, counts per unit,
    /// thermistor): a different configuration in the application reads them the way the board
    /// would with a wrong setting.
    pub config: Config,
    lvdt: LvdtChannel,
    inst: Instrument,
    rng: Rng,
    t_us: u64,
    /// Faults on the next samples.
    pub faults: SensorFaults,
    /// The thermistor's ADC code while it is faulty (0 = shorted, 4095 = open), else `None`.
    pub thermistor_fault: Option<u16>,
    lost_total: u32,
}

/// Encoder counts per mm or degree of a configuration.
fn counts_per_unit(cfg: &Config, axis: usize) -> f64 {
    cfg.axes.get(axis).map(|a| a.counts_per_unit).unwrap_or(1.0)
}

impl Sensors {
    /// The sensors of a bar of `bar_length_mm` with the instrument `inst` and noise seed
    /// `seed`, under the default configuration otherwise.
    pub fn new(bar_length_mm: f64, inst: &Instrument, seed: u64) -> Self {
        let config = Config {
            bar_length_mm: bar_length_mm as f32,
            sample_rate_hz: inst.sample_rate_hz as f32,
            ..Config::default()
        };
        Self::with_config(&config, inst, seed)
    }

    /// The sensors a pod configured as `config` reads (its bar, sample rate, excitation,
    /// encoders, thermistor), with the instrument `inst` otherwise (its sample rate is
    /// `config`'s) and noise seed `seed`.
    pub fn with_config(config: &Config, inst: &Instrument, seed: u64) -> Self {
        let config = *config;
        let inst = &Instrument {
            sample_rate_hz: f64::from(config.sample_rate_hz),
            ..*inst
        };
        Self {
            config,
            lvdt: LvdtChannel::new(&config),
            inst: *inst,
            rng: Rng::new(seed),
            t_us: 0,
            faults: SensorFaults::default(),
            thermistor_fault: None,
            lost_total: 0,
        }
    }

    /// Another bar is mounted (the technician swaps bars between procedures): its length,
    /// mm.
    pub fn set_bar_length(&mut self, bar_length_mm: f64) {
        self.config.bar_length_mm = bar_length_mm as f32;
    }

    /// The instrument.
    pub fn instrument(&self) -> &Instrument {
        &self.inst
    }

    /// The hardware counter values of axis positions `axes` (mm / degrees).
    pub fn raw(&self, axes: &[f64; MAX_AXES]) -> [u32; MAX_AXES] {
        let mut raw = [0u32; MAX_AXES];
        for (i, (r, p)) in raw.iter_mut().zip(axes).enumerate() {
            let c = (p * counts_per_unit(&self.config, i)).round() as i64;
            *r = c.rem_euclid(1 << 16) as u32;
        }
        raw
    }

    /// Homing at `axes` (mm / degrees): the counters read there and the positions they mean
    /// (rounded to whole counts), for `App::reference_axes`.
    pub fn reference(&self, axes: &[f64; MAX_AXES]) -> ([u32; MAX_AXES], [f64; MAX_AXES]) {
        let q: [f64; MAX_AXES] = std::array::from_fn(|i| {
            (axes[i] * counts_per_unit(&self.config, i)).round() / counts_per_unit(&self.config, i)
        });
        (self.raw(axes), q)
    }

    /// One sample period: the true bar-length deviation `dl_um` (ball distance − L_B, µm) and
    /// the axis positions `axes` the encoders read (mm / degrees). Advances virtual time by
    /// one period.
    pub fn read(&mut self, dl_um: f64, axes: &[f64; MAX_AXES]) -> Readings {
        let temp_c = self.bar_temp_now_c();
        // the thermistor task's read every 100 ms (a detached thermistor keeps reading the
        // temperature the bar had at the start)
        let thermistor = self.t_us.is_multiple_of(100_000).then(|| {
            self.thermistor_fault.unwrap_or_else(|| {
                self.thermistor_code_of(if self.inst.thermistor_detached {
                    self.inst.bar_temp_c
                } else {
                    temp_c
                })
            })
        });
        let expansion = f64::from(bar_expansion_um(
            self.config.bar_length_mm,
            self.config.bar_cte_ppm_per_k,
            temp_c as f32,
        ));
        let f = &mut self.faults;
        let mut x = dl_um + f.bar_offset_um + self.inst.bar_calibration_error_um - expansion
            + self.inst.bar_noise_um * self.rng.normal();
        x += self.inst.lvdt_nonlinearity_per_um * x * x;
        let mut lvdt = self.lvdt.model;
        if f.lvdt_open_samples > 0 {
            f.lvdt_open_samples -= 1;
            lvdt.amplitude_sum = 0.0;
        } else if f.lvdt_over_range_samples > 0 {
            f.lvdt_over_range_samples -= 1;
            x = OVER_RANGE_UM;
        }
        let (adc, reading) =
            self.lvdt
                .block_with(&lvdt, x, self.inst.adc_noise_counts, &mut self.rng);
        let glitch = std::mem::take(&mut f.encoder_glitch_counts);
        let mut raw = self.raw(axes);
        if glitch != 0 {
            raw[0] = (i64::from(raw[0]) + glitch).rem_euclid(1 << 16) as u32;
        }
        let r = Readings {
            t_us: self.t_us,
            lvdt: reading,
            raw,
            lost_total: self.lost_total,
            thermistor,
            adc,
        };
        self.t_us += self.period_us();
        r
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

    /// The thermistor code of the bar's true temperature now.
    pub fn thermistor_code(&self) -> u16 {
        self.thermistor_code_of(self.bar_temp_now_c())
    }

    /// Sample period, µs.
    pub fn period_us(&self) -> u64 {
        (1e6 / self.inst.sample_rate_hz).round() as u64
    }

    /// The next `n` sample periods' ADC blocks are lost upstream (a queue overrun): virtual time
    /// advances, the overrun counter grows by `n`, and the next sample carries `OVERRUN`.
    pub fn lose_samples(&mut self, n: u32) {
        self.lost_total = self.lost_total.wrapping_add(n);
        self.t_us += self.period_us() * u64::from(n);
    }

    /// Sample periods lost upstream so far (the cumulative count the pod is handed).
    pub fn lost_total(&self) -> u32 {
        self.lost_total
    }

    /// A probe edge now with the counters latched at `axes` (mm / degrees): (time µs, raw
    /// counters), for `App::on_probe_edge`.
    pub fn probe_edge(&self, axes: &[f64; MAX_AXES]) -> (u64, [u32; MAX_AXES]) {
        (self.t_us, self.raw(axes))
    }

    /// Virtual time of the next sample, µs.
    pub fn t_us(&self) -> u64 {
        self.t_us
    }
}
