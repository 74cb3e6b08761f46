//! Runs that start and stop themselves (`run_trigger = FEED_IN`, CIRCLE only), as ball-bar
//! users know it: the part program's radial feed-in onto the circle and the data arc that
//! follows are the trigger, read from the axes' positions (the encoders), not from the bar.
//!
//! - **Start**: once the tool has been at least [`FEED_IN_MIN_MM`] outside the circle (the
//!   feed-in point), the run starts at the first sample on the circle (within
//!   [`ON_CIRCLE_MM`] of the radius) whose step from the previous sample runs along the circle
//!   in the armed direction more than across it: the feed-in's radial samples stay out.
//! - **Stop**: after the sample at which the run has swept `circle_arc` degrees (the overshoot
//!   stays out; the run ends as the next sample arrives, before it is used), or — `circle_arc`
//!   not set — before the first sample off the circle whose step runs more across the circle
//!   than along it (the feed-out).
//!
//! A client's START and STOP keep working at any time. While an armed run waits, the procedure
//! note (CANopen 0x3007, `SESS:NOTE?`) says what it waits for.

use super::circle::CircleGeometry;
use super::pattern::Direction;
use crate::acquisition::MAX_AXES;
use crate::config::is_set;
use crate::metrology::pattern::Plane;

/// Radial distance outside the circle that marks the feed-in point, mm (ncgen's shortest
/// feed-in is 0.1 mm).
pub const FEED_IN_MIN_MM: f32 = 0.05;
/// Radial distance from the circle within which the tool is on it, mm (above the servo's
/// following and reversal errors, below any feed-in).
pub const ON_CIRCLE_MM: f32 = 0.01;

/// What the trigger decides at a sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TriggerEvent {
    /// Nothing changes.
    None,
    /// The run starts with this sample.
    Start,
    /// The run ends before this sample (the data arc was complete at the previous one, or the
    /// feed-out began).
    Stop,
}

/// The trigger of one armed CIRCLE run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArcTrigger {
    plane: Plane,
    centre_mm: [f32; 2],
    radius_mm: f32,
    /// +1 CCW, −1 CW.
    sign: f32,
    /// Data arc to sweep, rad (NaN: until the feed-out).
    span_rad: f64,
    fed_in: bool,
    running: bool,
    /// The data arc was complete at the last sample.
    arc_complete: bool,
    /// Swept so far, rad: summed in f64 (tens of thousands of steps of ~1e-4 rad would lose
    /// ~0.01° in an f32 sum).
    swept_rad: f64,
    /// The previous sample's offset from the centre, mm.
    prev: Option<[f32; 2]>,
}

impl ArcTrigger {
    /// The trigger of a run of `direction` on `geometry`, sweeping `arc_deg` (NaN: until the
    /// feed-out).
    pub fn new(geometry: &CircleGeometry, direction: Direction, arc_deg: f32) -> Self {
        let g = &geometry.fit.geometry;
        Self {
            plane: g.plane,
            centre_mm: [g.centre_u_mm, g.centre_v_mm],
            radius_mm: geometry.radius_mm,
            sign: direction.sign() as f32,
            span_rad: if is_set(arc_deg) {
                f64::from(arc_deg).to_radians()
            } else {
                f64::NAN
            },
            fed_in: false,
            running: false,
            arc_complete: false,
            swept_rad: 0.0,
            prev: None,
        }
    }

    /// The run started (by the trigger or by a client's START): the arc is swept from the run's
    /// first sample (after a client's START, the next sample's own step does not count).
    pub fn started(&mut self) {
        if !self.running {
            self.running = true;
            self.swept_rad = 0.0;
            self.prev = None;
        }
    }

    /// True once the tool has been at the feed-in point.
    pub fn fed_in(&self) -> bool {
        self.fed_in
    }

    /// The decision at a sample with the canonical axis positions `axes` (mm).
    #[inline(never)]
    pub fn on_sample(&mut self, axes: &[f32; MAX_AXES]) -> TriggerEvent {
        let (u, v) = self.plane.uv(axes);
        let d = [u - self.centre_mm[0], v - self.centre_mm[1]];
        let r = crate::num::sqrtf(d[0] * d[0] + d[1] * d[1]);
        let off_circle = r - self.radius_mm;
        let Some(prev) = self.prev.replace(d) else {
            self.fed_in |= off_circle >= FEED_IN_MIN_MM;
            return TriggerEvent::None;
        };
        // the step along the circle (in the run's direction) and across it, mm
        let step = [d[0] - prev[0], d[1] - prev[1]];
        let (along, across) = if r > 0.0 {
            (
                self.sign * (d[0] * step[1] - d[1] * step[0]) / r,
                libm::fabsf(d[0] * step[0] + d[1] * step[1]) / r,
            )
        } else {
            (0.0, 0.0)
        };
        let on_circle = libm::fabsf(off_circle) <= ON_CIRCLE_MM;
        if !self.running {
            self.fed_in |= off_circle >= FEED_IN_MIN_MM;
            if self.fed_in && on_circle && along > across {
                self.running = true;
                self.swept_rad = 0.0;
                return TriggerEvent::Start;
            }
            return TriggerEvent::None;
        }
        if self.arc_complete || (!on_circle && across > libm::fabsf(along)) {
            return TriggerEvent::Stop;
        }
        // the angle of the step, first order (a step is well under a degree)
        if r > 0.0 {
            self.swept_rad += f64::from(along / r);
        }
        self.arc_complete = self.swept_rad >= self.span_rad;
        TriggerEvent::None
    }
}
