//! CIRCLE: the ISO 230-4 circular test about the socket, in the configured plane, full circle
//! or partial arc.
//!
//! Each run feeds one direction of a [`CircularTest`]; arming a new run of a direction
//! replaces that direction's previous run (runs are never merged), the other direction is
//! kept while the geometry stays the same. At the end of a run: the run's limaçon fit, G and F
//! of its direction; once the latest CCW and CW runs are both complete: G(b), H, the mean
//! bi-directional radial deviation and (arcs with samples in all four quadrants) the ball-bar
//! diagnoses, and the servo mismatch when the feed is set.

use super::pattern::Direction;
use super::results::{ResultId, ResultSink, Results};
use crate::config::{CirclePlane, Field, TestSetup, is_set};
use crate::in_place::init_in_place;
use crate::metrology::bar_budget::BarBudget;
use crate::metrology::bar_budget::FigureKind::{Radial, Shape};
use crate::metrology::circle_fit::{CircleFitConfig, CircleFitError, SampleUse};
use crate::metrology::iso230_4::{self, CircularTest, Diagnosis, Fault, NotDeterminable};
use crate::metrology::pattern::{ArcGeometry, Plane, Sensitivity};
use core::mem::MaybeUninit;

/// Angular bins of the ISO 230-4 profile (1° each; 14.3 KiB of state: each bin its sums of
/// ΔL, n and the traced radius, and its count).
pub const ISO_BINS: usize = 360;

/// The geometry of a circular test, from the configuration's set-up.
#[derive(Clone, Copy, Debug)]
pub struct CircleGeometry {
    /// The fit: plane, centre (the socket), outward sensitivity, minimum arc.
    pub fit: CircleFitConfig,
    /// Nominal radius, mm.
    pub radius_mm: f32,
    /// Programmed feed, mm/min (NaN if not set: no servo mismatch).
    pub feed_mm_per_min: f32,
}

impl CircleGeometry {
    /// The geometry of the set-up, or the first field it lacks (the circle centre's in-plane
    /// coordinates and the radius).
    pub fn from_config(t: &TestSetup) -> Result<Self, Field> {
        let (plane, u, v) = match t.circle_plane {
            CirclePlane::XY => (Plane::XY, 0, 1),
            CirclePlane::YZ => (Plane::YZ, 1, 2),
            CirclePlane::ZX => (Plane::ZX, 2, 0),
        };
        let c = |k: u8| {
            t.circle_centre_mm
                .get(usize::from(k))
                .copied()
                .filter(|x| is_set(*x))
                .ok_or(Field::CircleCentreMm(k))
        };
        let (cu, cv) = (c(u)?, c(v)?);
        if !is_set(t.circle_radius_mm) {
            return Err(Field::CircleRadiusMm);
        }
        Ok(Self {
            fit: CircleFitConfig {
                geometry: ArcGeometry {
                    plane,
                    centre_u_mm: cu,
                    centre_v_mm: cv,
                    sensitivity: Sensitivity::Outward,
                },
                min_arc_deg: t.circle_min_arc_deg,
            },
            radius_mm: t.circle_radius_mm,
            feed_mm_per_min: t.circle_feed_mm_per_min,
        })
    }
}

/// The same circular test: field by field, with an unset (NaN) radius or feed equal to an unset
/// one (a derived `==` made every run without a programmed feed a new test and lost the
/// bi-directional figures).
impl PartialEq for CircleGeometry {
    fn eq(&self, other: &Self) -> bool {
        let same = |a: f32, b: f32| a == b || (a.is_nan() && b.is_nan());
        self.fit == other.fit
            && same(self.radius_mm, other.radius_mm)
            && same(self.feed_mm_per_min, other.feed_mm_per_min)
    }
}

/// The results of one direction's figures: G, F_max, F_min.
const fn figure_ids(d: Direction) -> (ResultId, ResultId, ResultId) {
    match d {
        Direction::Ccw => (ResultId::GCcw, ResultId::FMaxCcw, ResultId::FMinCcw),
        Direction::Cw => (ResultId::GCw, ResultId::FMaxCw, ResultId::FMinCw),
    }
}

