//! SCPI command interface: IEEE 488.2 common commands and status model, the SCPI-99 error
//! queue, configuration through the `config::FIELDS` table, session control, live values,
//! results and the log download — and every class of bad input rejected with its SCPI-99
//! error number and no change of state. The server executes every command in the pod
//! application ([`App`]) at once; the application is driven here only through the port and by
//! feeding it samples, and what it answers is checked against the standards' tables and a
//! forward model of the ball bar.
use ballpod::acquisition::{MAX_AXES, Sample, SampleFlags};
use ballpod::app::log::SampleLog;
use ballpod::app::{
    App, Direction, Live, Pattern, ResultId, ResultInfo, SessionState, SettingsRequest, Touch,
};
use ballpod::config::{AxisName, Config, FIELDS, Field};
use ballpod::protocol::scpi::status::ERROR_QUEUE_DEPTH;
use ballpod::protocol::scpi::{LINE_CAPACITY, ScpiServer, number};
use ballpod_host::app_state::snapshot as state;
use ballpod_host::vmt::machine::linear_circle_sample;

/// Forward model of a circle run: the ball bar about a socket at the origin of the XY plane,
/// the trajectory off-centre by E_UM and longer by R0_UM: ΔL(θ) = r0 + e_u cos θ + e_v sin θ
/// (the limaçon of seed 002 §3.5 / ISO 230-4 about the socket).
const RADIUS_MM: f64 = 150.0;
const E_UM: [f64; 2] = [12.5, -7.25];
const R0_UM: f64 = 3.0;
/// Samples per revolution of the model circle.
const STEPS: usize = 720;

/// Sample k of the forward model's revolution (θ = 2πk/STEPS, CCW from +X).
fn circle_sample(k: usize) -> Sample {
    let th = 2.0 * std::f64::consts::PI * k as f64 / STEPS as f64;
    linear_circle_sample(th, RADIUS_MM, E_UM, R0_UM)
}

/// The pod with its SCPI port, as the technician's PC sees it.
struct Bench {
    scpi: ScpiServer,
    app: App,
    log: SampleLog<32>,
    /// Number of the next sample.
    seq: u32,
}

impl Bench {
    fn new() -> Self {
        Self {
            scpi: ScpiServer::new(),
            app: App::new(Config::default(), [16; MAX_AXES]),
            log: SampleLog::new(),
            seq: 0,
        }
    }

    /// A bench whose port was unlocked for configuration writes (`CONF:UNL`).
    fn unlocked() -> Self {
        let mut b = Self::new();
        assert_eq!(b.send("CONF:UNL"), "");
        b
    }

    /// A bench whose application has the circle's set-up (centre at the origin, radius
    /// 150 mm); the port stays locked.
    fn with_circle() -> Self {
        let mut b = Self::new();
        b.app
            .configure(|c| {
                c.setup.circle_centre_mm = [0.0; 3];
                c.setup.circle_radius_mm = RADIUS_MM as f32;
            })
            .unwrap();
        b
    }

    /// Sends raw bytes; returns what came back. The jobs the commands left (a run's results)
    /// then run to their end, as the pod's worker runs them before a client's next message
    /// comes.
    fn raw(&mut self, bytes: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        self.scpi
            .feed(bytes, &mut self.app, &self.log, &mut |b: &[u8]| {
                out.extend_from_slice(b)
            });
        ballpod_host::run_jobs(&mut self.app);
        out
    }

    /// Sends one line; returns the response text (without its terminator; empty if none).
    fn send(&mut self, line: &str) -> String {
        let out = self.raw(format!("{line}\n").as_bytes());
        let s = String::from_utf8(out).unwrap();
        if s.is_empty() {
            return s;
        }
        assert!(s.ends_with('\n'), "response not terminated by NL: {s:?}");
        assert_eq!(
            s.matches('\n').count(),
            1,
            "one line per program message: {s:?}"
        );
        s.trim_end_matches('\n').to_string()
    }

    /// Feeds one sample to the application (numbered in sequence; a run's samples go to the
    /// log).
    fn feed(&mut self, mut s: Sample) {
        s.seq = self.seq;
        s.t_us = 1_000_000 + u64::from(self.seq) * 1000;
        self.seq += 1;
        self.app.on_sample(&s, &mut self.log);
    }

    /// Feeds samples k of the model circle for k in `ks`.
    fn feed_circle(&mut self, ks: impl IntoIterator<Item = usize>) {
        for k in ks {
            self.feed(circle_sample(k));
        }
    }

    /// Reads one `SYSTem:ERRor?` entry: (number, message).
    fn error(&mut self) -> (i32, String) {
        let r = self.send("SYST:ERR?");
        let (n, msg) = r.split_once(',').unwrap();
        assert!(
            msg.starts_with('"') && msg.ends_with('"'),
            "string response: {r}"
        );
        (n.parse().unwrap(), msg.trim_matches('"').to_string())
    }

    /// Drains the error queue: the numbers, oldest first.
    fn errors(&mut self) -> Vec<i32> {
        let mut v = Vec::new();
        loop {
            let (n, _) = self.error();
            if n == 0 {
                return v;
            }
            v.push(n);
            assert!(v.len() <= ERROR_QUEUE_DEPTH, "queue deeper than its depth");
        }
    }

    /// Sends a line that must be rejected with exactly `code`, with no response and no change
    /// of the application.
    fn rejected(&mut self, line: &str, code: i32) {
        let before = state(&self.app);
        let out = self.raw(format!("{line}\n").as_bytes());
        assert!(out.is_empty(), "{line}: unexpected response {out:?}");
        assert_eq!(state(&self.app), before, "{line}: state changed");
        assert_eq!(self.errors(), vec![code], "{line}");
    }

    /// As [`rejected`](Self::rejected), and the error's message is `message`.
    fn rejected_with(&mut self, line: &str, code: i32, message: &str) {
        let before = state(&self.app);
        let out = self.raw(format!("{line}\n").as_bytes());
        assert!(out.is_empty(), "{line}: unexpected response {out:?}");
        assert_eq!(state(&self.app), before, "{line}: state changed");
        assert_eq!(self.error(), (code, message.to_string()), "{line}");
        assert_eq!(self.errors(), Vec::<i32>::new(), "{line}");
    }
}

/// A value printed with 4 decimals (0.1 nm) is the model value to within half a step plus the
/// fit's rounding.
fn near(text: &str, want: f64, tol: f64) -> bool {
    let v: f64 = text.parse().unwrap_or(f64::NAN);
    (v - want).abs() <= tol + 0.5e-4
}

// ---------------------------------------------------------------------------------------------
// IEEE 488.2 common commands and status model
// ---------------------------------------------------------------------------------------------

#[test]
fn idn_has_the_four_fields_of_ieee488_2_10_14() {
    let mut b = Bench::new();
    let idn = b.send("*IDN?");
    let fields: Vec<&str> = idn.split(',').collect();
    assert_eq!(fields.len(), 4, "{idn}");
    assert!(fields.iter().all(|f| !f.is_empty()));
    // the crate's version and the commit this build comes from, asked of git here
    let head = std::process::Command::new("git")
        .args(["rev-parse", "--short=12", "HEAD"])
        .output()
        .unwrap();
    let head = String::from_utf8(head.stdout).unwrap();
    assert_eq!(
        fields[3],
        format!("{}+{}", env!("CARGO_PKG_VERSION"), head.trim())
    );
    // common command headers are case-insensitive (§7.6.1.3)
    assert_eq!(b.send("*idn?"), idn);
    // the serial: 0 until the shell sets it, then eight hex digits (as std formats them)
    assert_eq!(fields[2], "0");
    for serial in [0x0BA1_1000u32, 0xDEAD_BEEF, 1] {
        b.scpi.set_serial(serial);
        let idn = b.send("*IDN?");
        assert_eq!(
            idn.split(',').nth(2),
            Some(format!("{serial:08X}").as_str())
        );
    }
}

#[test]
fn power_on_sets_pon_and_esr_query_reads_and_clears() {
    let mut b = Bench::new();
    assert_eq!(b.send("*ESR?"), "128"); // §11.5.1.1: bit 7 PON
    assert_eq!(b.send("*ESR?"), "0");
    b.send("*OPC"); // §10.18: sets bit 0 OPC
    assert_eq!(b.send("*ESR?"), "1");
    assert_eq!(b.send("*OPC?"), "1"); // §10.19: ASCII 1
}

#[test]
fn error_classes_set_their_esr_bits() {
    // IEEE 488.2 §11.5.1.1: bit 5 CME (-1xx), bit 4 EXE (-2xx), bit 3 DDE (-3xx).
    let mut b = Bench::unlocked();
    b.send("*ESR?");
    b.send("NO:SUCH:COMMAND");
    assert_eq!(b.send("*ESR?"), "32");
    b.send("CONF:BAR_LENGTH 1");
    assert_eq!(b.send("*ESR?"), "16");
    b.raw(&[b'A'; LINE_CAPACITY + 10]);
    b.raw(b"\n");
    assert_eq!(b.send("*ESR?"), "8");
    assert_eq!(b.errors(), vec![-113, -222, -363]);
}

#[test]
fn status_byte_summarises_queue_and_enabled_events() {
    let mut b = Bench::new();
    b.send("*CLS");
    assert_eq!(b.send("*STB?"), "0");
    b.send("BOGUS");
    // SCPI-99 Vol 1 §9: bit 2 = error/event queue not empty; ESB (bit 5) needs *ESE.
    assert_eq!(b.send("*STB?"), "4");
    b.send("*ESE 32");
    assert_eq!(b.send("*ESE?"), "32");
    assert_eq!(b.send("*STB?"), "36");
    // MSS (bit 6) = STB & SRE over bits ≠ 6 (§11.2.2.2); SRE bit 6 cannot be set (§10.34)
    b.send("*SRE 96");
    assert_eq!(b.send("*SRE?"), "32");
    assert_eq!(b.send("*STB?"), "100");
    // *STB? does not clear (§10.36); *CLS clears queue and ESR, not the enables (§10.3)
    assert_eq!(b.send("*STB?"), "100");
    b.send("*CLS");
    assert_eq!(b.send("*STB?"), "0");
    assert_eq!(b.send("*ESE?"), "32");
    assert_eq!(b.send("*SRE?"), "32");
    assert_eq!(b.errors(), Vec::<i32>::new());
}

