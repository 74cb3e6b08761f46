//! The replay's session file (`session_file::parse_session`) on arbitrary bytes, read both as
//! TOML and as JSON. Invariants: no panic; an accepted session has runs, an `[rtest]` or a
//! `[dial]`; every pattern and direction it names is one the pod knows; an error names the
//! file.
#![no_main]

use std::path::Path;

use ballpod::app::{Direction, Pattern};
use ballpod_host::session_file::parse_session;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    for name in ["session.toml", "session.json"] {
        match parse_session(Path::new(name), text) {
            Ok(s) => {
                assert!(
                    !s.runs.is_empty() || s.rtest.is_some() || s.dial.is_some(),
                    "accepted with nothing to replay"
                );
                for r in &s.runs {
                    if let Some(p) = &r.pattern {
                        assert!(Pattern::from_name(p.as_bytes()).is_some(), "{p:?}");
                    }
                    if let Some(d) = &r.direction {
                        assert!(Direction::from_name(d.as_bytes()).is_some(), "{d:?}");
                    }
                }
            }
            Err(e) => assert_eq!(e.file, Path::new(name)),
        }
    }
});