pub(crate) const fn dir_index(d: Direction) -> usize {
    match d {
        Direction::Ccw => 0,
        Direction::Cw => 1,
    }
}

/// The circular test: both directions' latest runs (state 11.9 KiB).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CircleRun {
    /// The test's geometry; `None` before the first run (and after [`CircleRun::clear`]).
    geometry: Option<CircleGeometry>,
    test: CircularTest<ISO_BINS>,
    /// A completed run (with a fit) of each direction, CCW and CW.
    complete: [bool; 2],
    /// One sample's ΔL noise of the running direction as of the last refresh, µm, for the
    /// live u ([`Self::refresh_live_noise`]; NaN before the first, or when the profile is too
    /// short to tell).
    live_noise_um: f32,
    /// The count of used samples of the running direction's run at which the noise is next
    /// taken from its profile.
    next_noise_at: u32,
    /// The centre's shares (contributor `socket`) of the running direction's (r0, e_u, e_v)
    /// as of the last noise refresh ([`CircularTest::centre_shares`]; 0 before the first),
    /// µm.
    live_centre_um: [f32; 3],
    /// The step of the centre's refresh due at the next sample after a noise refresh
    /// ([`Self::refresh_live_centre`]).
    centre_step: CentreStep,
    /// The centre's u the shares are taken for (step [`CentreStep::Shares`]), µm.
    centre_u_um: f32,
    /// Runs begun in each direction (CCW, CW) since boot, and both at a new test or
    /// [`CircleRun::clear`]: a [`FiguresRequest`] computes and publishes only while the runs it
    /// read are still the latest.
    epochs: [u32; 2],
}

/// What a run's end leaves to a job ([`super::job`]): the ISO 230-4 figures of the run's
/// direction (G, F) and, once both directions are complete, the bi-directional figures and the
/// diagnoses ([`CircleRun::figures`]: 0.1–0.3 s on the pod).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FiguresRequest {
    /// The run's direction.
    pub direction: Direction,
    /// The centre's standard uncertainty as entered (`circle_u_centre_um`), µm; the job takes
    /// the traced offset's where it contradicts it ([`CircularTest::centre_u_um`]).
    pub u_centre_entered_um: f32,
    /// Both directions were complete when the run ended: the bi-directional figures and the
    /// diagnoses too.
    pub both_directions: bool,
    /// The bar's budget as configured when the run ended.
    pub bar: BarBudget,
    /// The bar's calibrated length when the run ended, mm (the mean scale's reference).
    pub bar_length_mm: f32,
    /// The test's geometry (the three-plane summary and the feed sweep file the results
    /// under it).
    pub geometry: Option<CircleGeometry>,
    /// [`CircleRun`]'s run epochs when the run ended.
    epochs: [u32; 2],
}

/// Samples between two refreshes of the sample noise the live u of a CIRCLE run takes (the
/// profile's third differences, as the run's results: a whole profile's work, spread to a few
/// dozen instructions a sample at this interval, 1 s at 1 kHz (`cargo bench-m4` counts it);
/// the noise is the instrument's and the machine's and moves slowly). While the profile is too short to tell it, the noise is
/// tried every [`LIVE_NOISE_RETRY`] samples instead. Counted from the run's start.
pub const LIVE_NOISE_EVERY: u32 = 1024;

/// Samples between two tries of the noise while the profile is too short to tell it (eight
/// runs of four filled 1° bins): the live u takes the residual's σ until then, which the
/// results never do once the profile tells the noise, so the profile is tried often enough
/// to tell it before e is observable (the minimum arc is at least 10°).
pub const LIVE_NOISE_RETRY: u32 = 256;

