//! ISO 230-4 circular test figures and ball-bar diagnostics for a circle about the socket.
//!
//! Names (ISO 230-4:2005 → ISO 230-4:2022, which calls the measured quantities "errors"):
//! - circular deviation G → circular error G: max − min radial deviation from the
//!   least-squares circle, per direction;
//! - radial deviation F (F_max, F_min) → radial error F: deviation of the actual path from the
//!   nominal radius about the nominal centre (the socket), per direction;
//! - bi-directional circular deviation G(b) → bi-directional circular error G(b): max − min of
//!   both directions from one least-squares circle fitted to both;
//! - mean bi-directional radial deviation → mean bi-directional radial error: the radius change
//!   of that joint circle;
//! - circular hysteresis H (both editions): max radial difference CW − CCW at equal angle.
//!
//! Per sample: the running limaçon fit of the direction ([`CircleFit`]) and the sample's
//! angular bin (`BINS` equal bins from +u, aligned with the quadrants; per bin the sums of ΔL
//! and n). Profile figures (G, F, G(b), H) and diagnostics are evaluated on the bin-averaged
//! profile: intra-bin extremes narrower than 360°/`BINS` are averaged, which is a
//! low-pass filter of that width. The least-squares centre subtracted is the exact one of the
//! running fit (the bin mean of e·n is e·(mean n), exactly).
//!
//! # Responsibilities
//!
//! - this module: the test's state — each direction's running fit and angular bins — and
//!   what a sample does to it;
//! - `figures`: G, F (each direction), G(b), H and the mean bi-directional radial deviation,
//!   with their bootstrap uncertainty;
//! - `centre`: the centre as entered — its shares in every figure, the centre the axes traced;
//! - `diagnostics`: the joint fit of the machine faults (squareness, scale mismatch, reversal
//!   steps at each reversal point, straightness, cyclic error) with their uncertainties;
//! - `support`: what an arc determines (and why not), when a fault is named, each fault's
//!   share of G;
//! - `planes`: the machine's three axis scales from circles in its three planes;
//! - `feed_sweep`: the servo mismatch and the feed limit of G(b) from one circle at several
//!   feeds;
//! - `spikes`: the reversal spikes from the samples about each reversal point;
//! - `lateral`: each axis's lateral play from the difference of the two directions.

mod centre;
mod diagnostics;
mod feed_sweep;
mod figures;
mod lateral;
mod oscillation;
mod planes;
mod spikes;
mod support;

pub use centre::TracedCentre;
pub use diagnostics::{
    CYCLIC_SIGNIFICANCE, DIAGNOSTIC_PARAMETERS, Diagnosed, Diagnostics, MAX_CYCLIC_ORDER,
    RESOLUTION_UM, mean_diagnostics,
};
pub use feed_sweep::{
    FeedLimitError, FeedPoint, SWEEP_MIN_FEEDS, feed_limit, sweep_servo_mismatch,
};
pub use figures::{BidirectionalFigures, DirectionFigures};
pub use oscillation::{
    AxisOscillation, NU_SPAN, OSCILLATION_FALSE_ALARM, Oscillation, OscillationKind,
    RunOscillations, RunReversals,
};
pub use planes::{
    AxisScales, AxisScalesError, PlaneScales, SCALE_READINGS, SUMMARY_PLANES, ScaleReading,
    axis_scales,
};
pub use spikes::{SPIKE_POST, SPIKE_PRE, SPIKE_WINDOW, Spike, SpikeCapture, TAU_SPAN};
pub use support::{
    ArcSupport, DIAGNOSES, Diagnosis, FAULT_SIGNIFICANCE, FULL_CIRCLE_GAP_DEG, Fault,
    NotDeterminable, REVERSAL_SIDE_DEG,
};

use super::angle::quadrant_angle;
use super::circle_fit::{CircleEstimate, CircleFit, CircleFitConfig, CircleFitError};
use super::extremes;
use crate::acquisition::Sample;
use crate::in_place::{self, init_in_place};
use core::mem::MaybeUninit;

