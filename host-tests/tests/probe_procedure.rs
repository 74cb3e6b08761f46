//! The touch-probe procedure's bookkeeping on the pod (seed 002 chapter 5, `app::probe`): which
//! sphere a PROBE run files where, what a missing tool length does, and which two tool lengths
//! the B-axis identification uses when a third one is probed. Spheres are placed by the literal
//! HTM model (`vmt::motion::probe_target`) and touched at sensor level (`vmt::probe_rig`); the
//! identified values are held against the machine's deviations.

use ballpod::app::{ProcedureNote, ResultId};
use ballpod::config::Field;
use ballpod::identify::mill_turn::urad_to_arcsec;
use ballpod_host::vmt::machine::Machine002;
use ballpod_host::vmt::motion::probe_target;
use ballpod_host::vmt::probe_rig::ProbeRig;
use ballpod_host::vmt::sensors::Instrument;

const ORIGIN_MM: [f64; 3] = [-490.0, 0.0, -536.838];
const RC_ZC_MM: [f64; 2] = [100.0, 64.838];

fn machine() -> Machine002 {
    Machine002 {
        dx_bt_um: 12.0,
        dz_bt_um: -7.5,
        ..Machine002::default()
    }
}

fn rig() -> ProbeRig {
    let mut rig = ProbeRig::new(&Instrument::default(), 5);
    rig.pod
        .app
        .configure(|c| {
            c.setup.s002_origin_mm = ORIGIN_MM.map(|v| v as f32);
            c.setup.s002_z_c_mm = RC_ZC_MM[1] as f32;
        })
        .unwrap();
    rig
}

/// Run `step` of the chapter 5 sequence with tool length `length_mm` (NaN: not set).
fn probe(rig: &mut ProbeRig, length_mm: f64, step: u32) {
    rig.pod
        .app
        .configure(|c| c.setup.probe_length_mm = length_mm as f32)
        .unwrap();
    let d = machine().deviations().to_array();
    let (centre, rotary) = probe_target(&d, ORIGIN_MM, RC_ZC_MM, length_mm, step);
    let m = rig.measure_sphere(centre, rotary).expect("sphere");
    assert_eq!(m.accepted, 9);
}

/// The B-axis results as (value, standard uncertainty), all valid.
fn b_results(rig: &ProbeRig) -> [(f64, f64); 5] {
    [
        ResultId::ProbeDxBt,
        ResultId::ProbeDzBt,
        ResultId::ProbeBetaXb,
        ResultId::ProbeAlphaBtPlusAlphaXb,
        ResultId::ProbeAlphaBtMinusGammaXb,
    ]
    .map(|id| {
        let e = rig.pod.app.result(id);
        assert!(e.valid, "{id:?} valid");
        (f64::from(e.value), f64::from(e.std_uncertainty))
    })
}

/// The truth of [`b_results`] (µm, arc-seconds).
fn b_truth() -> [f64; 5] {
    let d = machine().deviations();
    let a = urad_to_arcsec;
    [
        d.dx_bt_um,
        d.dz_bt_um,
        a(d.beta_xb_urad),
        a(d.alpha_bt_urad + d.alpha_xb_urad),
        a(d.alpha_bt_urad - d.gamma_xb_urad),
    ]
}

fn assert_near_truth(got: [(f64, f64); 5]) {
    for ((v, u), t) in got.into_iter().zip(b_truth()) {
        // noise-free probe: what is left is the encoders' 0.1 µm step
        assert!(
            (v - t).abs() <= (4.0 * u).max(0.1),
            "{v} ± {u} vs truth {t}"
        );
    }
}

#[test]
fn a_b_axis_sphere_without_a_tool_length_names_the_field() {
    let mut rig = rig();
    probe(&mut rig, f64::NAN, 5); // B = 90°
    assert_eq!(
        rig.pod.app.procedure_note(),
        Some(ProcedureNote::Missing(Field::ProbeLengthMm))
    );
    assert!(!rig.pod.app.result(ResultId::ProbeDxBt).valid);
    // the sphere itself is reported (in axis positions: no tool length to take off)
    assert!(rig.pod.app.result(ResultId::SphereX).valid);
}

#[test]
fn the_b_axis_needs_both_positions_for_two_tool_lengths() {
    let mut rig = rig();
    probe(&mut rig, 382.95, 4);
    probe(&mut rig, 382.95, 5);
    probe(&mut rig, 433.062, 4);
    // B = 90° missing for the second length: nothing yet
    assert!(!rig.pod.app.result(ResultId::ProbeDxBt).valid);
    // a sphere of the C-axis sequence does not count for the B axis
    probe(&mut rig, 433.062, 0);
    assert!(!rig.pod.app.result(ResultId::ProbeDxBt).valid);
    probe(&mut rig, 433.062, 5);
    assert_near_truth(b_results(&rig));
    assert_eq!(rig.pod.app.procedure_note(), None);
}

#[test]
fn a_third_tool_length_replaces_the_one_probed_less_recently() {
    let mut rig = rig();
    for length in [382.95, 433.062] {
        probe(&mut rig, length, 4);
        probe(&mut rig, length, 5);
    }
    let first = b_results(&rig);
    assert_near_truth(first);
    // a third stylus: its B = 0° sphere replaces the 382.95 mm pair (probed less recently);
    // with one position of it in, the table keeps what the last complete pairs gave
    probe(&mut rig, 480.0, 4);
    assert_eq!(b_results(&rig), first);
    probe(&mut rig, 480.0, 5);
    let second = b_results(&rig);
    assert_ne!(second, first, "identified again from 433.062 and 480 mm");
    assert_near_truth(second);
    // and 382.95 mm is gone: probing it at B = 90° alone identifies nothing new
    probe(&mut rig, 382.95, 5);
    assert_eq!(b_results(&rig), second);
}
