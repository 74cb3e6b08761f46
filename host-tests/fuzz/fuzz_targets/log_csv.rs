//! The log's CSV writer on arbitrary samples (any f32 including NaN, ±inf and extremes) and
//! metadata. Invariants: no panic; `csv_len` equals the bytes written; no line is cut short
//! (every line ends in `\n` and is at most `CSV_LINE_MAX` bytes); pulling the file with
//! `CsvCursor::fill` in arbitrary buffer sizes gives the same bytes as streaming it.
#![no_main]

use arbitrary::{Arbitrary, Unstructured};
use ballpod::acquisition::{Sample, SampleFlags};
use ballpod::config::AxisName;
use ballpod::protocol::log::{CSV_LINE_MAX, CsvCursor, LogMeta, SampleLog, csv_len, write_csv};
use ballpod::protocol::pod::{Direction, Pattern};
use libfuzzer_sys::fuzz_target;

#[derive(Arbitrary, Debug)]
struct RawSample {
    seq: u32,
    t_us: u64,
    delta_l_um: f32,
    axes: [f32; 5],
    temp_c: f32,
    flags: u16,
}

const PATTERNS: [Pattern; 8] = [
    Pattern::Circle,
    Pattern::Bx,
    Pattern::By,
    Pattern::Cr,
    Pattern::Ca,
    Pattern::CrPrime,
    Pattern::Ssm,
    Pattern::Probe,
];

fuzz_target!(|data: &[u8]| {
    let mut u = Unstructured::new(data);
    let Ok((bar, rate, pat, dir, names, dec)) =
        <(f32, f32, u8, bool, [u8; 5], u8)>::arbitrary(&mut u)
    else {
        return;
    };
    let mut axes = [AxisName::Unused; 5];
    for (a, n) in axes.iter_mut().zip(names) {
        *a = AxisName::from_u8(n % 8).unwrap_or(AxisName::Unused);
    }
    let meta = LogMeta {
        bar_length_mm: bar,
        pattern: PATTERNS[usize::from(pat) % PATTERNS.len()],
        direction: if dir { Direction::Cw } else { Direction::Ccw },
        sample_rate_hz: rate,
        axes,
    };
    let mut log: SampleLog<16> = SampleLog::new();
    log.set_decimation(u16::from(dec % 4));
    while !u.is_empty() {
        let Ok(r) = RawSample::arbitrary(&mut u) else {
            break;
        };
        log.push(&Sample {
            seq: r.seq,
            t_us: r.t_us,
            delta_l_um: r.delta_l_um,
            axes: r.axes,
            temp_c: r.temp_c,
            flags: SampleFlags(r.flags),
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
    let mut size = 1 + usize::from(dec % 61);
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
});