#[test]
fn ese_and_sre_take_0_to_255_only() {
    let mut b = Bench::new();
    b.rejected("*ESE 256", -222);
    b.rejected("*SRE -1", -222);
    b.rejected("*ESE", -109);
    b.rejected("*ESE ON", -104);
    assert_eq!(b.send("*ESE?"), "0");
}

#[test]
fn rst_resets_the_application_and_keeps_the_status_registers() {
    let mut b = Bench::with_circle();
    b.send("*ESE 4");
    b.send("BOGUS");
    b.send("SESS:ARM;STAR");
    assert_eq!(b.send("SESS:STAT?"), "RUNNING");
    b.feed_circle(0..=STEPS);
    b.send("SESS:STOP");
    assert_eq!(b.send("SESS:STAT?"), "DONE");
    assert!(b.app.results().valid_count() > 0);
    b.send("SESS:PATT PROBE;ARM");
    assert_eq!(b.send("SESS:STAT?"), "ARMED");
    assert_eq!(b.send("*RST"), "");
    // the run is gone, the state is IDLE, the results are forgotten; the configuration stays
    assert_eq!(b.send("SESS:STAT?;REAS?"), "IDLE;NONE");
    assert_eq!(b.app.results().valid_count(), 0);
    assert_eq!(b.app.config().setup.circle_radius_mm, RADIUS_MM as f32);
    // §10.32: *RST does not affect the status registers or the queue
    assert_eq!(b.send("*ESE?"), "4");
    assert_eq!(b.errors(), vec![-113]);
}

#[test]
fn sav_0_stores_settings() {
    let mut b = Bench::unlocked();
    assert_eq!(b.app.take_settings_request(), None);
    assert_eq!(b.send("*SAV 0"), "");
    assert_eq!(b.app.take_settings_request(), Some(SettingsRequest::Store));
    b.rejected("*SAV 3", -222);
    assert_eq!(b.app.take_settings_request(), None);
    // not while a run is armed or running (the flash work would stall the sampling): -221
    // with the reason, nothing asked of the shell; between runs again it stores
    for state in ["ARMED", "RUNNING"] {
        b.send("SESS:PATT PROBE;:SESS:ARM");
        if state == "RUNNING" {
            b.send("SESS:STAR");
        }
        assert_eq!(b.send("SESS:STAT?"), state);
        b.send("*SAV 0");
        assert_eq!(
            b.error(),
            (
                -221,
                "Settings conflict;not while a run is armed or running".into()
            )
        );
        assert_eq!(b.app.take_settings_request(), None);
        b.send("SESS:ABOR");
    }
    assert_eq!(b.send("*SAV 0"), "");
    assert_eq!(b.app.take_settings_request(), Some(SettingsRequest::Store));
}

#[test]
fn syst_boot_asks_for_the_rom_bootloader_on_an_unlocked_port_between_runs() {
    let mut b = Bench::new();
    b.rejected_with(
        "SYST:BOOT",
        -203,
        "Command protected;SYST:BOOT: CONF:UNL first",
    );
    assert!(!b.app.take_bootloader_request());
    b.send("CONF:UNL");
    for state in ["ARMED", "RUNNING"] {
        b.send("SESS:PATT PROBE;:SESS:ARM");
        if state == "RUNNING" {
            b.send("SESS:STAR");
        }
        b.rejected_with(
            "SYST:BOOT",
            -221,
            "Settings conflict;not while a run is armed or running",
        );
        assert!(!b.app.take_bootloader_request());
        b.send("SESS:ABOR");
    }
    assert_eq!(b.send("SYSTem:BOOTloader"), "");
    assert_eq!(b.errors(), Vec::<i32>::new());
    // asked once: the shell restarts into the bootloader
    assert!(b.app.take_bootloader_request());
    assert!(!b.app.take_bootloader_request());
}

// ---------------------------------------------------------------------------------------------
// SCPI-99 error queue and syntax
// ---------------------------------------------------------------------------------------------

#[test]
fn error_queue_is_fifo_and_reports_no_error_when_empty() {
    let mut b = Bench::unlocked();
    assert_eq!(b.error(), (0, "No error".to_string()));
    b.send("BOGUS");
    b.send("CONF:BAR_LENGTH 1000");
    b.send("SESS:STOP");
    let (n, msg) = b.error();
    assert_eq!((n, msg.as_str()), (-113, "Undefined header"));
    let (n, msg) = b.error();
    assert_eq!(n, -222);
    assert_eq!(
        msg, "Data out of range;bar_length out of range",
        "names the field"
    );
    let (n, msg) = b.error();
    assert_eq!(n, -221);
    assert_eq!(msg, "Settings conflict;STOP needs RUNNING", "the reason");
    assert_eq!(b.error().0, 0);
}

#[test]
fn error_queue_overflow_replaces_the_newest_entry_with_minus_350() {
    // SCPI-99 Vol 2 §21.8: a full queue keeps its oldest entries; the last becomes -350.
    let mut b = Bench::unlocked();
    for _ in 0..ERROR_QUEUE_DEPTH + 5 {
        b.send("BOGUS");
    }
    b.send("CONF:BAR_LENGTH 1"); // lost too
    let mut expected = vec![-113; ERROR_QUEUE_DEPTH - 1];
    expected.push(-350);
    assert_eq!(b.errors(), expected);
    assert_eq!(
        b.scpi.status().errors_discarded,
        22 - ERROR_QUEUE_DEPTH as u32
    );
    // the queue works normally afterwards
    b.send("CONF:BAR_LENGTH 1");
    assert_eq!(b.errors(), vec![-222]);
}

#[test]
fn short_long_and_optional_forms_are_case_insensitive() {
    // SCPI-99 Vol 1 §6.2.1: short form = upper-case letters; [NEXT] optional.
    let mut b = Bench::new();
    for q in [
        "SYST:ERR?",
        "SYSTEM:ERROR?",
        "system:error:next?",
        ":SyStEm:ErR:NeXt?",
        "SYST:ERR:NEXT?",
    ] {
        assert_eq!(b.send(q), "0,\"No error\"", "{q}");
    }
    assert_eq!(b.send("SYSTEM:VERSION?"), "1999.0");
    // neither short nor long form: undefined
    b.rejected("SYSTE:ERR?", -113);
    b.rejected("SYS:ERR?", -113);
    assert_eq!(b.send("MEAS:DL?"), b.send("measure:dl?"));
    assert_eq!(b.send("SESS:STAT?"), b.send("session:state?"));
    assert_eq!(b.send("MEAS:VAL?"), b.send("measure:valid?"));
}

#[test]
fn compound_messages_answer_in_order_separated_by_semicolons() {
    // IEEE 488.2 §8.4.1: response message units separated by ';', one NL at the end;
    // SCPI-99 Vol 1 §6.2.4: a header after ';' continues the previous command's path.
    let mut b = Bench::unlocked();
    let idn = b.send("*IDN?");
    assert_eq!(b.send("*IDN?;*OPC?"), format!("{idn};1"));
    assert_eq!(b.send("SYST:ERR?;VERS?"), "0,\"No error\";1999.0");
    assert_eq!(b.send(":SESS:PATT BX;DIR CW;PATT?;DIR?"), "BX;CW");
    assert_eq!(
        (b.app.pattern(), b.app.direction()),
        (Pattern::Bx, Direction::Cw)
    );
    // a leading ':' goes back to the root
    assert_eq!(b.send("SESS:STAT?;:SYST:VERS?"), "IDLE;1999.0");
    // a command error drops the rest of the line; an execution error does not
    assert_eq!(b.send("BOGUS;*OPC?"), "");
    assert_eq!(b.send("CONF:BAR_LENGTH 1;*OPC?"), "1");
    assert_eq!(b.errors(), vec![-113, -222]);
}

#[test]
fn lines_may_arrive_in_any_chunks_and_crlf_is_accepted() {
    let mut a = Bench::new();
    let mut b = Bench::new();
    // PROBE needs no set-up: it arms.
    let msg = b"*IDN?;:SESS:PATT PROBE\r\nSESS:ARM\r\nSESS:STAT?;PATT?\n";
    let whole = a.raw(msg);
    let mut bytes = Vec::new();
    for c in msg.chunks(1) {
        bytes.extend(b.raw(c));
    }
    assert_eq!(whole, bytes);
    assert_eq!(state(&a.app), state(&b.app));
    let text = String::from_utf8(whole).unwrap();
    assert!(text.ends_with("ARMED;PROBE\n"), "{text}");
    assert_eq!(b.app.session(), SessionState::Armed);
    assert_eq!(a.errors(), Vec::<i32>::new());
}

#[test]
fn an_over_long_line_is_rejected_whole_and_the_next_line_parses() {
    let mut b = Bench::unlocked();
    let before = state(&b.app);
    // valid commands that would change state, padded beyond the buffer
    let mut long = b"CONF:BAR_LENGTH 200;:SESS:PATT PROBE;".to_vec();
    while long.len() <= LINE_CAPACITY {
        long.extend_from_slice(b"*OPC?;");
    }
    long.extend_from_slice(b"SESS:ARM\n");
    let out = b.raw(&long);
    assert!(out.is_empty());
    assert_eq!(state(&b.app), before);
    // the next line, even in the same chunk, is parsed normally
    let out = b.raw(b"\xff\xfe\n*OPC?\n");
    assert_eq!(out, b"1\n");
    assert_eq!(b.errors(), vec![-363, -101]);
    assert_eq!(b.scpi.counters().lines_overrun, 1);
    // exactly LINE_CAPACITY bytes fit
    let mut fits = b"*OPC?".to_vec();
    fits.resize(LINE_CAPACITY, b' ');
    fits.push(b'\n');
    assert_eq!(b.raw(&fits), b"1\n");
}

