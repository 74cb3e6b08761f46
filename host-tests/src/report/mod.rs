//! The report: results JSON (serde_json), the truth of a simulated machine, SVG polar plots.

use ballpod::acquisition::Sample;

use crate::analysis::{Results, SessionDesc};
use crate::vmt::machine::MachineFile;

pub mod svg;

/// The results as pretty JSON.
pub fn results_json(r: &Results) -> Result<String, String> {
    serde_json::to_string_pretty(r).map_err(|e| format!("results JSON: {e}"))
}

/// The simulated machine (its deviations and faults) as pretty JSON.
pub fn truth_json(m: &MachineFile) -> Result<String, String> {
    serde_json::to_string_pretty(m).map_err(|e| format!("truth JSON: {e}"))
}

/// The SVG polar plots of a session: (file name, SVG text).
pub fn plots(desc: &SessionDesc, runs: &[Vec<Sample>], r: &Results) -> Vec<(String, String)> {
    svg::plots(desc, runs, r)
}
