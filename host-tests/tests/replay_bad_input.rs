//! Malformed pod CSV files (a `DATA:LOG?` download or a recorded USB stream), plain logs and
//! session files are rejected whole, with the file, line and field named, and no run is
//! returned. The files are written here by hand, so every expected line number is counted in
//! the text below; one stream is recorded on the simulated pod with a reader that fell behind.

use std::path::{Path, PathBuf};

use ballpod::acquisition::SampleFlags;
use ballpod::app::{AbortReason, Direction, Pattern, RunMeta};
use ballpod::config::Config;
use ballpod_host::recording::{Event, LogError, parse_plain, parse_runs};
use ballpod_host::session_file::{parse_session, read_inputs, read_runs, read_text};

/// A log download of a CA run (the default configuration's axes X, Y, Z, B, C), line by line:
/// 1 version, 2–6 header, 7 columns, 8–10 rows (sample 12 was lost), 11–15 how it ended.
const GOOD: &str = "# ballpod run v2\n\
# run=4\n\
# pattern=CA\n\
# direction=CW\n\
# source=log\n\
# records=3\n\
seq,t_s,dl_um,x_mm,y_mm,z_mm,b_deg,c_deg,temp_c,flags\n\
10,0.010000,1.5,50,0,165.53,0,0,20.5,0\n\
11,0.011000,1.25,49.99,0.31,165.53,0,0.36,20.5,0\n\
13,0.013000,1,49.98,0.62,165.53,0,0.72,20.5,16\n\
# end=DONE\n\
# reason=NONE\n\
# seen=3\n\
# used=3\n\
# lost=1\n";

/// Lines of [`GOOD`].
const GOOD_LINES: usize = 15;

fn read(text: &str) -> Result<usize, LogError> {
    parse_runs(Path::new("run.csv"), text).map(|r| r.len())
}

/// `text` must be rejected at `line` with `field` and a message containing `what`; the error
/// prints as `run.csv:<line>: …`.
fn rejected(text: &str, line: usize, field: Option<&str>, what: &str) -> LogError {
    let e = read(text).expect_err("must be rejected");
    assert_eq!(e.file, Path::new("run.csv"), "{e}");
    assert_eq!(e.line, line, "{e}");
    assert_eq!(e.field.as_deref(), field, "{e}");
    assert!(e.what.contains(what), "{e}");
    let shown = e.to_string();
    assert!(shown.starts_with(&format!("run.csv:{line}")), "{shown}");
    if let Some(f) = field {
        assert!(shown.contains(&format!("`{f}`")), "{shown}");
    }
    e
}

/// [`GOOD`] with line `n` (1-based) replaced by `with`.
fn replace_line(n: usize, with: &str) -> String {
    let mut lines: Vec<&str> = GOOD.lines().collect();
    lines[n - 1] = with;
    lines.join("\n") + "\n"
}

/// A fresh temporary directory for this test.
fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ballpod-bad-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

#[test]
fn the_good_file_reads() {
    assert_eq!(GOOD.lines().count(), GOOD_LINES);
    let runs = parse_runs(Path::new("run.csv"), GOOD).expect("good");
    assert_eq!(runs.len(), 1);
    let r = &runs[0];
    assert_eq!(
        (r.meta.run, r.meta.pattern, r.meta.direction),
        (4, Pattern::Ca, Direction::Cw)
    );
    let s: Vec<_> = r.samples().copied().collect();
    assert_eq!(s.len(), 3);
    assert_eq!((s[1].seq, s[1].t_us), (11, 11_000));
    assert_eq!(s[1].delta_l_um, 1.25);
    assert_eq!(s[1].axes, [49.99, 0.31, 165.53, 0.0, 0.36]);
    assert_eq!(s[1].temp_c, 20.5);
    assert_eq!((s[2].seq, s[2].flags), (13, SampleFlags::OVERRUN));
    let end = r.end.expect("ended");
    assert_eq!((end.run, end.abort), (4, None));
    assert_eq!(
        (end.counters.seen, end.counters.used, end.counters.lost),
        (3, 3, 1)
    );
}

