//! The feed-rate sweep: the same circle (centre, radius, arc) run at several feeds; each
//! feed's latest complete circle (both directions) since the session was cleared is kept, the
//! latest [`SWEEP_FEEDS`] feeds, one sweep per plane (XY, YZ, ZX: a three-plane test between
//! the feeds of a sweep does not end it; a circle of the same plane with another centre,
//! radius or arc starts a new one; a feed run again replaces its point). Published, for the
//! plane of the latest complete circle: the feeds kept, the servo mismatch over them and the
//! feed limit of G(b) at [`SWEEP_G_GROWTH`] ([`iso230_4::feed_limit`]).

use super::circle::CircleGeometry;
use super::results::{ResultId, ResultSink, Results};
use crate::metrology::iso230_4::{self, FeedLimitError, FeedPoint};
use crate::metrology::pattern::Plane;

/// Feeds a sweep keeps (the latest; an older one is forgotten when a ninth feed is run).
pub const SWEEP_FEEDS: usize = 8;

/// The growth of G(b) over the lowest feed's at which the feed limit is read: 20 %. A
/// constant, not a configuration field: each feed's G(b) is published, so a client reads any
/// other fraction from them.
pub const SWEEP_G_GROWTH: f32 = 0.2;

/// Why `sweep_feed_limit` is invalid, by [`FeedLimitError`].
const TOO_FEW: &str = " not available yet: a sweep needs the same circle (centre, radius, arc, plane) complete at three feeds or more since the session was cleared";
const NOT_REACHED: &str =
    " not reached: G(b) stays within 20 % of the lowest feed's up to the highest feed run";

/// One plane's sweep: its circle and its feeds.
#[derive(Clone, Debug, Default, PartialEq)]
struct Sweep {
    /// The circle's geometry with the feed unset (NaN): what makes two runs one sweep.
    circle: Option<CircleGeometry>,
    points: heapless::Vec<FeedPoint, SWEEP_FEEDS>,
}

/// The sweep of each plane (XY, YZ, ZX) and which one is published.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FeedSweep {
    sweeps: [Sweep; 3],
    /// The plane of the latest complete circle (the published sweep).
    latest: usize,
    /// Why the feed limit is not available, as of the last publish.
    limit: Option<FeedLimitError>,
}

impl FeedSweep {
    /// Forgets every sweep (a cleared session).
    pub fn clear(&mut self) {
        *self = Self::default();
    }

    /// Files the complete circle of `geometry` whose results `results` now holds (its G(b)
    /// and servo mismatch; a circle without a programmed feed, or in XZ, files nothing) and
    /// publishes its plane's sweep.
    pub fn file(&mut self, geometry: CircleGeometry, results: &mut Results) {
        let feed = geometry.feed_mm_per_min;
        let g = results.get(ResultId::GBidir);
        let k = match geometry.fit.geometry.plane {
            Plane::XY => 0,
            Plane::YZ => 1,
            Plane::ZX => 2,
            Plane::XZ => return,
        };
        if !(feed > 0.0 && g.valid) {
            return;
        }
        let Some(sweep) = self.sweeps.get_mut(k) else {
            return;
        };
        let circle = CircleGeometry {
            feed_mm_per_min: f32::NAN,
            ..geometry
        };
        if sweep.circle != Some(circle) {
            sweep.points.clear();
            sweep.circle = Some(circle);
        }
        let tau = results.get(ResultId::ServoMismatch);
        let point = FeedPoint {
            feed_mm_per_min: feed,
            g_bidir_um: [g.value, g.std_uncertainty],
            servo_mismatch_ms: if tau.valid {
                [tau.value, tau.std_uncertainty]
            } else {
                [f32::NAN; 2]
            },
        };
        // the feed's earlier point goes, or (a new feed, the sweep full) the oldest; rebuilt
        // rather than `Vec::remove`, whose index check is a panic path in the firmware
        let replaces = sweep.points.iter().any(|p| p.feed_mm_per_min == feed);
        let drop_oldest = usize::from(sweep.points.is_full() && !replaces);
        let mut kept = heapless::Vec::<FeedPoint, SWEEP_FEEDS>::new();
        for p in sweep
            .points
            .iter()
            .skip(drop_oldest)
            .filter(|p| p.feed_mm_per_min != feed)
        {
            // at most SWEEP_FEEDS − 1 kept: the pushes cannot fail
            let _ = kept.push(*p);
        }
        let _ = kept.push(point);
        sweep.points = kept;
        self.latest = k;
        self.publish(results);
    }

    fn publish(&mut self, results: &mut Results) {
        let points = self
            .sweeps
            .get(self.latest)
            .map_or(&[][..], |s| s.points.as_slice());
        results.set(ResultId::SweepFeeds, points.len() as f64, 0.0);
        results.clear(ResultId::SweepServoMismatch, ResultId::SweepFeedLimit);
        if let Some([tau, u]) = iso230_4::sweep_servo_mismatch(points) {
            results.set(ResultId::SweepServoMismatch, f64::from(tau), f64::from(u));
        }
        match iso230_4::feed_limit(points, SWEEP_G_GROWTH) {
            Ok([f, u]) => {
                self.limit = None;
                results.set(ResultId::SweepFeedLimit, f64::from(f), f64::from(u));
            }
            Err(e) => self.limit = Some(e),
        }
    }

    /// Why the sweep's result `id` is invalid (`None`: not a sweep result, or valid).
    pub fn why_invalid(&self, id: ResultId) -> Option<&'static str> {
        match id {
            ResultId::SweepFeeds | ResultId::SweepServoMismatch => Some(TOO_FEW),
            ResultId::SweepFeedLimit => Some(match self.limit {
                Some(FeedLimitError::NotReached) => NOT_REACHED,
                _ => TOO_FEW,
            }),
            _ => None,
        }
    }
}