#[test]
fn malformed_headers_and_parameters_get_their_error_numbers() {
    let mut b = Bench::new();
    b.rejected("*", -102);
    b.rejected("*FOO?", -113);
    b.rejected("CONF::BAR_LENGTH 100", -102);
    b.rejected("CONF:BAR_LENGTH=100", -102);
    b.rejected("SESS:ARM?", -113); // no query form
    b.rejected("SESS:CLE?", -113);
    b.rejected("SESS:NOTE", -113); // query only
    b.rejected("MEAS:DL", -113);
    b.rejected("MEAS:VAL", -113);
    b.rejected("FETC:TOUC:COUN", -113);
    b.rejected("MEAS:DL? 3", -108);
    b.rejected("MEAS:ALL? 3", -108);
    b.rejected("SESS:ARM 1", -108);
    b.rejected("SESS:CLE 1", -108);
    b.rejected("SESS:PATT", -109);
    b.rejected("SESS:PATT BX,BY", -108);
    b.rejected("SESS:PATT BX,", -109);
    b.rejected("SESS:PATT 'BX'", -158);
    b.rejected("SESS:PATT 3", -104);
    b.rejected("SESS:PATT B-X", -141);
    // the pattern names are Pattern::name(): CR2, not the old CRPRIME
    b.rejected("SESS:PATT CRP", -224);
    b.rejected("SESS:PATT CRPRIME", -224);
    b.rejected("SESS:DIR LEFT", -224);
    assert_eq!(
        b.app.pattern(),
        Pattern::Circle,
        "nothing of the above selected a pattern"
    );
}

#[test]
fn every_pattern_and_direction_name_is_accepted() {
    let mut b = Bench::new();
    for (name, p) in [
        ("CIRCLE", Pattern::Circle),
        ("BX", Pattern::Bx),
        ("BY", Pattern::By),
        ("CR", Pattern::Cr),
        ("CA", Pattern::Ca),
        ("CR2", Pattern::Cr2),
        ("SSM", Pattern::Ssm),
        ("PROBE", Pattern::Probe),
    ] {
        assert_eq!(b.send(&format!("SESS:PATT {name};PATT?")), name);
        assert_eq!(b.app.pattern(), p);
        assert_eq!(
            b.send(&format!("SESS:PATT {};PATT?", name.to_lowercase())),
            name
        );
    }
    for (name, d) in [("CW", Direction::Cw), ("CCW", Direction::Ccw)] {
        assert_eq!(b.send(&format!("SESS:DIR {name};DIR?")), name);
        assert_eq!(b.app.direction(), d);
    }
    assert_eq!(b.errors(), Vec::<i32>::new());
}

// ---------------------------------------------------------------------------------------------
// Configuration (config::FIELDS through Config::try_update)
// ---------------------------------------------------------------------------------------------

/// The SCPI header of every settable field instance: (header, field).
fn field_headers() -> Vec<(String, Field)> {
    let mut v = Vec::new();
    for f in FIELDS {
        match f.field {
            Field::LvdtPolyUm(_) => {
                for k in 0..4u8 {
                    v.push((format!("CONF:{}{k}", f.name), Field::LvdtPolyUm(k)));
                }
            }
            Field::AxisCountsPerUnit(_) => {
                for i in 0..5u8 {
                    v.push((
                        format!("CONF:{}{}", f.name, i + 1),
                        Field::AxisCountsPerUnit(i),
                    ));
                }
            }
            Field::AxisMaxSpeed(_) => {
                for i in 0..5u8 {
                    v.push((format!("CONF:{}{}", f.name, i + 1), Field::AxisMaxSpeed(i)));
                }
            }
            f => v.push((
                format!(
                    "CONF:{}",
                    FIELDS.iter().find(|i| i.field == f).unwrap().name
                ),
                f,
            )),
        }
    }
    v
}

/// The value of a field read directly from the configuration's members (independent of the
/// server and of `Config::field_value`); codes as their number.
fn read(c: &Config, f: Field) -> f64 {
    let s = &c.setup;
    let g = |v: f32| f64::from(v);
    match f {
        Field::BarLengthMm => g(c.bar_length_mm),
        Field::BarCtePpmPerK => g(c.bar_cte_ppm_per_k),
        Field::LvdtPolyUm(k) => g(c.lvdt_poly_um[k as usize]),
        Field::LvdtMaxAbsRatio => g(c.lvdt_max_abs_ratio),
        Field::LvdtMinSignal => g(c.lvdt_min_signal),
        Field::LvdtDcZeroV => g(c.lvdt_dc_zero_v),
        Field::LvdtDcSpanV => g(c.lvdt_dc_span_v),
        Field::ExcitationHz => g(c.excitation_hz),
        Field::SamplesPerPeriod => f64::from(c.samples_per_period),
        Field::SampleRateHz => g(c.sample_rate_hz),
        Field::AxisCountsPerUnit(i) => c.axes[i as usize].counts_per_unit,
        Field::AxisMaxSpeed(i) => g(c.axes[i as usize].max_speed_per_s),
        Field::ThermistorR25Ohm => g(c.thermistor_r25_ohm),
        Field::ThermistorBetaK => g(c.thermistor_beta_k),
        Field::ThermistorRFixedOhm => g(c.thermistor_r_fixed_ohm),
        Field::ProbeDebounceUs => f64::from(c.probe_debounce_us),
        Field::ProbeReseatUs => f64::from(c.probe_reseat_us),
        Field::CanNodeId => f64::from(c.can_node_id),
        Field::CirclePlane => f64::from(s.circle_plane as u8),
        Field::CircleCentreMm(k) => g(s.circle_centre_mm[k as usize]),
        Field::CircleRadiusMm => g(s.circle_radius_mm),
        Field::CircleFeed => g(s.circle_feed_mm_per_min),
        Field::CircleMinArcDeg => g(s.circle_min_arc_deg),
        Field::S002LbMm => g(s.s002_l_b_mm),
        Field::S002RbMm => g(s.s002_r_b_mm),
        Field::S002Rb2Mm => g(s.s002_r_b2_mm),
        Field::S002RcMm => g(s.s002_r_c_mm),
        Field::S002ZcMm => g(s.s002_z_c_mm),
        Field::S002ZtMm => g(s.s002_z_t_mm),
        Field::S002Zt2Mm => g(s.s002_z_t2_mm),
        Field::S002XtMm => g(s.s002_x_t_mm),
        Field::S002OriginMm(k) => g(s.s002_origin_mm[k as usize]),
        Field::SsmSocketMm(k) => g(s.ssm_socket_mm[k as usize]),
        Field::SsmWindowRadiusMm => g(s.ssm_window_radius_mm),
        Field::SsmDwellSpeed => g(s.ssm_dwell_speed_mm_per_s),
        Field::SsmSettleMs => g(s.ssm_settle_ms),
        Field::SsmMinDwellSamples => f64::from(s.ssm_min_dwell_samples),
        Field::TsMachine => f64::from(s.ts_machine as u8),
        Field::RunTrigger => f64::from(s.run_trigger as u8),
        Field::CircleArcDeg => g(s.circle_arc_deg),
        Field::TsToolZMm => g(s.ts_tool_z_mm),
        Field::TsZAlphaGammaMm => g(s.ts_z_alpha_gamma_mm),
        Field::TsReferenceMm(k) => g(s.ts_reference_mm[k as usize]),
        Field::TsOriginMm(k) => g(s.ts_origin_mm[k as usize]),
        Field::TsAngleDeg(k) => g(s.ts_angles_deg[k as usize]),
        Field::ProbeLengthMm => g(s.probe_length_mm),
        Field::S002UWClampUm => g(s.s002_u_w_clamp_um),
        Field::S002UTCentringUm => g(s.s002_u_t_centring_um),
        Field::S002UTAxialUm => g(s.s002_u_t_axial_um),
        Field::BarULengthUm => g(c.bar_u_length_um),
        Field::BarUTempK => g(c.bar_u_temp_k),
        Field::LvdtUScalePpm => g(c.lvdt_u_scale_ppm),
        Field::S002URcZcUm => g(s.s002_u_r_c_z_c_um),
        Field::ProbeULobingUm => g(s.probe_u_lobing_um),
        Field::SsmUSocketUm => g(s.ssm_u_socket_um),
        Field::CircleUCentreUm => g(s.circle_u_centre_um),
        Field::S002URbUm => g(s.s002_u_r_b_um),
        Field::BarSerial => f64::from(c.bar_serial),
        Field::BarCertificate => f64::from(c.bar_certificate),
        Field::BarCalibrated => f64::from(c.bar_calibrated),
        Field::LvdtSerial => f64::from(c.lvdt_serial),
        Field::PeriodsPerSample | Field::AxisNameDuplicate(_) | Field::AxisCounterReach(_) => {
            unreachable!()
        }
    }
}

fn info(f: Field) -> &'static ballpod::config::FieldInfo {
    Config::field_info(f).unwrap()
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-6 * b.abs().max(1.0)
}

/// The same value, a field that is not set (NaN) included.
fn same(a: f64, b: f64) -> bool {
    a == b || (a.is_nan() && b.is_nan())
}

