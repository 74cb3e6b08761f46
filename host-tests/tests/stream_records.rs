//! The sample stream's binary records (`protocol::stream`): the bytes at the offsets the format
//! table documents, decoded into the text the log writes for the same samples, read back by
//! the replay reader bit for bit against the samples fed in (the forward model), kept whole
//! through the ring's wrap, counted when dropped, and refused when cut.
use std::path::Path;

use ballpod::acquisition::{MAX_AXES, Sample, SampleFlags};
use ballpod::app::log::SampleLog;
use ballpod::app::{
    AbortReason, Direction, Pattern, Recorder, RunCounters, RunEnd, RunMeta, Touch,
};
use ballpod::config::{AxisName, Config};
use ballpod::protocol::download::write_csv;
use ballpod::protocol::stream::{
    DecodeError, RECORD_MAX, RECORD_TAG, SampleStream, decode, record_len,
};
use ballpod_host::recording::{Event, parse_runs};
use ballpod_host::rng::Rng;
use ballpod_host::session_file::read_recording;

/// Any f32 bit pattern that is finite, or NaN one time in 16.
fn any_f32(rng: &mut Rng) -> f32 {
    if rng.next_u64().is_multiple_of(16) {
        return f32::NAN;
    }
    loop {
        let v = f32::from_bits(rng.next_u64() as u32);
        if v.is_finite() {
            return v;
        }
    }
}

/// Axes C, X, unused, A, Z: the columns (X, Z, A, C) are inputs 1, 4, 3, 0.
fn meta() -> RunMeta {
    let mut c = Config::default();
    c.try_update(|c| {
        c.axes[0].name = AxisName::C;
        c.axes[1].name = AxisName::X;
        c.axes[2].name = AxisName::Unused;
        c.axes[3].name = AxisName::A;
        c.axes[4].name = AxisName::Z;
    })
    .unwrap();
    RunMeta {
        run: 7,
        pattern: Pattern::Probe,
        direction: Direction::Ccw,
        config: c,
    }
}

/// A run's events: samples with every f32 exponent, NaN, −0, temperatures to ±400 °C, and a
/// touch point every 37 samples.
fn events(n: usize, rng: &mut Rng) -> Vec<Event> {
    let mut out = Vec::new();
    for k in 0..n {
        let s = Sample {
            seq: 4_000_000_000 + k as u32,
            t_us: (5u64 << 32) - 100_000 + 1_000 * k as u64,
            delta_l_um: if k == 3 { -0.0 } else { any_f32(rng) },
            axes: core::array::from_fn(|_| any_f32(rng)),
            temp_c: match k % 5 {
                0 => f32::NAN,
                1 => 400.0,
                _ => (rng.next_u64() % 70_000) as f32 / 1000.0 - 35.0 + 1e-4,
            },
            flags: SampleFlags((rng.next_u64() & 0x3F) as u16),
        };
        out.push(Event::Sample(s));
        if k % 37 == 5 {
            out.push(Event::Touch(Touch {
                t_us: s.t_us + 300,
                axes: core::array::from_fn(|_| any_f32(rng)),
            }));
        }
    }
    out
}

/// The end of a run that saw `seen` samples.
fn end(seen: u32) -> RunEnd {
    RunEnd {
        run: 7,
        abort: Some(AbortReason::ByCommand),
        counters: RunCounters {
            seen,
            ..RunCounters::default()
        },
    }
}

fn feed(rec: &mut impl Recorder, m: &RunMeta, ev: &[Event]) {
    rec.begin_run(m);
    for e in ev {
        match e {
            Event::Sample(s) => rec.sample(s),
            Event::Touch(t) => rec.touch(t),
        }
    }
    let seen = ev.iter().filter(|e| matches!(e, Event::Sample(_))).count();
    rec.end_run(&end(seen as u32));
}