#[test]
fn bad_numbers_name_their_column() {
    rejected(
        &replace_line(9, "11,0.011000,1.2.5,49.99,0.31,165.53,0,0.36,20.5,0"),
        9,
        Some("dl_um"),
        "bad number \"1.2.5\"",
    );
    rejected(
        &replace_line(10, "13,0.013000,1,49.98,0.62,165.53,0,0.72,20.5,-1"),
        10,
        Some("flags"),
        "bad number",
    );
    rejected(
        &replace_line(8, "10,0.01,1.5,50,0,165.53,0,0,warm,0"),
        8,
        Some("temp_c"),
        "bad number",
    );
    // more than 6 decimals of a second: not the pod's 1 µs time stamp
    rejected(
        &replace_line(8, "10,0.0100001,1.5,50,0,165.53,0,0,20.5,0"),
        8,
        Some("t_s"),
        "bad number",
    );
    rejected(
        &replace_line(8, "x10,0.010000,1.5,50,0,165.53,0,0,20.5,0"),
        8,
        Some("seq"),
        "bad number",
    );
    // an infinite ΔL is no value the pod writes (`nan` marks an invalid one)
    rejected(
        &replace_line(9, "11,0.011000,inf,49.99,0.31,165.53,0,0.36,20.5,0"),
        9,
        Some("dl_um"),
        "bad number",
    );
}

#[test]
fn a_bad_axis_value_is_rejected_on_its_line() {
    let e = read(&replace_line(
        10,
        "13,0.013000,1,inf,0.62,165.53,0,0.72,20.5,16",
    ))
    .expect_err("must be rejected");
    assert_eq!(e.line, 10, "{e}");
    assert!(e.field.is_some() && e.what.contains("bad number"), "{e}");
}

/// The field of a bad axis value should be its column (`x_mm`), as for every other column.
#[test]
fn a_bad_axis_value_names_its_column() {
    rejected(
        &replace_line(10, "13,0.013000,1,inf,0.62,165.53,0,0.72,20.5,16"),
        10,
        Some("x_mm"),
        "bad number",
    );
}

#[test]
fn sample_numbers_must_increase() {
    rejected(
        &replace_line(10, "11,0.013000,1,49.98,0.62,165.53,0,0.72,20.5,16"),
        10,
        Some("seq"),
        "not increasing",
    );
}

#[test]
fn columns_must_be_known_configured_and_unique() {
    rejected(
        &GOOD.replace("x_mm", "x_in"),
        7,
        Some("x_in"),
        "unknown column",
    );
    rejected(
        &GOOD.replace("dl_um", "dl_mm"),
        7,
        Some("dl_mm"),
        "unknown column",
    );
    // no encoder input of the run's configuration reads an A axis
    rejected(
        &GOOD.replace("b_deg", "a_deg"),
        7,
        Some("a_deg"),
        "no encoder input is configured",
    );
    rejected(&GOOD.replace("b_deg", "c_deg"), 7, Some("c_deg"), "twice");
    rejected(&GOOD.replace("seq,t_s,", "t_s,"), 7, Some("seq"), "missing");
}

#[test]
fn wrong_field_count() {
    rejected(
        &replace_line(8, "10,0.010000,1.5,50,0,165.53,0,0,20.5"),
        8,
        None,
        "9 fields, the header has 10",
    );
}

#[test]
fn a_records_count_that_disagrees_with_the_rows() {
    // the header announces 4 records, the file holds 3: reported where the run's rows end
    rejected(
        &replace_line(6, "# records=4"),
        GOOD_LINES,
        Some("records"),
        "the header says 4 records, the file holds 3",
    );
    // a row lost in transfer
    let mut lines: Vec<&str> = GOOD.lines().collect();
    lines.remove(8);
    rejected(
        &(lines.join("\n") + "\n"),
        GOOD_LINES - 1,
        Some("records"),
        "the header says 3 records, the file holds 2",
    );
    rejected(
        &replace_line(6, "# records=three"),
        6,
        Some("records"),
        "not a count",
    );
}

