//! The desk's history: machines, their tolerances and every run (set-up, the pod's results,
//! the replay of the recorded stream, the raw stream deflated), in one SQLite file
//! (`rusqlite` with SQLite bundled: one file per shop or laptop, nothing to install). The
//! schema is versioned (`PRAGMA user_version`): each migration runs once, in order.

use std::collections::BTreeMap;
use std::io::{Read, Write};
use std::path::Path;

use rusqlite::{Connection, OptionalExtension, params};
use serde::{Deserialize, Serialize};

use super::decision::Tolerance;

/// The schema's migrations, oldest first: `user_version` counts those applied.
const MIGRATIONS: &[&str] = &["
CREATE TABLE machine (
    id INTEGER PRIMARY KEY,
    name TEXT NOT NULL UNIQUE,
    builder TEXT NOT NULL,
    model TEXT NOT NULL,
    serial TEXT NOT NULL,
    kinematics TEXT NOT NULL,
    axes TEXT NOT NULL,
    travel TEXT NOT NULL,
    created TEXT NOT NULL
);
CREATE TABLE tolerance (
    machine_id INTEGER NOT NULL REFERENCES machine(id),
    figure TEXT NOT NULL,
    lower_limit REAL,
    upper_limit REAL,
    PRIMARY KEY (machine_id, figure)
);
CREATE TABLE run (
    id INTEGER PRIMARY KEY,
    machine_id INTEGER NOT NULL REFERENCES machine(id),
    test TEXT NOT NULL,
    operator TEXT NOT NULL,
    started TEXT NOT NULL,
    state TEXT NOT NULL,
    note TEXT NOT NULL,
    pod_identity TEXT NOT NULL,
    setup TEXT NOT NULL,
    pod_results TEXT NOT NULL,
    replay TEXT NOT NULL,
    replay_check TEXT NOT NULL,
    stream BLOB
);
"];

/// A machine tool under test.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Machine {
    /// Row id (0 before it is stored).
    #[serde(default)]
    pub id: i64,
    /// The shop's name for it (unique).
    pub name: String,
    /// Builder.
    #[serde(default)]
    pub builder: String,
    /// Model.
    #[serde(default)]
    pub model: String,
    /// Builder's serial number.
    #[serde(default)]
    pub serial: String,
    /// Kinematics type (e.g. "table-table B/C", "spindle-head A/C", "3-axis").
    #[serde(default)]
    pub kinematics: String,
    /// Axes (e.g. "X Y Z B C").
    #[serde(default)]
    pub axes: String,
    /// Travel per axis, as the builder states it (e.g. "X 600 mm, Y 500 mm").
    #[serde(default)]
    pub travel: String,
    /// When it was entered (RFC 3339, UTC).
    #[serde(default)]
    pub created: String,
}

impl Machine {
    /// The first field that is missing or too long, named.
    pub fn check(&self) -> Result<(), String> {
        if self.name.trim().is_empty() {
            return Err("machine name is missing".into());
        }
        for (field, v) in [
            ("name", &self.name),
            ("builder", &self.builder),
            ("model", &self.model),
            ("serial", &self.serial),
            ("kinematics", &self.kinematics),
            ("axes", &self.axes),
            ("travel", &self.travel),
        ] {
            if v.chars().count() > 200 {
                return Err(format!("machine {field} is longer than 200 characters"));
            }
        }
        Ok(())
    }
}

/// What a run's row holds (the raw stream apart: [`Store::stream`]).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RunRow {
    /// Row id.
    pub id: i64,
    /// The machine.
    pub machine_id: i64,
    /// The test template's name (`circle`).
    pub test: String,
    /// Who ran it.
    pub operator: String,
    /// When it started (RFC 3339, UTC).
    pub started: String,
    /// `running`, `done`, `failed` (the pod refused or a run aborted: `note` says why) or
    /// `cut` (the pod went away mid-run: kept as far as it went).
    pub state: String,
    /// Why it failed or what was flagged.
    pub note: String,
    /// The pod's `*IDN?` (maker, model, serial, firmware).
    pub pod_identity: String,
    /// The set-up written to the pod (JSON).
    pub setup: serde_json::Value,
    /// The pod's own results as it reported them (JSON list of figures).
    pub pod_results: serde_json::Value,
    /// The replay of the recorded stream (`replay::Report` as JSON).
    pub replay: serde_json::Value,
    /// Empty when the replay's results equal the pod's bit for bit; else what differs.
    pub replay_check: String,
}

/// The history file.
pub struct Store {
    db: Connection,
}

fn sql(e: rusqlite::Error) -> String {
    format!("database: {e}")
}

