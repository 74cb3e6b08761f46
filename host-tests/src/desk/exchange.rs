//! What leaves and enters the history as files: a machine's runs as JSON (everything the
//! history holds but the raw streams, which `/api/runs/{id}/stream` gives one by one) or CSV
//! (one row per figure of each run, with U and the decision), and the project's own files
//! imported as runs — a recorded stream or a `DATA:LOG?` download (replayed, as recorded),
//! or a `results.json` of `cargo replay` / `cargo sim` (its figures, without a stream).

use std::fmt::Write;
use std::path::Path;

use super::report::{figures_of, view};
use super::store::{RunRow, Store};
use super::tests::{Template, stream_text};
use crate::replay::Report;

/// A machine's record as JSON: the machine, its tolerances, its runs.
pub fn export_json(store: &mut Store, machine: i64) -> Result<serde_json::Value, String> {
    Ok(serde_json::json!({
        "machine": store.machine(machine)?,
        "tolerances": store.tolerances(machine)?,
        "runs": store.runs(Some(machine))?,
    }))
}

/// A CSV field, quoted when it needs to be (RFC 4180).
fn field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// A machine's runs as CSV: one row per figure of each run.
pub fn export_csv(store: &mut Store, machine: i64) -> Result<String, String> {
    let mut out = String::from(
        "run_id,started,test,operator,state,figure,value,u,k,expanded_u,unit,lower_limit,upper_limit,decision\n",
    );
    let opt = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v}"));
    for r in store.runs(Some(machine))? {
        let v = view(store, r.id)?;
        for f in &v.figures {
            let decision = f
                .decision
                .and_then(|d| serde_json::to_value(d).ok())
                .and_then(|d| d.as_str().map(String::from))
                .unwrap_or_default();
            let _ = writeln!(
                out,
                "{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
                r.id,
                field(&r.started),
                field(&r.test),
                field(&r.operator),
                field(&r.state),
                field(&f.name),
                f.value,
                opt(f.u),
                opt(f.k),
                opt(f.expanded_u),
                field(&f.unit),
                opt(f.tolerance.and_then(|t| t.lower)),
                opt(f.tolerance.and_then(|t| t.upper)),
                decision
            );
        }
    }
    Ok(out)
}

/// The template whose runs' patterns a recording's runs are (`circle`, `seed002`, `ssm`,
/// `probe`), else `import`.
fn template_of(patterns: &[&str]) -> String {
    Template::ALL
        .into_iter()
        .find(|t| {
            !patterns.is_empty()
                && patterns
                    .iter()
                    .all(|p| t.runs().iter().any(|(q, _)| q == p))
        })
        .and_then(|t| serde_json::to_value(t).ok())
        .and_then(|v| v.as_str().map(String::from))
        .unwrap_or_else(|| "import".into())
}

/// Imports a file into a machine's history as one run; its id. `name` is the file's name (for
/// messages and the run's note).
pub fn import(
    store: &mut Store,
    machine: i64,
    operator: &str,
    name: &str,
    bytes: &[u8],
) -> Result<i64, String> {
    store.machine(machine)?;
    let started = super::store::now();
    // the file's own key: the same file imported again is the run stored the first time
    let key = format!("import-{:08x}-{}", ballpod::num::crc32(bytes), bytes.len());
    let mut run = RunRow {
        spool_key: key,
        machine_id: machine,
        operator: operator.to_string(),
        started,
        state: "done".into(),
        note: format!("imported from {name}"),
        ..RunRow::default()
    };
    if bytes.first() == Some(&b'{') {
        let report: Report = serde_json::from_slice(bytes)
            .map_err(|e| format!("{name}: not a results.json: {e}"))?;
        let patterns: Vec<&str> = report.runs.iter().map(|r| r.pattern.as_str()).collect();
        run.test = template_of(&patterns);
        run.replay = serde_json::to_value(&report).map_err(|e| e.to_string())?;
        run.note.push_str(" (results only: no stream)");
        if figures_of(&run).is_empty() {
            return Err(format!("{name}: no results in it"));
        }
        return store.add_run(&run, &[]);
    }
    // a recorded stream (records decoded) or a log download: text either way
    let text = stream_text(bytes);
    let text =
        crate::recording::strip_block_header(Path::new(name), &text).map_err(|e| e.to_string())?;
    let runs = crate::recording::parse_runs(Path::new(name), text).map_err(|e| e.to_string())?;
    let named: Vec<(String, _)> = runs.into_iter().map(|r| (name.to_string(), r)).collect();
    let report = crate::replay::replay(&named)?;
    let patterns: Vec<&str> = named.iter().map(|(_, r)| r.meta.pattern.name()).collect();
    run.test = template_of(&patterns);
    run.pod_identity = named
        .first()
        .and_then(|(_, r)| r.firmware.clone())
        .map_or(String::new(), |f| format!("firmware {f}"));
    run.replay = serde_json::to_value(&report).map_err(|e| e.to_string())?;
    store.add_run(&run, bytes)
}