#[test]
fn every_field_is_settable_at_its_limits_and_reads_back() {
    let headers = field_headers();
    assert_eq!(headers.len(), FIELDS.len() - 3 + 4 + 5 + 5);
    for (h, f) in &headers {
        let i = info(*f);
        // a code field takes and answers the names of its codes
        let cases: Vec<(f64, String)> = if i.choices().is_empty() {
            vec![
                (i.min, format!("{}", i.min)),
                (i.max, format!("{:e}", i.max)),
            ]
        } else {
            let last = i.choices().len() - 1;
            assert_eq!(i.max, last as f64, "{h}");
            vec![
                (0.0, i.choices()[0].to_lowercase()),
                (i.max, i.choices()[last].to_string()),
            ]
        };
        for (v, text) in cases {
            if !exact_in_f32(i, v) {
                // see table_limits_without_an_exact_f32_are_writable_by_value_and_keyword
                continue;
            }
            let mut b = Bench::unlocked();
            // (each limit alone: with the others at their defaults no cross-field check trips,
            // but for excitation and sample rate, whose partner is walked first)
            let partners = partner_steps(*f, v);
            for (ph, pv) in &partners {
                assert_eq!(b.send(&format!("{ph} {pv}")), "", "{ph} {pv}");
            }
            assert_eq!(b.send(&format!("{h} {text}")), "", "{h} {text}");
            assert!(close(read(b.app.config(), *f), v), "{h} {text}");
            let back = b.send(&format!("{h}?"));
            if i.choices().is_empty() {
                let back: f64 = back.parse().unwrap();
                assert!(close(back, v), "{h}? = {back}, set {v}");
            } else {
                assert_eq!(back, i.choices()[v as usize], "{h}?");
            }
            // the other fields did not move
            for (gh, g) in &headers {
                if g != f && !partners.iter().any(|(ph, _)| ph.eq_ignore_ascii_case(gh)) {
                    assert!(
                        same(read(b.app.config(), *g), read(&Config::default(), *g)),
                        "{h} moved {g:?}"
                    );
                }
            }
            assert_eq!(b.errors(), Vec::<i32>::new());
        }
    }
}

/// Excitation and sample rate are tied (a sample is 1 to 5 whole excitation periods): the
/// writes that make limit `v` of `f` realisable, each valid on its own (20 kHz excitation:
/// 5 kHz samples first; 200 Hz samples: a 1 kHz excitation; 10 kHz samples: 5 kHz samples,
/// then a 10 kHz excitation). The counters' reach ties counts, speed and rate: 200 Hz samples
/// need the linear axes (16-bit counters) at 600 mm/s first; a 16-bit input's count scale or
/// speed at its high limit, the input unused.
fn partner_steps(f: Field, v: f64) -> Vec<(String, String)> {
    let (rate, exc) = (
        "CONF:SAMPLE_RATE".to_string(),
        "CONF:EXCITATION".to_string(),
    );
    let unused = |i: u8| vec![(format!("CONF:AXIS{}:NAME", i + 1), "NONE".to_string())];
    match f {
        Field::ExcitationHz if v > 5000.0 => vec![(rate, "5000".into())],
        Field::SampleRateHz if v < 1000.0 => {
            let mut steps: Vec<_> = (1..=3)
                .map(|i| (format!("CONF:AXIS_MAX_SPEED{i}"), "600".to_string()))
                .collect();
            steps.push((exc, "1000".into()));
            steps
        }
        Field::SampleRateHz if v > 5000.0 => vec![(rate, "5000".into()), (exc, "10000".into())],
        Field::AxisCountsPerUnit(i) | Field::AxisMaxSpeed(i) if i < 3 && v > 5000.0 => unused(i),
        _ => vec![],
    }
}

/// True unless `v` is the limit of an f32 field that has no exact f32 (0.001, 0.01, 0.1).
fn exact_in_f32(i: &ballpod::config::FieldInfo, v: f64) -> bool {
    i.ty != ballpod::config::FieldType::F32 || f64::from(v as f32) == v
}

/// The table's limits that are not exact in f32 (lvdt_min_signal 0.001, lvdt_max_ratio and
/// lvdt_dc_span 0.01, ssm_window_radius 0.1, ssm_dwell_speed 0.01) must be writable as typed and
/// with the MINimum keyword (SCPI-99 Vol 1 §7.2.1.1: MIN is the smallest value accepted), also
/// 0.001 and 0.1, whose nearest f32 is above them (the value is compared as it will be stored).
#[test]
fn table_limits_without_an_exact_f32_are_writable_by_value_and_keyword() {
    let mut inexact = 0;
    for (h, f) in field_headers() {
        let i = info(f);
        for (v, keyword) in [(i.min, "MIN"), (i.max, "MAX")] {
            if exact_in_f32(i, v) {
                continue;
            }
            inexact += 1;
            for text in [format!("{v}"), keyword.to_string()] {
                let mut b = Bench::unlocked();
                assert_eq!(b.send(&format!("{h} {text}")), "");
                assert_eq!(b.errors(), Vec::<i32>::new(), "{h} {text}");
                assert_eq!(read(b.app.config(), f), f64::from(v as f32), "{h} {text}");
            }
        }
    }
    assert_eq!(inexact, 5);
}

#[test]
fn set_up_fields_read_scpi_nan_until_set() {
    // SCPI-99 Vol 1 §7.2.1.5: NaN is 9.91E+37.
    let mut b = Bench::unlocked();
    for h in [
        "CONF:CIRCLE_RADIUS?",
        "CONF:CIRCLE_CENTRE_X?",
        "CONF:CIRCLE_FEED?",
        "CONF:S002_L_B?",
        "CONF:S002_ORIGIN_Z?",
        "CONF:SSM_SOCKET_Y?",
        "CONF:TS_ANGLE_2?",
    ] {
        assert_eq!(b.send(h), "9.91E+37", "{h}");
    }
    // set-up fields that have a default are not "not set"
    assert_eq!(b.send("CONF:CIRCLE_MIN_ARC?"), "300");
    assert_eq!(b.send("CONF:CIRCLE_PLANE?"), "XY");
    assert_eq!(b.send("CONF:TS_MACHINE?"), "NONE");
    b.send("CONF:CIRCLE_RADIUS 150.25");
    assert_eq!(b.send("CONF:CIRCLE_RADIUS?"), "150.25");
    assert_eq!(b.app.config().setup.circle_radius_mm, 150.25);
    assert_eq!(b.errors(), Vec::<i32>::new());
}

#[test]
fn out_of_range_values_give_minus_222_naming_the_field_and_change_nothing() {
    for (h, f) in field_headers() {
        let i = info(f);
        let mut b = Bench::unlocked();
        let span = (i.max - i.min).max(1.0);
        let message = format!("Data out of range;{} out of range", i.name);
        b.rejected_with(&format!("{h} {}", i.max + span), -222, &message);
        b.rejected_with(&format!("{h} {}", i.min - span), -222, &message);
        b.rejected_with(&format!("{h} 1e300"), -222, &message);
        if i.is_integer() {
            // a whole number is required
            b.rejected_with(&format!("{h} {}", i.min + 0.5), -222, &message);
        }
    }
}

#[test]
fn min_max_def_keywords_follow_the_table() {
    // SCPI-99 Vol 1 §7.2.1.1: MINimum, MAXimum, DEFault as numeric values.
    let mut b = Bench::unlocked();
    assert_eq!(b.send("CONF:BAR_LENGTH? MIN"), "50");
    assert_eq!(b.send("CONF:BAR_LENGTH? MAXIMUM"), "600");
    assert_eq!(b.send("CONF:BAR_LENGTH? DEF"), "150");
    assert_eq!(b.send("CONF:CAN_NODE_ID? MAX"), "255"); // 255: none (LSS, CiA 305)
    b.send("CONF:BAR_LENGTH MAX");
    assert_eq!(b.app.config().bar_length_mm, 600.0);
    b.send("conf:bar_length def");
    assert_eq!(b.app.config().bar_length_mm, 150.0);
    b.send("CONF:BAR_LENGTH min");
    assert_eq!(b.app.config().bar_length_mm, 50.0);
    b.send("CONF:CAN_NODE_ID MAX");
    assert_eq!(b.app.config().can_node_id, 255);
    assert_eq!(b.errors(), Vec::<i32>::new());
}

#[test]
fn bad_numbers_get_their_error_numbers_and_change_nothing() {
    // IEEE 488.2 §7.7.2 NRf syntax; SCPI-99 Vol 2 §21.8 numbers.
    let mut b = Bench::unlocked();
    b.rejected("CONF:BAR_LENGTH abc", -104);
    b.rejected("CONF:BAR_LENGTH \"150\"", -104);
    b.rejected("CONF:BAR_LENGTH 1.2.3", -121);
    b.rejected("CONF:BAR_LENGTH 1e", -121);
    b.rejected("CONF:BAR_LENGTH -", -121);
    b.rejected("CONF:BAR_LENGTH 150 mm", -121);
    b.rejected("CONF:BAR_LENGTH 150MM", -131);
    b.rejected("CONF:BAR_LENGTH 1e40000", -123);
    // (-124 "Too many digits", > 255 digits, cannot fit in a line of LINE_CAPACITY bytes)
    b.rejected("CONF:BAR_LENGTH", -109);
    b.rejected("CONF:BAR_LENGTH 100,200", -108);
    b.rejected("CONF:NO_SUCH_FIELD 1", -113);
    b.rejected("CONF:LVDT_POLY4 1", -114);
    b.rejected("CONF:AXIS_COUNTS0 1", -114);
    b.rejected("CONF:AXIS_COUNTS6 1", -114);
    // accepted spellings of the same number
    for text in [
        "200", "+200", "200.", "2e2", "2.0E+02", "20000e-2", "0200.000",
    ] {
        b.send(&format!("CONF:BAR_LENGTH {text}"));
        assert_eq!(b.app.config().bar_length_mm, 200.0, "{text}");
        b.send("CONF:BAR_LENGTH 150");
    }
    assert_eq!(b.errors(), Vec::<i32>::new());
}