/// Now, RFC 3339 UTC to the second.
pub fn now() -> String {
    humantime::format_rfc3339_seconds(std::time::SystemTime::now()).to_string()
}

impl Store {
    /// Opens (or creates) the history file at `path` and brings its schema up to date.
    pub fn open(path: &Path) -> Result<Self, String> {
        let db = Connection::open(path).map_err(|e| format!("{}: {e}", path.display()))?;
        db.busy_timeout(std::time::Duration::from_secs(5))
            .map_err(sql)?;
        db.pragma_update(None, "foreign_keys", true).map_err(sql)?;
        let mut s = Self { db };
        s.migrate()?;
        Ok(s)
    }

    fn migrate(&mut self) -> Result<(), String> {
        let version: i64 = self
            .db
            .pragma_query_value(None, "user_version", |r| r.get(0))
            .map_err(sql)?;
        let version = usize::try_from(version).unwrap_or(usize::MAX);
        if version > MIGRATIONS.len() {
            return Err(format!(
                "database schema version {version} is newer than this desk's ({}): update the desk",
                MIGRATIONS.len()
            ));
        }
        for (k, m) in MIGRATIONS.iter().enumerate().skip(version) {
            let tx = self.db.transaction().map_err(sql)?;
            tx.execute_batch(m).map_err(sql)?;
            tx.pragma_update(None, "user_version", (k + 1) as i64)
                .map_err(sql)?;
            tx.commit().map_err(sql)?;
        }
        Ok(())
    }

    /// Stores a new machine; its id.
    pub fn add_machine(&self, m: &Machine) -> Result<i64, String> {
        m.check()?;
        self.db
            .execute(
                "INSERT INTO machine (name, builder, model, serial, kinematics, axes, travel, created)
                 VALUES ($1, $2, $3, $4, $5, $6, $7, $8)",
                params![
                    m.name.trim(),
                    m.builder,
                    m.model,
                    m.serial,
                    m.kinematics,
                    m.axes,
                    m.travel,
                    now()
                ],
            )
            .map_err(|e| match e {
                rusqlite::Error::SqliteFailure(f, _)
                    if f.code == rusqlite::ErrorCode::ConstraintViolation =>
                {
                    format!("a machine named {:?} exists already", m.name.trim())
                }
                e => sql(e),
            })?;
        Ok(self.db.last_insert_rowid())
    }

    /// Every machine, by name.
    pub fn machines(&self) -> Result<Vec<Machine>, String> {
        let mut q = self
            .db
            .prepare("SELECT id, name, builder, model, serial, kinematics, axes, travel, created FROM machine ORDER BY name")
            .map_err(sql)?;
        let rows = q
            .query_map([], |r| {
                Ok(Machine {
                    id: r.get(0)?,
                    name: r.get(1)?,
                    builder: r.get(2)?,
                    model: r.get(3)?,
                    serial: r.get(4)?,
                    kinematics: r.get(5)?,
                    axes: r.get(6)?,
                    travel: r.get(7)?,
                    created: r.get(8)?,
                })
            })
            .map_err(sql)?;
        rows.collect::<Result<_, _>>().map_err(sql)
    }

    /// The machine with this id.
    pub fn machine(&self, id: i64) -> Result<Machine, String> {
        self.machines()?
            .into_iter()
            .find(|m| m.id == id)
            .ok_or_else(|| format!("no machine with id {id}"))
    }

    /// Sets (replaces) a machine's tolerance for one figure (a result's name).
    pub fn set_tolerance(&self, machine: i64, figure: &str, t: Tolerance) -> Result<(), String> {
        self.machine(machine)?;
        if !ballpod::app::ResultId::ALL
            .iter()
            .any(|r| r.info().name == figure)
        {
            return Err(format!("tolerance: {figure:?} is not a result of the pod"));
        }
        for (side, v) in [("lower", t.lower), ("upper", t.upper)] {
            if v.is_some_and(|v| !v.is_finite()) {
                return Err(format!(
                    "tolerance of {figure}: the {side} limit is not a number"
                ));
            }
        }
        if let (Some(l), Some(h)) = (t.lower, t.upper)
            && l > h
        {
            return Err(format!(
                "tolerance of {figure}: lower limit {l} above upper limit {h}"
            ));
        }
        if t.lower.is_none() && t.upper.is_none() {
            return Err(format!("tolerance of {figure}: neither limit is set"));
        }
        self.db
            .execute(
                "INSERT INTO tolerance (machine_id, figure, lower_limit, upper_limit) VALUES ($1, $2, $3, $4)
                 ON CONFLICT (machine_id, figure) DO UPDATE SET lower_limit = excluded.lower_limit, upper_limit = excluded.upper_limit",
                params![machine, figure, t.lower, t.upper],
            )
            .map_err(sql)?;
        Ok(())
    }