/// A `DATA:LOG?` answer saved as it came, with its IEEE 488.2 block header: read as the CSV it
/// carries when the length fits; a header that promises more than the file holds (a cut
/// download) or bytes after the block are errors on line 1.
#[test]
fn a_download_saved_with_its_block_header() {
    let block = |len: usize, tail: &str| {
        let digits = len.to_string();
        format!("#{}{digits}{GOOD}{tail}", digits.len())
    };
    let runs = parse_runs(Path::new("run.csv"), &block(GOOD.len(), "\n")).expect("reads");
    let plain = parse_runs(Path::new("run.csv"), GOOD).unwrap();
    assert_eq!(runs.len(), 1);
    assert_eq!(runs[0].events, plain[0].events);
    assert_eq!(read(&block(GOOD.len(), "")), Ok(1));
    assert_eq!(read(&format!("#0{GOOD}")), Ok(1));
    rejected(
        &format!("#9999999999{GOOD}\n"),
        1,
        None,
        &format!(
            "the block header says 999999999 bytes, the file holds {}: the download was cut",
            GOOD.len() + 1
        ),
    );
    rejected(&block(GOOD.len() - 40, "\n"), 1, None, "bytes after the");
    rejected(&format!("#3x{GOOD}"), 1, None, "3 length digits expected");
}

#[test]
fn a_run_with_dropped_stream_lines_cannot_be_replayed() {
    let stream = GOOD
        .replace("# source=log\n# records=3\n", "# source=stream\n")
        .replace("# lost=1\n", "# lost=1\n# stream_dropped=2\n");
    // the two log lines became one, the `stream_dropped` line is the last: line 15
    assert_eq!(stream.lines().count(), 15);
    rejected(
        &stream,
        15,
        Some("stream_dropped"),
        "run 4 lost 2 lines of the stream: it cannot be replayed",
    );
    // none dropped: it reads
    let whole = stream.replace("stream_dropped=2", "stream_dropped=0");
    assert_eq!(read(&whole).expect("whole stream"), 1);
}

/// Rows of the CIRCLE run recorded with a slow stream reader (≈ 80 bytes each: 6000 of them do
/// not fit the stream's ring).
const SLOW_ROWS: usize = 6000;

/// A simulated pod set for a CIRCLE about (0, 0) of R 150 mm, armed and started with the reader
/// `reading` the stream, homed at the first of the circle machine's `n` poses a turn (F6000,
/// 1 kHz; `pose(i)` gives sample i's ΔL and axes).
fn circle_run_started(
    reading: bool,
) -> (
    ballpod_host::vmt::virtual_pod::VirtualPod<1024>,
    impl Fn(usize) -> (f64, [f64; ballpod::acquisition::MAX_AXES]),
    usize,
) {
    use ballpod::app::Command;
    use ballpod_host::vmt::machine::CircleMachine;
    use ballpod_host::vmt::virtual_pod::{VirtualPod, VirtualSetup};
    let mut vp: VirtualPod<1024> = VirtualPod::new(VirtualSetup::default());
    vp.stream_reader(reading);
    vp.app
        .configure(|c| {
            c.setup.circle_centre_mm = [0.0, 0.0, 0.0];
            c.setup.circle_radius_mm = 150.0;
        })
        .expect("set-up");
    let m = CircleMachine {
        feed_mm_per_min: 6000.0,
        ..CircleMachine::default()
    };
    let n = m.samples_per_rev(1000.0);
    let pose = move |i: usize| m.pose(2.0 * std::f64::consts::PI * i as f64 / n as f64, 1.0);
    vp.home(&pose(0).1);
    vp.app.execute(Command::Arm).expect("arm");
    vp.app.execute(Command::Start).expect("start");
    (vp, pose, n)
}

/// A CIRCLE run on the simulated pod whose stream reader does not read while it runs: the ring
/// (`STREAM_BYTES`) fills and lines are dropped. With `catch_up` the reader drains the ring
/// before the run ends (its end lines get through), else only after. Returns the stream text,
/// the lines the pod dropped, and the host's own (never dropped) record of the run as text.
fn slow_reader_stream(catch_up: bool) -> (String, u32, String) {
    use ballpod::acquisition::MAX_AXES;
    use ballpod::app::Command;
    use ballpod_host::vmt::virtual_pod::{STREAM_BYTES, VirtualPod};

    let (mut vp, pose, _) = circle_run_started(true);
    const { assert!(SLOW_ROWS * 60 > STREAM_BYTES) };
    let mut text = Vec::new();
    let drain = |vp: &mut VirtualPod<1024>, text: &mut Vec<u8>| loop {
        let chunk = vp.pull_stream(4096);
        if chunk.is_empty() {
            break;
        }
        text.extend(chunk);
    };
    for i in 0..SLOW_ROWS {
        let (dl, axes): (f64, [f64; MAX_AXES]) = pose(i);
        vp.sample_at(dl, &axes);
    }
    if catch_up {
        drain(&mut vp, &mut text);
    }
    vp.app.execute(Command::Stop).expect("stop");
    // the end lines go out with the next sample
    vp.sample_at(pose(SLOW_ROWS).0, &pose(SLOW_ROWS).1);
    drain(&mut vp, &mut text);
    let whole = vp.recording.runs.last().expect("recorded").to_csv();
    let mut decoded = Vec::new();
    ballpod::protocol::stream::decode(&text, |l| decoded.extend_from_slice(l)).expect("records");
    (
        String::from_utf8(decoded).expect("the stream is text"),
        vp.stream_dropped(),
        whole,
    )
}

