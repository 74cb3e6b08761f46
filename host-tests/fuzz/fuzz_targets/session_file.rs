//! The replay's session description (`ballpod_host::logfile::parse_session`) on arbitrary
//! bytes, read both as TOML and as JSON, and the analysis after it. Invariants: no panic; an
//! accepted session has at least one run, each with a known method and direction and the
//! geometry its method needs; analysing it with no logs, with empty logs or with a tiny log
//! (three samples, far too few for any circle fit) per run gives an error, never results.
#![no_main]

use std::path::Path;

use ballpod::acquisition::Sample;
use libfuzzer_sys::fuzz_target;

use ballpod_host::analysis::{analyse, parse_direction};
use ballpod_host::logfile::parse_session;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    for name in ["session.toml", "session.json"] {
        let Ok(desc) = parse_session(Path::new(name), text) else {
            continue;
        };
        assert!(!desc.runs.is_empty(), "accepted without runs");
        for r in &desc.runs {
            assert!(parse_direction(&r.direction).is_some(), "{:?}", r.direction);
            if r.method == "ISO230-4" {
                assert!(desc.circle.is_some(), "ISO run without circle geometry");
            } else {
                assert!(
                    ballpod::session::seed002::Step::from_name(&r.method).is_some(),
                    "{:?}",
                    r.method
                );
                assert!(desc.seed002.is_some(), "seed 002 run without geometry");
            }
        }
        // Analyses of far too little data: always an error.
        let n = desc.runs.len();
        assert!(analyse(&desc, &[]).is_err(), "results from no logs");
        assert!(
            analyse(&desc, &vec![Vec::new(); n]).is_err(),
            "results from empty logs"
        );
        let tiny: Vec<Sample> = (0..3u64)
            .map(|i| Sample {
                seq: i as u32,
                t_us: i * 1000,
                delta_l_um: 1.0,
                axes: [50.0, 0.0, 10.0, 0.0, 0.0],
                temp_c: 20.0,
                ..Sample::default()
            })
            .collect();
        assert!(
            analyse(&desc, &vec![tiny; n]).is_err(),
            "results from 3-sample logs"
        );
    }
});