/// The live refresh after the noise, a step a sample: each step is one long computation
/// (the noise ≈ 62 000 Cortex-M4F instructions, the traced centre ≈ 154 000, the shares), so
/// the application task's turn is the longest of them, not their sum (6.4 ms of block queue
/// at 10 kHz).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum CentreStep {
    /// Nothing due.
    Done,
    /// The centre's u: the entered one, or the traced offset where it contradicts it.
    TracedCentre,
    /// The centre's shares for that u.
    Shares,
}

/// The fit the state holds before the first run (never fed: the test has no geometry).
const NO_TEST: CircleFitConfig = CircleFitConfig {
    geometry: ArcGeometry {
        plane: Plane::XY,
        centre_u_mm: 0.0,
        centre_v_mm: 0.0,
        sensitivity: Sensitivity::Outward,
    },
    min_arc_deg: 360.0,
};

impl CircleRun {
    /// No test yet, built in place in `slot` (the state never passes through the stack).
    pub fn init(slot: &mut MaybeUninit<Self>) -> &mut Self {
        init_in_place!(slot, Self {
            geometry: None,
            complete: [false; 2],
            live_noise_um: f32::NAN,
            next_noise_at: 0,
            live_centre_um: [0.0; 3],
            centre_step: CentreStep::Done,
            centre_u_um: 0.0,
            epochs: [0; 2],
        } in place {
            test: |s| CircularTest::init(s, NO_TEST, f32::NAN),
        })
    }

    /// Forgets the test: the next run starts a new one.
    pub fn clear(&mut self) {
        self.geometry = None;
        self.epochs = self.epochs.map(|e| e.wrapping_add(1));
    }

    /// Whether the runs `request` read are still this test's latest (no run of theirs begun
    /// again, no new test since).
    pub fn current(&self, request: &FiguresRequest) -> bool {
        let k = dir_index(request.direction);
        if request.both_directions {
            self.epochs == request.epochs
        } else {
            self.epochs.get(k) == request.epochs.get(k)
        }
    }

    /// A run of direction `d` begins with `geometry`: a new geometry starts a new test (in
    /// place), else the direction's previous run is forgotten.
    pub fn begin_run(&mut self, geometry: CircleGeometry, d: Direction) {
        self.live_noise_um = f32::NAN;
        self.next_noise_at = LIVE_NOISE_RETRY;
        self.live_centre_um = [0.0; 3];
        self.centre_step = CentreStep::Done;
        if self.geometry != Some(geometry) {
            self.geometry = Some(geometry);
            self.test.restart(geometry.fit, geometry.radius_mm);
            self.complete = [false; 2];
            self.epochs = self.epochs.map(|e| e.wrapping_add(1));
        } else {
            self.test.reset_direction(d);
            let k = dir_index(d);
            if let Some(c) = self.complete.get_mut(k) {
                *c = false;
            }
            if let Some(e) = self.epochs.get_mut(k) {
                *e = e.wrapping_add(1);
            }
        }
    }

    /// Feeds one sample of the run in direction `d`.
    pub fn update(&mut self, s: &crate::acquisition::Sample, d: Direction) -> SampleUse {
        self.test.update(s, d)
    }

    /// The direction n (u, v) of a sample at `axes` from the test's centre (`None` before the
    /// first run, or at the centre).
    pub fn direction_of(&self, axes: &[f32; crate::acquisition::MAX_AXES]) -> Option<[f32; 2]> {
        self.geometry?.fit.geometry.direction(axes)
    }

    /// The arc turned by the latest run of direction `d`, degrees.
    pub fn arc_deg(&self, d: Direction) -> f32 {
        self.test.fit(d).arc_deg()
    }

