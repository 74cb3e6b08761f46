//! SVG polar plots (stub).
use ballpod::acquisition::Sample;

use crate::analysis::{Results, SessionDesc};

/// The plots.
pub fn plots(_desc: &SessionDesc, _runs: &[Vec<Sample>], _r: &Results) -> Vec<(String, String)> {
    Vec::new()
}
