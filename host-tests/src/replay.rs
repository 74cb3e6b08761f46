//! Replay: recorded runs fed back into the pod's own application (`ballpod::app::App`), run by
//! run — the run's configuration, pattern and direction, arm, start, its samples and touch
//! points, stop (or abort as recorded) — and what the application reports, as JSON. The
//! simulator reports its live runs with the same [`Report`], so a replay of what it recorded
//! gives the same `results.json` byte for byte.

use serde::{Deserialize, Serialize};

use ballpod::app::{AbortReason, App, Command, JobSlot, ResultId, RunCounters, SessionState};

use crate::recording::{Event, RecordedRun};

/// One figure of the results table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Figure {
    /// Name (`ballpod::app::ResultInfo::all`).
    pub name: String,
    /// Value in `unit`.
    pub value: f32,
    /// Standard uncertainty (`null`: not evaluated).
    pub u: Option<f32>,
    /// Effective degrees of freedom of `u` (Welch–Satterthwaite, GUM G.4) for the dial gauge's
    /// and an axis centre's figures whose u has a Type A part from the fit's residual (absent:
    /// not evaluated, or a u from stated inputs only, for which k = 2). The expanded U for
    /// 95.45 % is k·u, k from Student's t at it (`ballpod_host::gum::coverage_factor`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dof: Option<u32>,
    /// Unit.
    pub unit: String,
    /// Its (up to) three largest contributors to `u`, largest first (the pod's budget,
    /// `ballpod::app::Contributor`; for the R-test and the dial gauge their Type A and the
    /// instrument's calibration, for an axis centre the touches' and the touch-off's; empty
    /// for the other host methods' figures).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub contributors: Vec<Share>,
}

/// One contributor's share of a figure's standard uncertainty.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Share {
    /// `type_a`, `bar_offset`, `lvdt_scale`, `w_ball`, `t_ball`, `probe_lobing`, `socket`
    /// (`ballpod::app::CONTRIBUTORS`);
    /// for the host's R-test `type_a`, `head_scale`, dial gauge `type_a`, `gauge_scale` and
    /// axis centre `touch` or `type_a`, `touch_offset`.
    pub name: String,
    /// The standard uncertainty it gives, the figure's unit.
    pub u: f32,
}

/// The valid figures among `ids`, in catalogue order.
pub fn figures(app: &App, ids: &[ResultId]) -> Vec<Figure> {
    ids.iter()
        .filter_map(|&id| {
            let e = app.result(id);
            e.valid.then(|| Figure {
                name: id.info().name.to_string(),
                value: e.value,
                u: (!e.std_uncertainty.is_nan()).then_some(e.std_uncertainty),
                dof: None,
                unit: id.info().unit.as_str().to_string(),
                contributors: e
                    .largest_contributors()
                    .into_iter()
                    .flatten()
                    .map(|(c, u)| Share {
                        name: c.name().to_string(),
                        u,
                    })
                    .collect(),
            })
        })
        .collect()
}

/// What one run gave.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunReport {
    /// Run number (the pod's).
    pub run: u32,
    /// Where it was recorded (file name).
    pub source: String,
    /// Pattern name.
    pub pattern: String,
    /// Direction name.
    pub direction: String,
    /// `DONE` or `ABORTED`.
    pub outcome: String,
    /// Abort reason (`NONE` when done).
    pub reason: String,
    /// Samples recorded.
    pub samples: usize,
    /// Touch points recorded.
    pub touches: usize,
    /// The run monitor's counters by name (`ballpod::app::RunCounters::NAMES`).
    pub counters: std::collections::BTreeMap<String, u32>,
    /// The run's own results (its fit, E, or sphere).
    pub results: Vec<Figure>,
    /// The instrument it was measured with, as the pod's configuration named it (traceability
    /// fields `bar_serial`, `bar_certificate`, `bar_calibrated`, `lvdt_serial`; 0: not entered).
    #[serde(default)]
    pub instrument: Instrument,
}

/// The instrument of a run (the pod's traceability fields; 0: not entered).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Instrument {
    /// The ball bar's serial number.
    pub bar_serial: u32,
    /// Its calibration certificate's number.
    pub bar_certificate: u32,
    /// Its calibration date, YYYYMMDD.
    pub bar_calibrated: u32,
    /// Its LVDT's serial number.
    pub lvdt_serial: u32,
}