    /// The live (r0, e_u, e_v) of the run of direction `d`, µm, and at every
    /// [`super::LIVE_U_EVERY`]th used sample of the run their u with the bar's shares (as the
    /// seed 002 steps' live fit; `last_u_at`: the count of the last refresh). The u takes one sample's noise from the
    /// profile, as [`CircularTest::fit_estimate`] does at the run's end, every
    /// [`LIVE_NOISE_EVERY`] used samples (every [`LIVE_NOISE_RETRY`] while the profile is too
    /// short to tell it, and the residual's σ meanwhile), and the centre's share
    /// (`circle_u_centre`, or the traced offset where it contradicts that, as at the run's
    /// end) through the profile as of the same refresh.
    pub fn live(
        &mut self,
        d: Direction,
        config: &crate::config::Config,
        last_u_at: &mut u32,
    ) -> (Option<[f32; 3]>, Option<[f32; 3]>) {
        let used = self.test.fit(d).samples();
        let mut refreshed = false;
        if used >= self.next_noise_at {
            self.refresh_live_noise(d, used);
        } else if self.centre_step != CentreStep::Done {
            refreshed = self.refresh_live_centre(d, config.setup.circle_u_centre_um);
        }
        // the u at its interval, and at once when a refresh is complete
        let with_u = super::live_fit::live_u_due(used, last_u_at) || refreshed;
        let (noise, socket) = (self.live_noise_um, self.live_centre_um);
        super::live_fit::live_fit(self.test.fit(d), noise, socket, with_u, config)
    }

    /// Takes the sample noise of the run of direction `d` from its profile
    /// ([`CircularTest::noise_um`]) at `used` samples, and when to take it next; the centre's
    /// shares follow at the next samples ([`Self::refresh_live_centre`]).
    #[inline(never)] // off the per-sample path: one sample in [`LIVE_NOISE_EVERY`]
    fn refresh_live_noise(&mut self, d: Direction, used: u32) {
        self.live_noise_um = self.test.noise_um(d);
        self.centre_step = CentreStep::TracedCentre;
        let every = if self.live_noise_um.is_nan() {
            LIVE_NOISE_RETRY
        } else {
            LIVE_NOISE_EVERY
        };
        self.next_noise_at = used.saturating_add(every);
    }

    /// The centre's refresh, a step a sample ([`CentreStep`]): the centre's u, `u_centre_um`
    /// or the traced offset where it contradicts that
    /// ([`iso230_4::TracedCentre::centre_u_um`]), then the centre's shares for it
    /// ([`CircularTest::centre_shares`]; the last ones kept while the fit is not available).
    /// True when this step completed the refresh.
    #[inline(never)] // off the per-sample path: two samples in [`LIVE_NOISE_EVERY`]
    fn refresh_live_centre(&mut self, d: Direction, u_centre_um: f32) -> bool {
        match self.centre_step {
            CentreStep::TracedCentre => {
                self.centre_u_um = self.test.centre_u_um(d, u_centre_um);
                self.centre_step = CentreStep::Shares;
                false
            }
            CentreStep::Shares | CentreStep::Done => {
                if let Ok(s) = self.test.centre_shares(d, self.centre_u_um) {
                    self.live_centre_um = s;
                }
                self.centre_step = CentreStep::Done;
                true
            }
        }
    }

    /// Ends the run of direction `d`: whether it has a fit (`Err`: too short an arc, too few
    /// samples — the run is aborted), and what is left to a job ([`Self::figures`]): the run's
    /// results, which are invalid until it publishes them (cleared here). The centre's entered
    /// standard uncertainty is `u_centre_um`. A least-squares solve: what is longer runs in the
    /// job (the traced centre and the centre's shares).
    pub fn finish_run(
        &mut self,
        d: Direction,
        results: &mut Results,
        u_centre_um: f32,
        bar: BarBudget,
        bar_length_mm: f32,
    ) -> Result<FiguresRequest, CircleFitError> {
        results.clear(ResultId::GBidir, ResultId::CentreDv);
        results.clear(ResultId::ReversalUPos, ResultId::ScaleMean);
        results.clear(ResultId::LateralPlayU, ResultId::ShareLateralPlayV);
        let (g, fmax, fmin) = figure_ids(d);
        for id in [
            g,
            fmax,
            fmin,
            ResultId::EccU,
            ResultId::EccV,
            ResultId::R0,
            ResultId::ResidualRms,
            ResultId::Arc,
        ] {
            results.clear(id, id);
        }
        self.test.fit(d).estimate()?;
        if let Some(c) = self.complete.get_mut(dir_index(d)) {
            *c = true;
        }
        Ok(FiguresRequest {
            direction: d,
            u_centre_entered_um: u_centre_um,
            both_directions: self.complete == [true, true],
            bar,
            bar_length_mm,
            geometry: self.geometry,
            epochs: self.epochs,
        })
    }