/// Everything a stream of `N` bytes gives when it is drained `chunk` bytes at a time after
/// every event.
fn stream_bytes<const N: usize>(m: &RunMeta, ev: &[Event], chunk: usize) -> (Vec<u8>, u32) {
    struct Drained<'a, const N: usize>(&'a mut SampleStream<N>, Vec<u8>, usize);
    impl<const N: usize> Drained<'_, N> {
        fn drain(&mut self) {
            self.1.extend(take(self.0, self.2));
        }
    }
    impl<const N: usize> Recorder for Drained<'_, N> {
        fn begin_run(&mut self, m: &RunMeta) {
            self.0.begin_run(m);
            while self.0.pending() > 0 {
                self.drain();
            }
        }
        fn sample(&mut self, s: &Sample) {
            self.0.sample(s);
            self.drain();
        }
        fn touch(&mut self, t: &Touch) {
            self.0.touch(t);
            self.drain();
        }
        fn end_run(&mut self, e: &RunEnd) {
            self.0.end_run(e);
            while self.0.pending() > 0 {
                self.drain();
            }
        }
    }
    let mut s = Box::new(SampleStream::<N>::new());
    s.set_enabled(true);
    let mut d = Drained(&mut s, Vec::new(), chunk);
    feed(&mut d, m, ev);
    let bytes = d.1;
    (bytes, s.dropped_lines())
}

/// Up to `max` bytes the stream hands out ([`SampleStream::drain`]).
fn take<const N: usize>(st: &mut SampleStream<N>, max: usize) -> Vec<u8> {
    let mut out = Vec::new();
    st.drain(max, &mut |b| out.extend_from_slice(b));
    out
}

fn decoded(bytes: &[u8]) -> String {
    let mut text = Vec::new();
    let n = decode(bytes, |l| text.extend_from_slice(l)).expect("decodes");
    assert_eq!(n, bytes.len());
    String::from_utf8(text).unwrap()
}

fn same_f32(a: f32, b: f32) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

#[test]
fn a_record_holds_the_documented_bytes() {
    let m = meta();
    let s = Sample {
        seq: 0x0403_0201,
        t_us: 0x0C0B_0A09_0807_0605,
        delta_l_um: 1.5,
        axes: [10.0, 11.0, 12.0, 13.0, 14.0],
        temp_c: 20.25,
        flags: SampleFlags(0x1234),
    };
    let mut st = SampleStream::<4096>::new();
    st.set_enabled(true);
    st.begin_run(&m);
    let head = take(&mut st, usize::MAX);
    assert!(!head.contains(&RECORD_TAG), "the header is text");
    st.sample(&s);
    let rec = take(&mut st, 64);
    // NULs up to the next multiple of 4 bytes of the stream, then the record
    let pad = head.len().next_multiple_of(4) - head.len();
    assert!(rec[..pad].iter().all(|&b| b == 0));
    let rec = &rec[pad..];
    // four axis columns: 24 + 16 bytes
    assert_eq!(rec.len(), 40);
    assert_eq!(record_len(4), 40);
    assert_eq!(RECORD_MAX, 44);
    let f = |v: f32| v.to_le_bytes().to_vec();
    // tag, n, flags, seq, t_us, ΔL, the columns X, Z, A, C (inputs 1, 4, 3, 0), °C
    let mut want = vec![0xB5, 4, 0x34, 0x12, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12];
    for v in [1.5, 11.0, 14.0, 13.0, 10.0, 20.25] {
        want.extend(f(v));
    }
    assert_eq!(rec, &want[..]);
}

