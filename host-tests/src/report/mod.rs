//! The report: results JSON ([`crate::replay::Report`]), the truth of a simulated machine, SVG
//! polar plots.

use crate::recording::RecordedRun;
use crate::replay::Report;
use crate::vmt::machine::MachineFile;

pub mod svg;

/// The simulated machine (its deviations and faults) as pretty JSON.
pub fn truth_json(m: &MachineFile) -> Result<String, String> {
    serde_json::to_string_pretty(m).map_err(|e| format!("truth JSON: {e}"))
}

/// The SVG polar plots of a session: (file name, SVG text).
pub fn plots(runs: &[(String, RecordedRun)], r: &Report) -> Vec<(String, String)> {
    svg::plots(runs, r)
}