    /// What a run's end left ([`Self::finish_run`]), 0.1–0.3 s on the pod, so a job runs it on
    /// its own copy of the test ([`super::job`]): into `results` the traced offset of the centre
    /// (`centre_du`, `centre_dv`); the run's fit (e, r0, their u with the bar's share and the
    /// centre's, [`CircularTest::centre_shares`], for the entered u of the centre or the traced
    /// offset's where it contradicts that, [`iso230_4::TracedCentre::centre_u_um`]; residual,
    /// arc); G and F of its direction; when both directions were complete, G(b), H, the radial
    /// deviation and the diagnoses, for the larger of the two directions' centre u. Each u with
    /// the bar's share (the request's, `metrology::bar_budget`) and the centre's (each figure's
    /// and diagnosis's `Diagnosed::centre_um`, H none; the servo mismatch's from the two
    /// directions' signed squareness changes, [`servo_mismatch_ms`]).
    pub fn figures(&self, request: &FiguresRequest, results: &mut impl ResultSink) {
        let (d, bar) = (request.direction, &request.bar);
        if let Ok(t) = self.test.traced_centre(d) {
            let ([du, dv], [u_du, u_dv]) = (t.offset_um, t.u_um);
            results.set(ResultId::CentreDu, f64::from(du), f64::from(u_du));
            results.set(ResultId::CentreDv, f64::from(dv), f64::from(u_dv));
        }
        let entered = request.u_centre_entered_um;
        let [u_ccw, u_cw] =
            [Direction::Ccw, Direction::Cw].map(|d| self.test.centre_u_um(d, entered));
        let u_run = if d == Direction::Ccw { u_ccw } else { u_cw };
        if let (Ok(e), Ok(socket)) = (self.test.fit_estimate(d), self.test.centre_shares(d, u_run))
        {
            super::live_fit::publish_fit(results, &e, self.arc_deg(d), bar, socket);
        }
        let (g, fmax, fmin) = figure_ids(d);
        if let Ok(f) = self.test.direction_figures(d, u_run) {
            for (id, v, kind) in [
                (g, f.circular_deviation_g_um, Shape),
                (fmax, f.radial_deviation_f_max_um, Radial),
                (fmin, f.radial_deviation_f_min_um, Radial),
            ] {
                results.set_with_bar(id, v.value, [v.std_uncertainty, v.centre_um], bar, kind);
            }
        }
        if request.both_directions {
            let u_centre = if u_ccw > u_cw { u_ccw } else { u_cw };
            self.bidirectional(results, request, u_centre);
        }
    }