#[test]
fn a_stream_the_reader_fell_behind_on_is_rejected() {
    let (text, dropped, whole) = slow_reader_stream(true);
    assert!(dropped > 0, "the ring overflowed");
    let line = text
        .lines()
        .position(|l| l.starts_with("# stream_dropped="))
        .expect("the end lines made it")
        + 1;
    let e = parse_runs(Path::new("stream.csv"), &text).expect_err("must be rejected");
    assert_eq!(
        (e.line, e.field.as_deref()),
        (line, Some("stream_dropped")),
        "{e}"
    );
    assert!(
        e.what
            .contains(&format!("lost {dropped} lines of the stream")),
        "{e}"
    );
    // the host's own record of the same run (never dropped) reads and is whole
    let runs = parse_runs(Path::new("whole.csv"), &whole).expect("whole run");
    assert_eq!(runs[0].samples().count(), SLOW_ROWS);
}

/// A stream whose reader caught up only after the run ended lost the run's last rows and most
/// of its end lines, `stream_dropped` among them: what is left must not read as a whole run
/// (its rows disagree with its `seen` counter, its end lacks the counters and the
/// `stream_dropped` line).
#[test]
fn a_stream_whose_end_lines_were_dropped_is_rejected() {
    let (text, dropped, _) = slow_reader_stream(false);
    assert!(dropped > 0, "the ring overflowed");
    assert!(!text.contains("# stream_dropped="), "the line was dropped");
    match parse_runs(Path::new("stream.csv"), &text) {
        Err(e) => assert!(e.line > 0, "{e}"),
        Ok(runs) => panic!(
            "accepted: {} rows of {SLOW_ROWS}, end {:?}",
            runs[0].samples().count(),
            runs[0].end
        ),
    }
    // the same with a hand-made stream: 3 rows, `seen=5`
    let stream = GOOD
        .replace("# source=log\n# records=3\n", "# source=stream\n")
        .replace("# seen=3", "# seen=5")
        .replace("# lost=1\n", "# lost=1\n# stream_dropped=0\n");
    rejected(&stream, 12, Some("seen"), "5");
}

#[test]
fn an_unknown_pattern_lists_the_known_ones() {
    let e = rejected(
        &replace_line(3, "# pattern=ELLIPSE"),
        3,
        Some("pattern"),
        "unknown pattern",
    );
    for p in Pattern::ALL {
        assert!(e.what.contains(p.name()), "{e} lacks {}", p.name());
    }
    // names are read in any letter case
    assert_eq!(read(&replace_line(3, "# pattern=ca")).expect("ca"), 1);
}

#[test]
fn bad_header_lines() {
    rejected(
        &replace_line(1, "# ballpod run v1"),
        1,
        None,
        "format version",
    );
    rejected(
        &replace_line(4, "# direction=UP"),
        4,
        Some("direction"),
        "CW or CCW",
    );
    rejected(
        &replace_line(2, "# run=first"),
        2,
        Some("run"),
        "not a run number",
    );
    rejected(
        &replace_line(5, "# colour=blue"),
        5,
        Some("colour"),
        "unknown key",
    );
    rejected(
        &replace_line(5, "# bar_length=long"),
        5,
        Some("bar_length"),
        "bad number",
    );
    rejected(
        &replace_line(5, "# axis_name1=Q"),
        5,
        Some("axis_name1"),
        "X, Y, Z, A, B, C or -",
    );
    rejected(
        &replace_line(5, "# axis_name9=X"),
        5,
        Some("axis_name9"),
        "no such encoder input",
    );
    // a configuration the pod would not run with (bar length below 50 mm): rejected before
    // the first row
    let e = read(&replace_line(5, "# bar_length=20")).expect_err("invalid configuration");
    assert_eq!(e.line, 7, "{e}");
    assert!(e.what.contains("configuration is not valid"), "{e}");
}