#[test]
fn records_decode_to_the_log_s_text_and_replay_bit_for_bit() {
    let m = meta();
    let mut rng = Rng(0x05EE_D0B5);
    let ev = events(700, &mut rng);
    let (bytes, dropped) =
        stream_bytes::<{ ballpod::protocol::stream::FIRMWARE_RING_BYTES }>(&m, &ev, 64);
    assert_eq!(dropped, 0);
    let text = decoded(&bytes);
    // the log of the same run writes the same text but for how it was made
    let mut log = Box::new(SampleLog::<1024>::new());
    feed(&mut *log, &m, &ev);
    let mut log_text = Vec::new();
    write_csv(&*log, &m, &mut |c: &[u8]| log_text.extend_from_slice(c));
    let log_text = String::from_utf8(log_text).unwrap();
    let body = |t: &str| -> Vec<String> {
        t.lines()
            .filter(|l| {
                ![
                    "# source=",
                    "# decimation=",
                    "# records=",
                    "# overwritten=",
                    "# stream_dropped=",
                ]
                .iter()
                .any(|p| l.starts_with(p))
            })
            .map(str::to_string)
            .collect()
    };
    assert_eq!(body(&text), body(&log_text));
    assert!(text.contains("\n# source=stream\n") && text.ends_with("# stream_dropped=0\n"));
    // the replay reader gives back every event, bit for bit (temperature at 0.01 °C)
    let runs = parse_runs(Path::new("stream.bin"), &text).unwrap();
    assert_eq!(runs.len(), 1);
    // both texts name the firmware that made them, and the reader keeps it
    assert!(text.contains(&format!("\n# firmware={}\n", ballpod::FIRMWARE_VERSION)));
    assert_eq!(runs[0].firmware.as_deref(), Some(ballpod::FIRMWARE_VERSION));
    let got = &runs[0].events;
    assert_eq!(got.len(), ev.len());
    let columns = [1usize, 3, 4]; // X, A, Z … and C: input 0
    for (k, (g, e)) in got.iter().zip(&ev).enumerate() {
        match (g, e) {
            (Event::Sample(g), Event::Sample(e)) => {
                assert_eq!((g.seq, g.t_us, g.flags), (e.seq, e.t_us, e.flags), "{k}");
                assert!(same_f32(g.delta_l_um, e.delta_l_um), "{k}");
                for i in columns.into_iter().chain([0]) {
                    assert!(same_f32(g.axes[i], e.axes[i]), "{k} axis {i}");
                }
                if e.temp_c.is_finite() && e.temp_c.abs() < 327.0 {
                    assert!((g.temp_c - e.temp_c).abs() <= 0.005 + 1e-4, "{k}");
                } else {
                    assert!(g.temp_c.is_nan(), "{k}");
                }
            }
            (Event::Touch(g), Event::Touch(e)) => {
                assert_eq!(g.t_us, e.t_us);
                for i in columns.into_iter().chain([0]) {
                    assert!(same_f32(g.axes[i], e.axes[i]), "{k} axis {i}");
                }
            }
            _ => panic!("event {k}: {g:?} vs {e:?}"),
        }
    }
}

#[test]
fn the_ring_wraps_without_reordering_a_byte() {
    let m = meta();
    let mut rng = Rng(77);
    let ev = events(300, &mut rng);
    let (whole, _) = stream_bytes::<{ 1 << 20 }>(&m, &ev, 1 << 20);
    // a ring of an odd size that holds the header, drained in odd chunks: it wraps every
    // 2 111 bytes, at every offset of a record
    for chunk in [45, 61, 200] {
        let (wrapped, dropped) = stream_bytes::<2111>(&m, &ev, chunk);
        assert_eq!(dropped, 0, "chunk {chunk}");
        assert_eq!(wrapped, whole, "chunk {chunk}");
    }
}

#[test]
fn a_full_ring_drops_whole_records_and_counts_them() {
    let m = meta();
    let mut rng = Rng(5);
    let ev = events(200, &mut rng);
    let mut st = Box::new(SampleStream::<8192>::new());
    st.set_enabled(true);
    st.begin_run(&m);
    let mut out = take(&mut st, usize::MAX);
    for e in &ev {
        match e {
            Event::Sample(s) => st.sample(s),
            Event::Touch(t) => st.touch(t),
        }
    }
    // 8192 bytes hold 204 records of 40 bytes (and the first one's padding): the rest were
    // dropped whole
    let kept = 8192 / record_len(4);
    assert_eq!(st.dropped_lines() as usize, ev.len() - kept);
    let rest = take(&mut st, usize::MAX);
    st.end_run(&end(200));
    let tail = take(&mut st, usize::MAX);
    out.extend(rest);
    out.extend(tail);
    let text = decoded(&out);
    let rows = text.lines().filter(|l| !l.starts_with('#')).count() - 1;
    assert_eq!(rows, kept);
    assert!(text.ends_with(&format!("# stream_dropped={}\n", ev.len() - kept)));
    assert!(
        parse_runs(Path::new("s"), &text)
            .unwrap_err()
            .to_string()
            .contains("cannot be replayed")
    );
}

