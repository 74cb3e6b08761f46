//! The log's CSV writer on arbitrary runs (samples with any f32 including NaN, ±inf and
//! extremes, touches, an end with arbitrary counters) and metadata. Invariants: no panic;
//! `csv_len` equals the bytes written; no line is cut short (every line ends in `\n` and is at
//! most `CSV_LINE_MAX` bytes); pulling the file with `CsvCursor::fill` in arbitrary buffer sizes
//! gives the same bytes as streaming it; with a valid configuration the replay's reader takes
//! the file back with the log's samples (number, time, flags and finite ΔL bit for bit; a
//! non-finite ΔL as `nan`).
#![no_main]

use std::path::Path;

use arbitrary::{Arbitrary, Unstructured};
use ballpod::acquisition::{MAX_AXES, Sample, SampleFlags};
use ballpod::app::log::SampleLog;
use ballpod::app::{
    AbortReason, Direction, Pattern, Recorder, RunCounters, RunEnd, RunMeta, Touch,
};
use ballpod::config::{AxisName, Config};
use ballpod::protocol::csv::CSV_LINE_MAX;
use ballpod::protocol::download::{CsvCursor, csv_len, write_csv};
use ballpod_host::recording::parse_runs;
use libfuzzer_sys::fuzz_target;

#[derive(Arbitrary, Debug)]
enum Event {
    Sample {
        seq_step: u8,
        t_step_us: u32,
        delta_l_um: f32,
        axes: [f32; MAX_AXES],
        temp_c: f32,
        flags: u16,
    },
    Touch {
        axes: [f32; MAX_AXES],
    },
}

fuzz_target!(|data: &[u8]| {
    let mut u = Unstructured::new(data);
    let Ok((bar, pat, dir, names, end, abort, counters)) = <(
        f32,
        u8,
        bool,
        [u8; MAX_AXES],
        bool,
        u8,
        [u32; RunCounters::LEN],
    )>::arbitrary(&mut u) else {
        return;
    };
    let mut config = Config {
        bar_length_mm: bar,
        ..Config::default()
    };
    for (a, n) in config.axes.iter_mut().zip(names) {
        a.name = AxisName::from_u8(n % 8).unwrap_or(AxisName::Unused);
    }
    let meta = RunMeta {
        run: u32::from(pat),
        pattern: Pattern::ALL[usize::from(pat) % Pattern::ALL.len()],
        direction: if dir { Direction::Cw } else { Direction::Ccw },
        config,
    };
    let mut log: SampleLog<16> = SampleLog::new();
    log.begin_run(&meta);
    let (mut seq, mut t_us) = (0u32, 0u64);
    while !u.is_empty() {
        let Ok(e) = Event::arbitrary(&mut u) else {
            break;
        };
        match e {
            Event::Sample {
                seq_step,
                t_step_us,
                delta_l_um,
                axes,
                temp_c,
                flags,
            } => {
                seq = seq.wrapping_add(u32::from(seq_step).max(1));
                t_us += u64::from(t_step_us);
                log.sample(&Sample {
                    seq,
                    t_us,
                    delta_l_um,
                    axes,
                    temp_c,
                    flags: SampleFlags(flags),
                });
            }
            Event::Touch { axes } => log.touch(&Touch { t_us, axes }),
        }
    }
    if end {
        log.end_run(&RunEnd {
            run: meta.run,
            abort: AbortReason::from_u8(abort),
            counters: RunCounters::from_array(counters),
        });
    }
    let mut file = Vec::new();
    let mut lines = Vec::new();
    let n = write_csv(&log, &meta, &mut |b: &[u8]| {
        file.extend_from_slice(b);
        lines.push(b.to_vec());
    });
    assert_eq!(n, file.len());
    assert_eq!(csv_len(&log, &meta), n);
    for l in &lines {
        assert!(l.len() <= CSV_LINE_MAX, "line longer than the line buffer");
        assert_eq!(
            l.last(),
            Some(&b'\n'),
            "line cut short: {:?}",
            String::from_utf8_lossy(l)
        );
    }
    let mut pulled = Vec::new();
    let mut c = CsvCursor::new();
    let mut size = 1 + usize::from(pat % 61);
    loop {
        let mut buf = vec![0u8; size];
        let k = c.fill(&log, &meta, &mut buf);
        if k == 0 {
            break;
        }
        pulled.extend_from_slice(&buf[..k]);
        size = size % 97 + 3;
    }
    assert_eq!(pulled, file);
    // The replay reads what the pod wrote (a run with a valid configuration and samples).
    let kept: Vec<Sample> = log
        .iter()
        .filter(|r| !r.record.is_touch())
        .map(|r| r.sample())
        .collect();
    if meta.config.validate().is_ok() && !kept.is_empty() {
        let text = String::from_utf8(file).expect("the pod writes ASCII");
        let runs = parse_runs(Path::new("log.csv"), &text)
            .unwrap_or_else(|e| panic!("the replay refused the pod's own log: {e}\n{text}"));
        let got: Vec<&Sample> = runs[0].samples().collect();
        assert_eq!(got.len(), kept.len());
        // A finite ΔL reads back bit for bit; any other (NaN, ±inf) is not a valid value and
        // the format writes it `nan`.
        let same = |got: f32, logged: f32| {
            if logged.is_finite() {
                got.to_bits() == logged.to_bits()
            } else {
                got.is_nan()
            }
        };
        for (g, k) in got.iter().zip(&kept) {
            assert_eq!((g.seq, g.t_us, g.flags), (k.seq, k.t_us, k.flags));
            assert!(same(g.delta_l_um, k.delta_l_um), "{g:?} vs {k:?}");
        }
    }
});
