//! The seed 002 procedure end to end on the virtual machine tool: sensor streams → the core's
//! acquisition → session → model-based identification recovers the machine's deviations.
//! Truth: the machine preset (thesis Table 4.5 values, spec seed-002 §5.7), simulated by the
//! independent forward model `forward_seed002`.

use ballpod::identify::multitasking::model_lsq::ModelLsq;
use ballpod::identify::multitasking::{Parameter, urad_to_arcsec};
use ballpod_host::analysis::analyse;
use ballpod_host::simulate::{SimOptions, simulate};
use ballpod_host::vmt::machine::MachineFile;

#[test]
fn identified_deviations_match_the_truth_within_their_uncertainty() {
    let m = MachineFile::default();
    // a fast feed keeps the debug-build test short; one repeat: u comes from the fits alone
    let o = SimOptions {
        seed: 7,
        repeats: 1,
        feed_mm_per_min: 4000.0,
        seed002: true,
        circle: false,
    };
    let s = simulate(&m, &o, &mut |_, _, _| {});
    let r = analyse(&s.desc, &s.runs).expect("analysis");
    let id = r.seed002.expect("procedure complete");
    let truth = m.seed002.deviations();
    let free = ModelLsq::without_squareness().free;
    let mut checked = 0;
    for p in Parameter::ALL {
        if !free[p.index()] {
            continue;
        }
        let v = id.model.iter().find(|v| v.name == p.name()).expect("value");
        let t = if p.is_positional() {
            truth.get(p)
        } else {
            urad_to_arcsec(truth.get(p))
        };
        let d = (v.value - t).abs();
        assert!(v.u > 0.0 && v.u < 0.2, "{}: u = {}", v.name, v.u);
        // k = 3: the test must not fail by chance on one of ten normal deviates
        assert!(
            d <= 3.0 * v.u,
            "{}: |{} − {t}| > 3·{}",
            v.name,
            v.value,
            v.u
        );
        assert!(d <= 0.5, "{}: {} vs {t}", v.name, v.value);
        checked += 1;
    }
    assert_eq!(checked, 10);
    // corrections are the negative of the deviations
    for (c, v) in id.corrections.iter().zip(id.model.iter()) {
        assert_eq!(c.value, -v.value);
    }
}

#[test]
fn an_incomplete_procedure_reports_no_identification() {
    let m = MachineFile::default();
    let o = SimOptions {
        seed: 3,
        repeats: 1,
        feed_mm_per_min: 8000.0,
        seed002: true,
        circle: false,
    };
    let mut s = simulate(&m, &o, &mut |_, _, _| {});
    // drop the last run (CR2 CCW)
    s.runs.pop();
    s.desc.runs.pop();
    let r = analyse(&s.desc, &s.runs).expect("analysis");
    assert!(r.seed002.is_none());
    assert_eq!(r.runs.len(), 9);
}