#[test]
fn numeric_suffix_selects_the_coefficient_or_input_and_defaults_to_1() {
    // SCPI-99 Vol 1 §6.2.5.2: an omitted suffix means 1.
    let mut b = Bench::unlocked();
    b.send("CONF:LVDT_POLY0 -3.5");
    b.send("CONF:LVDT_POLY 2100");
    b.send("CONF:AXIS_COUNTS3 20000");
    b.send("CONF:AXIS_MAX_SPEED 500");
    let c = b.app.config();
    assert_eq!(c.lvdt_poly_um, [-3.5, 2100.0, 0.0, 0.0]);
    assert_eq!(c.axes[2].counts_per_unit, 20000.0);
    assert_eq!(c.axes[0].max_speed_per_s, 500.0);
    // values read back as typed, not with the f32's binary noise (150.002106)
    b.send("CONF:BAR_LENGTH 150.0021");
    assert_eq!(b.send("CONF:BAR_LENGTH?"), "150.0021");
    b.send("CONF:LVDT_MAX_RATIO 0.55");
    assert_eq!(b.send("CONF:LVDT_MAX_RATIO?"), "0.55");
    b.send("CONF:AXIS_COUNTS2 12345.678901");
    assert_eq!(b.send("CONF:AXIS_COUNTS2?"), "12345.678901");
    // a field name ending in digits is not a suffix
    b.send("CONF:NTC_R25 4700");
    assert_eq!(b.app.config().thermistor_r25_ohm, 4700.0);
    assert_eq!(b.send("CONF:NTC_R25?"), "4700");
    b.send("CONF:TS_ANGLE_2 -45.5");
    assert!(b.app.config().setup.ts_angles_deg[0].is_nan());
    assert_eq!(b.app.config().setup.ts_angles_deg[1], -45.5);
    assert_eq!(b.errors(), Vec::<i32>::new());
}

#[test]
fn code_fields_take_their_names() {
    let mut b = Bench::unlocked();
    b.send("CONF:CIRCLE_PLANE yz");
    assert_eq!(b.send("CONF:CIRCLE_PLANE?"), "YZ");
    assert_eq!(b.app.config().setup.circle_plane as u8, 1);
    b.send("CONF:TS_MACHINE RTTTR_TABLE");
    assert_eq!(b.send("CONF:TS_MACHINE?"), "RTTTR_TABLE");
    assert_eq!(b.app.config().setup.ts_machine as u8, 4);
    assert_eq!(b.errors(), Vec::<i32>::new());
    b.rejected("CONF:CIRCLE_PLANE 3", -222);
    assert_eq!(b.send("CONF:CIRCLE_PLANE?"), "YZ");
}

#[test]
fn cross_field_conflicts_give_minus_221_and_change_nothing() {
    let mut b = Bench::unlocked();
    // 20 kHz / 1 kHz = 20 excitation periods a sample: more than the ADC ring's 5
    b.rejected_with(
        "CONF:EXCITATION 20000",
        -221,
        "Settings conflict;excitation / sample_rate (whole periods, 1 to 5) out of range",
    );
    // 5 000 mm/s × 10 000 counts/mm is 25 000 counts between two reads of encoder 1's 16-bit
    // counter at 1 kHz, 50 000 at the glitch limit: beyond the ±32 767 its extension follows
    b.rejected_with(
        "CONF:AXIS_MAX_SPEED1 5000",
        -221,
        "Settings conflict;encoder input 1: axis_counts * axis_max_speed / sample_rate (counts per counter read) out of range",
    );
    // encoder 4's counter is 32 bits wide
    assert_eq!(b.send("CONF:AXIS_MAX_SPEED4 5000"), "");
    // the excitation table has 20 points
    b.rejected_with(
        "CONF:SAMPLES_PER_PERIOD 64",
        -222,
        "Data out of range;samples_per_period out of range",
    );
    // two inputs cannot read the same axis
    b.rejected_with(
        "CONF:AXIS2:NAME X",
        -221,
        "Settings conflict;axis name used twice",
    );
}

#[test]
fn axis_names_are_set_per_input() {
    let mut b = Bench::unlocked();
    assert_eq!(b.send("CONF:AXIS4:NAME?"), "B");
    assert_eq!(b.send("CONF:AXIS4:NAME A"), "");
    assert_eq!(b.app.config().axes[3].name, AxisName::A);
    b.send("CONF:AXIS5:NAME none");
    assert_eq!(b.send("CONF:AXIS5:NAME?"), "NONE");
    assert_eq!(b.app.config().axes[4].name, AxisName::Unused);
    assert_eq!(b.send("CONF:AXIS:NAME?"), "X"); // suffix 1 by default
    b.rejected("CONF:AXIS6:NAME Y", -114);
    b.rejected("CONF:AXIS1:NAME W", -224);
}

#[test]
fn several_config_writes_in_one_line_all_take_effect() {
    let mut b = Bench::unlocked();
    assert_eq!(
        b.send("CONF:BAR_LENGTH 200;BAR_CTE 12;:CONF:SAMPLE_RATE 2500"),
        ""
    );
    let c = b.app.config();
    assert_eq!(
        (c.bar_length_mm, c.bar_cte_ppm_per_k, c.sample_rate_hz),
        (200.0, 12.0, 2500.0)
    );
    assert_eq!(b.errors(), Vec::<i32>::new());
}

// ---------------------------------------------------------------------------------------------
// Session control: commands execute at once in the application, which refuses with a reason
// ---------------------------------------------------------------------------------------------

#[test]
fn a_full_circle_session_from_set_up_to_results() {
    let mut b = Bench::unlocked();
    for l in [
        "CONF:CIRCLE_CENTRE_X 0",
        "CONF:CIRCLE_CENTRE_Y 0",
        "CONF:CIRCLE_CENTRE_Z 0",
        "CONF:CIRCLE_RADIUS 150",
    ] {
        assert_eq!(b.send(l), "", "{l}");
    }
    assert_eq!(b.send("SESS:PATT CIRCLE;DIR CCW;PATT?;DIR?"), "CIRCLE;CCW");
    assert_eq!(b.send("SESS:ARM;STAT?"), "ARMED");
    assert_eq!(b.send("SESS:STAR;STAT?"), "RUNNING");
    // Half a turn: e and r0 are not observable yet (minimum arc 300°).
    b.feed_circle(0..=STEPS / 2);
    assert_eq!(b.send("MEAS:VAL?"), "\"delta_l\",\"temp\"");
    b.feed_circle(STEPS / 2 + 1..=STEPS);
    assert_eq!(
        b.send("MEAS:VAL?"),
        "\"delta_l\",\"ecc_u\",\"ecc_v\",\"r0\",\"temp\",\"u_ecc_u\",\"u_ecc_v\",\"u_r0\""
    );
    // MEAS:ALL?: counter, the 14 live values (NaN = 9.91E+37), status word, validity mask.
    let all = b.send("MEAS:ALL?");
    let f: Vec<&str> = all.split(',').collect();
    assert_eq!(f.len(), 17, "{all}");
    assert_eq!(f[0], (b.seq - 1).to_string());
    assert!(
        near(f[1], f64::from(circle_sample(STEPS).delta_l_um), 0.0),
        "{all}"
    );
    assert_eq!(&f[2..5], ["9.91E+37"; 3], "SSM not observable on a circle");
    assert!(near(f[5], E_UM[0], 1e-3), "e_u {all}");
    assert!(near(f[6], E_UM[1], 1e-3), "e_v {all}");
    assert!(near(f[7], R0_UM, 1e-3), "r0 {all}");
    assert_eq!(f[8], "20.0000");
    assert_eq!(&f[9..12], ["9.91E+37"; 3], "no SSM E, no u of it");
    // the live fit's u (refreshed at the run's 704th sample, the last multiple of 32), as
    // printed and unrounded: checked against the results' after the stop below
    for v in &f[12..15] {
        assert!(v.parse::<f64>().unwrap() > 0.0, "{all}");
    }
    let live_u = [Live::UEccU, Live::UEccV, Live::UR0].map(|k| b.app.live().get(k).unwrap());
    // status: bit 9 running + bit 12 live valid; mask: bits 0, 4, 5, 6, 7, 11, 12, 13
    assert_eq!(f[15], ((1 << 9) | (1 << 12)).to_string());
    assert_eq!(
        f[16],
        (1 | 1 << 4 | 1 << 5 | 1 << 6 | 1 << 7 | 1 << 11 | 1 << 12 | 1 << 13).to_string()
    );
    assert_eq!(b.send("STAT:POD?"), f[15]);
    assert_eq!(b.send("SESS:STOP;STAT?;REAS?"), "DONE;NONE");
    // every sample seen was used (seen, used, 5 skip counters, lost, temperature, overrun)
    let n = STEPS + 1;
    assert_eq!(b.send("SESS:COUN?"), format!("{n},{n},0,0,0,0,0,0,0,0"));
    // the run's fit: the model's eccentricity and radius change, in µm
    for (k, (name, id, want)) in [
        ("ecc_u", ResultId::EccU, E_UM[0]),
        ("ecc_v", ResultId::EccV, E_UM[1]),
        ("r0", ResultId::R0, R0_UM),
    ]
    .into_iter()
    .enumerate()
    {
        let r = b.send(&format!("FETC:RES? {name}"));
        let p: Vec<&str> = r.split(',').collect();
        assert_eq!(p.len(), 3, "{r}");
        assert!(near(p[0], want, 1e-3), "{name}: {r}");
        // the live u of 17 samples before: the same noise (at its floor, q/√12: the circle is
        // noiseless) and bar shares, the Type A part over 704 samples instead of 721
        let u_end = b.app.result(id).std_uncertainty;
        assert!(
            (live_u[k] / u_end - 1.0).abs() < 2e-3,
            "{name}: live u {live_u:?} vs {u_end} ({r})"
        );
        assert!(near(p[1], f64::from(u_end), 1e-4), "{r}");
        assert_eq!(p[2], "UM");
    }
    let arc = b.send("FETC:RES? arc");
    assert!(arc.ends_with(",DEG"), "{arc}");
    assert!(near(arc.split(',').next().unwrap(), 360.0, 0.01), "{arc}");
    // the same result by its index in the catalogue
    let k = ResultInfo::all().position(|r| r.name == "ecc_u").unwrap();
    assert_eq!(b.send(&format!("FETC:RES? {k}")), b.send("FETC:RES? ECC_U"));
    assert_eq!(b.errors(), Vec::<i32>::new());
}