pub use super::pattern::Direction;

/// Why ISO 230-4 figures are not available.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum IsoError {
    /// The least-squares circle of a direction is not available (too few samples, short arc).
    Fit(CircleFitError),
    /// A bi-directional figure needs both directions.
    MissingDirection,
    /// The diagnostics need bins all around the circle (every quadrant covered).
    NotFullCircle,
    /// The harmonic fit is singular.
    IllConditioned,
}

#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Bin {
    dl_um: f32,
    nu: f32,
    nv: f32,
    /// Σ of the positions' distance from the centre as entered less the nominal radius, µm.
    traced_um: f32,
    n: u32,
}

impl Bin {
    /// Means of ΔL (µm) and of n's components, f32 (the figures' small numbers).
    fn mean(&self) -> Option<(f32, f32, f32)> {
        if self.n == 0 {
            return None;
        }
        let k = 1.0 / self.n as f32;
        Some((self.dl_um * k, self.nu * k, self.nv * k))
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Run<const BINS: usize> {
    fit: CircleFit,
    bins: [Bin; BINS],
}

impl<const BINS: usize> Run<BINS> {
    /// An empty run of the fit `config`, built in `slot`.
    fn init(slot: &mut MaybeUninit<Self>, config: CircleFitConfig) -> &mut Self {
        init_in_place!(slot, Self {
            fit: CircleFit::new(config),
        } in place {
            bins: |s| in_place::fill(s, Bin::default()),
        })
    }

    /// One sample's ΔL noise, µm, from the bin profile ([`extremes::sample_noise_um`]); NaN
    /// if the profile is too short to tell.
    fn noise_um(&self) -> f32 {
        let mut scratch = [0.0f32; BINS];
        let bin = |i: usize| {
            self.bins
                .get(i)
                .and_then(|b| {
                    b.mean().map(|(dl, _, _)| extremes::BinMean {
                        mean_um: dl,
                        n: b.n,
                    })
                })
                .unwrap_or_default()
        };
        extremes::sample_noise_um(BINS, bin, &mut scratch).unwrap_or(f32::NAN)
    }
}

/// Marks a CW bin's sample count for the bidirectional bootstrap's noise (a bin never holds
/// 2³¹ samples).
const CW_BIN: u32 = 1 << 31;

/// Five profile figures of a test, computed with `shift(i, n)` added to each bin: bin `i` of
/// `n` samples (the CW profile's n marked with [`CW_BIN`]) moves its mean ΔL by the first
/// value and its residual about the circle by both.
type Figures<'a> = &'a dyn Fn(&mut dyn FnMut(usize, u32) -> (f32, f32)) -> [f32; 5];

/// An ISO 230-4 circular test about the socket (both directions), `BINS` angular bins
/// (a multiple of 4, at most 4096). State: 32·BINS + 252 bytes (11 772 B for 360 bins).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CircularTest<const BINS: usize> {
    radius_mm: f32,
    ccw: Run<BINS>,
    cw: Run<BINS>,
}

impl<const BINS: usize> CircularTest<BINS> {
    /// Angle bins per quadrant (at least 1).
    const BINS_PER_QUADRANT: usize = if BINS >= 4 { BINS / 4 } else { 1 };

    const CHECK: () = assert!(
        BINS.is_multiple_of(4) && BINS >= 8 && BINS <= 4096,
        "BINS: multiple of 4"
    );

    /// A new test; `config.geometry` is the circle about the socket, `radius_mm` its nominal
    /// radius (the bar length, for the diagnostics' angular units).
    pub fn new(config: CircleFitConfig, radius_mm: f32) -> Self {
        in_place::build(|s| Self::init(s, config, radius_mm))
    }