#[test]
fn with_no_reader_the_stream_writes_and_counts_nothing() {
    let m = meta();
    let mut rng = Rng(9);
    let ev = events(50, &mut rng);
    let mut st = SampleStream::<256>::new();
    feed(&mut st, &m, &ev);
    assert_eq!((st.pending(), st.dropped_lines()), (0, 0));
    // a reader attached mid-run gets the records from then on, in the run's columns
    st.begin_run(&m);
    st.set_enabled(true);
    if let Event::Sample(s) = &ev[0] {
        st.sample(s);
    }
    assert_eq!(st.pending(), record_len(4));
}

#[test]
fn a_cut_or_foreign_record_is_refused_with_its_byte_offset() {
    let m = meta();
    let mut rng = Rng(3);
    let ev = events(10, &mut rng);
    let (bytes, _) = stream_bytes::<4096>(&m, &ev, 4096);
    let first = bytes.iter().position(|&b| b == RECORD_TAG).unwrap();
    // the recording ends inside its third record
    let cut = &bytes[..first + 2 * record_len(4) + 7];
    assert_eq!(
        decode(cut, |_| {}),
        Err(DecodeError::Cut {
            offset: first + 2 * record_len(4)
        })
    );
    let mut bad = bytes.clone();
    bad[first + 1] = (MAX_AXES + 1) as u8;
    assert_eq!(
        decode(&bad, |_| {}),
        Err(DecodeError::BadRecord { offset: first })
    );
    // replay names the file, the line the row would be on, and the byte
    let dir = std::env::temp_dir().join(format!("ballpod-stream-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let f = dir.join("cut.bin");
    std::fs::write(&f, cut).unwrap();
    let e = read_recording(&f).unwrap_err().to_string();
    let header_lines = bytes[..first].iter().filter(|&&b| b == b'\n').count();
    assert!(e.contains("cut.bin"), "{e}");
    assert!(e.contains(&format!("cut.bin:{}:", header_lines + 3)), "{e}");
    assert!(
        e.contains(&format!(
            "byte {}: the recording ends inside a sample record",
            first + 2 * record_len(4)
        )),
        "{e}"
    );
    // the whole recording reads as its text
    std::fs::write(&f, &bytes).unwrap();
    assert_eq!(read_recording(&f).unwrap(), decoded(&bytes));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The firmware's ring holds the longest header a run can have — every real-valued
/// configuration field set to a value that prints long (no "nan" left where a field is
/// optional), five axis columns — with room for 46 records after it, for every pattern; no
/// line is dropped.
#[test]
fn the_firmware_ring_holds_the_longest_header_and_46_records() {
    use ballpod::config::{FIELDS, FieldType};
    use ballpod::protocol::stream::FIRMWARE_RING_BYTES;
    let mut c = meta().config;
    let mut set = 0;
    for row in FIELDS {
        if !matches!(row.ty, FieldType::F32 | FieldType::F64) {
            continue;
        }
        let span = row.max - row.min;
        let v = if span.is_finite() {
            row.min + 0.712_345_678_9 * span
        } else {
            -12_345.678_912_3
        };
        for f in row.fields() {
            // a cross-field rule may refuse one value: the field keeps its default then
            if c.try_update(|c| c.set_field(f, v)).is_ok() {
                set += 1;
            }
        }
    }
    assert!(set > 40, "only {set} fields took a long value");
    for pattern in Pattern::ALL {
        let m = RunMeta {
            pattern,
            config: c,
            ..meta()
        };
        let mut s = Box::new(SampleStream::<FIRMWARE_RING_BYTES>::new());
        s.set_enabled(true);
        s.begin_run(&m);
        assert_eq!(s.dropped_lines(), 0, "{pattern:?}: header lines dropped");
        let header = s.pending();
        assert!(
            header + 46 * RECORD_MAX <= FIRMWARE_RING_BYTES,
            "{pattern:?}: header {header} B leaves no room for 46 records in {FIRMWARE_RING_BYTES} B"
        );
    }
}
