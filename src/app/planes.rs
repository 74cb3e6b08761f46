//! The three-plane summary: the machine's three squarenesses (XY, YZ, ZX) and three axis
//! scales from circles in its three planes in one set-up (an XY full circle and YZ, ZX arcs of
//! 220° or more are what a service engineer runs).
//!
//! Each plane keeps the latest complete circle (both directions) of that plane since the
//! session was cleared: its squareness, mean scale and scale mismatch as published
//! ([`super::circle`]). A plane's squareness is published as soon as it has one; the scales once
//! all three planes have a mean scale ([`iso230_4::axis_scales`]). Every share of a reading's
//! u propagates through the solution in quadrature, except the bar's length and temperature
//! (`bar_offset`): one bar, one error, the same in every plane's radius, so it propagates
//! linearly (as δL/R it reads as the same scale on every axis). That needs one bar: planes run
//! with different calibrated bar lengths are no one set-up, and the scales are refused
//! (the squarenesses, which do not depend on the bar's length, stay).

use super::results::{CONTRIBUTOR_COUNT, Contributor, ResultEntry, ResultId, Results};
use crate::metrology::iso230_4::{self, PlaneScales, ScaleReading};
use crate::metrology::pattern::Plane;

/// Each plane's squareness result, in [`iso230_4::SUMMARY_PLANES`] order.
const SQUARENESS: [ResultId; 3] = [
    ResultId::SquarenessXy,
    ResultId::SquarenessYz,
    ResultId::SquarenessZx,
];

/// Each axis's scale result (X, Y, Z).
const SCALES: [ResultId; 3] = [ResultId::ScaleX, ResultId::ScaleY, ResultId::ScaleZ];

/// Why a summary result is invalid (the text after its name).
const NOT_YET: &str = " not available yet: needs a complete circle or arc (both directions, every quadrant) in each of XY, YZ and ZX since the session was cleared";
/// Why the scales are invalid when the planes' circles were run with different bars.
const MIXED_BARS: &str = " not determinable: the planes' circles were run with different bar lengths (bar_length), not in one set-up; run XY, YZ and ZX with one bar";
/// Why a plane's squareness is invalid.
const NO_PLANE: &str = " not available yet: needs a complete circle or arc (both directions, every quadrant) in that plane since the session was cleared";

/// What the summary keeps of a plane's latest complete circle.
#[derive(Clone, Copy, Debug, PartialEq)]
struct PlaneRecord {
    squareness: ResultEntry,
    scale_mean: ResultEntry,
    scale_mismatch: ResultEntry,
    /// The bar's calibrated length the circle was run with, mm.
    bar_length_mm: f32,
}

/// The latest complete circle of each plane (XY, YZ, ZX).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PlaneRecords {
    records: [Option<PlaneRecord>; 3],
    /// The three planes' circles were run with different bar lengths.
    mixed_bars: bool,
}

impl PlaneRecords {
    /// Forgets every plane (a cleared session).
    pub fn clear(&mut self) {
        *self = Self::default();
    }

    /// Files the complete circle in `plane`, run with a bar of `bar_length_mm`, whose results
    /// `results` now holds, and publishes the summary into it (a plane outside the summary, XZ,
    /// files nothing).
    pub fn file(&mut self, plane: Plane, bar_length_mm: f32, results: &mut Results) {
        let k = match plane {
            Plane::XY => 0,
            Plane::YZ => 1,
            Plane::ZX => 2,
            Plane::XZ => return,
        };
        if let Some(r) = self.records.get_mut(k) {
            *r = Some(PlaneRecord {
                squareness: results.get(ResultId::Squareness),
                scale_mean: results.get(ResultId::ScaleMean),
                scale_mismatch: results.get(ResultId::ScaleMismatch),
                bar_length_mm,
            });
        }
        self.publish(results);
    }

    /// Every summary result from the records (invalid where they do not give it).
    fn publish(&mut self, results: &mut Results) {
        for (record, id) in self.records.iter().zip(SQUARENESS) {
            match record.map(|r| r.squareness).filter(|e| e.valid) {
                Some(e) => results.set_budget(id, f64::from(e.value), e.shares),
                None => results.clear(id, id),
            }
        }
        results.clear(ResultId::ScaleX, ResultId::ScaleZ);
        let mut bars = self.records.iter().flatten().map(|r| r.bar_length_mm);
        let first = bars.next();
        self.mixed_bars = bars.any(|b| Some(b) != first);
        if self.mixed_bars {
            return;
        }
        let mut readings = [PlaneScales {
            mean: ScaleReading {
                value: f32::NAN,
                u: f32::NAN,
            },
            mismatch: None,
        }; 3];
        // the readings' shares, in reading order (means, then mismatches)
        let mut shares = [[0.0f32; CONTRIBUTOR_COUNT]; iso230_4::SCALE_READINGS];
        for (p, (record, reading)) in self.records.iter().zip(readings.iter_mut()).enumerate() {
            let Some(r) = record.filter(|r| r.scale_mean.valid) else {
                return;
            };
            reading.mean = own_reading(&r.scale_mean);
            if let Some(s) = shares.get_mut(p) {
                *s = r.scale_mean.shares;
            }
            if r.scale_mismatch.valid {
                reading.mismatch = Some(own_reading(&r.scale_mismatch));
                if let Some(s) = shares.get_mut(p + 3) {
                    *s = r.scale_mismatch.shares;
                }
            }
        }
        let Ok(scales) = iso230_4::axis_scales(&readings) else {
            return;
        };
        for ((id, k), sens) in SCALES
            .into_iter()
            .zip(scales.scale_um_per_m)
            .zip(scales.sensitivity)
        {
            let mut out = [0.0f32; CONTRIBUTOR_COUNT];
            for (c, o) in out.iter_mut().enumerate() {
                let terms = sens
                    .iter()
                    .zip(shares.iter())
                    .map(|(s, sh)| s * sh.get(c).copied().unwrap_or(0.0));
                *o = if c == Contributor::BarOffset as usize {
                    libm::fabsf(terms.sum())
                } else {
                    crate::num::sqrtf(terms.map(|t| t * t).sum())
                };
            }
            results.set_budget(id, f64::from(k), out);
        }
    }

    /// Why the summary result `id` is invalid (`None`: it is valid, or not a summary result).
    pub fn why_invalid(&self, id: ResultId) -> Option<&'static str> {
        if SQUARENESS.contains(&id) {
            Some(NO_PLANE)
        } else if SCALES.contains(&id) {
            Some(if self.mixed_bars { MIXED_BARS } else { NOT_YET })
        } else {
            None
        }
    }
}

/// A reading's value with the u that weights it: every share but the bar's length (common to
/// the planes, propagated apart).
fn own_reading(e: &ResultEntry) -> ScaleReading {
    let u2: f32 = e
        .shares
        .iter()
        .enumerate()
        .filter(|(c, _)| *c != Contributor::BarOffset as usize)
        .map(|(_, s)| s * s)
        .sum();
    ScaleReading {
        value: e.value,
        u: crate::num::sqrtf(u2),
    }
}
