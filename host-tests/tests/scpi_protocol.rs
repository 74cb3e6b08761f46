//! SCPI command interface: IEEE 488.2 common commands and status model, the SCPI-99 error
//! queue, configuration through the `config::FIELDS` table, session control, live values,
//! results and the log download — and every class of bad input rejected with its SCPI-99
//! error number and no change of state.
use ballpod::acquisition::Sample;
use ballpod::config::{AxisName, Config, FIELDS, Field};
use ballpod::protocol::log::SampleLog;
use ballpod::protocol::pod::{
    Direction, Pattern, PodModel, RESULTS, ResultEntry, SessionCommand, SessionState,
};
use ballpod::protocol::scpi::status::ERROR_QUEUE_DEPTH;
use ballpod::protocol::scpi::{LINE_CAPACITY, ScpiServer, number};

/// The pod with its SCPI port, as the technician's PC sees it.
struct Bench {
    scpi: ScpiServer,
    pod: PodModel,
    log: SampleLog<32>,
}

impl Bench {
    fn new() -> Self {
        Self {
            scpi: ScpiServer::new(),
            pod: PodModel::default(),
            log: SampleLog::new(),
        }
    }

    /// A bench whose port was unlocked for configuration writes (`CONF:UNL`).
    fn unlocked() -> Self {
        let mut b = Self::new();
        assert_eq!(b.send("CONF:UNL"), "");
        b
    }

    /// Sends raw bytes; returns what came back and the session actions.
    fn raw(&mut self, bytes: &[u8]) -> (Vec<u8>, Vec<SessionCommand>) {
        let mut out = Vec::new();
        let actions = self
            .scpi
            .feed(bytes, &mut self.pod, &self.log, &mut |b: &[u8]| {
                out.extend_from_slice(b)
            });
        // A minimal application: executes the session actions on the model.
        for a in &actions {
            match a {
                SessionCommand::Arm { .. } => self.pod.session = SessionState::Armed,
                SessionCommand::Start => self.pod.session = SessionState::Running,
                SessionCommand::Stop => self.pod.session = SessionState::Done,
                SessionCommand::Abort => self.pod.session = SessionState::Aborted,
                SessionCommand::Reset => self.pod.session = SessionState::Idle,
                _ => {}
            }
        }
        (out, actions.to_vec())
    }

