//! The pod's log of a run and its CSV text (format v2, `protocol::csv` / `protocol::download`):
//! the run header with every configuration field, decimation of whole runs when the log is full,
//! touch rows, end lines, `nan` for what is not valid — read back by the host's replay reader
//! (`ballpod_host::recording::parse_runs`), which must give back the same samples bit for bit,
//! and checked line by line against the format's documentation.
use std::path::Path;

use ballpod::acquisition::{MAX_AXES, Sample, SampleFlags};
use ballpod::app::log::{LOG_CAPACITY, LogRecord, SampleLog};
use ballpod::app::{
    AbortReason, App, Direction, Pattern, Recorder, RunCounters, RunEnd, RunMeta, Touch,
};
use ballpod::config::{
    AxisName, CanBitrate, CirclePlane, Config, FIELDS, LvdtInput, TwoStepMachine,
};
use ballpod::protocol::download::{CsvCursor, csv_len, write_csv};
use ballpod_host::recording::{Event, RecordedRun, parse_runs};

/// xorshift64* for reproducible samples.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// Uniform in [-a, a].
    fn sym(&mut self, a: f64) -> f64 {
        ((self.next() >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0) * a
    }
    /// Any finite f32, every exponent equally likely (subnormals and zeros included).
    fn any_f32(&mut self) -> f32 {
        loop {
            let v = f32::from_bits(self.next() as u32);
            if v.is_finite() {
                return v;
            }
        }
    }
}

/// The CSV text of a log, written whole; checks that the byte count, `csv_len` and a cursor
/// filling buffers of several sizes all give the same text.
fn csv_of<const N: usize>(log: &SampleLog<N>, meta: &RunMeta) -> String {
    let mut out = Vec::new();
    let n = write_csv(log, meta, &mut |c: &[u8]| out.extend_from_slice(c));
    assert_eq!(n, out.len());
    assert_eq!(csv_len(log, meta), out.len());
    for size in [1usize, 13, 200] {
        let mut cursor = CsvCursor::new();
        let mut buf = vec![0u8; size];
        let mut pulled = Vec::new();
        loop {
            let k = cursor.fill(log, meta, &mut buf);
            if k == 0 {
                break;
            }
            pulled.extend_from_slice(&buf[..k]);
        }
        assert!(cursor.is_done(log));
        assert_eq!(pulled, out, "cursor with {size}-byte buffers");
    }
    let text = String::from_utf8(out).unwrap();
    assert!(text.ends_with('\n'));
    assert!(!text.contains('\r'));
    text
}

/// The runs of a text, read by the replay reader.
fn replay(text: &str) -> Vec<RecordedRun> {
    parse_runs(Path::new("log.csv"), text).unwrap_or_else(|e| panic!("{e}\n{text}"))
}

/// The single run of a log's text.
fn replay_one(text: &str) -> RecordedRun {
    let mut runs = replay(text);
    assert_eq!(runs.len(), 1);
    runs.pop().unwrap()
}

/// The same f32, bit for bit (any NaN equals any NaN: the text has one `nan`).
fn same_f32(a: f32, b: f32) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

/// Two samples equal bit for bit.
fn same_sample(a: &Sample, b: &Sample) -> bool {
    a.seq == b.seq
        && a.t_us == b.t_us
        && same_f32(a.delta_l_um, b.delta_l_um)
        && a.axes.iter().zip(&b.axes).all(|(x, y)| same_f32(*x, *y))
        && same_f32(a.temp_c, b.temp_c)
        && a.flags == b.flags
}

/// A configuration compared as text (NaN — a set-up field not set — equals itself there, and
/// `{:?}` prints every float in its shortest round-trip form, so equal text = equal bits).
fn config_text(c: &Config) -> String {
    format!("{c:?}")
}

fn meta(run: u32, pattern: Pattern, direction: Direction, config: Config) -> RunMeta {
    RunMeta {
        run,
        pattern,
        direction,
        config,
    }
}

fn default_meta() -> RunMeta {
    meta(1, Pattern::Circle, Direction::Ccw, Config::default())
}

fn random_samples(n: usize, first_seq: u32, t0_us: u64, rng: &mut Rng) -> Vec<Sample> {
    (0..n)
        .map(|k| Sample {
            seq: first_seq + k as u32,
            t_us: t0_us + k as u64 * 997 + (rng.next() % 3),
            delta_l_um: rng.sym(1000.0) as f32,
            axes: [
                rng.sym(1000.0) as f32,
                rng.sym(1000.0) as f32,
                rng.sym(600.0) as f32,
                rng.sym(360.0) as f32,
                rng.sym(720.0) as f32,
            ],
            temp_c: (20.0 + rng.sym(15.0)) as f32,
            flags: SampleFlags((rng.next() & 0x37) as u16), // no probe event
        })
        .collect()
}