#[test]
fn not_a_pod_file() {
    rejected("t_s,dl_um\n0,1\n", 1, None, "not a ballpod run file");
    rejected("# run=3\n", 1, None, "no `# ballpod run v2` line");
    rejected("# ballpod run v2\n# run=1\n", 0, None, "no run in the file");
    rejected("", 0, None, "no run in the file");
}

#[test]
fn a_row_after_the_runs_end() {
    let t = format!("{GOOD}14,0.014000,1,49.97,0.93,165.53,0,1.08,20.5,0\n");
    rejected(&t, GOOD_LINES + 1, None, "a row after the run's end");
    rejected(
        &GOOD.replace("# used=3", "# used=3\n# colour=blue"),
        15,
        Some("colour"),
        "unknown key after the run's rows",
    );
    rejected(
        &GOOD.replace("# reason=NONE", "# reason=TIRED"),
        12,
        Some("reason"),
        "unknown reason",
    );
    // the reasons the pod writes read back
    let aborted = GOOD
        .replace("# end=DONE", "# end=ABORTED")
        .replace("# reason=NONE", "# reason=OVERRUN");
    let runs = parse_runs(Path::new("run.csv"), &aborted).expect("aborted run");
    assert_eq!(runs[0].end.expect("end").abort, Some(AbortReason::Overrun));
}

