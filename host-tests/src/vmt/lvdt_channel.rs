//! One LVDT channel of the pod as the ADCs see it: the transformer model of
//! [`crate::lvdt_model`] sampled into 12-bit blocks over the excitation periods of one sample,
//! demodulated by the core's `ballpod::acquisition::lvdt::demodulate` — the board's path
//! from a core displacement to an [`LvdtReading`]. The ball bar uses one ([`super::sensors`]),
//! the R-test head three ([`super::rtest_rig`]).

use ballpod::acquisition::lvdt::{DemodError, ExcitationTable, LvdtReading, demodulate};
use ballpod::config::Config;

use crate::lvdt_model::LvdtModel;
use crate::rng::Rng;

/// ADC samples per excitation period (the default configuration's DAC table).
pub const P: usize = 20;

/// An LVDT channel: transformer model, excitation table, periods per sample.
#[derive(Clone, Debug)]
pub struct LvdtChannel {
    /// The transformer (gain, amplitude, phase, ADC offset).
    pub model: LvdtModel,
    table: ExcitationTable<P>,
    periods: usize,
}

impl LvdtChannel {
    /// A channel sampled as `cfg` says (excitation frequency / sample rate periods a block).
    pub fn new(cfg: &Config) -> Self {
        let periods =
            (f64::from(cfg.excitation_hz) / f64::from(cfg.sample_rate_hz)).round() as usize;
        Self {
            model: LvdtModel::default(),
            table: ExcitationTable::<P>::new(),
            periods: periods.max(1),
        }
    }

    /// The demodulated block of a core displacement `x_um` (µm) through the transformer
    /// `model` (the channel's own, or one with a fault), with ADC noise σ `adc_noise_counts`.
    pub fn read_with(
        &self,
        model: &LvdtModel,
        x_um: f64,
        adc_noise_counts: f64,
        rng: &mut Rng,
    ) -> Result<LvdtReading, DemodError> {
        self.block_with(model, x_um, adc_noise_counts, rng).1
    }

    /// [`read_with`](Self::read_with) with the block's 12-bit ADC codes of both secondaries
    /// (what the emulated board's ADC is handed).
    pub fn block_with(
        &self,
        model: &LvdtModel,
        x_um: f64,
        adc_noise_counts: f64,
        rng: &mut Rng,
    ) -> ((Vec<u16>, Vec<u16>), Result<LvdtReading, DemodError>) {
        let (a, b) = model.block_adc(x_um, P, self.periods, adc_noise_counts, rng);
        let reading = demodulate(&a, &b, &self.table);
        ((a, b), reading)
    }

    /// [`read_with`](Self::read_with) the channel's own transformer.
    pub fn read(
        &self,
        x_um: f64,
        adc_noise_counts: f64,
        rng: &mut Rng,
    ) -> Result<LvdtReading, DemodError> {
        self.read_with(&self.model, x_um, adc_noise_counts, rng)
    }
}

/// A displacement probe on one LVDT channel (a dial-gauge-like contact probe, seed 004): a
/// true displacement plus the probe's noise, through the channel and the core's calibration
/// (`LvdtCalibration::displacement_um`), as the pod reads it.
pub struct LvdtProbe {
    channel: LvdtChannel,
    cal: ballpod::acquisition::lvdt::LvdtCalibration,
    noise_um: f64,
    adc_noise_counts: f64,
    rng: Rng,
}

impl LvdtProbe {
    /// A probe under the default configuration's calibration, with noise σ `noise_um` (µm) on
    /// the displacement and 0.5 ADC counts.
    pub fn new(noise_um: f64, seed: u64) -> Self {
        let cfg = Config::default();
        let cal =
            ballpod::acquisition::Acquisition::new(&cfg, [16; ballpod::acquisition::MAX_AXES])
                .lvdt_calibration();
        Self {
            channel: LvdtChannel::new(&cfg),
            cal,
            noise_um,
            adc_noise_counts: 0.5,
            rng: Rng::new(seed),
        }
    }

    /// The pod's reading (µm) of the true displacement `x_um`, or why it has none (open,
    /// over-range, demodulation error).
    pub fn read_um(&mut self, x_um: f64) -> Result<f64, String> {
        use ballpod::acquisition::lvdt::LvdtStatus;
        let x = x_um + self.noise_um * self.rng.normal();
        let r = self
            .channel
            .read(x, self.adc_noise_counts, &mut self.rng)
            .map_err(|e| format!("LVDT probe: {e:?}"))?;
        match self.cal.displacement_um(&r) {
            (v, LvdtStatus::Ok) => Ok(f64::from(v)),
            (_, st) => Err(format!("LVDT probe: {st:?} at {x_um} µm")),
        }
    }
}
