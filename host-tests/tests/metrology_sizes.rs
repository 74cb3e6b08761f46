//! Fixed memory (issue 3 item 5): the bytes of each estimator's state, printed with
//! `cargo host-test --test metrology_sizes -- --nocapture`, and held to a budget.

use ballpod::metrology::circle_fit::CircleFit;
use ballpod::metrology::iso230_4::CircularTest;
use ballpod::metrology::ssm::station::StationCollector;
use ballpod::metrology::ssm::streaming::StreamingSsm;
use core::mem::size_of;

#[test]
fn estimator_state_sizes() {
    let rows = [
        ("CircleFit (one direction)", size_of::<CircleFit>(), 128),
        (
            "CircularTest<360> (ISO 230-4, CW + CCW, 1° bins)",
            size_of::<CircularTest<360>>(),
            2 * (20 * 360 + 160),
        ),
        (
            "CircularTest<720> (0.5° bins)",
            size_of::<CircularTest<720>>(),
            2 * (20 * 720 + 160),
        ),
        (
            "StationCollector<16>",
            size_of::<StationCollector<16>>(),
            48 * 16 + 256,
        ),
        (
            "StreamingSsm<256>",
            size_of::<StreamingSsm<256>>(),
            28 * 256 + 264,
        ),
        (
            "StreamingSsm<2048>",
            size_of::<StreamingSsm<2048>>(),
            28 * 2048 + 264,
        ),
    ];
    println!("estimator state sizes (host, 64-bit; the target's usize is 4 bytes, so ≤ these):");
    for (name, bytes, budget) in rows {
        println!("  {name:<50} {bytes:>7} B  (budget {budget} B)");
        assert!(bytes <= budget, "{name}: {bytes} B over budget {budget} B");
    }
}
