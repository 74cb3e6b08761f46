//! The feed-rate sweep: the same circle run at several feeds. Servo mismatch τ_u − τ_v is a
//! time, so a pure lag mismatch gives the same τ at every feed while the out-of-squareness it
//! causes, S_ccw − S_cw = 2ω(τ_u − τ_v), grows with the feed (ω = F/60R): the sweep's τ is the
//! weighted mean of the feeds' (the least-squares slope of S_ccw − S_cw against 2ω through the
//! origin). G(b) grows with the feed where the servo's contouring error does: the **feed
//! limit** is the feed at which G(b) first exceeds the lowest feed's G(b) by a stated fraction,
//! interpolated linearly between the two feeds about the crossing.

/// Feeds a sweep needs before it reports (its servo mismatch and feed limit): three, so that a
/// limit is read against more than the two feeds that bound it and a mismatch that is not a
/// pure lag (τ moving with the feed) shows as scatter rather than as a line through two points.
pub const SWEEP_MIN_FEEDS: usize = 3;

/// One feed's circle as the sweep reads it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FeedPoint {
    /// The programmed feed, mm/min.
    pub feed_mm_per_min: f32,
    /// The bi-directional circular deviation G(b) and its standard uncertainty, µm.
    pub g_bidir_um: [f32; 2],
    /// The servo mismatch τ_u − τ_v and its standard uncertainty, ms (NaN: not available).
    pub servo_mismatch_ms: [f32; 2],
}

/// Why the feed limit is not available.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FeedLimitError {
    /// Fewer than [`SWEEP_MIN_FEEDS`] feeds.
    TooFewFeeds,
    /// G(b) stays within the stated growth up to the highest feed run.
    NotReached,
}

/// The servo mismatch of the sweep, ms, with its standard uncertainty: the mean of the feeds'
/// weighted by 1/u² (those with a finite τ and u > 0); `None` with fewer than
/// [`SWEEP_MIN_FEEDS`].
pub fn sweep_servo_mismatch(points: &[FeedPoint]) -> Option<[f32; 2]> {
    let (mut sw, mut swx, mut n) = (0.0f32, 0.0f32, 0u32);
    for p in points {
        let [tau, u] = p.servo_mismatch_ms;
        if tau.is_finite() && u.is_finite() && u > 0.0 {
            let w = 1.0 / (u * u);
            sw += w;
            swx += w * tau;
            n += 1;
        }
    }
    (n as usize >= SWEEP_MIN_FEEDS && sw > 0.0).then(|| [swx / sw, crate::num::sqrtf(1.0 / sw)])
}

/// The feed limit and its standard uncertainty, mm/min: the feed at which G(b) first exceeds
/// (1 + `growth`) times the lowest feed's G(b), linear between the feeds about the crossing;
/// `points` in any order. The u propagates each G(b)'s u (the lowest feed's, and the two
/// about the crossing) through the interpolation, each taken apart (finite differences of one
/// u).
pub fn feed_limit(points: &[FeedPoint], growth: f32) -> Result<[f32; 2], FeedLimitError> {
    // ascending feed, by index (no allocation: at most a few feeds)
    let n = points.len();
    if n < SWEEP_MIN_FEEDS {
        return Err(FeedLimitError::TooFewFeeds);
    }
    let nth = |k: usize| -> Option<&FeedPoint> {
        // the k-th smallest feed (ties by index)
        points.iter().enumerate().find_map(|(i, p)| {
            let rank = points
                .iter()
                .enumerate()
                .filter(|(j, q)| {
                    q.feed_mm_per_min < p.feed_mm_per_min
                        || (q.feed_mm_per_min == p.feed_mm_per_min && *j < i)
                })
                .count();
            (rank == k).then_some(p)
        })
    };
    let lowest = nth(0).ok_or(FeedLimitError::TooFewFeeds)?;
    // the crossing with G(b) of (reference, a, b) given: the feed between a and b
    let cross = |g_ref: f32, a: &FeedPoint, g_a: f32, b: &FeedPoint, g_b: f32| {
        let threshold = (1.0 + growth) * g_ref;
        let t = (threshold - g_a) / (g_b - g_a);
        a.feed_mm_per_min + t * (b.feed_mm_per_min - a.feed_mm_per_min)
    };
    let threshold = (1.0 + growth) * lowest.g_bidir_um[0];
    for k in 1..n {
        let (Some(a), Some(b)) = (nth(k - 1), nth(k)) else {
            break;
        };
        let [g_b, u_b] = b.g_bidir_um;
        if g_b <= threshold {
            continue;
        }
        let [g_a, u_a] = a.g_bidir_um;
        let [g_0, u_0] = lowest.g_bidir_um;
        let f = cross(g_0, a, g_a, b, g_b);
        // each G(b) moved by its u alone (the lowest feed's is a's too when a is the lowest)
        let a_is_lowest = k == 1;
        let d0 = if a_is_lowest {
            cross(g_0 + u_0, a, g_a + u_a, b, g_b) - f
        } else {
            cross(g_0 + u_0, a, g_a, b, g_b) - f
        };
        let da = if a_is_lowest {
            0.0
        } else {
            cross(g_0, a, g_a + u_a, b, g_b) - f
        };
        let db = cross(g_0, a, g_a, b, g_b + u_b) - f;
        return Ok([f, crate::num::sqrtf(d0 * d0 + da * da + db * db)]);
    }
    Err(FeedLimitError::NotReached)
}