    /// Sends one line; returns the response text (without its terminator; empty if none).
    fn send(&mut self, line: &str) -> String {
        let (out, _) = self.raw(format!("{line}\n").as_bytes());
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

    /// Sends one line; returns the session actions.
    fn act(&mut self, line: &str) -> Vec<SessionCommand> {
        self.raw(format!("{line}\n").as_bytes()).1
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

    /// Sends a line that must be rejected with exactly `code`, with no response, no action and
    /// no change of the pod.
    fn rejected(&mut self, line: &str, code: i32) {
        let before = self.pod;
        let (out, actions) = self.raw(format!("{line}\n").as_bytes());
        assert!(out.is_empty(), "{line}: unexpected response {out:?}");
        assert!(actions.is_empty(), "{line}: unexpected actions {actions:?}");
        assert_eq!(self.pod, before, "{line}: state changed");
        assert_eq!(self.errors(), vec![code], "{line}");
    }
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
    assert_eq!(fields[3], env!("CARGO_PKG_VERSION"));
    // common command headers are case-insensitive (§7.6.1.3)
    assert_eq!(b.send("*idn?"), idn);
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
fn rst_asks_for_a_reset_and_keeps_the_status_registers() {
    let mut b = Bench::new();
    b.send("*ESE 4");
    b.send("BOGUS");
    assert_eq!(b.act("*RST"), vec![SessionCommand::Reset]);
    // §10.32: *RST does not affect the status registers or the queue
    assert_eq!(b.send("*ESE?"), "4");
    assert_eq!(b.errors(), vec![-113]);
}

#[test]
fn sav_0_stores_settings() {
    let mut b = Bench::unlocked();
    assert_eq!(b.act("*SAV 0"), vec![SessionCommand::StoreSettings]);
    b.rejected("*SAV 3", -222);
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
    assert!(msg.starts_with("Data out of range"), "{msg}");
    assert!(msg.contains("bar_length"), "names the field: {msg}");
    let (n, msg) = b.error();
    assert_eq!(n, -221);
    assert!(msg.starts_with("Settings conflict"), "{msg}");
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
        (b.pod.pattern, b.pod.direction),
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
    let msg = b"*IDN?;:SESS:PATT CA\r\nSESS:ARM\r\nSESS:STAT?;PATT?\n";
    let (whole, wa) = a.raw(msg);
    let mut bytes = Vec::new();
    let mut acts = Vec::new();
    for c in msg.chunks(1) {
        let (o, x) = b.raw(c);
        bytes.extend(o);
        acts.extend(x);
    }
    assert_eq!(whole, bytes);
    assert_eq!(wa, acts);
    assert_eq!(a.pod, b.pod);
    let text = String::from_utf8(whole).unwrap();
    assert!(text.ends_with("ARMED;CA\n"), "{text}");
}

#[test]
fn an_over_long_line_is_rejected_whole_and_the_next_line_parses() {
    let mut b = Bench::new();
    let before = b.pod;
    // a valid command that would change state, padded beyond the buffer
    let mut long = b"CONF:BAR_LENGTH 200;".to_vec();
    while long.len() <= LINE_CAPACITY {
        long.extend_from_slice(b"*OPC?;");
    }
    long.extend_from_slice(b"SESS:ARM\n");
    let (out, actions) = b.raw(&long);
    assert!(out.is_empty() && actions.is_empty());
    assert_eq!(b.pod, before);
    // the next line, even in the same chunk, is parsed normally
    let (out, _) = b.raw(b"\xff\xfe\n*OPC?\n");
    assert_eq!(out, b"1\n");
    assert_eq!(b.errors(), vec![-363, -101]);
    assert_eq!(b.scpi.counters().lines_overrun, 1);
    // exactly LINE_CAPACITY bytes fit
    let mut fits = b"*OPC?".to_vec();
    fits.resize(LINE_CAPACITY, b' ');
    fits.push(b'\n');
    assert_eq!(b.raw(&fits).0, b"1\n");
}

#[test]
fn malformed_headers_and_parameters_get_their_error_numbers() {
    let mut b = Bench::new();
    b.rejected("*", -102);
    b.rejected("*FOO?", -113);
    b.rejected("CONF::BAR_LENGTH 100", -102);
    b.rejected("CONF:BAR_LENGTH=100", -102);
    b.rejected("SESS:ARM?", -113); // no query form
    b.rejected("MEAS:DL", -113); // query only
    b.rejected("MEAS:DL? 3", -108);
    b.rejected("SESS:ARM 1", -108);
    b.rejected("SESS:PATT", -109);
    b.rejected("SESS:PATT BX,BY", -108);
    b.rejected("SESS:PATT BX,", -109);
    b.rejected("SESS:PATT 'BX'", -158);
    b.rejected("SESS:PATT 3", -104);
    b.rejected("SESS:PATT B-X", -141);
    b.rejected("SESS:PATT CRP", -224);
    b.rejected("SESS:DIR LEFT", -224);
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

/// The value of a field read directly from the configuration (independent of the server).
fn read(c: &Config, f: Field) -> f64 {
    match f {
        Field::BarLengthMm => c.bar_length_mm as f64,
        Field::BarCtePpmPerK => c.bar_cte_ppm_per_k as f64,
        Field::LvdtPolyUm(k) => c.lvdt_poly_um[k as usize] as f64,
        Field::LvdtMaxAbsRatio => c.lvdt_max_abs_ratio as f64,
        Field::LvdtMinSignal => c.lvdt_min_signal as f64,
        Field::LvdtDcZeroV => c.lvdt_dc_zero_v as f64,
        Field::LvdtDcSpanV => c.lvdt_dc_span_v as f64,
        Field::ExcitationHz => c.excitation_hz as f64,
        Field::SamplesPerPeriod => c.samples_per_period as f64,
        Field::SampleRateHz => c.sample_rate_hz as f64,
        Field::AxisCountsPerUnit(i) => c.axes[i as usize].counts_per_unit,
        Field::AxisMaxSpeed(i) => c.axes[i as usize].max_speed_per_s as f64,
        Field::ThermistorR25Ohm => c.thermistor_r25_ohm as f64,
        Field::ThermistorBetaK => c.thermistor_beta_k as f64,
        Field::ThermistorRFixedOhm => c.thermistor_r_fixed_ohm as f64,
        Field::ProbeDebounceUs => c.probe_debounce_us as f64,
        Field::ProbeReseatUs => c.probe_reseat_us as f64,
        Field::CanNodeId => c.can_node_id as f64,
        _ => unreachable!(),
    }
}

fn info(f: Field) -> &'static ballpod::config::FieldInfo {
    Config::field_info(f).unwrap()
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-6 * b.abs().max(1.0)
}

#[test]
fn every_field_is_settable_at_its_limits_and_reads_back() {
    let headers = field_headers();
    assert_eq!(headers.len(), FIELDS.len() - 3 + 4 + 5 + 5);
    for (h, f) in &headers {
        let i = info(*f);
        for (v, text) in [
            (i.min, format!("{}", i.min)),
            (i.max, format!("{:e}", i.max)),
        ] {
            let mut b = Bench::unlocked();
            // (each limit alone: with the others at their defaults no cross-field check trips)
            let actions = b.act(&format!("{h} {text}"));
            assert_eq!(actions, vec![SessionCommand::ConfigChanged], "{h} {text}");
            assert!(close(read(&b.pod.config, *f), v), "{h} {text}");
            let back: f64 = b.send(&format!("{h}?")).parse().unwrap();
            assert!(close(back, v), "{h}? = {back}, set {v}");
            // the other fields did not move
            for (_, g) in &headers {
                if g != f {
                    assert_eq!(
                        read(&b.pod.config, *g),
                        read(&Config::default(), *g),
                        "{h} moved {g:?}"
                    );
                }
            }
            assert_eq!(b.errors(), Vec::<i32>::new());
        }
    }
}

#[test]
fn out_of_range_values_give_minus_222_and_change_nothing() {
    for (h, f) in field_headers() {
        let i = info(f);
        let mut b = Bench::unlocked();
        let span = (i.max - i.min).max(1.0);
        b.rejected(&format!("{h} {}", i.max + span), -222);
        b.rejected(&format!("{h} {}", i.min - span), -222);
        b.rejected(&format!("{h} 1e300"), -222);
    }
}

#[test]
fn min_max_def_keywords_follow_the_table() {
    // SCPI-99 Vol 1 §7.2.1.1: MINimum, MAXimum, DEFault as numeric values.
    let mut b = Bench::unlocked();
    assert_eq!(b.send("CONF:BAR_LENGTH? MIN"), "50");
    assert_eq!(b.send("CONF:BAR_LENGTH? MAXIMUM"), "600");
    b.send("CONF:BAR_LENGTH MAX");
    assert_eq!(b.pod.config.bar_length_mm, 600.0);
    b.send("conf:bar_length def");
    assert_eq!(b.pod.config.bar_length_mm, 150.0);
    b.send("CONF:BAR_LENGTH min");
    assert_eq!(b.pod.config.bar_length_mm, 50.0);
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
        assert_eq!(b.pod.config.bar_length_mm, 200.0, "{text}");
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
    let c = &b.pod.config;
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
    assert_eq!(b.pod.config.thermistor_r25_ohm, 4700.0);
    assert_eq!(b.send("CONF:NTC_R25?"), "4700");
    assert_eq!(b.errors(), Vec::<i32>::new());
}

#[test]
fn cross_field_conflicts_give_minus_221_and_change_nothing() {
    let mut b = Bench::unlocked();
    b.send("CONF:SAMPLES_PER_PERIOD 64"); // 64 × 5 kHz = 320 kS/s
    b.errors();
    // 64 × 20 kHz = 1.28 MS/s > the ADC limit: config::validate rejects it
    b.rejected("CONF:EXCITATION 20000", -221);
    // two inputs cannot read the same axis
    b.rejected("CONF:AXIS2:NAME X", -221);
}

#[test]
fn axis_names_are_set_per_input() {
    let mut b = Bench::unlocked();
    assert_eq!(b.send("CONF:AXIS4:NAME?"), "B");
    assert_eq!(
        b.act("CONF:AXIS4:NAME A"),
        vec![SessionCommand::ConfigChanged]
    );
    assert_eq!(b.pod.config.axes[3].name, AxisName::A);
    b.send("CONF:AXIS5:NAME none");
    assert_eq!(b.send("CONF:AXIS5:NAME?"), "NONE");
    assert_eq!(b.send("CONF:AXIS:NAME?"), "X"); // suffix 1 by default
    b.rejected("CONF:AXIS6:NAME Y", -114);
    b.rejected("CONF:AXIS1:NAME W", -224);
}

#[test]
fn several_config_writes_in_one_chunk_report_one_config_changed() {
    let mut b = Bench::unlocked();
    let actions = b.act("CONF:BAR_LENGTH 200;BAR_CTE 12;:CONF:SAMPLE_RATE 500");
    assert_eq!(actions, vec![SessionCommand::ConfigChanged]);
    assert_eq!(b.pod.config.sample_rate_hz, 500.0);
}

// ---------------------------------------------------------------------------------------------
// Session control
// ---------------------------------------------------------------------------------------------

#[test]
fn a_full_session_emits_its_actions_in_order() {
    let mut b = Bench::new();
    assert_eq!(b.act("SESS:PATT CRPRIME;DIR CW"), vec![]);
    assert_eq!(b.send("SESS:PATT?"), "CRPR"); // character response in short form
    assert_eq!(
        b.act("SESS:ARM"),
        vec![SessionCommand::Arm {
            pattern: Pattern::CrPrime,
            direction: Direction::Cw
        }]
    );
    assert_eq!(b.act("SESS:STAR"), vec![SessionCommand::Start]);
    assert_eq!(b.send("SESS:STAT?"), "RUNNING");
    assert_eq!(b.act("SESSION:STOP"), vec![SessionCommand::Stop]);
    assert_eq!(b.send("SESS:STAT?"), "DONE");
    assert_eq!(b.errors(), Vec::<i32>::new());
}

#[test]
fn one_line_may_arm_and_start() {
    let mut b = Bench::new();
    assert_eq!(
        b.act("SESS:ARM;STAR;STAT?"),
        vec![
            SessionCommand::Arm {
                pattern: Pattern::Circle,
                direction: Direction::Ccw
            },
            SessionCommand::Start
        ]
    );
    assert_eq!(b.pod.session, SessionState::Running); // as the application executed them
}

#[test]
fn session_commands_in_the_wrong_state_give_minus_221_and_change_nothing() {
    let mut b = Bench::unlocked();
    b.rejected("SESS:STAR", -221);
    b.rejected("SESS:STOP", -221);
    b.rejected("SESS:ABOR", -221);
    b.pod.session = SessionState::Armed;
    b.rejected("SESS:ARM", -221);
    b.rejected("SESS:STOP", -221);
    b.rejected("SESS:PATT BY", -221);
    b.rejected("SESS:DIR CW", -221);
    b.rejected("CONF:BAR_LENGTH 200", -221);
    assert_eq!(b.act("SESS:ABOR"), vec![SessionCommand::Abort]);
    b.pod.session = SessionState::Running;
    b.rejected("SESS:STAR", -221);
    b.rejected("SESS:ARM", -221);
    b.rejected("CONF:AXIS1:NAME Y", -221);
    b.pod.session = SessionState::Aborted;
    assert!(matches!(
        b.act("SESS:ARM")[..],
        [SessionCommand::Arm { .. }]
    ));
}

#[test]
fn more_actions_than_fit_are_rejected_and_counted() {
    let mut b = Bench::new();
    let (_, actions) = b.raw(b"SESS:ARM;ABOR;ARM;ABOR;ARM\n");
    assert_eq!(actions.len(), 4);
    assert_eq!(b.errors(), vec![-200]);
    assert_eq!(b.scpi.counters().actions_rejected, 1);
}

// ---------------------------------------------------------------------------------------------
// Live values, results, log
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
        b.pod.live.delta_l_um = v;
        assert_eq!(b.send("MEAS:DL?"), text, "{v}");
    }
    b.pod.live.delta_l_um = 1.5;
    b.pod.live.sample_counter = 4711;
    b.pod.live.ssm_e_um = [0.1, -0.2, 0.0];
    b.pod.live.temp_c = 20.25;
    b.pod.live.status.0 = 0x0101;
    assert_eq!(
        b.send("MEAS:ALL?"),
        "4711,1.5000,0.1000,-0.2000,0.0000,0.0000,0.0000,0.0000,20.2500,257"
    );
}

#[test]
fn results_by_name_or_index_with_uncertainty_and_unit() {
    let mut b = Bench::new();
    b.pod.results[3] = ResultEntry {
        value: 4.25,
        std_uncertainty: 0.125,
        valid: true,
    };
    b.pod.results[9] = ResultEntry {
        value: -12.0,
        std_uncertainty: 1.5,
        valid: true,
    };
    assert_eq!(RESULTS[3].0, "G_ccw");
    assert_eq!(b.send("FETC:RES? G_CCW"), "4.2500,0.1250,UM");
    assert_eq!(b.send("FETCH:RESULT? 3"), "4.2500,0.1250,UM");
    assert_eq!(b.send("FETC:RES? alpha_cz"), "-12.0000,1.5000,URAD");
    b.rejected("FETC:RES? 0", -230); // not computed
    b.rejected("FETC:RES? 16", -222);
    b.rejected("FETC:RES? 1.5", -222);
    b.rejected("FETC:RES? nonsense", -224);
    b.rejected("FETC:RES?", -109);
    let cat = b.send("FETC:RES:CAT?");
    let names: Vec<String> = cat
        .split(',')
        .map(|s| s.trim_matches('"').to_string())
        .collect();
    let expected: Vec<String> = RESULTS.iter().map(|(n, _)| n.to_string()).collect();
    assert_eq!(names, expected);
}

#[test]
fn log_download_is_a_definite_length_block_of_csv() {
    let mut b = Bench::new();
    for k in 0..40u64 {
        b.log.push(&Sample {
            t_us: 1_000_000 + k * 1000,
            delta_l_um: k as f32 * 0.5,
            ..Sample::default()
        });
    }
    assert_eq!(b.send("DATA:LOG:COUN?"), "32");
    let (out, _) = b.raw(b"DATA:LOG?\n");
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
    let csv = std::str::from_utf8(&body[..len]).unwrap();
    assert!(csv.starts_with("# ballpod log v1\n"));
    assert!(csv.contains("# overwritten=8\n"));
    let rows = csv.lines().filter(|l| !l.starts_with('#')).count();
    assert_eq!(rows, 1 + 32);
    // the same bytes as the log module writes
    let mut direct = Vec::new();
    ballpod::protocol::log::write_csv(
        &b.log,
        &ballpod::protocol::log::LogMeta::from_pod(&b.pod),
        &mut |c: &[u8]| direct.extend_from_slice(c),
    );
    assert_eq!(direct, &body[..len]);
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
fn random_input_never_panics_and_changes_nothing_without_an_action() {
    let alphabet =
        b"SYST:ERR?CONF:BAR_LENGTH SESS:ARM*IDN?;,.'\"#0123456789eE+- \t\r\x00\xff:?;abcxyz";
    let mut r = Rng(7);
    let mut b = Bench::new();
    for _ in 0..20_000 {
        let before = b.pod;
        let mut chunk: Vec<u8> = (0..r.below(40))
            .map(|_| alphabet[r.below(alphabet.len() as u64) as usize])
            .collect();
        if r.below(4) == 0 {
            chunk.push(b'\n');
        }
        let (_, actions) = b.raw(&chunk);
        if actions.is_empty() {
            // only pattern and direction are written without an action, and only validly
            let mut p = b.pod;
            p.pattern = before.pattern;
            p.direction = before.direction;
            assert_eq!(p, before, "{chunk:?}");
        } else {
            b.pod.config.validate().unwrap();
        }
        b.pod.session = SessionState::Idle;
    }
}

#[test]
fn status_word_query_adds_the_error_bit_while_errors_are_queued() {
    use ballpod::acquisition::SampleFlags;
    use ballpod::protocol::pod::StatusWord;
    let mut b = Bench::new();
    b.pod.live.status = StatusWord::new(SampleFlags::LVDT_OPEN, SessionState::Running, false);
    // bit 1 LVDT open, bit 9 running (pod.rs StatusWord)
    assert_eq!(b.send("STAT:POD?"), "514");
    b.send("BOGUS");
    // bit 15: an error is pending
    assert_eq!(b.send("STATUS:POD?"), "33282");
    b.send("*CLS");
    assert_eq!(b.send("STAT:POD?"), "514");
}

/// A bench with 20 logged samples.
fn bench_with_log() -> Bench {
    let mut b = Bench::new();
    for k in 0..20u64 {
        b.log.push(&Sample {
            t_us: 5_000_000 + k * 1000,
            delta_l_um: k as f32 * -0.125,
            temp_c: 21.5,
            ..Sample::default()
        });
    }
    b
}

#[test]
fn pulled_download_is_byte_for_byte_the_streamed_one() {
    let mut streamed = bench_with_log();
    let (whole, _) = streamed.raw(b"*OPC?;DATA:LOG?\n");
    for size in [1usize, 7, 64, 4096] {
        let mut b = bench_with_log();
        b.scpi.set_pull_download(true);
        let (mut got, _) = b.raw(b"*OPC?;DATA:LOG?\n");
        assert!(got.starts_with(b"1;#"), "only the header in feed");
        assert!(b.scpi.download_pending());
        let mut buf = vec![0u8; size];
        loop {
            let n = b.scpi.pull_download(&b.log, &mut buf);
            if n == 0 {
                break;
            }
            got.extend_from_slice(&buf[..n]);
        }
        assert!(!b.scpi.download_pending());
        assert_eq!(got, whole, "buffer of {size} bytes");
    }
}

#[test]
fn pulled_download_ends_its_line_and_keeps_the_stream_order() {
    let mut streamed = bench_with_log();
    let (whole, _) = streamed.raw(b"DATA:LOG?\n");
    let mut b = bench_with_log();
    b.scpi.set_pull_download(true);
    // a unit after DATA:LOG? in the same line: -440, not executed
    let (mut got, actions) = b.raw(b"DATA:LOG?;SESS:ARM\n");
    assert!(actions.is_empty());
    let mut buf = [0u8; 100];
    let n = b.scpi.pull_download(&b.log, &mut buf);
    got.extend_from_slice(&buf[..n]);
    // input before the rest is pulled: the download completes first, then the new response
    let (rest, _) = b.raw(b"*OPC?\n");
    got.extend_from_slice(&rest);
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
    b.rejected("CONF:AXIS2:NAME Z", -203);
    b.rejected("*SAV 0", -203);
    b.send("CONF:BAR_LENGTH 200");
    assert_eq!(b.error(), (-203, "Command protected;CONF:UNL first".into()));
    // Queries and session commands are not locked.
    assert_eq!(
        b.send("CONF:BAR_LENGTH?").parse::<f32>().unwrap(),
        Config::default().bar_length_mm
    );
    assert_eq!(b.act("SESS:PATT BX;:SESS:ARM").len(), 1);
    b.send("SESS:ABOR");
    b.send("*RST");
    // Unlocked: the same writes go through.
    assert_eq!(b.send("CONFigure:UNLock"), "");
    assert_eq!(b.send("CONF:LOCK?"), "0");
    assert_eq!(
        b.act("CONF:BAR_LENGTH 200"),
        vec![SessionCommand::ConfigChanged]
    );
    assert_eq!(b.pod.config.bar_length_mm, 200.0);
    assert_eq!(b.act("*SAV 0"), vec![SessionCommand::StoreSettings]);
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
    assert_eq!(b.pod.config, Config::default());
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