    fn bidirectional(
        &self,
        results: &mut impl ResultSink,
        request: &FiguresRequest,
        u_centre_um: f32,
    ) {
        let bar = &request.bar;
        if let Ok(b) = self.test.bidirectional_figures(u_centre_um) {
            for (id, v, kind) in [
                (
                    ResultId::GBidir,
                    b.bidirectional_circular_deviation_um,
                    Shape,
                ),
                (ResultId::H, b.circular_hysteresis_h_um, Shape),
                (
                    ResultId::RadialBidir,
                    b.mean_bidirectional_radial_deviation_um,
                    Radial,
                ),
            ] {
                results.set_with_bar(id, v.value, [v.std_uncertainty, v.centre_um], bar, kind);
            }
        }
        let Ok([ccw, cw, m]) = self.test.both_directions(u_centre_um) else {
            // an arc short of a quadrant: no diagnoses (IsoError::NotFullCircle)
            return;
        };
        // what the arcs do not determine stays invalid ([`CircleRun::not_determinable`])
        for (id, which) in DIAGNOSIS_RESULTS {
            if let Ok(v) = m.determined(which) {
                results.set_with_bar(id, v.value, [v.std_uncertainty, v.centre_um], bar, Shape);
            }
        }
        if m.determined(Diagnosis::Cyclic).is_ok() {
            // 0: no harmonic of order 4–16 is significant (none named)
            let order = m.named_cyclic_order().unwrap_or(0);
            results.set(ResultId::CyclicOrder, f64::from(order), 0.0);
        }
        for (id, fault) in SHARE_RESULTS {
            if let Some(v) = m.share_of_g(fault, self.test.radius_mm()) {
                results.set_with_bar(id, v.value, [v.std_uncertainty, v.centre_um], bar, Shape);
            }
        }
        results.set(ResultId::FaultsNamed, f64::from(m.named_faults()), 0.0);
        if let Ok(r) = m.determined(Diagnosis::Radius) {
            publish_scale_mean(results, &r, self.test.radius_mm(), request);
        }
        let tau = self.geometry.and_then(|g| {
            servo_mismatch_ms(
                &ccw,
                &cw,
                f64::from(g.radius_mm),
                f64::from(g.feed_mm_per_min),
            )
        });
        if let Some((t, u, centre)) = tau {
            // a difference of squareness: a shape figure
            results.set_with_bar(
                ResultId::ServoMismatch,
                t as f32,
                [u as f32, centre as f32],
                bar,
                Shape,
            );
        }
    }

    /// Why the diagnosis result `id` is not determinable from the latest runs (`None`: it is,
    /// or `id` is not a diagnosis): the text after the result's name that the protocols give
    /// for an invalid result.
    pub fn not_determinable(&self, id: ResultId) -> Option<NotDeterminable> {
        let which = DIAGNOSIS_RESULTS
            .iter()
            .find(|(r, _)| *r == id)
            .map(|(_, w)| *w)
            .or_else(|| {
                SHARE_RESULTS
                    .iter()
                    .find(|(r, _)| *r == id)
                    .and_then(|(_, f)| f.diagnoses().first().copied())
            })
            .or((id == ResultId::CyclicOrder).then_some(Diagnosis::Cyclic))
            .or((id == ResultId::ScaleMean).then_some(Diagnosis::Radius))?;
        if self.complete != [true; 2] {
            return Some(NotDeterminable::NeedsBothDirections);
        }
        let both = self
            .test
            .support(Direction::Ccw)
            .both(&self.test.support(Direction::Cw));
        both.determinable(which).err()
    }
}

/// The diagnosis results and the diagnosis each publishes (the mean of the two directions).
const DIAGNOSIS_RESULTS: [(ResultId, Diagnosis); 13] = [
    (ResultId::Squareness, Diagnosis::Squareness),
    (ResultId::ScaleMismatch, Diagnosis::ScaleMismatch),
    (ResultId::ReversalU, Diagnosis::ReversalU),
    (ResultId::ReversalV, Diagnosis::ReversalV),
    (ResultId::CyclicAmplitude, Diagnosis::Cyclic),
    (ResultId::ReversalUPos, Diagnosis::ReversalUPos),
    (ResultId::ReversalUNeg, Diagnosis::ReversalUNeg),
    (ResultId::ReversalVPos, Diagnosis::ReversalVPos),
    (ResultId::ReversalVNeg, Diagnosis::ReversalVNeg),
    (ResultId::StraightnessU, Diagnosis::StraightnessU),
    (ResultId::StraightnessV, Diagnosis::StraightnessV),
    (ResultId::LateralPlayU, Diagnosis::LateralPlayU),
    (ResultId::LateralPlayV, Diagnosis::LateralPlayV),
];

