//! Sample logs (stub).
use ballpod::acquisition::Sample;

use crate::analysis::SessionDesc;

/// Writes the logs and the session file.
pub fn write_session(
    _dir: &std::path::Path,
    _d: &SessionDesc,
    _runs: &[Vec<Sample>],
) -> Result<(), String> {
    Err("not yet".into())
}
