//! Runs waiting for the history: a run is written here first (its row as JSON, its raw
//! stream as it came), then stored, then taken out — so a database that is locked or
//! unreachable loses nothing, and a run is stored once however often it is retried (its
//! `spool_key` is unique in the history).

use std::path::{Path, PathBuf};

use super::store::{RunRow, StoreHandle};

/// The spool folder.
#[derive(Clone, Debug)]
pub struct Spool {
    dir: PathBuf,
}

/// A file name for a key (RFC 3339 times hold ':').
fn file_stem(key: &str) -> String {
    key.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

impl Spool {
    /// The spool in `dir` (created when first written).
    pub fn new(dir: PathBuf) -> Self {
        Self { dir }
    }

    /// Where it is.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Keeps a run: the stream first, then the row (the row's file marks it whole).
    pub fn put(&self, run: &RunRow, stream: &[u8]) -> Result<(), String> {
        let err = |e: std::io::Error| format!("spool {}: {e}", self.dir.display());
        std::fs::create_dir_all(&self.dir).map_err(err)?;
        let stem = file_stem(&run.spool_key);
        std::fs::write(self.dir.join(format!("{stem}.stream")), stream).map_err(err)?;
        let tmp = self.dir.join(format!("{stem}.json.part"));
        let json = serde_json::to_vec_pretty(run).map_err(|e| e.to_string())?;
        std::fs::write(&tmp, json).map_err(err)?;
        std::fs::rename(&tmp, self.dir.join(format!("{stem}.json"))).map_err(err)
    }

    /// The runs waiting (their row files), oldest key first.
    pub fn waiting(&self) -> Vec<PathBuf> {
        let mut v: Vec<PathBuf> = std::fs::read_dir(&self.dir)
            .map(|d| {
                d.filter_map(|e| e.ok().map(|e| e.path()))
                    .filter(|p| p.extension().is_some_and(|x| x == "json"))
                    .collect()
            })
            .unwrap_or_default();
        v.sort();
        v
    }

    /// Stores every waiting run; the ids of those stored by key, or the first error (the rest
    /// wait for the next try).
    pub fn flush(&self, store: &StoreHandle) -> Result<Vec<(String, i64)>, String> {
        let mut stored = Vec::new();
        for row_file in self.waiting() {
            let run: RunRow = serde_json::from_slice(
                &std::fs::read(&row_file).map_err(|e| format!("{}: {e}", row_file.display()))?,
            )
            .map_err(|e| format!("{}: {e}", row_file.display()))?;
            let stream_file = row_file.with_extension("stream");
            let stream = std::fs::read(&stream_file)
                .map_err(|e| format!("{}: {e}", stream_file.display()))?;
            let key = run.spool_key.clone();
            let id = store.call(move |s| s.add_run(&run, &stream))?;
            // stored: only now out of the spool (a crash between the two stores it again as
            // the same key: once)
            let _ = std::fs::remove_file(&row_file);
            let _ = std::fs::remove_file(&stream_file);
            stored.push((key, id));
        }
        Ok(stored)
    }
}
