//! The replay's sample-log CSV reader (`ballpod_host::logfile::read_log`) on arbitrary bytes,
//! for each kind of run (the method decides the required axis columns). Invariants: no panic;
//! an accepted log has at least one sample, strictly increasing time, finite ΔL, axes and
//! temperature, a header naming `t_s`, `dl_um` and the method's plane axes, and samples
//! numbered 0, 1, 2, … in file order.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;

use ballpod_host::logfile::read_log;

/// Every method a run can have and the axis columns its pattern plane needs.
const METHODS: [(&str, [&str; 2]); 6] = [
    ("ISO230-4", ["x_mm", "y_mm"]),
    ("BX", ["x_mm", "z_mm"]),
    ("BY", ["y_mm", "z_mm"]),
    ("CR", ["x_mm", "y_mm"]),
    ("CA", ["x_mm", "y_mm"]),
    ("CR2", ["x_mm", "y_mm"]),
];

fuzz_target!(|data: &[u8]| {
    let Some((&sel, rest)) = data.split_first() else {
        return;
    };
    let Ok(text) = std::str::from_utf8(rest) else {
        return;
    };
    let (method, axes) = METHODS[usize::from(sel) % METHODS.len()];
    let Ok(samples) = read_log(Path::new("run.csv"), text, method) else {
        return;
    };
    assert!(!samples.is_empty(), "accepted without samples");
    // The header is the first line that is neither a comment nor blank.
    let header = text
        .lines()
        .map(|l| l.trim_end_matches('\r'))
        .find(|l| !l.starts_with('#') && !l.trim().is_empty())
        .expect("accepted without a header");
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    for req in ["t_s", "dl_um"].iter().chain(axes.iter()) {
        assert!(names.contains(req), "accepted without {req}: {header:?}");
    }
    for (i, s) in samples.iter().enumerate() {
        assert_eq!(s.seq as usize, i);
        assert!(s.delta_l_um.is_finite(), "ΔL {}", s.delta_l_um);
        assert!(s.temp_c.is_finite(), "temperature {}", s.temp_c);
        assert!(s.axes.iter().all(|a| a.is_finite()), "axes {:?}", s.axes);
    }
    for w in samples.windows(2) {
        assert!(
            w[1].t_us > w[0].t_us,
            "time {} then {}",
            w[0].t_us,
            w[1].t_us
        );
    }
});