#[test]
fn one_line_may_arm_and_start() {
    let mut b = Bench::with_circle();
    assert_eq!(b.send("SESS:ARM;STAR;STAT?"), "RUNNING");
    assert_eq!(b.app.session(), SessionState::Running);
    assert_eq!(b.errors(), Vec::<i32>::new());
}

#[test]
fn a_pattern_armed_without_its_geometry_is_refused_with_minus_221_naming_the_field() {
    let mut b = Bench::unlocked();
    b.rejected_with(
        "SESS:ARM",
        -221,
        "Settings conflict;circle_centre_x not set",
    );
    b.send("CONF:CIRCLE_CENTRE_X 0;CIRCLE_CENTRE_Y 0");
    b.rejected_with("SESS:ARM", -221, "Settings conflict;circle_radius not set");
    b.send("SESS:PATT CR2");
    b.rejected_with("SESS:ARM", -221, "Settings conflict;s002_l_b not set");
    b.send("SESS:PATT SSM");
    b.rejected_with("SESS:ARM", -221, "Settings conflict;ssm_socket_x not set");
    assert_eq!(b.send("SESS:STAT?"), "IDLE");
    // with its geometry the circle arms
    b.send("SESS:PATT CIRCLE;:CONF:CIRCLE_RADIUS 150");
    assert_eq!(b.send("SESS:ARM;STAT?"), "ARMED");
    assert_eq!(b.errors(), Vec::<i32>::new());
}

#[test]
fn session_commands_in_the_wrong_state_give_minus_221_and_change_nothing() {
    let mut b = Bench::with_circle();
    assert_eq!(b.send("CONF:UNL"), "");
    b.rejected_with("SESS:STAR", -221, "Settings conflict;START needs ARMED");
    b.rejected_with("SESS:STOP", -221, "Settings conflict;STOP needs RUNNING");
    b.rejected_with(
        "SESS:ABOR",
        -221,
        "Settings conflict;ABORT needs ARMED or RUNNING",
    );
    b.send("SESS:ARM");
    assert_eq!(b.app.session(), SessionState::Armed);
    let busy = "Settings conflict;not while a run is armed or running";
    b.rejected_with(
        "SESS:ARM",
        -221,
        "Settings conflict;ARM needs IDLE, DONE or ABORTED",
    );
    b.rejected("SESS:STOP", -221);
    b.rejected_with("SESS:PATT BY", -221, busy);
    b.rejected_with("SESS:DIR CW", -221, busy);
    b.rejected_with("SESS:CLE", -221, busy);
    b.rejected_with("CONF:BAR_LENGTH 200", -221, busy);
    assert_eq!(b.send("SESS:ABOR;STAT?;REAS?"), "ABORTED;COMMAND");
    b.send("SESS:ARM;STAR");
    assert_eq!(b.app.session(), SessionState::Running);
    b.rejected("SESS:STAR", -221);
    b.rejected("SESS:ARM", -221);
    b.rejected_with("CONF:AXIS1:NAME Y", -221, busy);
    b.rejected_with("CONF:CIRCLE_RADIUS 100", -221, busy);
    b.rejected_with("CONF:CAN_NODE_ID 20", -221, busy);
    // stopped without samples: no results, aborted as not observable
    assert_eq!(b.send("SESS:STOP;STAT?;REAS?"), "ABORTED;UNOBSERVABLE");
    assert_eq!(b.send("SESS:ARM;STAT?"), "ARMED");
    assert_eq!(b.errors(), Vec::<i32>::new());
}

#[test]
fn commands_of_one_line_all_execute_in_order() {
    let mut b = Bench::with_circle();
    assert_eq!(b.send("SESS:ARM;ABOR;ARM;ABOR;ARM;STAT?"), "ARMED");
    assert_eq!(b.app.run_number(), 3, "three runs armed");
    assert_eq!(b.errors(), Vec::<i32>::new());
}

#[test]
fn sess_clear_forgets_the_results_and_sess_note_is_empty_without_a_note() {
    let mut b = Bench::with_circle();
    b.send("SESS:ARM;STAR");
    b.feed_circle(0..=STEPS);
    b.send("SESS:STOP");
    assert!(b.send("FETC:RES? ecc_u").ends_with(",UM"));
    assert_eq!(b.send("SESS:NOTE?"), "\"\"");
    assert_eq!(b.send("SESS:CLE"), "");
    assert_eq!(b.app.results().valid_count(), 0);
    b.rejected_with(
        "FETC:RES? ecc_u",
        -230,
        "Data corrupt or stale;ecc_u has no valid value",
    );
    assert_eq!(b.errors(), Vec::<i32>::new());
}

// ---------------------------------------------------------------------------------------------
// Live values, results, touch points, log
// ---------------------------------------------------------------------------------------------

#[test]
fn live_values_print_in_fixed_point_with_0_1_nm_resolution() {
    let mut b = Bench::new();
    for (v, text) in [
        (-1.23456f32, "-1.2346"),
        (0.00004, "0.0000"),
        (-0.00004, "0.0000"),
        (0.03125, "0.0313"), // exact binary tie: half away from zero
        (-0.03125, "-0.0313"),
        (812.5, "812.5000"),
        (f32::NAN, "9.91E+37"), // SCPI-99 Vol 1 §7.2.1.5: NaN
    ] {
        b.feed(Sample {
            delta_l_um: v,
            temp_c: 20.0,
            ..Sample::default()
        });
        assert_eq!(b.send("MEAS:DL?"), text, "{v}");
    }
    // an idle sample: ΔL and the temperature are valid, nothing else; a probe-event flag is no
    // fault (status bit 3 only)
    b.feed(Sample {
        delta_l_um: 1.5,
        temp_c: 20.25,
        flags: SampleFlags::PROBE_EVENT,
        ..Sample::default()
    });
    let nan = "9.91E+37";
    assert_eq!(
        b.send("MEAS:ALL?"),
        format!(
            "{},1.5000,{nan},{nan},{nan},{nan},{nan},{nan},20.2500,{nan},{nan},{nan},{nan},{nan},{nan},8,{}",
            b.seq - 1,
            1 | 1 << 7
        )
    );
    assert_eq!(b.send("MEAS:VAL?"), "\"delta_l\",\"temp\"");
}

#[test]
fn invalid_live_values_read_scpi_nan_and_leave_the_valid_list() {
    let mut b = Bench::new();
    // before any sample nothing is valid
    assert_eq!(b.send("MEAS:DL?"), "9.91E+37");
    assert_eq!(b.send("MEAS:VAL?"), "");
    let all = b.send("MEAS:ALL?");
    assert!(all.ends_with(",0,0"), "{all}");
    assert_eq!(all.matches("9.91E+37").count(), 14, "{all}");
    // LVDT open: ΔL invalid (a fault: status bit 1 and bit 15)
    b.feed(Sample {
        delta_l_um: 0.0,
        temp_c: 21.0,
        flags: SampleFlags::LVDT_OPEN,
        ..Sample::default()
    });
    assert_eq!(b.send("MEAS:DL?"), "9.91E+37");
    assert_eq!(b.send("MEAS:VAL?"), "\"temp\"");
    let all = b.send("MEAS:ALL?");
    let f: Vec<&str> = all.split(',').collect();
    assert_eq!(f[1], "9.91E+37");
    assert_eq!(f[8], "21.0000");
    assert_eq!(f[15], (1 << 1 | 1 << 15).to_string());
    assert_eq!(f[16], (1 << 7).to_string());
    // a thermistor fault: the temperature is invalid
    b.feed(Sample {
        delta_l_um: 2.0,
        temp_c: 21.0,
        flags: SampleFlags::TEMPERATURE_FAULT,
        ..Sample::default()
    });
    assert_eq!(b.send("MEAS:DL?"), "2.0000");
    assert_eq!(b.send("MEAS:VAL?"), "\"delta_l\"");
}

#[test]
fn results_by_name_or_index_with_uncertainty_and_unit_and_no_data_when_invalid() {
    let mut b = Bench::with_circle();
    assert_eq!(ResultInfo::all().count(), 131);
    // nothing computed yet: -230 naming the result
    b.rejected_with(
        "FETC:RES? ecc_u",
        -230,
        "Data corrupt or stale;ecc_u has no valid value",
    );
    b.rejected_with(
        "FETC:RES? 0",
        -230,
        "Data corrupt or stale;ecc_u has no valid value",
    );
    b.send("SESS:ARM;STAR");
    b.feed_circle(0..=STEPS);
    b.send("SESS:STOP");
    let k = ResultInfo::all().position(|r| r.name == "r0").unwrap();
    let r = b.send("FETC:RES? R0");
    assert_eq!(b.send(&format!("FETCH:RESULT? {k}")), r);
    assert!(near(r.split(',').next().unwrap(), R0_UM, 1e-3), "{r}");
    // the bi-directional results need a CW run as well
    b.rejected_with(
        "FETC:RES? g_bidir",
        -230,
        "Data corrupt or stale;G_bidir has no valid value",
    );
    // a diagnosis says why it has no value
    b.rejected_with(
        "FETC:RES? squareness",
        -230,
        "Data corrupt or stale;squareness not determinable yet: needs the latest CCW and CW runs, both complete",
    );
    // a summary result says what it waits for
    b.rejected_with(
        "FETC:RES? scale_x",
        -230,
        "Data corrupt or stale;scale_x not available yet: needs a complete circle or arc (both directions, every quadrant) in each of XY, YZ and ZX since the session was cleared",
    );
    b.rejected("FETC:RES? 131", -222);
    b.rejected("FETC:RES? -1", -222);
    b.rejected("FETC:RES? 1.5", -222);
    b.rejected("FETC:RES? nonsense", -224);
    b.rejected("FETC:RES?", -109);
    b.rejected("FETC:RES? ecc_u,ecc_v", -108);
    let cat = b.send("FETC:RES:CAT?");
    let names: Vec<String> = cat
        .split(',')
        .map(|s| s.trim_matches('"').to_string())
        .collect();
    let expected: Vec<String> = ResultInfo::all().map(|r| r.name.to_string()).collect();
    assert_eq!(names, expected);
}

