//! The live values and results of a running circle fit, shared by CIRCLE ([`super::circle`])
//! and the seed 002 steps: r0, e_u, e_v per sample, their u at every
//! [`LIVE_U_EVERY`](super::LIVE_U_EVERY)th used sample, and a run's fit into the results.

use super::live::{LIVE_U_EVERY, Live, LiveValues};
use super::results::{ResultId, ResultSink};
use crate::config::Config;
use crate::metrology::bar_budget::{BarBudget, FigureKind};
use crate::metrology::circle_fit::{CircleEstimate, CircleFit};

/// The live values of a running circle fit (CIRCLE and the seed 002 steps).
pub(super) const LIVE_FIT: u16 = LiveValues::mask(&[Live::EccU, Live::EccV, Live::R0]);
/// From the bit of a live circle-fit value to that of its u.
pub(super) const LIVE_FIT_U_SHIFT: u16 = Live::UEccU as u16 - Live::EccU as u16;
/// The live values of a running circle fit with their u.
pub(super) const LIVE_FIT_ALL: u16 = LIVE_FIT | LIVE_FIT << LIVE_FIT_U_SHIFT;
/// The live SSM E.
pub(super) const LIVE_SSM_E: u16 = LiveValues::mask(&[Live::SsmEx, Live::SsmEy, Live::SsmEz]);
/// From the bit of a component of the live E to that of its u.
pub(super) const LIVE_U_SHIFT: u16 = Live::USsmEx as u16 - Live::SsmEx as u16;
/// The live values of a running SSM: E and its u.
pub(super) const LIVE_SSM: u16 = LIVE_SSM_E | LIVE_SSM_E << LIVE_U_SHIFT;

/// The live (r0, e_u, e_v) of a running circle fit, µm (`None` while not observable), and
/// when `with_u` their standard uncertainties as the run's results would state them: the
/// fit's Type A ([`CircleFit::live_with_uncertainty`], σ = `sample_noise_um` or the
/// residual's where NaN) with the bar's shares and the centre's (`socket_um`, µm, for r0,
/// e_u, e_v) (`None` when not refreshed at this sample or not observable).
pub(crate) fn live_fit(
    fit: &CircleFit,
    sample_noise_um: f32,
    socket_um: [f32; 3],
    with_u: bool,
    config: &Config,
) -> (Option<[f32; 3]>, Option<[f32; 3]>) {
    if with_u {
        live_fit_with_u(fit, sample_noise_um, socket_um, config)
    } else {
        (fit.live().ok(), None)
    }
}

/// Whether the live u of a circle fit is due at `used` samples of its run: at every
/// [`LIVE_U_EVERY`]th, once (samples the fit does not use, e.g. flagged ones, do not refresh it
/// again); `last` is the count of the last refresh.
pub(crate) fn live_u_due(used: u32, last: &mut u32) -> bool {
    let due = used.is_multiple_of(LIVE_U_EVERY) && used != *last;
    if due {
        *last = used;
    }
    due
}

/// A run's fit into `results`: e and r0 with their u (the bar's share of `bar` and the centre's
/// `[s_r0, s_eu, s_ev]`), the residual RMS and the arc, degrees.
pub(super) fn publish_fit(
    results: &mut impl ResultSink,
    e: &CircleEstimate,
    arc_deg: f32,
    bar: &BarBudget,
    [s_r0, s_eu, s_ev]: [f32; 3],
) {
    for (id, v, u, kind, socket) in [
        (
            ResultId::EccU,
            e.e_um[0],
            e.u_e_um[0],
            FigureKind::Shape,
            s_eu,
        ),
        (
            ResultId::EccV,
            e.e_um[1],
            e.u_e_um[1],
            FigureKind::Shape,
            s_ev,
        ),
        (ResultId::R0, e.r0_um, e.u_r0_um, FigureKind::Radial, s_r0),
    ] {
        results.set_with_bar(id, v, [u, socket], bar, kind);
    }
    results.set(
        ResultId::ResidualRms,
        f64::from(e.residual_rms_um),
        f64::NAN,
    );
    results.set(ResultId::Arc, f64::from(arc_deg), f64::NAN);
}

/// Sets the live values of a running circle fit (`fit`: r0, e_u, e_v) and, when refreshed,
/// their u (held otherwise, but never where its value is not valid); the bits it keeps.
pub(super) fn set_live_fit(
    live: &mut LiveValues,
    fit: Option<[f32; 3]>,
    u: Option<[f32; 3]>,
) -> u16 {
    live.set(Live::EccU, fit.map(|[_, eu, _]| eu));
    live.set(Live::EccV, fit.map(|[_, _, ev]| ev));
    live.set(Live::R0, fit.map(|[r0, _, _]| r0));
    if let Some([u_r0, u_eu, u_ev]) = u {
        live.set(Live::UEccU, Some(u_eu));
        live.set(Live::UEccV, Some(u_ev));
        live.set(Live::UR0, Some(u_r0));
    }
    // a u is never valid where its value is not
    live.invalidate((!live.valid & LIVE_FIT) << LIVE_FIT_U_SHIFT);
    LIVE_FIT_ALL
}

/// [`live_fit`] at a refresh of the u.
#[inline(never)] // off the per-sample path: one used sample in [`LIVE_U_EVERY`]
fn live_fit_with_u(
    fit: &CircleFit,
    sample_noise_um: f32,
    [s_r0, s_eu, s_ev]: [f32; 3],
    config: &Config,
) -> (Option<[f32; 3]>, Option<[f32; 3]>) {
    match fit.live_with_uncertainty(sample_noise_um) {
        Ok(([r0, eu, ev], [u_r0, u_eu, u_ev])) => {
            let bar = BarBudget::from_config(config);
            let with = |kind, v, u: f32, s: f32| {
                let b = bar.combined(kind, v, u);
                crate::num::sqrtf(b * b + s * s)
            };
            let u = [
                with(FigureKind::Radial, r0, u_r0, s_r0),
                with(FigureKind::Shape, eu, u_eu, s_eu),
                with(FigureKind::Shape, ev, u_ev, s_ev),
            ];
            (Some([r0, eu, ev]), Some(u))
        }
        Err(_) => (None, None),
    }
}
