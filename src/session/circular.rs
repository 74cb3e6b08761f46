//! ISO 230-4 circular test session helpers on top of [`crate::metrology::iso230_4`].

use crate::metrology::iso230_4::Diagnostics;

/// Servo mismatch τ_u − τ_v (ms) from the per-direction squareness figures of a circular test
/// at `feed_mm_per_min` on radius `radius_mm`.
///
/// An axis that follows its command τ late on a circle at angular speed ω errs by
/// E_u = ω·τ_u·v (CCW; the sign flips CW), which is an out-of-squareness of ω·(τ_u − τ_v)
/// (E_u = S·v convention of [`crate::metrology::iso230_4`]) that changes sign with the
/// direction, so S_ccw − S_cw = 2ω(τ_u − τ_v) while the true squareness cancels.
/// Returns 0 for a non-positive feed or radius.
pub fn servo_mismatch_ms(
    ccw: &Diagnostics,
    cw: &Diagnostics,
    radius_mm: f64,
    feed_mm_per_min: f64,
) -> f64 {
    if !(radius_mm > 0.0 && feed_mm_per_min > 0.0) {
        return 0.0;
    }
    let omega_rad_per_s = feed_mm_per_min / 60.0 / radius_mm;
    let ds_urad = f64::from(ccw.squareness_urad) - f64::from(cw.squareness_urad);
    ds_urad * 0.5 * 1e-6 / omega_rad_per_s * 1e3
}