    /// A machine's tolerances by figure name.
    pub fn tolerances(&self, machine: i64) -> Result<BTreeMap<String, Tolerance>, String> {
        let mut q = self
            .db
            .prepare("SELECT figure, lower_limit, upper_limit FROM tolerance WHERE machine_id = $1")
            .map_err(sql)?;
        let rows = q
            .query_map(params![machine], |r| {
                Ok((
                    r.get::<_, String>(0)?,
                    Tolerance {
                        lower: r.get(1)?,
                        upper: r.get(2)?,
                    },
                ))
            })
            .map_err(sql)?;
        rows.collect::<Result<_, _>>().map_err(sql)
    }

    /// Starts a run's row (state `running`); its id.
    pub fn begin_run(
        &self,
        machine: i64,
        test: &str,
        operator: &str,
        pod_identity: &str,
        setup: &serde_json::Value,
    ) -> Result<i64, String> {
        self.machine(machine)?;
        self.db
            .execute(
                "INSERT INTO run (machine_id, test, operator, started, state, note, pod_identity, setup, pod_results, replay, replay_check)
                 VALUES ($1, $2, $3, $4, 'running', '', $5, $6, '[]', '{}', '')",
                params![machine, test, operator, now(), pod_identity, setup.to_string()],
            )
            .map_err(sql)?;
        Ok(self.db.last_insert_rowid())
    }

    /// Ends a run's row: its state, note, the pod's results, the replay, the check and the raw
    /// stream (stored deflated).
    #[allow(clippy::too_many_arguments)]
    pub fn finish_run(
        &self,
        id: i64,
        state: &str,
        note: &str,
        pod_results: &serde_json::Value,
        replay: &serde_json::Value,
        replay_check: &str,
        stream: &[u8],
    ) -> Result<(), String> {
        let mut z = flate2::write::DeflateEncoder::new(Vec::new(), flate2::Compression::default());
        z.write_all(stream).map_err(|e| e.to_string())?;
        let packed = z.finish().map_err(|e| e.to_string())?;
        let n = self
            .db
            .execute(
                "UPDATE run SET state = $1, note = $2, pod_results = $3, replay = $4, replay_check = $5, stream = $6 WHERE id = $7",
                params![
                    state,
                    note,
                    pod_results.to_string(),
                    replay.to_string(),
                    replay_check,
                    packed,
                    id
                ],
            )
            .map_err(sql)?;
        if n != 1 {
            return Err(format!("no run with id {id}"));
        }
        Ok(())
    }

    /// A machine's runs, oldest first (`None`: every machine's).
    pub fn runs(&self, machine: Option<i64>) -> Result<Vec<RunRow>, String> {
        let mut q = self
            .db
            .prepare(
                "SELECT id, machine_id, test, operator, started, state, note, pod_identity, setup, pod_results, replay, replay_check
                 FROM run WHERE $1 IS NULL OR machine_id = $1 ORDER BY id",
            )
            .map_err(sql)?;
        let json = |s: String| serde_json::from_str(&s).unwrap_or(serde_json::Value::Null);
        let rows = q
            .query_map(params![machine], |r| {
                Ok(RunRow {
                    id: r.get(0)?,
                    machine_id: r.get(1)?,
                    test: r.get(2)?,
                    operator: r.get(3)?,
                    started: r.get(4)?,
                    state: r.get(5)?,
                    note: r.get(6)?,
                    pod_identity: r.get(7)?,
                    setup: json(r.get(8)?),
                    pod_results: json(r.get(9)?),
                    replay: json(r.get(10)?),
                    replay_check: r.get(11)?,
                })
            })
            .map_err(sql)?;
        rows.collect::<Result<_, _>>().map_err(sql)
    }

    /// One run.
    pub fn run(&self, id: i64) -> Result<RunRow, String> {
        self.runs(None)?
            .into_iter()
            .find(|r| r.id == id)
            .ok_or_else(|| format!("no run with id {id}"))
    }

    /// A run's raw stream as the pod sent it (inflated).
    pub fn stream(&self, id: i64) -> Result<Vec<u8>, String> {
        let packed: Option<Vec<u8>> = self
            .db
            .query_row("SELECT stream FROM run WHERE id = $1", params![id], |r| {
                r.get(0)
            })
            .optional()
            .map_err(sql)?
            .ok_or_else(|| format!("no run with id {id}"))?;
        let mut out = Vec::new();
        if let Some(p) = packed {
            flate2::read::DeflateDecoder::new(&p[..])
                .read_to_end(&mut out)
                .map_err(|e| format!("run {id}'s stream: {e}"))?;
        }
        Ok(out)
    }
}
