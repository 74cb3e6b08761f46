//! The replay's readers on arbitrary bytes: the pod's CSV (`recording::parse_runs`: a log
//! download or a recorded stream) and a plain log (`recording::parse_plain`, for each
//! pattern), then every accepted run replayed into the pod's application. Invariants: no
//! panic; an accepted file has at least one run; a run's sample numbers increase; a stream
//! run holds as many samples as the pod saw; replaying gives a report or an error, never a
//! panic.
#![no_main]

use std::path::Path;

use ballpod::app::{Direction, Pattern, RunMeta};
use ballpod::config::Config;
use ballpod_host::recording::{parse_plain, parse_runs};
use ballpod_host::replay::replay;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&sel, rest)) = data.split_first() else {
        return;
    };
    let Ok(text) = std::str::from_utf8(rest) else {
        return;
    };
    let runs = if sel & 1 == 0 {
        let Ok(runs) = parse_runs(Path::new("run.csv"), text) else {
            return;
        };
        assert!(!runs.is_empty(), "accepted without runs");
        runs
    } else {
        let mut config = Config::default();
        config.setup.circle_centre_mm = [0.0; 3];
        config.setup.circle_radius_mm = 150.0;
        let meta = RunMeta {
            pattern: Pattern::ALL[usize::from(sel >> 1) % Pattern::ALL.len()],
            direction: if sel & 0x80 == 0 {
                Direction::Ccw
            } else {
                Direction::Cw
            },
            config,
            ..RunMeta::ZERO
        };
        let Ok(run) = parse_plain(Path::new("run.csv"), text, meta) else {
            return;
        };
        vec![run]
    };
    for r in &runs {
        let seqs: Vec<u32> = r.samples().map(|s| s.seq).collect();
        assert!(
            seqs.windows(2).all(|w| w[1] > w[0]),
            "sample numbers {seqs:?}"
        );
    }
    let named: Vec<(String, _)> = runs
        .into_iter()
        .map(|r| ("run.csv".to_string(), r))
        .collect();
    let _ = replay(&named);
});