/// The ranking results: each fault's share of G ([`iso230_4::Diagnostics::share_of_g`]).
const SHARE_RESULTS: [(ResultId, Fault); 9] = [
    (ResultId::ShareSquareness, Fault::Squareness),
    (ResultId::ShareScaleMismatch, Fault::ScaleMismatch),
    (ResultId::ShareReversalU, Fault::ReversalU),
    (ResultId::ShareReversalV, Fault::ReversalV),
    (ResultId::ShareStraightnessU, Fault::StraightnessU),
    (ResultId::ShareStraightnessV, Fault::StraightnessV),
    (ResultId::ShareCyclic, Fault::Cyclic),
    (ResultId::ShareLateralPlayU, Fault::LateralPlayU),
    (ResultId::ShareLateralPlayV, Fault::LateralPlayV),
];

/// Publishes the mean scale (k_u + k_v)/2 of the plane's axes, µm/m, from the joint fit's
/// radius change `r0` (µm) on radius `radius_mm`: r0 = (R − L)·10³ + R·k̄ with L the bar's
/// calibrated length (the circle's radius may differ from it within the bar's stroke), so
/// k̄ = (r0 − (R − L)·10³)/R. Its u: the fit's and the centre's, the bar's offset (length and
/// temperature, δL/R) and the LVDT scale's (on r0), each over R.
fn publish_scale_mean(
    results: &mut impl ResultSink,
    r0: &iso230_4::Diagnosed,
    radius_mm: f32,
    request: &FiguresRequest,
) {
    if !(radius_mm > 0.0) {
        return;
    }
    // µm over mm is 10⁻³: × 10³ for µm/m
    let per_r = 1e3 / radius_mm;
    let offset_um = (radius_mm - request.bar_length_mm) * 1e3;
    let [bar_offset, lvdt] = request.bar.shares(Radial, r0.value);
    results.set_budget(
        ResultId::ScaleMean,
        f64::from((r0.value - offset_um) * per_r),
        [
            r0.std_uncertainty * per_r,
            bar_offset * per_r,
            lvdt * per_r,
            0.0,
            0.0,
            0.0,
            r0.centre_um * per_r,
        ],
    );
}

/// Servo mismatch τ_u − τ_v, its standard uncertainty from the noise and the centre's share
/// (ms; from the two directions' signed squareness changes, `Diagnostics::centre_moves`) from
/// the per-direction squareness of a circular test at `feed_mm_per_min` on radius `radius_mm`;
/// `None` if the feed or radius is not a positive number.
///
/// An axis that follows its command τ late on a circle at angular speed ω errs by
/// E_u = ω·τ_u·v (CCW; the sign flips CW), which is an out-of-squareness of ω·(τ_u − τ_v)
/// (E_u = S·v convention of [`crate::metrology::iso230_4`]) that changes sign with the
/// direction, so S_ccw − S_cw = 2ω(τ_u − τ_v) while the true squareness cancels.
pub fn servo_mismatch_ms(
    ccw: &iso230_4::Diagnostics,
    cw: &iso230_4::Diagnostics,
    radius_mm: f64,
    feed_mm_per_min: f64,
) -> Option<(f64, f64, f64)> {
    if !(radius_mm > 0.0 && feed_mm_per_min > 0.0) {
        return None;
    }
    let omega_rad_per_s = feed_mm_per_min / 60.0 / radius_mm;
    let (a, b) = (
        ccw.get(Diagnosis::Squareness),
        cw.get(Diagnosis::Squareness),
    );
    let ds_urad = f64::from(a.value) - f64::from(b.value);
    let u_ds_urad = f64::from(crate::num::sqrtf(
        a.std_uncertainty * a.std_uncertainty + b.std_uncertainty * b.std_uncertainty,
    ));
    let ms_per_urad = 0.5 * 1e-6 / omega_rad_per_s * 1e3;
    // the difference's change under each of the centre's moves (a step's edge moves the two
    // directions' squareness apart)
    let moved: f32 = ccw
        .centre_moves
        .iter()
        .zip(cw.centre_moves)
        .map(|([a, ..], [b, ..])| (a - b) * (a - b))
        .sum();
    let centre_urad = f64::from(crate::num::sqrtf(0.5 * moved));
    Some((
        ds_urad * ms_per_urad,
        u_ds_urad * ms_per_urad,
        centre_urad * ms_per_urad,
    ))
}