/// A log of one run of `samples` with header `m` (not ended).
fn log_of<const N: usize>(m: &RunMeta, samples: &[Sample]) -> SampleLog<N> {
    let mut log = SampleLog::<N>::new();
    log.begin_run(m);
    for s in samples {
        log.sample(s);
    }
    log
}

/// The `# key=value` lines of the text before its column header.
fn header_values(text: &str) -> Vec<(String, String)> {
    text.lines()
        .take_while(|l| l.starts_with('#'))
        .filter_map(|l| l.strip_prefix("# ")?.split_once('='))
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect()
}

fn value<'a>(h: &'a [(String, String)], key: &str) -> &'a str {
    &h.iter()
        .find(|(k, _)| k == key)
        .unwrap_or_else(|| panic!("no {key}"))
        .1
}

/// The data rows (between the column header and the end lines), split at commas.
fn rows(text: &str) -> Vec<Vec<String>> {
    text.lines()
        .skip_while(|l| l.starts_with('#'))
        .skip(1)
        .take_while(|l| !l.starts_with('#'))
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

fn columns(text: &str) -> Vec<String> {
    let l = text.lines().find(|l| !l.starts_with('#')).unwrap();
    l.split(',').map(str::to_string).collect()
}

// ---------------------------------------------------------------------------------------------
// The run header
// ---------------------------------------------------------------------------------------------

/// A configuration with every kind of field away from its default.
fn unusual_config() -> Config {
    let mut c = Config::default();
    c.try_update(|c| {
        c.bar_length_mm = 150.0021; // needs 9 digits: 150.002106
        c.bar_cte_ppm_per_k = -1.25;
        c.lvdt_input = LvdtInput::DcConditioner;
        c.lvdt_poly_um = [-3.5, 2100.25, 1.0e-5, -0.125];
        c.lvdt_dc_zero_v = -0.0312;
        c.sample_rate_hz = 2500.0;
        c.axes[0].name = AxisName::C;
        c.axes[1].name = AxisName::X;
        c.axes[2].name = AxisName::Unused;
        c.axes[3].name = AxisName::A;
        c.axes[4].name = AxisName::Z;
        c.axes[1].reversed = true;
        c.axes[1].counts_per_unit = 12345.678901;
        c.axes[3].counts_per_unit = 0.1;
        c.axes[0].max_speed_per_s = 7.3;
        c.probe_debounce_us = 99_999;
        c.can_node_id = 127;
        c.can_bitrate = CanBitrate::M1;
        c.setup.circle_plane = CirclePlane::ZX;
        c.setup.circle_centre_mm = [1.5, -2.25, 0.0];
        c.setup.circle_radius_mm = 149.875;
        c.setup.circle_min_arc_deg = 220.0;
        c.setup.s002_l_b_mm = 200.5;
        c.setup.ssm_min_dwell_samples = 1_000_000;
        c.setup.ts_machine = TwoStepMachine::Tttrr;
        c.setup.ts_angles_deg = [90.0, -45.0];
    })
    .unwrap();
    c
}

#[test]
fn the_header_names_the_run_and_every_configuration_field() {
    let m = meta(3, Pattern::Cr2, Direction::Cw, unusual_config());
    let log = SampleLog::<4>::new();
    let text = csv_of(&log, &m);
    assert_eq!(text.lines().next(), Some("# ballpod run v2"));
    let h = header_values(&text);
    for (k, v) in [
        ("run", "3"),
        ("pattern", "CR2"),
        ("direction", "CW"),
        ("bar_length", "150.002106"),
        ("bar_cte", "-1.25"),
        ("lvdt_poly0", "-3.5"),
        ("lvdt_poly1", "2100.25"),
        ("lvdt_poly2", "9.99999975e-6"),   // below 1e-5: d.ddde±x
        ("lvdt_dc_zero", "-0.0311999992"), // the f32 nearest -0.0312
        ("sample_rate", "2500"),
        ("axis_counts1", "12345.678901"),
        ("axis_counts3", "0.1"),
        ("axis_max_speed0", "7.30000019"),
        ("probe_debounce", "99999"),
        ("can_node_id", "127"),
        ("circle_plane", "ZX"),
        ("circle_centre_x", "1.5"),
        ("circle_centre_y", "-2.25"),
        ("circle_centre_z", "0"),
        ("circle_radius", "149.875"),
        ("circle_feed", "nan"),
        ("circle_min_arc", "220"),
        ("s002_l_b", "200.5"),
        ("s002_r_b", "nan"),
        ("ssm_min_dwell", "1000000"),
        ("ts_machine", "TTTRR"),
        ("ts_angle_1", "90"),
        ("ts_angle_2", "-45"),
        ("ts_origin_z", "nan"),
        ("lvdt_input", "DC"),
        ("can_bitrate", "1000000"),
        ("axis_name0", "C"),
        ("axis_name1", "X"),
        ("axis_name2", "-"),
        ("axis_reversed1", "1"),
        ("axis_reversed2", "0"),
        ("source", "log"),
        ("decimation", "1"),
        ("records", "0"),
        ("overwritten", "0"),
    ] {
        assert_eq!(value(&h, k), v, "# {k}");
    }
    // every element of config::FIELDS has its line, in table order, then the enumerations
    let names: Vec<String> = FIELDS
        .iter()
        .flat_map(|f| {
            (0..f.elements.max(1)).map(move |k| {
                if f.elements > 0 {
                    format!("{}{k}", f.name)
                } else {
                    f.name.to_string()
                }
            })
        })
        .chain(["lvdt_input".to_string(), "can_bitrate".to_string()])
        .chain((0..MAX_AXES).flat_map(|i| [format!("axis_name{i}"), format!("axis_reversed{i}")]))
        .collect();
    let keys: Vec<&String> = h.iter().map(|(k, _)| k).skip(3).take(names.len()).collect();
    assert_eq!(keys, names.iter().collect::<Vec<_>>());
    // columns: the configured axes in the order X, Y, Z, A, B, C
    assert_eq!(
        columns(&text),
        [
            "seq", "t_s", "dl_um", "x_mm", "z_mm", "a_deg", "c_deg", "temp_c", "flags"
        ]
    );
}

#[test]
fn the_header_round_trips_through_the_replay_reader() {
    for m in [
        meta(3, Pattern::Cr2, Direction::Cw, unusual_config()),
        meta(1, Pattern::Circle, Direction::Ccw, Config::default()),
        meta(u32::MAX, Pattern::Probe, Direction::Ccw, Config::default()),
    ] {
        let log = log_of::<4>(&m, &[]);
        let run = replay_one(&csv_of(&log, &m));
        assert_eq!(run.meta.run, m.run);
        assert_eq!(run.meta.pattern, m.pattern);
        assert_eq!(run.meta.direction, m.direction);
        assert_eq!(config_text(&run.meta.config), config_text(&m.config));
        assert_eq!(run.events, vec![]);
        assert_eq!(run.end, None);
        assert_eq!(run.decimation, 1);
    }
}

// ---------------------------------------------------------------------------------------------
// Samples
// ---------------------------------------------------------------------------------------------

#[test]
fn samples_round_trip_bit_for_bit() {
    const N: usize = 600;
    let mut rng = Rng(0x0BA1_1B0D);
    // 0.2 s before a 32-bit µs wrap: the run straddles it (the log keeps the low word)
    let t0 = 8 * (1u64 << 32) - 200_000;
    let mut samples = random_samples(500, 77_000, t0, &mut rng);
    // every exponent of f32 in ΔL and the axes, and what is not valid: nan
    for s in samples.iter_mut().skip(100).take(300) {
        s.delta_l_um = rng.any_f32();
        for a in s.axes.iter_mut() {
            *a = rng.any_f32();
        }
    }
    samples[3].delta_l_um = f32::NAN;
    samples[3].flags = SampleFlags::LVDT_OPEN;
    samples[4].axes[2] = f32::NAN;
    samples[5].temp_c = f32::NAN;
    samples[5].flags = SampleFlags::TEMPERATURE_FAULT;
    samples[6].temp_c = 400.0; // beyond the log's ±327 °C: not valid
    assert!(
        samples[0].t_us >> 32 != samples[499].t_us >> 32,
        "crosses the wrap"
    );
    let m = default_meta(); // axes X, Y, Z, B, C
    let log = log_of::<N>(&m, &samples);
    let text = csv_of(&log, &m);
    let run = replay_one(&text);
    let got: Vec<Sample> = run.samples().copied().collect();
    assert_eq!(got.len(), samples.len());
    for (k, ((g, r), s)) in got.iter().zip(log.iter()).zip(&samples).enumerate() {
        // the replay gives back what the log holds, bit for bit …
        assert!(
            same_sample(g, &r.sample()),
            "row {k}: {g:?} vs {:?}",
            r.sample()
        );
        // … which is the sample, its temperature at the log's 0.01 °C
        let t = Sample {
            temp_c: g.temp_c,
            ..*s
        };
        assert!(same_sample(g, &t), "row {k}: {g:?} vs {s:?}");
        if s.temp_c.abs() < 327.0 {
            assert!((g.temp_c - s.temp_c).abs() <= 0.005 + 1e-4, "row {k}");
        } else {
            assert!(g.temp_c.is_nan(), "row {k}");
        }
    }
    // the text of the invalid values and the columns' formats
    let r = rows(&text);
    let col = |name: &str| columns(&text).iter().position(|c| c == name).unwrap();
    assert_eq!(r[3][col("dl_um")], "nan");
    assert_eq!(r[4][col("z_mm")], "nan");
    assert_eq!(r[5][col("temp_c")], "nan");
    assert_eq!(r[6][col("temp_c")], "nan");
    assert_eq!(r[0][col("seq")], "77000");
    for (row, s) in r.iter().zip(&samples) {
        let t = &row[col("t_s")];
        let (sec, frac) = t.split_once('.').unwrap();
        assert_eq!(frac.len(), 6, "t_s has µs resolution: {t}");
        assert_eq!(
            sec.parse::<u64>().unwrap() * 1_000_000 + frac.parse::<u64>().unwrap(),
            s.t_us
        );
        let temp = &row[col("temp_c")];
        if temp != "nan" {
            assert_eq!(temp.split_once('.').unwrap().1.len(), 2, "{temp}");
        }
        assert_eq!(row[col("flags")], s.flags.0.to_string());
        // 9 significant digits at most
        let digits = row[col("dl_um")]
            .split('e')
            .next()
            .unwrap()
            .chars()
            .filter(char::is_ascii_digit)
            .collect::<String>();
        let significant = digits.trim_start_matches('0').trim_end_matches('0');
        assert!(significant.len() <= 9, "{}", row[col("dl_um")]);
    }
}

#[test]
fn columns_follow_the_configured_axes_in_xyzabc_order() {
    let mut c = Config::default();
    c.try_update(|c| {
        c.axes[0].name = AxisName::C;
        c.axes[1].name = AxisName::X;
        c.axes[2].name = AxisName::Unused;
        c.axes[3].name = AxisName::A;
        c.axes[4].name = AxisName::Z;
    })
    .unwrap();
    let m = meta(2, Pattern::Cr2, Direction::Cw, c);
    let s = Sample {
        seq: 41,
        t_us: 3_000_001,
        delta_l_um: -0.25,
        axes: [90.5, 12.5, 99.0, -45.25, -3.0],
        temp_c: f32::NAN,
        flags: SampleFlags::TEMPERATURE_FAULT,
    };
    let text = csv_of(&log_of::<4>(&m, &[s]), &m);
    assert_eq!(
        columns(&text),
        [
            "seq", "t_s", "dl_um", "x_mm", "z_mm", "a_deg", "c_deg", "temp_c", "flags"
        ]
    );
    assert_eq!(
        rows(&text),
        [[
            "41", "3.000001", "-0.25", "12.5", "-3", "-45.25", "90.5", "nan", "32"
        ]]
    );
    // the unused input is not in the file: the replay reads it as not valid
    let run = replay_one(&text);
    let g = run.samples().next().unwrap();
    assert_eq!(g.axes[..2], [90.5, 12.5]);
    assert!(g.axes[2].is_nan());
    assert_eq!(g.axes[3..], [-45.25, -3.0]);
}

#[test]
fn a_negative_zero_keeps_its_value() {
    // -0.0 is written `-0` and read back with its sign bit.
    let m = default_meta();
    let s = Sample {
        seq: 1,
        t_us: 1,
        delta_l_um: -0.0,
        axes: [-0.0, 0.0, 1.0, 2.0, 3.0],
        temp_c: 21.25, // stored in 0.01 °C: a -0.0 would be 0
        ..Sample::default()
    };
    let text = csv_of(&log_of::<4>(&m, &[s]), &m);
    assert_eq!(rows(&text)[0][2..8], ["-0", "-0", "0", "1", "2", "3"]);
    let g = *replay_one(&text).samples().next().unwrap();
    assert!(same_sample(&g, &s), "{g:?}");
    assert!(g.delta_l_um.is_sign_negative() && g.axes[0].is_sign_negative());
}

// ---------------------------------------------------------------------------------------------
// Decimation: whole runs at the best rate that fits
// ---------------------------------------------------------------------------------------------

/// Checks a log of `n` consecutive samples from `first` against the documented rule: the
/// decimation d is a power of two, the log holds the run's samples first + k·d (so it spans the
/// whole run) and no more than fit; at d/2 the run did not fit.
fn check_decimation<const N: usize>(log: &SampleLog<N>, first: u32, n: usize) -> u32 {
    let d = log.decimation();
    assert!(d.is_power_of_two(), "{d}");
    let kept: Vec<u32> = log.iter().map(|r| r.record.seq).collect();
    let want: Vec<u32> = (0..n as u32)
        .step_by(d as usize)
        .map(|k| first + k)
        .collect();
    assert_eq!(kept, want, "n = {n}, d = {d}");
    assert!(kept.len() <= N);
    if d > 1 {
        assert!(
            n.div_ceil(d as usize / 2) >= N,
            "n = {n}: d = {d} is not the best rate"
        );
    }
    assert_eq!(
        log.overwritten(),
        0,
        "samples are thinned, never overwritten"
    );
    d
}

#[test]
fn a_full_log_decimates_and_the_text_says_so() {
    let mut rng = Rng(5);
    let m = default_meta();
    for n in [0usize, 1, 15, 16, 17, 31, 32, 33, 64, 65, 100, 257] {
        let samples = random_samples(n, 1000, 0, &mut rng);
        let log = log_of::<16>(&m, &samples);
        let d = check_decimation(&log, 1000, n);
        let text = csv_of(&log, &m);
        let h = header_values(&text);
        assert_eq!(value(&h, "decimation"), d.to_string());
        assert_eq!(value(&h, "records"), log.len().to_string());
        let run = replay_one(&text);
        assert_eq!(run.decimation, d);
        let want: Vec<&Sample> = samples.iter().step_by(d as usize).collect();
        let got: Vec<&Sample> = run.samples().collect();
        assert_eq!(got.len(), want.len());
        for (g, w) in got.iter().zip(&want) {
            assert_eq!(
                (g.seq, g.t_us, g.delta_l_um.to_bits()),
                (w.seq, w.t_us, w.delta_l_um.to_bits())
            );
        }
    }
}

#[test]
fn a_57_s_circle_at_1_khz_is_logged_at_1_khz_over_256() {
    // app::log's own example: 57 000 samples in LOG_CAPACITY = 432 records: 57 000 / 128 =
    // 446 records would not fit, 57 000 / 256 = 223 do.
    assert_eq!(LOG_CAPACITY, 416);
    let m = default_meta();
    let mut log = Box::new(SampleLog::<LOG_CAPACITY>::new());
    log.begin_run(&m);
    for k in 0..57_000u32 {
        log.sample(&Sample {
            seq: 5 + k,
            t_us: u64::from(k) * 1000,
            ..Sample::default()
        });
    }
    assert_eq!(check_decimation(&*log, 5, 57_000), 256);
    assert_eq!(log.len(), 57_000usize.div_ceil(256));
}

#[test]
fn a_run_longer_than_the_low_time_word_keeps_its_full_times() {
    // 80 min at 1 kHz: the records' low 32-bit µs words wrap at 71.6 min; the pod's clock runs
    // 50 ppm fast of the nominal period, a stretch of 2 000 periods is lost (sample numbers
    // skip it) and the run starts 3 h after boot. Every logged time must be the sample's own.
    let m = default_meta();
    let mut log = Box::new(SampleLog::<LOG_CAPACITY>::new());
    log.begin_run(&m);
    let t0_us = 3 * 3_600_000_000u64;
    let time_of = |seq: u32| t0_us + (f64::from(seq - 7) * 1000.05) as u64;
    let mut truth = std::collections::HashMap::new();
    for k in 0..4_800_000u32 {
        let seq = 7 + k + if k >= 1_000_000 { 2_000 } else { 0 };
        let t_us = time_of(seq);
        truth.insert(seq, t_us);
        log.sample(&Sample {
            seq,
            t_us,
            ..Sample::default()
        });
    }
    let last = log.iter().last().expect("records");
    assert!(
        last.t_us - t0_us > (1u64 << 32),
        "the run spans the low word's wrap"
    );
    for r in log.iter() {
        assert_eq!(r.t_us, truth[&r.record.seq], "sample {}", r.record.seq);
    }
    // the CSV's times are the same
    let run = replay_one(&csv_of(&*log, &m));
    for s in run.samples() {
        assert_eq!(s.t_us, truth[&s.seq], "sample {} in the CSV", s.seq);
    }
}

#[test]
fn decimation_counts_from_the_run_s_first_sample_and_lost_samples_leave_gaps() {
    // sample numbers with gaps (lost upstream): the kept ones are those a multiple of d after
    // the run's first
    let m = default_meta();
    let seqs: Vec<u32> = (0..40u32).map(|k| 300 + k + k / 10).collect(); // a gap every 10
    let samples: Vec<Sample> = seqs
        .iter()
        .map(|&seq| Sample {
            seq,
            t_us: u64::from(seq) * 1000,
            ..Sample::default()
        })
        .collect();
    let log = log_of::<16>(&m, &samples);
    let d = log.decimation();
    assert!(d > 1);
    let kept: Vec<u32> = log.iter().map(|r| r.record.seq).collect();
    let want: Vec<u32> = seqs
        .iter()
        .copied()
        .filter(|s| (s - 300) % d == 0)
        .collect();
    assert_eq!(kept, want);
    let run = replay_one(&csv_of(&log, &m));
    let got: Vec<u32> = run.samples().map(|s| s.seq).collect();
    assert_eq!(got, want);
}

// ---------------------------------------------------------------------------------------------
// Touch points
// ---------------------------------------------------------------------------------------------

#[test]
fn touch_rows_are_flagged_bit_15_and_never_decimated() {
    let m = meta(4, Pattern::Probe, Direction::Ccw, Config::default());
    let mut log = SampleLog::<16>::new();
    log.begin_run(&m);
    let mut rng = Rng(11);
    let mut events = Vec::new();
    for k in 0..60u32 {
        let s = Sample {
            seq: 10 + k,
            t_us: 2_000_000 + u64::from(k) * 1000,
            delta_l_um: rng.sym(5.0) as f32,
            temp_c: 20.5,
            ..Sample::default()
        };
        log.sample(&s);
        events.push(Event::Sample(s));
        if k % 9 == 4 {
            let t = Touch {
                t_us: s.t_us + 400,
                axes: [
                    rng.sym(100.0) as f32,
                    rng.sym(100.0) as f32,
                    rng.sym(50.0) as f32,
                    0.0,
                    (k as f32) * 15.0,
                ],
            };
            log.touch(&t);
            events.push(Event::Touch(t));
        }
    }
    let touches = events
        .iter()
        .filter(|e| matches!(e, Event::Touch(_)))
        .count();
    assert_eq!(touches, 7);
    let d = log.decimation();
    assert!(d > 1, "the log thinned its samples");
    // every touch kept, the samples of the decimation, in their order
    let want: Vec<Event> = events
        .iter()
        .copied()
        .filter(|e| match e {
            Event::Sample(s) => (s.seq - 10) % d == 0,
            Event::Touch(_) => true,
        })
        .collect();
    let text = csv_of(&log, &m);
    let run = replay_one(&text);
    assert_eq!(run.events, want);
    // the rows: flags 32768, ΔL and temperature nan, the sample number of the next sample
    let r = rows(&text);
    let col = |name: &str| columns(&text).iter().position(|c| c == name).unwrap();
    let touch_rows: Vec<&Vec<String>> = r
        .iter()
        .filter(|row| row[col("flags")] == "32768")
        .collect();
    assert_eq!(touch_rows.len(), 7);
    for row in &touch_rows {
        assert_eq!(row[col("dl_um")], "nan");
        assert_eq!(row[col("temp_c")], "nan");
    }
    assert_eq!(touch_rows[0][0], "15", "after sample 14");
    let rec: Vec<LogRecord> = log.iter().map(|r| r.record).collect();
    assert!(
        rec.iter()
            .filter(|r| r.is_touch())
            .all(|r| r.flags == LogRecord::TOUCH)
    );
}

#[test]
fn touch_points_that_do_not_fit_are_counted() {
    let m = meta(1, Pattern::Probe, Direction::Ccw, Config::default());
    let mut log = SampleLog::<4>::new();
    log.begin_run(&m);
    for k in 0..6u64 {
        log.touch(&Touch {
            t_us: 1000 + k,
            axes: [k as f32; MAX_AXES],
        });
    }
    assert_eq!((log.len(), log.overwritten()), (4, 2));
    let text = csv_of(&log, &m);
    let h = header_values(&text);
    assert_eq!(value(&h, "overwritten"), "2");
    assert_eq!(value(&h, "records"), "4");
    let run = replay_one(&text);
    let t: Vec<u64> = run
        .events
        .iter()
        .map(|e| match e {
            Event::Touch(t) => t.t_us,
            Event::Sample(_) => panic!("no samples"),
        })
        .collect();
    assert_eq!(t, [1000, 1001, 1002, 1003], "the first ones are kept");
}

// ---------------------------------------------------------------------------------------------
// End lines
// ---------------------------------------------------------------------------------------------

#[test]
fn end_lines_say_how_the_run_ended_with_every_counter() {
    let m = meta(9, Pattern::Circle, Direction::Cw, Config::default());
    let samples = random_samples(5, 0, 1000, &mut Rng(3));
    let counters = RunCounters {
        seen: 10,
        used: 6,
        skipped_lvdt_open: 2,
        skipped_jump: 1,
        skipped_quadrature: 1,
        lost: 3,
        temperature_faults: 4,
        after_overrun: 2,
        ..RunCounters::ZERO
    };
    for (abort, end, reason) in [
        (None, "DONE", "NONE"),
        (Some(AbortReason::ByCommand), "ABORTED", "COMMAND"),
        (Some(AbortReason::LvdtFault), "ABORTED", "LVDT"),
        (Some(AbortReason::Overrun), "ABORTED", "OVERRUN"),
        (Some(AbortReason::NotObservable), "ABORTED", "UNOBSERVABLE"),
    ] {
        let mut log = log_of::<8>(&m, &samples);
        let e = RunEnd {
            run: 9,
            abort,
            counters,
        };
        log.end_run(&e);
        let text = csv_of(&log, &m);
        let tail = format!(
            "# end={end}\n# reason={reason}\n# seen=10\n# used=6\n# skipped_lvdt_open=2\n\
             # skipped_lvdt_over_range=0\n# skipped_quadrature=1\n# skipped_jump=1\n\
             # skipped_overrun=0\n# lost=3\n# temperature_faults=4\n# after_overrun=2\n"
        );
        assert!(text.ends_with(&tail), "{text}");
        let run = replay_one(&text);
        assert_eq!(run.end, Some(e));
        assert_eq!(run.samples().count(), 5);
    }
    // not ended: no end lines
    let text = csv_of(&log_of::<8>(&m, &samples), &m);
    assert!(!text.contains("# end="));
    assert_eq!(replay_one(&text).end, None);
}

// ---------------------------------------------------------------------------------------------
// The log in the pod
// ---------------------------------------------------------------------------------------------

#[test]
fn an_empty_log_is_header_and_columns_only() {
    let m = default_meta();
    let log = SampleLog::<8>::new();
    assert!(log.is_empty());
    assert_eq!(log.meta(), None);
    let text = csv_of(&log, &m);
    assert_eq!(rows(&text).len(), 0);
    assert_eq!(value(&header_values(&text), "records"), "0");
    let run = replay_one(&text);
    assert!(run.events.is_empty());
    // a log of no capacity keeps nothing and counts it
    let mut zero = SampleLog::<0>::new();
    zero.begin_run(&m);
    zero.sample(&Sample::default());
    zero.touch(&Touch {
        t_us: 0,
        axes: [0.0; MAX_AXES],
    });
    assert_eq!((zero.len(), zero.overwritten()), (0, 2));
}

#[test]
fn a_new_run_clears_the_log_and_clear_forgets_the_header() {
    let m1 = meta(1, Pattern::Circle, Direction::Ccw, Config::default());
    let m2 = meta(2, Pattern::Bx, Direction::Cw, Config::default());
    let mut rng = Rng(8);
    let mut log = log_of::<8>(&m1, &random_samples(20, 0, 0, &mut rng));
    log.end_run(&RunEnd {
        run: 1,
        abort: None,
        counters: RunCounters::ZERO,
    });
    assert!(log.decimation() > 1);
    log.begin_run(&m2);
    assert_eq!((log.len(), log.decimation(), log.overwritten()), (0, 1, 0));
    assert_eq!(log.end(), None);
    assert_eq!(log.meta().map(|m| m.run), Some(2));
    log.sample(&random_samples(1, 50, 0, &mut rng)[0]);
    assert_eq!(log.iter().next().unwrap().record.seq, 50);
    log.clear();
    assert_eq!((log.len(), log.meta(), log.end()), (0, None, None));
}

#[test]
fn the_firmware_log_fits_its_ram_share() {
    // app::log: 36 bytes per record (u32 seq, u32 time, f32 ΔL, 5 × f32 axes, i16, u16);
    // LOG_CAPACITY of them plus the run's header (~0.5 KiB).
    assert_eq!(std::mem::size_of::<LogRecord>(), 4 + 4 + 4 + 5 * 4 + 2 + 2);
    let bytes = std::mem::size_of::<SampleLog<LOG_CAPACITY>>();
    assert!(bytes <= 36 * LOG_CAPACITY + 1024, "{bytes}");
}

#[test]
fn metadata_of_the_run_survives_later_setting_changes() {
    use ballpod::protocol::scpi::ScpiServer;
    let mut app = App::new(Config::default(), [16; MAX_AXES]);
    app.configure(|c| {
        c.setup.circle_centre_mm = [0.0; 3];
        c.setup.circle_radius_mm = 150.0;
    })
    .unwrap();
    app.set_direction(Direction::Cw).unwrap();
    let mut log = SampleLog::<8>::new();
    app.execute(ballpod::app::Command::Arm).unwrap();
    app.execute(ballpod::app::Command::Start).unwrap();
    for k in 0..5u32 {
        app.on_sample(
            &Sample {
                seq: 100 + k,
                t_us: 7_000_000 + u64::from(k) * 1000,
                delta_l_um: 0.5,
                axes: [150.0, 0.0, 0.0, 0.0, 0.0],
                temp_c: 20.0,
                ..Sample::default()
            },
            &mut log,
        );
    }
    app.execute(ballpod::app::Command::Stop).unwrap();
    ballpod_host::run_jobs(&mut app);
    // the end reaches the log with the next sample (not the run's)
    app.on_sample(
        &Sample {
            seq: 105,
            ..Sample::default()
        },
        &mut log,
    );
    // after the run the technician prepares the next one
    app.set_pattern(Pattern::Bx).unwrap();
    app.set_direction(Direction::Ccw).unwrap();
    app.configure(|c| c.bar_length_mm = 300.0).unwrap();
    let mut scpi = ScpiServer::new();
    let mut out = Vec::new();
    scpi.feed(b"DATA:LOG?\n", &mut app, &log, &mut |b: &[u8]| {
        out.extend_from_slice(b)
    });
    let text = String::from_utf8(out).unwrap();
    // definite-length block: '#', n, n length digits, the CSV, NL
    let n = (text.as_bytes()[1] - b'0') as usize;
    let csv = &text[2 + n..text.len() - 1];
    let h = header_values(csv);
    assert_eq!(value(&h, "pattern"), "CIRCLE");
    assert_eq!(value(&h, "direction"), "CW");
    assert_eq!(value(&h, "bar_length"), "150");
    let run = replay_one(csv);
    assert_eq!(run.meta.run, 1);
    assert_eq!(run.meta.config.bar_length_mm, 150.0);
    assert_eq!(run.meta.config.setup.circle_radius_mm, 150.0);
    let seqs: Vec<u32> = run.samples().map(|s| s.seq).collect();
    assert_eq!(seqs, [100, 101, 102, 103, 104]);
    // five samples are too few for a circle: aborted as not observable
    let end = run.end.unwrap();
    assert_eq!(end.abort, Some(AbortReason::NotObservable));
    assert_eq!((end.counters.seen, end.counters.used), (5, 5));
}

/// A log whose column header lacks a configured axis (`y_mm` cut out of every line) is refused
/// with the file, the header's line and the column, not replayed as an axis fault.
#[test]
fn a_log_missing_a_configured_axis_column_is_refused_with_line_and_column() {
    let mut rng = Rng(9);
    let m = default_meta();
    let text = csv_of(&log_of::<64>(&m, &random_samples(20, 1, 0, &mut rng)), &m);
    let header_line = text
        .lines()
        .position(|l| l.starts_with("seq,"))
        .expect("column header")
        + 1;
    let y = columns(&text)
        .iter()
        .position(|c| c == "y_mm")
        .expect("a y_mm column");
    let cut: String = text
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i + 1 >= header_line && !l.starts_with('#') {
                let mut f: Vec<&str> = l.split(',').collect();
                f.remove(y);
                f.join(",") + "\n"
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    let e = parse_runs(Path::new("log.csv"), &cut).expect_err("y_mm is missing");
    assert_eq!(
        e.to_string(),
        format!(
            "log.csv:{header_line}: field `y_mm`: column missing (the run's configuration has this encoder input)"
        )
    );
}