impl Instrument {
    /// The fields of a configuration.
    pub fn of(c: &ballpod::config::Config) -> Self {
        Self {
            bar_serial: c.bar_serial,
            bar_certificate: c.bar_certificate,
            bar_calibrated: c.bar_calibrated,
            lvdt_serial: c.lvdt_serial,
        }
    }
}

/// A session's report: each run, then the results table at the end (procedures included).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Report {
    /// The runs, in order.
    pub runs: Vec<RunReport>,
    /// Every valid result at the end, in catalogue order.
    pub results: Vec<Figure>,
    /// Results of the host-only methods (seed 003 R-test, seed 004 dial gauge), when replayed.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub host: Vec<Figure>,
    /// The covariance of the seed 002 model mode's deviations, when the procedure is complete
    /// (what `ncgen correct` propagates into each corrected point).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed002_covariance: Option<DeviationCovariance>,
    /// The covariance of the R-test's figures (`host[]`'s `rtest_*`, the ones reported), when
    /// replayed (what `ncgen kins` propagates into each pin).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rtest_covariance: Option<DeviationCovariance>,
}

/// The covariance of the seed 002 model mode's identified deviations
/// (`ballpod::app::bc_ballbar::Procedure::model_covariance`), in their results' units: its
/// diagonal is the square of each result's u.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DeviationCovariance {
    /// The deviations by result name (`dx_BT` … `beta_CZ`), the rows' and columns' order.
    pub names: Vec<String>,
    /// Their units (`um`, `arcsec`).
    pub units: Vec<String>,
    /// The covariance, the product of the row's and the column's units.
    pub matrix: Vec<Vec<f64>>,
}

impl DeviationCovariance {
    /// The covariance of the procedure on `app`, if it is complete.
    pub fn of(app: &App) -> Option<Self> {
        use ballpod::identify::mill_turn::model_lsq::ModelLsq;
        use ballpod::identify::mill_turn::urad_to_arcsec;
        let bar = ballpod::metrology::bar_budget::BarBudget::from_config(app.config());
        let cov = app.seed002()?.model_covariance(&bar).ok()?;
        let params: Vec<_> = ModelLsq::without_squareness().free_parameters().collect();
        // µrad → arcsec on an angular row or column
        let unit = |p: &ballpod::identify::mill_turn::Parameter| {
            if p.is_positional() {
                ("um", 1.0)
            } else {
                ("arcsec", urad_to_arcsec(1.0))
            }
        };
        Some(Self {
            names: params.iter().map(|p| p.name().to_string()).collect(),
            units: params.iter().map(|p| unit(p).0.to_string()).collect(),
            matrix: params
                .iter()
                .map(|p| {
                    params
                        .iter()
                        .map(|q| cov[p.index()][q.index()] * unit(p).1 * unit(q).1)
                        .collect()
                })
                .collect(),
        })
    }
}

impl Report {
    /// Adds the run that just ended on `app`, recorded as `source` with `samples` samples and
    /// `touches` touch points.
    pub fn capture_run(&mut self, app: &App, source: &str, samples: usize, touches: usize) {
        let meta = app.run_meta();
        let counters = app.run_counters();
        self.runs.push(RunReport {
            run: meta.run,
            source: source.to_string(),
            pattern: meta.pattern.name().to_string(),
            direction: meta.direction.name().to_string(),
            outcome: app.session().name().to_string(),
            reason: app
                .abort_reason()
                .map_or("NONE", AbortReason::name)
                .to_string(),
            samples,
            touches,
            counters: RunCounters::NAMES
                .iter()
                .zip(counters.as_array())
                .map(|(n, v)| (n.to_string(), v))
                .collect(),
            results: figures(app, ResultId::of_run(meta.pattern)),
            instrument: Instrument::of(&meta.config),
        });
    }

    /// Takes the final results table of `app`.
    pub fn finish(&mut self, app: &App) {
        self.results = figures(app, ResultId::ALL);
        self.seed002_covariance = DeviationCovariance::of(app);
    }

    /// The value of result `name`, if valid.
    pub fn result(&self, name: &str) -> Option<&Figure> {
        self.results.iter().find(|f| f.name == name)
    }

    /// As pretty JSON.
    pub fn to_json(&self) -> Result<String, String> {
        serde_json::to_string_pretty(self).map_err(|e| format!("results JSON: {e}"))
    }
}

