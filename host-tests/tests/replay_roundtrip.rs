//! Replaying the logs and session file the simulator wrote gives the simulator's results bit
//! for bit (the JSON text is compared, and the samples themselves).

use ballpod_host::analysis::analyse;
use ballpod_host::logfile::{read_session, write_session};
use ballpod_host::report::results_json;
use ballpod_host::simulate::{SimOptions, simulate};
use ballpod_host::vmt::machine::MachineFile;

#[test]
fn replay_of_the_simulators_logs_reproduces_its_results_bit_for_bit() {
    let m = MachineFile::default();
    let o = SimOptions {
        seed: 5,
        repeats: 1,
        feed_mm_per_min: 8000.0,
        seed002: true,
        circle: true,
    };
    let s = simulate(&m, &o, &mut |_, _, _| {});
    let sim = analyse(&s.desc, &s.runs).expect("sim analysis");
    assert!(sim.seed002.is_some() && sim.iso230_4.is_some());
    let dir = std::env::temp_dir().join(format!("ballpod-replay-{}", std::process::id()));
    write_session(&dir, &s.desc, &s.runs).expect("write logs");
    let (desc, runs) = read_session(&dir.join("session.json")).expect("read logs");
    assert_eq!(desc, s.desc);
    // every sample field the pod logs comes back exactly (f32 shortest round-trip repr)
    for (a, b) in runs.iter().zip(&s.runs) {
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(b) {
            assert_eq!(x.delta_l_um.to_bits(), y.delta_l_um.to_bits());
            assert_eq!(x.axes.map(f32::to_bits), y.axes.map(f32::to_bits));
            assert_eq!(
                (x.t_us, x.flags, x.temp_c.to_bits()),
                (y.t_us, y.flags, y.temp_c.to_bits())
            );
        }
    }
    let replay = analyse(&desc, &runs).expect("replay analysis");
    assert_eq!(
        results_json(&replay).expect("json"),
        results_json(&sim).expect("json")
    );
    let _ = std::fs::remove_dir_all(&dir);
}