    /// [`CircularTest::new`] built in place in `slot` (no stack copy of the 14.3 KiB state).
    pub fn init(
        slot: &mut MaybeUninit<Self>,
        config: CircleFitConfig,
        radius_mm: f32,
    ) -> &mut Self {
        #[allow(clippy::let_unit_value)]
        let () = Self::CHECK;
        init_in_place!(slot, Self {
            radius_mm: radius_mm,
        } in place {
            ccw: |s| Run::init(s, config),
            cw: |s| Run::init(s, config),
        })
    }

    /// Starts a new test in place (as [`CircularTest::new`]).
    pub fn restart(&mut self, config: CircleFitConfig, radius_mm: f32) {
        in_place::reinit(self, |s| Self::init(s, config, radius_mm));
    }

    /// Forgets the samples of direction `d` (a new run of that direction replaces the old one:
    /// runs are not merged); the other direction is kept.
    pub fn reset_direction(&mut self, d: Direction) {
        let run = self.run_mut(d);
        let config = *run.fit.config();
        in_place::reinit(run, |s| Run::init(s, config));
    }

    /// The nominal radius the test was built with, mm.
    pub fn radius_mm(&self) -> f32 {
        self.radius_mm
    }

    fn run(&self, d: Direction) -> &Run<BINS> {
        match d {
            Direction::Ccw => &self.ccw,
            Direction::Cw => &self.cw,
        }
    }

    fn run_mut(&mut self, d: Direction) -> &mut Run<BINS> {
        match d {
            Direction::Ccw => &mut self.ccw,
            Direction::Cw => &mut self.cw,
        }
    }

    /// The running fit of one direction.
    pub fn fit(&self, d: Direction) -> &CircleFit {
        &self.run(d).fit
    }

    /// The limaçon fit of direction `d` (r0, e) with its u from the samples' noise (the
    /// profile's third differences, as G's), σ·√((AᵀA)⁻¹ᵢᵢ), rather than from the fit's
    /// residual: the profile's shape is what is measured, not noise (the residual of a circle
    /// with machine faults holds those faults, so its u(e) would be several times the
    /// scatter). The residual's u where the
    /// profile is too short to tell its noise.
    pub fn fit_estimate(&self, d: Direction) -> Result<CircleEstimate, CircleFitError> {
        let run = self.run(d);
        let mut est = run.fit.estimate()?;
        let s = run.noise_um();
        if let (true, Ok(c)) = (s.is_finite(), run.fit.moments().normal_matrix().cholesky()) {
            let inv = c.inverse();
            let u = |a: f64| crate::num::sqrtf(s * s * a as f32);
            est.u_r0_um = u(inv.a00);
            est.u_e_um = [u(inv.a11), u(inv.a22)];
        }
        Ok(est)
    }

    /// One sample's ΔL noise of the run in direction `d`, µm, from its profile's third
    /// differences ([`extremes::sample_noise_um`]); NaN while the profile is too short to tell.
    pub fn noise_um(&self, d: Direction) -> f32 {
        self.run(d).noise_um()
    }

    /// Feeds one sample of the run in direction `d` (O(1): the fit update, a polynomial atan
    /// for the bin, 4 adds).
    pub fn update(&mut self, sample: &Sample, d: Direction) -> super::circle_fit::SampleUse {
        let radius_mm = self.radius_mm;
        let run = self.run_mut(d);
        let ([nu, nv], r_mm) = match run.fit.update_direction(sample) {
            Ok(nr) => nr,
            Err(skipped) => return skipped,
        };
        let dl = sample.delta_l_um;
        let (q, a) = quadrant_angle(nu, nv);
        // a constant divisor: no division-by-zero check (a panic path) in the bin loops
        let per_q = Self::BINS_PER_QUADRANT;
        let k = ((a * (per_q as f32 / core::f32::consts::FRAC_PI_2)) as usize).min(per_q - 1);
        if let Some(bin) = run.bins.get_mut(usize::from(q) * per_q + k) {
            bin.dl_um += dl;
            bin.nu += nu;
            bin.nv += nv;
            bin.traced_um += (r_mm - radius_mm) * 1e3;
            bin.n = bin.n.saturating_add(1);
        }
        super::circle_fit::SampleUse::Used
    }
}
