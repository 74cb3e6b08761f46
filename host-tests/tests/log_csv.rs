//! The sample log: ring capacity and overwrite counting, time-stamp reconstruction, and the
//! CSV download — parsed back here by an independent reader and compared with the samples at
//! the printed resolution (t 1 µs, ΔL 0.1 nm, mm 0.1 µm, degrees 1e-7 °, °C 0.01).
use ballpod::acquisition::{Sample, SampleFlags};
use ballpod::config::AxisName;
use ballpod::protocol::log::{LOG_CAPACITY, LogMeta, LogRecord, SampleLog, csv_len, write_csv};
use ballpod::protocol::pod::{Direction, Pattern, PodModel};
use std::collections::HashMap;

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
}

/// A parsed CSV file: metadata, header, rows of fields.
struct Csv {
    meta: HashMap<String, String>,
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

/// An independent reader of the format: `# key=value` lines, a header, comma-separated rows.
fn parse(text: &str) -> Csv {
    assert!(text.ends_with('\n'));
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("# ballpod log v1"));
    let mut meta = HashMap::new();
    let mut header = None;
    for l in lines.by_ref() {
        if let Some(m) = l.strip_prefix("# ") {
            let (k, v) = m.split_once('=').expect("key=value");
            meta.insert(k.to_string(), v.to_string());
        } else {
            header = Some(l.split(',').map(str::to_string).collect::<Vec<_>>());
            break;
        }
    }
    let header = header.expect("header line");
    let rows: Vec<Vec<String>> = lines
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect();
    for r in &rows {
        assert_eq!(r.len(), header.len());
    }
    Csv { meta, header, rows }
}

impl Csv {
    fn col(&self, row: usize, name: &str) -> &str {
        let i = self.header.iter().position(|h| h == name).expect(name);
        &self.rows[row][i]
    }
    fn f(&self, row: usize, name: &str) -> f64 {
        self.col(row, name).parse().unwrap()
    }
    /// t_s as exact microseconds (no float on the way: "s.ffffff").
    fn t_us(&self, row: usize) -> u64 {
        let (s, f) = self.col(row, "t_s").split_once('.').unwrap();
        assert_eq!(f.len(), 6, "t_s has µs resolution");
        s.parse::<u64>().unwrap() * 1_000_000 + f.parse::<u64>().unwrap()
    }
}

fn csv_of<const N: usize>(log: &SampleLog<N>, meta: &LogMeta) -> String {
    let mut out = Vec::new();
    let n = write_csv(log, meta, &mut |c: &[u8]| out.extend_from_slice(c));
    assert_eq!(n, out.len());
    assert_eq!(csv_len(log, meta), out.len());
    String::from_utf8(out).unwrap()
}

fn random_samples(n: usize, t0_us: u64, rng: &mut Rng) -> Vec<Sample> {
    (0..n)
        .map(|k| Sample {
            seq: k as u32,
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
            flags: SampleFlags((rng.next() & 0x3F) as u16),
        })
        .collect()
}

#[test]
fn csv_round_trips_every_value_to_its_printed_resolution() {
    const N: usize = 100;
    let mut rng = Rng(0x0BA1_1B0D);
    // 0.2 s before a 32-bit µs wrap: the kept samples (the last 0.1 s) straddle it
    let t0 = 8 * (1u64 << 32) - 200_000;
    let samples = random_samples(250, t0, &mut rng);
    let mut log = SampleLog::<N>::new();
    for s in &samples {
        log.push(s);
    }
    let pod = PodModel::default(); // axes X, Y, Z, B, C
    let csv = parse(&csv_of(&log, &LogMeta::from_pod(&pod)));
    assert_eq!(
        csv.header,
        [
            "t_s", "dl_um", "x_mm", "y_mm", "z_mm", "b_deg", "c_deg", "temp_c", "flags"
        ]
    );
    assert_eq!(csv.meta["bar_length_mm"], "150");
    assert_eq!(csv.meta["pattern"], "CIRCLE");
    assert_eq!(csv.meta["direction"], "CCW");
    assert_eq!(csv.meta["sample_rate_hz"], "1000");
    assert_eq!(csv.meta["samples"], "100");
    assert_eq!(csv.meta["overwritten"], "150");
    assert_eq!(csv.rows.len(), N);
    let kept = &samples[samples.len() - N..];
    assert!(
        kept[0].t_us >> 32 != kept[N - 1].t_us >> 32,
        "crosses the wrap"
    );
    let within = |got: f64, want: f32, res: f64, what: &str| {
        let err = (got - f64::from(want)).abs();
        assert!(err <= 0.5 * res * (1.0 + 1e-9), "{what}: {got} vs {want}");
    };
    for (row, s) in kept.iter().enumerate() {
        assert_eq!(csv.t_us(row), s.t_us, "row {row}");
        within(csv.f(row, "dl_um"), s.delta_l_um, 1e-4, "dl_um");
        within(csv.f(row, "x_mm"), s.axes[0], 1e-4, "x_mm");
        within(csv.f(row, "y_mm"), s.axes[1], 1e-4, "y_mm");
        within(csv.f(row, "z_mm"), s.axes[2], 1e-4, "z_mm");
        within(csv.f(row, "b_deg"), s.axes[3], 1e-7, "b_deg");
        within(csv.f(row, "c_deg"), s.axes[4], 1e-7, "c_deg");
        within(csv.f(row, "temp_c"), s.temp_c, 1e-2, "temp_c");
        assert_eq!(csv.col(row, "flags").parse::<u16>().unwrap(), s.flags.0);
        // the printed resolution is exactly the stated one
        assert_eq!(csv.col(row, "dl_um").split_once('.').unwrap().1.len(), 4);
        assert_eq!(csv.col(row, "c_deg").split_once('.').unwrap().1.len(), 7);
    }
}