#[test]
fn touch_points_of_a_probe_run() {
    let mut b = Bench::new();
    assert_eq!(b.send("FETC:TOUC:COUN?"), "0");
    b.rejected("FETC:TOUC? 1", -222);
    b.send("SESS:PATT PROBE;ARM;STAR");
    assert_eq!(b.app.session(), SessionState::Running);
    let points = [[10.0f32, 20.0, -5.0], [10.5, 19.25, -5.125]];
    for (k, p) in points.iter().enumerate() {
        b.feed(Sample {
            temp_c: 20.0,
            ..Sample::default()
        });
        let t = Touch {
            t_us: 5_000_000 + k as u64 * 1000,
            axes: [p[0], p[1], p[2], 0.0, 0.0],
        };
        b.app.on_recorded_touch(&t, &mut b.log);
    }
    assert_eq!(b.send("FETC:TOUC:COUN?"), "2");
    assert_eq!(b.send("FETC:TOUC? 1"), "10.0000,20.0000,-5.0000");
    assert_eq!(b.send("FETCH:TOUCH? 2"), "10.5000,19.2500,-5.1250");
    b.rejected("FETC:TOUC? 3", -222);
    b.rejected("FETC:TOUC? 0", -222);
    b.rejected("FETC:TOUC? 1.5", -222);
    b.rejected("FETC:TOUC?", -109);
}

/// The log download's block: (announced length, body without the final NL).
fn block(out: &[u8]) -> (usize, Vec<u8>) {
    // IEEE 488.2 §8.7.9: '#', one digit n, n digits of length, the bytes; then NL.
    assert_eq!(out[0], b'#');
    let n = (out[1] - b'0') as usize;
    let len: usize = std::str::from_utf8(&out[2..2 + n])
        .unwrap()
        .parse()
        .unwrap();
    let body = &out[2 + n..];
    assert_eq!(body.len(), len + 1);
    assert_eq!(body[len], b'\n');
    (len, body[..len].to_vec())
}

#[test]
fn log_download_is_a_definite_length_block_of_csv() {
    let mut b = Bench::with_circle();
    b.send("SESS:ARM;STAR");
    // 40 samples into a log of 32 records: full at the 33rd, it keeps every other sample from
    // then on (app::log: whole runs at the best rate that fits) → 20 records.
    b.feed_circle(0..40);
    b.send("SESS:STOP");
    // the end of the run reaches the log with the next sample (app: recorder events wait for
    // it); that sample is not the run's
    b.feed(circle_sample(40));
    assert_eq!(b.send("DATA:LOG:COUN?"), "20");
    let out = b.raw(b"DATA:LOG?\n");
    let (len, body) = block(&out);
    assert_eq!(body.len(), len);
    let csv = std::str::from_utf8(&body).unwrap();
    assert!(csv.starts_with("# ballpod run v2\n"), "{csv}");
    for line in [
        "# run=1",
        "# pattern=CIRCLE",
        "# direction=CCW",
        "# circle_radius=150",
        "# source=log",
        "# decimation=2",
        "# records=20",
        "# overwritten=0",
        "# end=ABORTED",
        "# reason=UNOBSERVABLE",
        "# seen=40",
    ] {
        assert!(csv.lines().any(|l| l == line), "{line} in\n{csv}");
    }
    // the firmware that made it: *IDN?'s fourth field (the client tests check it against git)
    let idn = b.send("*IDN?");
    let version = idn.split(',').nth(3).unwrap();
    assert!(
        csv.lines().any(|l| l == format!("# firmware={version}")),
        "{version} in\n{csv}"
    );
    let rows: Vec<&str> = csv.lines().filter(|l| !l.starts_with('#')).collect();
    assert_eq!(rows.len(), 1 + 20);
    assert!(rows[0].starts_with("seq,t_s,dl_um,"), "{}", rows[0]);
    // every other sample of the run, from its first
    let seqs: Vec<u32> = rows[1..]
        .iter()
        .map(|r| r.split(',').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(seqs, (0..40).step_by(2).collect::<Vec<u32>>());
    // the same bytes as the download module writes from the log
    let mut direct = Vec::new();
    ballpod::protocol::download::write_csv(&b.log, b.log.meta().unwrap(), &mut |c: &[u8]| {
        direct.extend_from_slice(c)
    });
    assert_eq!(direct, body);
}

// ---------------------------------------------------------------------------------------------
// Numbers and robustness
// ---------------------------------------------------------------------------------------------

/// A small deterministic generator (xorshift64*).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
}

#[test]
fn decimal_parser_agrees_with_the_standard_library() {
    // Rust's `str::parse::<f64>` is correctly rounded: the oracle.
    let mut r = Rng(0x1234_5678);
    for _ in 0..20_000 {
        let mut s = String::new();
        if r.below(3) == 0 {
            s.push('-');
        }
        for _ in 0..=r.below(8) {
            s.push((b'0' + r.below(10) as u8) as char);
        }
        if r.below(2) == 0 {
            s.push('.');
            for _ in 0..r.below(10) {
                s.push((b'0' + r.below(10) as u8) as char);
            }
        }
        if r.below(3) == 0 {
            s.push_str(&format!("e{}", r.below(40) as i64 - 20));
        }
        let ours = number::parse_decimal(s.as_bytes()).unwrap();
        let std: f64 = s.parse().unwrap();
        let tol = std.abs() * 4.0 * f64::EPSILON;
        assert!((ours - std).abs() <= tol, "{s}: {ours} vs {std}");
    }
}

#[test]
fn fixed_point_printing_is_the_value_rounded_to_the_resolution() {
    let mut r = Rng(99);
    for _ in 0..20_000 {
        let v = (r.next() as i64 as f64) / 2f64.powi(50); // ±8192, fine fractions
        let decimals = r.below(8) as u32;
        let mut t: number::Text<64> = number::Text::new();
        assert!(number::push_fixed(&mut t, v, decimals, false, b"nan"));
        let s = std::str::from_utf8(&t).unwrap();
        // exactly `decimals` decimals
        assert_eq!(
            s.split_once('.').map_or(0, |(_, f)| f.len()),
            decimals as usize,
            "{s}"
        );
        let back: f64 = s.parse().unwrap();
        let step = 10f64.powi(-(decimals as i32));
        assert!((back - v).abs() <= 0.5 * step * (1.0 + 1e-9), "{v} → {s}");
        // and it is the nearest multiple of the step (the oracle: std formatting)
        let std = format!("{:.*}", decimals as usize, v);
        if ((v / step).fract().abs() - 0.5).abs() > 1e-6 {
            assert_eq!(
                s.trim_start_matches('-'),
                std.trim_start_matches('-'),
                "{v}"
            );
        }
    }
}

#[test]
fn random_input_never_panics_and_never_changes_the_locked_configuration() {
    let alphabet =
        b"SYST:ERR?CONF:BAR_LENGTH SESS:ARM*IDN?;,.'\"#0123456789eE+- \t\r\x00\xff:?;abcxyz";
    let mut r = Rng(7);
    let mut b = Bench::new();
    let config = format!("{:?}", b.app.config());
    for _ in 0..20_000 {
        let mut chunk: Vec<u8> = (0..r.below(40))
            .map(|_| alphabet[r.below(alphabet.len() as u64) as usize])
            .collect();
        if r.below(4) == 0 {
            chunk.push(b'\n');
        }
        b.raw(&chunk);
        // the port is locked and no CONF:UNL can be spelt from the alphabet
        assert_eq!(format!("{:?}", b.app.config()), config, "{chunk:?}");
        b.app.config().validate().unwrap();
        // a circle without its geometry never arms
        assert_eq!(b.app.session(), SessionState::Idle, "{chunk:?}");
    }
}

#[test]
fn status_word_query_adds_the_error_bit_while_errors_are_queued() {
    let mut b = Bench::with_circle();
    b.send("SESS:ARM;STAR");
    // a sample after lost ones: status bit 4 (overrun) and bit 9 (running); no fault
    b.feed(Sample {
        delta_l_um: 0.5,
        temp_c: 20.0,
        flags: SampleFlags::OVERRUN,
        ..Sample::default()
    });
    assert_eq!(b.send("STAT:POD?"), (1 << 4 | 1 << 9).to_string());
    b.send("BOGUS");
    // bit 15: an error is pending
    assert_eq!(
        b.send("STATUS:POD?"),
        (1 << 4 | 1 << 9 | 1 << 15).to_string()
    );
    b.send("*CLS");
    assert_eq!(b.send("STAT:POD?"), (1 << 4 | 1 << 9).to_string());
    // an LVDT fault sets bit 15 by itself (bit 1: LVDT open)
    b.feed(Sample {
        delta_l_um: 0.5,
        temp_c: 20.0,
        flags: SampleFlags::LVDT_OPEN,
        ..Sample::default()
    });
    assert_eq!(b.send("STAT:POD?"), (1 << 1 | 1 << 9 | 1 << 15).to_string());
}

/// A bench with a run of 20 samples in its log.
fn bench_with_log() -> Bench {
    let mut b = Bench::with_circle();
    b.send("SESS:ARM;STAR");
    for k in 0..20 {
        b.feed(Sample {
            delta_l_um: k as f32 * -0.125,
            ..circle_sample(k)
        });
    }
    assert_eq!(b.log.len(), 20);
    b
}

