//! The touch-probe sphere measurement (pattern PROBE; seed 002 Fig. 5.12): nine touches along
//! the sphere's normals — the directions the simulated pod probes
//! ([`crate::vmt::motion::probing_directions`]: the pole, four at 45° latitude, four on the
//! equator) — each a probing move from `clearance_mm` outside the contact sphere to
//! `overtravel_mm` inside it (`G38.2` on LinuxCNC, `G31` skip on an ISO/Fanuc control: the
//! dialect's one difference here), then back out along the normal. Between touches the stylus
//! rises to `safe_mm` above the sphere, crosses over and comes down onto the next approach
//! point, so no move but a probing one comes near the sphere. The pod latches its encoders at
//! the probe's edge; the program need not print positions.

use std::fmt::Write as _;

use ballpod::config::CirclePlane;

use super::{Dialect, NcError, num};
use crate::vmt::motion::probing_directions;

/// A sphere measurement.
#[derive(Clone, Debug, PartialEq)]
pub struct SphereTest {
    /// The sphere's nominal centre, as the stylus ball's centre (X, Y, Z), mm.
    pub centre_mm: [f64; 3],
    /// Sphere radius plus stylus ball radius (the contact radius), mm.
    pub contact_radius_mm: f64,
    /// The rotary axes during the measurement (B, C), degrees.
    pub rotary_deg: [f64; 2],
    /// Probing feed, mm/min.
    pub probe_feed_mm_per_min: f64,
    /// Positioning feed between touches, mm/min.
    pub feed_mm_per_min: f64,
    /// Start of each probing move outside the contact sphere, mm.
    pub clearance_mm: f64,
    /// End of each probing move inside the contact sphere, mm.
    pub overtravel_mm: f64,
    /// Height above the contact sphere for crossing between touches, mm.
    pub safe_mm: f64,
}

impl SphereTest {
    /// A measurement of the sphere at `centre_mm` (stylus-ball centre coordinates) of contact
    /// radius `contact_radius_mm` at rotary positions `rotary_deg`, with the usual distances
    /// (0.5 mm clearance and overtravel, 5 mm safe height, probing at 100 mm/min, positioning
    /// at 1000 mm/min); every value finite, the radius and feeds > 0.
    pub fn new(
        centre_mm: [f64; 3],
        contact_radius_mm: f64,
        rotary_deg: [f64; 2],
    ) -> Result<Self, NcError> {
        let bad = |field: &'static str, x: f64| NcError {
            field,
            what: format!("{x}: must be finite"),
        };
        for (x, f) in centre_mm
            .iter()
            .zip(["--sphere-x", "--sphere-y", "--sphere-z"])
        {
            if !x.is_finite() {
                return Err(bad(f, *x));
            }
        }
        for (x, f) in rotary_deg.iter().zip(["--b-deg", "--c-deg"]) {
            if !x.is_finite() {
                return Err(bad(f, *x));
            }
        }
        if !(contact_radius_mm.is_finite() && contact_radius_mm > 0.0) {
            return Err(NcError {
                field: "--contact-radius",
                what: format!("{contact_radius_mm} mm: must be > 0"),
            });
        }
        Ok(Self {
            centre_mm,
            contact_radius_mm,
            rotary_deg,
            probe_feed_mm_per_min: 100.0,
            feed_mm_per_min: 1000.0,
            clearance_mm: 0.5,
            overtravel_mm: 0.5,
            safe_mm: 5.0,
        })
    }

    /// The point at distance `r_mm` from the centre along unit normal `n`.
    fn on(&self, n: [f64; 3], r_mm: f64) -> [f64; 3] {
        std::array::from_fn(|i| self.centre_mm[i] + n[i] * r_mm)
    }

    /// The part program in `dialect`.
    pub fn program(&self, dialect: Dialect) -> String {
        let mut out = String::new();
        let xyz = |p: [f64; 3]| format!("X{} Y{} Z{}", num(p[0]), num(p[1]), num(p[2]));
        let header = [
            "ballpod touch-probe sphere measurement, nine touches along the normals".to_string(),
            format!(
                "sphere centre X {} Y {} Z {} as the stylus ball centre, contact radius {} mm, B {} C {} deg",
                num(self.centre_mm[0]),
                num(self.centre_mm[1]),
                num(self.centre_mm[2]),
                num(self.contact_radius_mm),
                num(self.rotary_deg[0]),
                num(self.rotary_deg[1])
            ),
            format!(
                "probing {} mm/min from {} mm outside to {} mm inside, crossing {} mm above",
                num(self.probe_feed_mm_per_min),
                num(self.clearance_mm),
                num(self.overtravel_mm),
                num(self.safe_mm)
            ),
            "pod set-up: pattern PROBE, arm and start before the first touch, stop after the last"
                .to_string(),
            "start clear of the sphere: the rotary axes turn first, then the stylus goes over it"
                .to_string(),
        ];
        dialect.begin(&mut out, &header);
        let _ = writeln!(out, "{}", dialect.modal(CirclePlane::XY));
        let top = self.centre_mm[2] + self.contact_radius_mm + self.safe_mm;
        let approach_r = self.contact_radius_mm + self.clearance_mm;
        let first = self.on(probing_directions()[0], approach_r);
        // the rotary axes first, where the program starts (clear of the sphere), then over it
        let _ = writeln!(
            out,
            "G0 B{} C{}",
            num(self.rotary_deg[0]),
            num(self.rotary_deg[1])
        );
        let _ = writeln!(
            out,
            "G0 X{} Y{} Z{}",
            num(first[0]),
            num(first[1]),
            num(top)
        );
        for (k, n) in probing_directions().into_iter().enumerate() {
            let approach = self.on(n, approach_r);
            let end = self.on(n, self.contact_radius_mm - self.overtravel_mm);
            dialect.comment(&mut out, &format!("touch {}", k + 1));
            // over the approach point at the safe height, then down onto it
            let _ = writeln!(
                out,
                "G1 X{} Y{} Z{} F{}",
                num(approach[0]),
                num(approach[1]),
                num(top),
                num(self.feed_mm_per_min)
            );
            let _ = writeln!(out, "G1 {}", xyz(approach));
            let _ = writeln!(
                out,
                "{} {} F{}",
                dialect.probe_word(),
                xyz(end),
                num(self.probe_feed_mm_per_min)
            );
            // back out along the normal, then up
            let _ = writeln!(out, "G1 {} F{}", xyz(approach), num(self.feed_mm_per_min));
            let _ = writeln!(out, "G1 Z{}", num(top));
        }
        dialect.end(&mut out);
        out
    }
}
