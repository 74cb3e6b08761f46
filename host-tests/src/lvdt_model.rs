//! Forward model of a ball-bar LVDT's two secondaries, in f64, independent of the core's
//! demodulator: for a core displacement `x_um`, secondary A carries amplitude
//! `E·(1/2 + x/(2·G))` and B `E·(1/2 − x/(2·G))` (a linear differential transformer with gain
//! `G` µm per unit ratio), both at phase `phase_rad` to the excitation, on an ADC offset.

/// One LVDT channel as the ADCs see it.
#[derive(Clone, Copy, Debug)]
pub struct LvdtModel {
    /// µm of core travel per unit of (A−B)/(A+B).
    pub gain_um: f64,
    /// Sum of the two secondary amplitudes, ADC counts (scales with the excitation amplitude).
    pub amplitude_sum: f64,
    /// Phase of the secondaries relative to the excitation sine, rad.
    pub phase_rad: f64,
    /// DC level of the ADC inputs, counts.
    pub offset: f64,
}

impl Default for LvdtModel {
    fn default() -> Self {
        Self {
            gain_um: 2000.0,
            amplitude_sum: 3000.0,
            phase_rad: 0.0,
            offset: 2048.0,
        }
    }
}

impl LvdtModel {
    /// Amplitudes (A, B) in counts at displacement `x_um`.
    pub fn amplitudes(&self, x_um: f64) -> (f64, f64) {
        let r = x_um / self.gain_um;
        (
            self.amplitude_sum * 0.5 * (1.0 + r),
            self.amplitude_sum * 0.5 * (1.0 - r),
        )
    }

    /// Noise-free sample k (of `period` per excitation period) of both secondaries, in counts.
    pub fn sample(&self, x_um: f64, k: usize, period: usize) -> (f64, f64) {
        let (a, b) = self.amplitudes(x_um);
        let ph = 2.0 * std::f64::consts::PI * k as f64 / period as f64 + self.phase_rad;
        let s = ph.sin();
        (self.offset + a * s, self.offset + b * s)
    }

    /// A block of `periods` excitation periods as f32 values (noise-free, not quantised).
    pub fn block_f32(&self, x_um: f64, period: usize, periods: usize) -> (Vec<f32>, Vec<f32>) {
        (0..period * periods)
            .map(|k| self.sample(x_um, k % period, period))
            .map(|(a, b)| (a as f32, b as f32))
            .unzip()
    }

    /// A block as 12-bit ADC codes with Gaussian noise `sigma` counts per sample (rounded,
    /// clamped to 0…4095; `sigma` 0 draws nothing from `rng`).
    pub fn block_adc(
        &self,
        x_um: f64,
        period: usize,
        periods: usize,
        sigma: f64,
        rng: &mut crate::rng::Rng,
    ) -> (Vec<u16>, Vec<u16>) {
        let q = |v: f64| v.round().clamp(0.0, 4095.0) as u16;
        // one period's samples, each computed once (the sines are most of the simulator's
        // time); the same values as `sample` gives
        let one: Vec<(f64, f64)> = (0..period).map(|k| self.sample(x_um, k, period)).collect();
        if sigma == 0.0 {
            // noiseless: every period alike, no draws (the simulator's time is in them)
            let codes: Vec<(u16, u16)> = one.iter().map(|&(a, b)| (q(a), q(b))).collect();
            return (0..periods).flat_map(|_| codes.iter().copied()).unzip();
        }
        (0..period * periods)
            .map(|k| {
                let (a, b) = one.get(k % period).copied().unwrap_or_default();
                (q(a + sigma * rng.normal()), q(b + sigma * rng.normal()))
            })
            .unzip()
    }
}