#[test]
fn pulled_download_is_byte_for_byte_the_streamed_one() {
    let mut streamed = bench_with_log();
    let whole = streamed.raw(b"*OPC?;DATA:LOG?\n");
    for size in [1usize, 7, 64, 4096] {
        let mut b = bench_with_log();
        b.scpi.set_pull_download(true);
        let mut got = b.raw(b"*OPC?;DATA:LOG?\n");
        assert_eq!(
            got, b"1",
            "feed sends what came before; the pulls count, then send"
        );
        assert!(b.scpi.download_pending());
        let mut buf = vec![0u8; size];
        // the block's length is counted a few lines a pull (0 bytes), then the header goes out
        // alone, then the CSV
        let mut counting_pulls = 0;
        while b.scpi.download_pending() {
            let n = b.scpi.pull_download(&b.log, &mut buf);
            if n == 0 {
                assert!(b.scpi.download_header_pending());
                counting_pulls += 1;
            }
            got.extend_from_slice(&buf[..n]);
        }
        // the CSV's lines (the block's terminator is the last `\n`)
        let lines = whole.iter().filter(|&&c| c == b'\n').count() - 1;
        assert_eq!(
            counting_pulls,
            lines / ballpod::protocol::scpi::COUNT_LINES_PER_PULL,
            "lines counted {} a pull",
            ballpod::protocol::scpi::COUNT_LINES_PER_PULL
        );
        assert!(!b.scpi.download_pending());
        assert_eq!(got, whole, "buffer of {size} bytes");
    }
}

#[test]
fn pulled_download_ends_its_line_and_keeps_the_stream_order() {
    let mut streamed = bench_with_log();
    let whole = streamed.raw(b"DATA:LOG?\n");
    let mut b = bench_with_log();
    b.scpi.set_pull_download(true);
    // a unit after DATA:LOG? in the same line: -440, not executed
    let mut got = b.raw(b"DATA:LOG?;SESS:ABOR\n");
    assert_eq!(
        b.app.session(),
        SessionState::Running,
        "SESS:ABOR not executed"
    );
    let mut buf = [0u8; 100];
    let n = b.scpi.pull_download(&b.log, &mut buf);
    got.extend_from_slice(&buf[..n]);
    // input before the rest is pulled: the download completes first, then the new response
    got.extend_from_slice(&b.raw(b"*OPC?\n"));
    assert!(!b.scpi.download_pending());
    assert_eq!(b.scpi.pull_download(&b.log, &mut buf), 0);
    let mut expected = whole.clone();
    expected.extend_from_slice(b"1\n");
    assert_eq!(got, expected);
    assert_eq!(b.errors(), vec![-440]);
}

// ---------------------------------------------------------------------------------------------
// Configuration lock (issue 7: configuration over USB only after an explicit unlock)
// ---------------------------------------------------------------------------------------------

#[test]
fn configuration_writes_need_the_unlock_and_get_minus_203_before() {
    let mut b = Bench::new();
    assert_eq!(b.send("CONF:LOCK?"), "1");
    // SCPI-99 Vol 2 §21.8.9: -203 "Command protected".
    b.rejected("CONF:BAR_LENGTH 200", -203);
    b.rejected("CONF:CIRCLE_RADIUS 150", -203);
    b.rejected("CONF:AXIS2:NAME Z", -203);
    b.rejected("*SAV 0", -203);
    assert_eq!(b.app.take_settings_request(), None);
    b.send("CONF:BAR_LENGTH 200");
    assert_eq!(b.error(), (-203, "Command protected;CONF:UNL first".into()));
    // Queries and session commands are not locked.
    assert_eq!(
        b.send("CONF:BAR_LENGTH?").parse::<f32>().unwrap(),
        Config::default().bar_length_mm
    );
    assert_eq!(b.send("SESS:PATT PROBE;:SESS:ARM;STAT?"), "ARMED");
    b.send("SESS:ABOR");
    b.send("*RST");
    // Unlocked: the same writes go through.
    assert_eq!(b.send("CONFigure:UNLock"), "");
    assert_eq!(b.send("CONF:LOCK?"), "0");
    assert_eq!(b.send("CONF:BAR_LENGTH 200"), "");
    assert_eq!(b.app.config().bar_length_mm, 200.0);
    assert_eq!(b.send("*SAV 0"), "");
    assert_eq!(b.app.take_settings_request(), Some(SettingsRequest::Store));
    assert_eq!(b.errors(), Vec::<i32>::new());
}

#[test]
fn the_port_locks_again_on_lock_rst_and_disconnect() {
    let mut b = Bench::unlocked();
    b.send("CONF:LOCK");
    assert_eq!(b.send("CONF:LOCK?"), "1");
    b.rejected("CONF:BAR_LENGTH 150", -203);

    let mut b = Bench::unlocked();
    b.send("*RST");
    assert_eq!(b.send("CONF:LOCK?"), "1");
    b.rejected("CONF:BAR_LENGTH 150", -203);

    let mut b = Bench::unlocked();
    // A disconnect mid-line also drops the partial line.
    b.raw(b"CONF:BAR_LENGTH 1");
    b.scpi.connection_closed();
    assert!(!b.scpi.config_unlocked());
    b.raw(b"50\n");
    assert_eq!(b.errors(), vec![-102]);
    assert_eq!(
        format!("{:?}", b.app.config()),
        format!("{:?}", Config::default())
    );
    b.rejected("CONF:BAR_LENGTH 150", -203);
}

#[test]
fn a_device_error_is_reported_by_syst_err_with_its_detail() {
    let mut b = Bench::new();
    b.scpi.push_device_error("panic at src/x.rs:12");
    assert_eq!(
        b.error(),
        (-300, "Device-specific error;panic at src/x.rs:12".into())
    );
    assert_eq!(b.error(), (0, "No error".into()));
}

#[test]
fn axes_are_referenced_with_axis_position_on_a_locked_port() {
    use ballpod::acquisition::lvdt::{BlockReading, LvdtReading};
    let block = || {
        BlockReading::Ac(Ok(LvdtReading {
            ratio: 0.1,
            signal_level: 1000.0,
            iq_a: [0.0; 2],
            clipped: false,
        }))
    };
    let mut b = Bench::new();
    // before the first reading: refused with the reason
    assert_eq!(b.send("AXIS2:POS 50"), "");
    let (n, msg) = b.error();
    assert_eq!(n, -221);
    assert!(msg.contains("not read yet"), "{msg}");
    b.app
        .on_raw_sample(1_000, block(), [100, 200, 300, 400, 500], 0, &mut ());
    // the port is locked (configuration) but a reference is not configuration
    assert_eq!(b.send("AXIS2:POS 50;:AXIS2:POS?"), "50.0000");
    // forward model: Y moved +25 counts at 10 000 counts per mm
    b.app
        .on_raw_sample(2_000, block(), [100, 225, 300, 400, 500], 0, &mut ());
    assert_eq!(b.send("AXIS2:POSITION?"), "50.0025");
    assert_eq!(
        b.send("AXIS1:POS?"),
        "0.0000",
        "X: counts from its first reading"
    );
    // out of range, no such input, not a number
    assert_eq!(b.send("AXIS2:POS 10000.5"), "");
    assert_eq!(b.error().0, -222);
    assert_eq!(b.send("AXIS6:POS?"), "");
    assert_eq!(b.error().0, -114);
    assert_eq!(b.send("AXIS2:POS X"), "");
    assert_eq!(b.error().0, -104);
    assert_eq!(b.send("AXIS2:POS?"), "50.0025", "nothing changed");
    // not while a run is armed
    assert_eq!(b.send("SESS:PATT PROBE;ARM"), "");
    assert_eq!(b.send("AXIS2:POS 0"), "");
    assert_eq!(
        b.error(),
        (
            -221,
            "Settings conflict;not while a run is armed or running".into()
        )
    );
}

/// A pulled `DATA:LOG?` whose host stops reading ends after `DOWNLOAD_STALL_US` (10 s) without
/// a pull, so that logging resumes (it is paused while a download is pending); -410 says so
/// and `downloads_cut` counts it. A host that reads slowly but on, a pull every 9 s, keeps it.
#[test]
fn a_download_nobody_reads_for_10_s_ends_and_logging_resumes() {
    use ballpod::protocol::scpi::DOWNLOAD_STALL_US;
    assert_eq!(DOWNLOAD_STALL_US, 10_000_000);
    let mut b = bench_with_log();
    b.scpi.set_pull_download(true);
    b.raw(b"DATA:LOG?\n");
    assert!(b.scpi.download_pending());
    let mut buf = [0u8; 64];
    // slow but steady: a pull every 9 s for a minute
    let mut t = 1_000_000u64;
    b.scpi.watch_download(t);
    for _ in 0..7 {
        t += 9_000_000;
        b.scpi.pull_download(&b.log, &mut buf);
        b.scpi.watch_download(t);
        assert!(b.scpi.download_pending(), "at {t} µs");
    }
    // then nothing: still pending 9.9 s after the last pull, ended at 10 s
    b.scpi.watch_download(t + 9_900_000);
    assert!(b.scpi.download_pending());
    b.scpi.watch_download(t + 10_000_000);
    assert!(!b.scpi.download_pending());
    assert_eq!(b.scpi.counters().downloads_cut, 1);
    assert_eq!(
        b.error(),
        (
            -410,
            "Query INTERRUPTED;DATA:LOG? ended: not read for 10 s".into()
        )
    );
    // a new download is whole again
    let mut streamed = bench_with_log();
    let whole = streamed.raw(b"DATA:LOG?\n");
    let mut got = b.raw(b"DATA:LOG?\n");
    while b.scpi.download_pending() {
        let n = b.scpi.pull_download(&b.log, &mut buf);
        got.extend_from_slice(&buf[..n]);
    }
    assert_eq!(got, whole);
}