#[test]
fn columns_follow_the_configured_axes_in_xyzabc_order() {
    let mut pod = PodModel::default();
    pod.config
        .try_update(|c| {
            c.axes[0].name = AxisName::C;
            c.axes[1].name = AxisName::X;
            c.axes[2].name = AxisName::Unused;
            c.axes[3].name = AxisName::A;
            c.axes[4].name = AxisName::Z;
        })
        .unwrap();
    pod.pattern = Pattern::CrPrime;
    pod.direction = Direction::Cw;
    let mut log = SampleLog::<4>::new();
    log.push(&Sample {
        t_us: 3_000_001,
        delta_l_um: -0.25,
        axes: [90.5, 12.5, 99.0, -45.25, -3.0],
        temp_c: f32::NAN,
        flags: SampleFlags::TEMPERATURE_FAULT,
        ..Sample::default()
    });
    let text = csv_of(&log, &LogMeta::from_pod(&pod));
    let csv = parse(&text);
    assert_eq!(
        csv.header,
        [
            "t_s", "dl_um", "x_mm", "z_mm", "a_deg", "c_deg", "temp_c", "flags"
        ]
    );
    assert_eq!(csv.meta["pattern"], "CRPRIME");
    assert_eq!(csv.meta["direction"], "CW");
    assert_eq!(
        csv.rows[0],
        [
            "3.000001",
            "-0.2500",
            "12.5000",
            "-3.0000",
            "-45.2500000",
            "90.5000000",
            "nan",
            "32"
        ]
    );
}

#[test]
fn ring_keeps_the_newest_and_counts_what_it_overwrote() {
    let mut rng = Rng(3);
    let samples = random_samples(10, 1_000, &mut rng);
    let mut log = SampleLog::<4>::new();
    assert!(log.is_empty());
    for (k, s) in samples.iter().enumerate() {
        log.push(s);
        assert_eq!(log.len(), (k + 1).min(4));
        assert_eq!(log.overwritten() as usize, (k + 1).saturating_sub(4));
    }
    let got: Vec<u64> = log.iter().map(|s| s.t_us).collect();
    let want: Vec<u64> = samples[6..].iter().map(|s| s.t_us).collect();
    assert_eq!(got, want);
    let recs: Vec<LogRecord> = log.iter().map(|s| s.record).collect();
    for (r, s) in recs.iter().zip(&samples[6..]) {
        assert_eq!(r.delta_l_um, s.delta_l_um); // stored bit for bit
        assert_eq!(r.axes, s.axes);
    }
    log.clear();
    assert_eq!((log.len(), log.overwritten()), (0, 0));
    assert_eq!(log.iter().count(), 0);
}

#[test]
fn decimation_logs_one_sample_in_k_and_states_the_logging_rate() {
    let mut rng = Rng(5);
    let samples = random_samples(95, 0, &mut rng);
    let mut log = SampleLog::<64>::new();
    log.set_decimation(10);
    for s in &samples {
        log.record(s);
    }
    let got: Vec<u64> = log.iter().map(|s| s.t_us).collect();
    let want: Vec<u64> = samples.iter().step_by(10).map(|s| s.t_us).collect();
    assert_eq!(got, want);
    let csv = parse(&csv_of(&log, &LogMeta::from_pod(&PodModel::default())));
    assert_eq!(csv.meta["sample_rate_hz"], "100");
    assert_eq!(csv.meta["decimation"], "10");
}

#[test]
fn an_empty_log_is_metadata_and_header_only() {
    let log = SampleLog::<8>::new();
    let csv = parse(&csv_of(&log, &LogMeta::from_pod(&PodModel::default())));
    assert_eq!(csv.rows.len(), 0);
    assert_eq!(csv.meta["samples"], "0");
    let zero = SampleLog::<0>::new();
    let mut z = zero.clone();
    z.push(&Sample::default());
    assert_eq!((z.len(), z.overwritten()), (0, 1));
}

#[test]
fn the_firmware_log_fits_its_ram_share() {
    // 32 bytes per record; the firmware's log is half of the 64 KiB static-RAM budget.
    assert_eq!(std::mem::size_of::<LogRecord>(), 32);
    let bytes = std::mem::size_of::<SampleLog<LOG_CAPACITY>>();
    assert!(bytes <= 32 * 1024 + 64, "{bytes}");
}

#[test]
fn metadata_of_the_run_survives_later_setting_changes() {
    use ballpod::protocol::scpi::ScpiServer;
    let mut pod = PodModel {
        pattern: Pattern::Cr,
        direction: Direction::Cw,
        ..PodModel::default()
    };
    let mut log = SampleLog::<8>::new();
    log.begin_run(LogMeta::from_pod(&pod));
    log.push(&Sample::default());
    // after the run the technician prepares the next one
    pod.pattern = Pattern::Bx;
    pod.direction = Direction::Ccw;
    pod.config.try_update(|c| c.bar_length_mm = 300.0).unwrap();
    let mut scpi = ScpiServer::new();
    let mut out = Vec::new();
    scpi.feed(b"DATA:LOG?\n", &mut pod, &log, &mut |b: &[u8]| {
        out.extend_from_slice(b)
    });
    let text = String::from_utf8(out).unwrap();
    // definite-length block: '#', n, n length digits, the CSV, NL
    let n = (text.as_bytes()[1] - b'0') as usize;
    let csv = parse(&text[2 + n..text.len() - 1]);
    assert_eq!(csv.meta["pattern"], "CR");
    assert_eq!(csv.meta["direction"], "CW");
    assert_eq!(csv.meta["bar_length_mm"], "150");
    log.clear();
    assert_eq!(log.meta(), None);
}