#[test]
fn non_utf8_bytes_are_reported_with_line_and_column() {
    let dir = temp_dir("utf8");
    let p = dir.join("run.csv");
    // a Latin-1 'µ' (0xB5) in line 9, column 17
    let mut bytes = GOOD.as_bytes().to_vec();
    let line9 = GOOD.lines().take(8).map(|l| l.len() + 1).sum::<usize>();
    assert!(GOOD[line9..].starts_with("11,0.011000,1.25"));
    bytes.insert(line9 + 16, 0xB5);
    std::fs::write(&p, &bytes).expect("write");
    for e in [
        read_text(&p).expect_err("not UTF-8"),
        read_inputs(std::slice::from_ref(&p)).expect_err("not UTF-8"),
    ] {
        assert_eq!(e.file, p, "{e}");
        assert_eq!(e.line, 9, "{e}");
        assert!(
            e.what.contains("column 17") && e.what.contains("UTF-8"),
            "{e}"
        );
    }
    // in the first line, first column
    std::fs::write(&p, b"\xFF# ballpod run v2\n").expect("write");
    let e = read_text(&p).expect_err("not UTF-8");
    assert_eq!(e.line, 1, "{e}");
    assert!(e.what.contains("column 1:"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A plain log of one run (no pod header): lines 1 comment, 2 columns, 3–5 rows.
const PLAIN: &str = "# exported from another recorder\n\
t_s,dl_um,x_mm,y_mm\n\
0.000,1.5,50,0\n\
0.001,1.25,49.99,0.31\n\
0.002,1.0,49.98,0.62\n";

fn plain_meta(pattern: Pattern) -> RunMeta {
    RunMeta {
        run: 1,
        pattern,
        direction: Direction::Ccw,
        config: Config::default(),
    }
}

#[test]
fn plain_logs_are_checked_on_their_own_line_numbers() {
    let f = Path::new("plain.csv");
    let r = parse_plain(f, PLAIN, plain_meta(Pattern::Ca)).expect("good plain log");
    let s: Vec<_> = r.samples().copied().collect();
    assert_eq!(s.len(), 3);
    assert_eq!(
        (s[2].seq, s[2].t_us, s[2].delta_l_um),
        (2, 2000, 1.0),
        "numbered by row"
    );
    let e = parse_plain(f, &PLAIN.replace("1.25", "1,25"), plain_meta(Pattern::Ca))
        .expect_err("a comma too many");
    assert_eq!((e.file.as_path(), e.line), (f, 4), "{e}");
    let e = parse_plain(f, &PLAIN.replace("49.98", "4x"), plain_meta(Pattern::Ca))
        .expect_err("bad number");
    assert_eq!(e.line, 5, "{e}");
    // a CIRCLE in the ZX plane needs z_mm
    let mut meta = plain_meta(Pattern::Circle);
    meta.config.setup.circle_plane = ballpod::config::CirclePlane::ZX;
    let e = parse_plain(f, PLAIN, meta).expect_err("no z_mm");
    assert_eq!((e.line, e.field.as_deref()), (2, Some("z_mm")), "{e}");
    assert!(e.what.contains("CIRCLE"), "{e}");
    let e = parse_plain(f, &PLAIN.replace("dl_um", "dl"), plain_meta(Pattern::Ca))
        .expect_err("no dl_um");
    assert_eq!((e.line, e.field.as_deref()), (2, Some("dl_um")), "{e}");
}

#[test]
fn bad_session_files() {
    let dir = temp_dir("session");
    let p = dir.join("session.json");
    let f = Path::new("session.json");
    let e = parse_session(
        f,
        "{\n  \"runs\": [\n    {\"log\": \"a.csv\", \"pattern\": \"BX\", \"direction\": \"UP\"}\n  ]\n}\n",
    )
    .expect_err("bad direction");
    assert_eq!(
        (e.file.as_path(), e.field.as_deref()),
        (f, Some("runs[0].direction")),
        "{e}"
    );
    assert!(
        e.what.contains("\"UP\"") && e.what.contains("CW or CCW"),
        "{e}"
    );
    // a type error: the JSON parser's line
    let e = parse_session(f, "{\n  \"runs\": [\n    {\"log\": 5}\n  ]\n}\n").expect_err("bad type");
    assert_eq!(e.line, 3, "{e}");
    let e = parse_session(
        f,
        "{\n  \"runs\": [\n    {\"log\": \"a.csv\",\n     \"method\": \"CA\"}\n  ]\n}\n",
    )
    .expect_err("unknown key");
    assert_eq!(e.line, 4, "{e}");
    assert!(e.what.contains("method"), "{e}");
    // an unknown pattern lists the known ones
    let e = parse_session(
        Path::new("session.toml"),
        "[[runs]]\nlog = \"a.csv\"\npattern = \"ellipse\"\ndirection = \"CW\"\n",
    )
    .expect_err("unknown pattern");
    assert_eq!(
        (e.line, e.field.as_deref()),
        (3, Some("runs[0].pattern")),
        "{e}"
    );
    assert!(e.what.contains("unknown pattern \"ellipse\""), "{e}");
    for pat in Pattern::ALL {
        assert!(e.what.contains(pat.name()), "{e} lacks {}", pat.name());
    }
    // TOML: an unknown key, on its line
    let e = parse_session(
        Path::new("session.toml"),
        "[[runs]]\nlog = \"a.csv\"\npattern = \"CA\"\ndirection = \"CW\"\nbogus = 1\n",
    )
    .expect_err("unknown key");
    assert!(e.line > 0, "{e}");
    assert!(e.what.contains("bogus"), "{e}");
    let e = parse_session(Path::new("session.toml"), "# nothing\n").expect_err("empty");
    assert!(e.what.contains("nothing to replay"), "{e}");
    // read from disk: the file is named
    std::fs::write(&p, "{\"runs\": [{\"log\": \"missing.csv\"}]}").expect("write");
    let e = read_inputs(std::slice::from_ref(&p)).expect_err("missing log");
    assert_eq!(e.file, dir.join("missing.csv"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_session_file_checks_its_logs_against_what_they_recorded() {
    let dir = temp_dir("logs");
    std::fs::write(dir.join("ca.csv"), GOOD).expect("write");
    std::fs::write(dir.join("plain.csv"), PLAIN).expect("write");
    let read = |toml: &str| {
        let p = dir.join("session.toml");
        std::fs::write(&p, toml).expect("write");
        let s = parse_session(&p, toml)?;
        read_runs(&p, &s)
    };
    let runs = read("[[runs]]\nlog = \"ca.csv\"\n").expect("a pod file");
    assert_eq!(runs.len(), 1);
    assert_eq!(runs[0].0, "ca.csv");
    // the session says CCW, the log recorded CW
    let e = read("[[runs]]\nlog = \"ca.csv\"\ndirection = \"ccw\"\n").expect_err("disagrees");
    assert_eq!(e.field.as_deref(), Some("runs[0].direction"), "{e}");
    assert!(e.what.contains("CW"), "{e}");
    let e = read("[[runs]]\nlog = \"ca.csv\"\npattern = \"BX\"\n").expect_err("disagrees");
    assert_eq!(e.field.as_deref(), Some("runs[0].pattern"), "{e}");
    // a plain log needs its pattern, and a circular one its direction
    let e = read("[[runs]]\nlog = \"plain.csv\"\n").expect_err("no pattern");
    assert_eq!(e.field.as_deref(), Some("runs[0].pattern"), "{e}");
    let e = read("[[runs]]\nlog = \"plain.csv\"\npattern = \"CA\"\n").expect_err("no direction");
    assert_eq!(e.field.as_deref(), Some("runs[0].direction"), "{e}");
    let runs = read("[[runs]]\nlog = \"plain.csv\"\npattern = \"CA\"\ndirection = \"CW\"\n")
        .expect("a plain log");
    assert_eq!(runs[0].1.events.len(), 3);
    assert!(matches!(runs[0].1.events[0], Event::Sample(_)));
    // set-up overrides are fields of the configuration, by name, in range
    let e = read("[setup]\nbogus = 1\n[[runs]]\nlog = \"ca.csv\"\n").expect_err("unknown field");
    assert_eq!(e.field.as_deref(), Some("setup.bogus"), "{e}");
    let e = read("[setup]\nbar_length = 20\n[[runs]]\nlog = \"ca.csv\"\n").expect_err("range");
    assert_eq!(e.field.as_deref(), Some("setup.bar_length"), "{e}");
    let e = read("[setup]\ncircle_plane = \"XZ\"\n[[runs]]\nlog = \"ca.csv\"\n")
        .expect_err("no such plane");
    assert_eq!(e.field.as_deref(), Some("setup.circle_plane"), "{e}");
    // … each on its own line, with what the field takes
    assert_eq!(e.line, 2, "{e}");
    assert!(e.what.contains("is not one of XY, YZ, ZX"), "{e}");
    let e =
        read("[setup]\ncircle_radius = 150\nbar_length = \"long\"\n[[runs]]\nlog = \"ca.csv\"\n")
            .expect_err("text for a number");
    assert_eq!(
        (e.field.as_deref(), e.line),
        (Some("setup.bar_length"), 3),
        "{e}"
    );
    assert!(
        e.what
            .contains("is not a number: the field takes a number (mm)"),
        "{e}"
    );
    // a saved `DATA:LOG?` download keeps its block header: listed in a session, it is a pod
    // file as it is given alone
    let block = format!("#{}{}{GOOD}", GOOD.len().to_string().len(), GOOD.len());
    std::fs::write(dir.join("download.csv"), &block).expect("write");
    let runs = read("[[runs]]\nlog = \"download.csv\"\n").expect("a saved download");
    let alone = parse_runs(Path::new("ca.csv"), GOOD).expect("GOOD");
    assert_eq!(
        (runs[0].1.meta.run, runs[0].1.events.len()),
        (alone[0].meta.run, alone[0].events.len())
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A missing required column should be named as the file names it (`t_s`), in the field.
#[test]
fn a_missing_column_is_named() {
    rejected(&GOOD.replace("seq,t_s,", "seq,"), 7, Some("t_s"), "missing");
}

/// A TOML session file's error is on the line of the offending key.
#[test]
fn a_toml_error_is_on_its_line() {
    let e = parse_session(
        Path::new("session.toml"),
        "[[runs]]\nlog = \"a.csv\"\npattern = \"CA\"\ndirection = \"CW\"\nbogus = 1\n",
    )
    .expect_err("unknown key");
    assert_eq!(e.line, 5, "{e}");
}

/// An unknown pattern or direction in a session file is reported on its line, like a syntax
/// error.
#[test]
fn a_bad_pattern_in_a_session_file_is_on_its_line() {
    let e = parse_session(
        Path::new("session.toml"),
        "[[runs]]\nlog = \"a.csv\"\npattern = \"ellipse\"\n",
    )
    .expect_err("unknown pattern");
    assert_eq!(e.line, 3, "{e}");
}

/// A readings file of a host-only method (read with the `csv` crate): errors on the file's own
/// lines — after comment lines — with the column named.
#[test]
fn a_readings_file_is_checked_on_its_own_lines() {
    let dir = temp_dir("readings");
    let session = dir.join("session.toml");
    std::fs::write(&session, "[rtest]\nreadings = \"rtest.csv\"\n").unwrap();
    let read = |table: &str| {
        std::fs::write(dir.join("rtest.csv"), table).unwrap();
        read_inputs(std::slice::from_ref(&session)).expect_err("rejected")
    };
    // 1 comment, 2 header, 3 a row, 4 a bad number in dy_um
    let e = read("# R-test, path K4\na_deg,c_deg,dx_um,dy_um,dz_um\n0,0,1,2,3\n0,90,1,2.x,3\n");
    assert_eq!(e.file, dir.join("rtest.csv"));
    assert_eq!((e.line, e.field.as_deref()), (4, Some("dy_um")), "{e}");
    assert!(e.what.contains("bad number"), "{e}");
    let e = read("# R-test\n\n# K4\na_deg,c_deg,dx_um,dz_um\n0,0,1,3\n");
    assert_eq!((e.line, e.field.as_deref()), (4, Some("dy_um")), "{e}");
    assert!(e.what.contains("required column missing"), "{e}");
    let e = read("a_deg,c_deg,dx_um,dy_um,dz_um\n# nothing measured\n");
    assert!(e.what.contains("no readings"), "{e}");
}

/// The R-test head's calibration budget is a standard uncertainty: a negative one is refused with
/// the field named.
#[test]
fn a_negative_head_calibration_u_is_refused_by_name() {
    let dir = temp_dir("rtest-budget");
    let session = dir.join("session.toml");
    std::fs::write(
        &session,
        "[rtest]\nreadings = \"rtest.csv\"\nu_reading_scale_ppm = -5.0\n",
    )
    .unwrap();
    let rows: String = (0..8)
        .map(|i| format!("{},{},1,2,3\n", -10.0 * f64::from(i), 45.0 * f64::from(i)))
        .collect();
    std::fs::write(
        dir.join("rtest.csv"),
        format!("a_deg,c_deg,dx_um,dy_um,dz_um\n{rows}"),
    )
    .unwrap();
    let e = read_inputs(std::slice::from_ref(&session)).expect_err("rejected");
    assert_eq!(e.field.as_deref(), Some("rtest.u_reading_scale_ppm"), "{e}");
}

/// A stream reader that connects while a run is recorded gets that run's header at once: before
/// its first sample the run arrives whole and replays; after it, the header says
/// `# partial=1` and replay refuses the run with the reason (the samples before it are not on
/// this stream).
#[test]
fn a_reader_that_joins_a_run_gets_its_header_and_a_late_one_is_told_partial() {
    use ballpod::acquisition::MAX_AXES;
    use ballpod::app::Command;
    use ballpod_host::replay::replay;

    let stream_of = |join_after: usize| {
        let (mut vp, pose, n) = circle_run_started(false);
        let mut bytes = Vec::new();
        for i in 0..=n {
            if i == join_after {
                vp.stream_reader(true);
            }
            let (dl, axes): (f64, [f64; MAX_AXES]) = pose(i);
            vp.sample_at(dl, &axes);
            bytes.extend(vp.pull_stream(1 << 16));
        }
        vp.app.execute(Command::Stop).expect("stop");
        vp.sample_at(pose(n + 1).0, &pose(n + 1).1);
        bytes.extend(vp.pull_stream(1 << 16));
        let mut text = Vec::new();
        ballpod::protocol::stream::decode(&bytes, |l| text.extend_from_slice(l)).expect("records");
        String::from_utf8(text).expect("text")
    };
    // armed and started, no sample yet when the reader joins (a client that connects and arms
    // at once): the whole run
    let whole = stream_of(0);
    let runs = parse_runs(Path::new("stream.csv"), &whole).expect("a whole run");
    assert!(!runs[0].partial && runs[0].end.is_some());
    let report = replay(&[("stream.csv".into(), runs[0].clone())]).expect("replays");
    assert_eq!(report.runs[0].outcome, "DONE");
    // a hundred samples in: the header, marked partial; replay says why it does not replay it
    let late = stream_of(100);
    assert!(
        late.contains("# source=stream\n# partial=1\n"),
        "{late:.300}"
    );
    let runs = parse_runs(Path::new("stream.csv"), &late).expect("a partial run parses");
    assert!(runs[0].partial);
    let e = replay(&[("stream.csv".into(), runs[0].clone())]).expect_err("partial");
    assert!(e.contains("joined the run after its first samples"), "{e}");
}
