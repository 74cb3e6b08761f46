//! The R-test head of seed 003 on the virtual machine tool: the exact A/C table-tilting chain
//! of [`crate::forward_seed003`] (44 ISO 230 errors, the 11 location/ball errors of the
//! identification among them) gives the sphere-centre displacement at each pose; each of the
//! head's three flat-tip sensors reads its component along its measuring direction plus noise,
//! through its own LVDT channel ([`super::lvdt_channel`]: ADC blocks → the core's
//! `demodulate`); the core's `crate::methods::rtest_head::RtestHead` turns the three
//! channels back into the displacement vector that `crate::methods::rtest::identify` takes.

use crate::methods::rtest::{ARCSEC_RAD, RtestSample};
use crate::methods::rtest_head::{HeadReading, RtestHead};
use ballpod::acquisition::lvdt::LvdtCalibration;
use ballpod::acquisition::{Acquisition, MAX_AXES};
use ballpod::config::Config;

use super::lvdt_channel::LvdtChannel;
use crate::forward_seed003 as fw;
use crate::rng::Rng;

/// The seed 003 Table 3 set-up of the A/C table-tilting machine (mm), as the forward model
/// takes it; the core's counterpart is `RtestGeometry::SEED003_TABLE3`.
pub fn seed003_table3_kinematics() -> fw::Kin {
    fw::Kin {
        x_w: -217.504,
        y_w: -0.279,
        z_w: 211.537,
        z_c: 29.794,
        z_p: 184.670,
        ..Default::default()
    }
}

/// Path K4 of seed 003 with `n` poses: A 0 → −90° while C turns 0 → 360° (degrees).
pub fn path_k4(n: usize) -> Vec<(f64, f64)> {
    let last = n.saturating_sub(1).max(1) as f64;
    (0..n)
        .map(|i| (-90.0 * i as f64 / last, 360.0 * i as f64 / last))
        .collect()
}

/// The 11 identified errors XOW YOW ZOW YOA ZOA BOA COA XOC YOC AOC BOC from µm / arc-seconds
/// to the forward model's mm / rad.
pub fn errors_si(errors: &[f64; 11]) -> [f64; 11] {
    const ANGULAR: [bool; 11] = [
        false, false, false, false, false, true, true, false, false, true, true,
    ];
    std::array::from_fn(|i| {
        if ANGULAR[i] {
            errors[i] * ARCSEC_RAD
        } else {
            errors[i] * 1e-3
        }
    })
}

/// The R-test head: three LVDT channels, the core's combination, sensor noise.
pub struct RtestRig {
    /// The head's sensor arrangement (the core's).
    pub head: RtestHead,
    channels: [LvdtChannel; 3],
    cal: LvdtCalibration,
    sensor_noise_um: f64,
    adc_noise_counts: f64,
    rng: Rng,
    /// Samples the head flagged (a sensor open or over-range).
    pub invalid_samples: u32,
}

impl RtestRig {
    /// A head with the default sensor arrangement, the default configuration's LVDT
    /// calibration, sensor noise σ `sensor_noise_um` (µm, each sensor), 0.5 ADC counts.
    pub fn new(sensor_noise_um: f64, seed: u64) -> Self {
        let cfg = Config::default();
        let cal = Acquisition::new(&cfg, [16; MAX_AXES]).lvdt_calibration();
        let ch = LvdtChannel::new(&cfg);
        Self {
            head: RtestHead::default(),
            channels: [ch.clone(), ch.clone(), ch],
            cal,
            sensor_noise_um,
            adc_noise_counts: 0.5,
            rng: Rng::new(seed),
            invalid_samples: 0,
        }
    }

    /// One sample of the head for a true sphere-centre displacement `q_um` (µm, probe frame,
    /// the R-test reading's sign: probe − ball).
    pub fn sample(&mut self, q_um: [f64; 3]) -> HeadReading {
        let n = self.head.directions();
        let readings: [_; 3] = std::array::from_fn(|k| {
            let x = (0..3).map(|i| f64::from(n[k][i]) * q_um[i]).sum::<f64>()
                + self.sensor_noise_um * self.rng.normal();
            self.channels[k]
                .read(x, self.adc_noise_counts, &mut self.rng)
                .ok()
        });
        let r = self.head.read(&self.cal, readings);
        if !r.is_valid() {
            self.invalid_samples += 1;
        }
        r
    }

    /// The head's readings along `path` (A, C degrees) on the machine `k` with the 11
    /// location/ball errors `errors` (µm / arc-seconds): one sample per pose, invalid ones
    /// left out (counted in [`invalid_samples`](Self::invalid_samples)).
    pub fn measure(
        &mut self,
        k: &fw::Kin,
        errors: &[f64; 11],
        path: &[(f64, f64)],
    ) -> Vec<RtestSample> {
        let si = errors_si(errors);
        path.iter()
            .filter_map(|&(a, c)| {
                let q = fw::exact_reduced_reading_um(k, &si, a.to_radians(), c.to_radians());
                let r = self.sample(q);
                r.is_valid().then(|| RtestSample {
                    a_deg: a,
                    c_deg: c,
                    reading_um: r.displacement_um.map(f64::from),
                })
            })
            .collect()
    }

    /// The head's readings at `poses` (A, C degrees, the servo positions X_m, Y_m, Z_m in mm)
    /// on the machine `k` with the 11 location/ball errors `errors` (µm / arc-seconds): a
    /// control that commands its own kinematics, not the ideal TCP of [`Self::measure`].
    pub fn measure_commanded(
        &mut self,
        k: &fw::Kin,
        errors: &[f64; 11],
        poses: &[(f64, f64, [f64; 3])],
    ) -> Vec<RtestSample> {
        let e = fw::reduced_errors(&errors_si(errors));
        poses
            .iter()
            .filter_map(|&(a, c, [xm, ym, zm])| {
                let q = fw::reading(k, &e, a.to_radians(), c.to_radians(), xm, ym, zm);
                let r = self.sample([q[0] * 1e3, q[1] * 1e3, q[2] * 1e3]);
                r.is_valid().then(|| RtestSample {
                    a_deg: a,
                    c_deg: c,
                    reading_um: r.displacement_um.map(f64::from),
                })
            })
            .collect()
    }
}