/// Feeds one recorded run into `app` as the pod ran it (a refusal or a run that ends
/// otherwise than recorded is an error naming the run).
pub fn replay_run(app: &mut App, r: &RecordedRun) -> Result<(), String> {
    let name = format!(
        "run {} ({} {})",
        r.meta.run,
        r.meta.pattern.name(),
        r.meta.direction.name()
    );
    let refused = |what: &str, e: ballpod::app::CommandError| {
        let (a, b) = e.text();
        format!("{name}: {what} refused: {a}{b}")
    };
    if r.partial {
        return Err(format!(
            "{name}: the stream's reader joined the run after its first samples (`# partial=1`): \
             its samples are not the whole run, so not replayed (open the stream port before arming)"
        ));
    }
    let cfg = r.meta.config;
    if *app.config() != cfg {
        app.configure(|c| *c = cfg)
            .map_err(|e| refused("configuration", e))?;
    }
    app.set_pattern(r.meta.pattern)
        .map_err(|e| refused("pattern", e))?;
    app.set_direction(r.meta.direction)
        .map_err(|e| refused("direction", e))?;
    app.execute(Command::Arm).map_err(|e| refused("arm", e))?;
    app.execute(Command::Start)
        .map_err(|e| refused("start", e))?;
    // a decimated log (`# decimation=d`: the pod's DATA:LOG? of a run longer than it holds)
    // keeps the run's samples first + k·d: they are numbered first + k here, so the
    // application counts a gap the log has as lost and not the samples it thinned out (the
    // results are those of the logged samples)
    let d = r.decimation.max(1);
    let first = r.samples().next().map_or(0, |s| s.seq);
    for e in &r.events {
        match e {
            Event::Sample(s) if d > 1 => {
                let k = s.seq.wrapping_sub(first);
                if k % d != 0 {
                    return Err(format!(
                        "{name}: sample {} is not one the log keeps (1 in {d} from {first})",
                        s.seq
                    ));
                }
                let s = ballpod::acquisition::Sample {
                    seq: first.wrapping_add(k / d),
                    ..*s
                };
                app.on_sample(&s, &mut ());
            }
            Event::Sample(s) => app.on_sample(s, &mut ()),
            Event::Touch(t) => app.on_recorded_touch(t, &mut ()),
        }
    }
    let recorded = r.end.map(|e| e.abort);
    match (app.session(), recorded) {
        // the application aborted by itself (a fault in the samples), as recorded
        (SessionState::Aborted, Some(Some(reason))) if app.abort_reason() == Some(reason) => {}
        (SessionState::Running, Some(Some(AbortReason::ByCommand))) => {
            app.execute(Command::Abort)
                .map_err(|e| refused("abort", e))?;
        }
        // stopped (or the recording ends before the run did: stop there)
        (SessionState::Running, Some(None) | None) => {
            let _ = app.execute(Command::Stop);
        }
        (SessionState::Running, Some(Some(reason))) => {
            // the pod stopped and found no results (too few samples, too short an arc)
            let _ = app.execute(Command::Stop);
            if app.abort_reason() != Some(reason) {
                return Err(format!(
                    "{name}: recorded as aborted ({}), replayed as {}",
                    reason.name(),
                    app.abort_reason().map_or("done", |a| a.name())
                ));
            }
        }
        (state, rec) => {
            return Err(format!(
                "{name}: replayed as {} ({}), recorded as {}",
                state.name(),
                app.abort_reason().map_or("NONE", |a| a.name()),
                match rec {
                    Some(Some(a)) => a.name(),
                    Some(None) => "DONE",
                    None => "not ended",
                }
            ));
        }
    }
    // the jobs the run's end wanted (its figures; an identification), as the pod runs them
    app.run_jobs(&mut JobSlot::new());
    Ok(())
}

/// Replays recorded runs (each with the name of its file) into a fresh application and
/// reports them.
pub fn replay(runs: &[(String, RecordedRun)]) -> Result<Report, String> {
    let Some((_, first)) = runs.first() else {
        return Err("no runs to replay".into());
    };
    let mut app = App::new(first.meta.config, [16; ballpod::acquisition::MAX_AXES]);
    let mut report = Report::default();
    for (source, r) in runs {
        replay_run(&mut app, r)?;
        let touches = r
            .events
            .iter()
            .filter(|e| matches!(e, Event::Touch(_)))
            .count();
        report.capture_run(&app, source, r.events.len() - touches, touches);
    }
    report.finish(&app);
    Ok(report)
}
