//! When a configuration change takes effect (issue 13 item 3): the LVDT input mode and the DC
//! conditioner's zero and span at the next sample, without losing state that did not change;
//! the sampling fields (`config::AT_RESET`) at the next reset, reported pending until then
//! (status word bit 14) while the pod keeps its sample period. Expectations are computed here
//! from the definitions (r = (v − zero)/span, ΔL = the calibration polynomial at r).
use ballpod::acquisition::lvdt::{BlockReading, DemodError};
use ballpod::acquisition::{MAX_AXES, SampleFlags};
use ballpod::app::{App, CommandError, StatusWord};
use ballpod::config::{AT_RESET, Config, ConfigError, Field, LvdtInput};
use ballpod_host::vmt::virtual_pod::{VirtualPod, VirtualSetup};

/// A raw AC block reading of ratio `r` with a healthy signal.
fn ac(r: f32) -> BlockReading {
    BlockReading::Ac(Ok(ballpod::acquisition::lvdt::LvdtReading {
        ratio: r,
        signal_level: 1000.0,
        iq_a: [0.0; 2],
        clipped: false,
    }))
}

#[test]
fn the_lvdt_mode_zero_and_span_apply_at_the_next_sample_and_keep_the_rest() {
    let mut app = App::new(Config::default(), [16; MAX_AXES]);
    let poly = app.config().lvdt_poly_um;
    let at = |r: f64| {
        poly.iter()
            .rev()
            .fold(0.0, |acc, &c| acc * r + f64::from(c))
    };
    let raw = [1000; MAX_AXES];
    // AC: the demodulated ratio goes through the polynomial (20 °C bar: no expansion)
    let s = app.on_raw_sample(0, ac(0.1), raw, 0, &mut ());
    assert!((f64::from(s.delta_l_um) - at(0.1)).abs() < 1e-3, "{s:?}");
    let seq_before = s.seq;
    // switch to the DC conditioner with zero 1 V, span 4 V (its signal level is the span in
    // volts: the open threshold goes to 1 V)
    app.set_field(Field::LvdtMinSignal, 1.0).unwrap();
    app.configure(|c| c.lvdt_input = LvdtInput::DcConditioner)
        .unwrap();
    app.set_field(Field::LvdtDcZeroV, 1.0).unwrap();
    app.set_field(Field::LvdtDcSpanV, 4.0).unwrap();
    assert_eq!(app.config().lvdt_input, LvdtInput::DcConditioner);
    // a block still acquired in AC (the shell had not switched yet) is not read as DC
    assert_eq!(app.lvdt_reading(ac(0.1)), Err(DemodError::ModeChanged));
    let s = app.on_raw_sample(1000, ac(0.1), raw, 0, &mut ());
    assert!(s.flags.contains(SampleFlags::LVDT_OPEN), "{s:?}");
    // 2.2 V: r = (2.2 − 1)/4 = 0.3
    let s = app.on_raw_sample(2000, BlockReading::DcVolts(2.2), raw, 0, &mut ());
    // (no thermistor reading yet: the samples carry TEMPERATURE_FAULT throughout)
    assert!(!s.flags.contains(SampleFlags::LVDT_OPEN), "{s:?}");
    assert!((f64::from(s.delta_l_um) - at(0.3)).abs() < 1e-2, "{s:?}");
    // a new zero applies to the very next sample: (2.2 − 0.6)/4 = 0.4
    app.set_field(Field::LvdtDcZeroV, 0.6).unwrap();
    let s2 = app.on_raw_sample(3000, BlockReading::DcVolts(2.2), raw, 0, &mut ());
    assert!((f64::from(s2.delta_l_um) - at(0.4)).abs() < 1e-2, "{s2:?}");
    // nothing else was lost: the sample numbers went on, the positions are the same
    assert_eq!(s2.seq, seq_before + 3);
    assert_eq!(s2.axes, s.axes);
    assert_eq!(app.acquisition_counters().samples, 4);
}

#[test]
fn sampling_fields_take_effect_at_reset_and_are_reported_pending() {
    let pending = |app: &App| app.live().status.0 & StatusWord::RESET_PENDING != 0;
    // each AT_RESET field alone (to a value the rules accept with the others at their
    // defaults) marks the change pending; the pod runs with the boot value
    for (f, v) in [
        (Field::ExcitationHz, 4000.0),
        (Field::SamplesPerPeriod, 20.0),
        (Field::SampleRateHz, 2500.0),
    ] {
        assert!(AT_RESET.contains(&f));
        let mut app = App::new(Config::default(), [16; MAX_AXES]);
        app.set_field(f, v).unwrap();
        let changed = app.config().field_value(f) != Config::default().field_value(f);
        assert_eq!(pending(&app), changed, "{f:?}");
        let run = app.running_config();
        assert_eq!(
            (
                run.excitation_hz,
                run.samples_per_period,
                run.sample_rate_hz
            ),
            (5000.0, 20, 1000.0)
        );
    }
    // a field that applies at once is never pending
    let mut app = App::new(Config::default(), [16; MAX_AXES]);
    app.set_field(Field::BarLengthMm, 300.0).unwrap();
    assert!(!pending(&app));
    // writing the boot value back clears it
    app.set_field(Field::SampleRateHz, 2500.0).unwrap();
    assert!(pending(&app));
    app.set_field(Field::SampleRateHz, 1000.0).unwrap();
    assert!(!pending(&app));
}

#[test]
fn until_the_reset_the_counters_are_held_to_the_rate_the_pod_runs_with() {
    // with 5 kHz pending, encoder 1 at 5 000 mm/s would step 2 × 5 000 × 10 000 / 10 000 =
    // 10 000 counts a read at the glitch limit (a configuration valid on its own), but until the
    // reset the pod reads it at 2 kHz: 50 000 counts, beyond its 16-bit counter's 32 767
    let mut app = App::new(Config::default(), [16; MAX_AXES]);
    app.set_field(Field::SampleRateHz, 5000.0).unwrap();
    let mut later = *app.config();
    later.axes[0].max_speed_per_s = 5000.0;
    assert_eq!(later.validate(), Ok(()));
    let e = app.set_field(Field::AxisMaxSpeed(0), 5000.0).unwrap_err();
    assert!(matches!(
        e,
        CommandError::Config(ConfigError::OutOfRange {
            field: Field::AxisCounterReach(0),
            ..
        })
    ));
    assert_eq!(app.config().axes[0].max_speed_per_s, 1000.0);
    // after the reset (a pod booted with the saved configuration) it is taken
    let mut rebooted = App::new(*app.config(), [16; MAX_AXES]);
    rebooted.set_field(Field::AxisMaxSpeed(0), 5000.0).unwrap();
}

/// One SCPI line to the simulated pod's command port; its response line.
fn scpi(vp: &mut VirtualPod, line: &str) -> String {
    let out = vp.usb(format!("{line}\n").as_bytes());
    String::from_utf8(out).unwrap().trim_end().to_string()
}

#[test]
fn the_simulated_pod_keeps_its_period_until_a_reset_with_the_saved_rate() {
    let mut vp: VirtualPod = VirtualPod::new(VirtualSetup::default());
    let at = [0.0; MAX_AXES];
    vp.sample_at(0.0, &at);
    assert_eq!(vp.period_us(), 1000.0);
    assert_eq!(scpi(&mut vp, "CONF:UNL;:CONF:SAMPLE_RATE 2500;*SAV 0"), "");
    vp.sample_at(0.0, &at);
    // still 1 kHz, bit 14 over both protocols
    assert_eq!(vp.period_us(), 1000.0);
    let status: u16 = scpi(&mut vp, "STAT:POD?").parse().unwrap();
    assert_ne!(status & StatusWord::RESET_PENDING, 0);
    // after the reset the saved 2.5 kHz runs and nothing is pending
    let mut after = vp.power_on();
    after.sample_at(0.0, &at);
    assert_eq!(after.period_us(), 400.0);
    let status: u16 = scpi(&mut after, "STAT:POD?").parse().unwrap();
    assert_eq!(status & StatusWord::RESET_PENDING, 0);
}

#[test]
fn the_lvdt_mode_is_handed_to_the_board_once_at_start_and_once_per_change() {
    let mut app = App::new(Config::default(), [16; MAX_AXES]);
    // the board's LVDT task is told the mode once at start …
    assert_eq!(app.take_lvdt_input(), Some(LvdtInput::AcRatiometric));
    assert_eq!(app.take_lvdt_input(), None);
    // … not when another field changes …
    app.set_field(Field::BarLengthMm, 200.0).unwrap();
    assert_eq!(app.take_lvdt_input(), None);
    // … and once when the mode changes
    app.set_field(Field::LvdtMinSignal, 1.0).unwrap();
    app.configure(|c| c.lvdt_input = LvdtInput::DcConditioner)
        .unwrap();
    assert_eq!(app.take_lvdt_input(), Some(LvdtInput::DcConditioner));
    assert_eq!(app.take_lvdt_input(), None);
    // a refused change hands nothing over
    assert!(
        app.configure(|c| {
            c.lvdt_input = LvdtInput::AcRatiometric;
            c.bar_length_mm = -1.0;
        })
        .is_err()
    );
    assert_eq!(app.take_lvdt_input(), None);
}
