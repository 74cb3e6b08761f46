//! The interpreted path of a part program (`vmt::nc_motion`, the motion source of `sim --nc`)
//! on canonical commands as LinuxCNC's `rs274 -g` prints them (copied from its output for
//! programs of `cargo ncgen`): the runs between the programs' comments, the samples on the
//! nominal geometry (analytic), the block durations from the feed as LinuxCNC plans them.
use ballpod::app::Direction;
use ballpod_host::vmt::nc_motion::runs;

/// A full CCW circle in XY about (0, 0), R 150, F1000, after a radial feed-in (from
/// `ncgen circle`, interpreted).
const CIRCLE: &str = r#"    7 N..... COMMENT("ballpod ISO 230-4 circle test, plane XY, CCW")
   12 N..... SET_FEED_MODE(0, 0)
   13 N..... SET_FEED_RATE(0.0000)
   15 N..... SELECT_PLANE(CANON_PLANE_XY)
   18 N..... STRAIGHT_TRAVERSE(151.0000, 0.0000, 0.0000, 0.0000, 0.0000, 0.0000)
   19 N..... SET_FEED_RATE(1000.0000)
   20 N..... STRAIGHT_FEED(150.0000, 0.0000, 0.0000, 0.0000, 0.0000, 0.0000)
   21 N..... COMMENT("CCW data arc start")
   22 N..... ARC_FEED(150.0000, 0.0000, 0.0000, 0.0000, 1, 0.0000, 0.0000, 0.0000, 0.0000)
   23 N..... COMMENT("CCW data arc end, overshoot")
   24 N..... ARC_FEED(106.0660, 106.0660, 0.0000, 0.0000, 1, 0.0000, 0.0000, 0.0000, 0.0000)
"#;

/// Two blocks of a B quarter turn each way (from `ncgen pattern BX --steps 4`, shortened).
const PATTERN: &str = r#"   16 N..... STRAIGHT_TRAVERSE(456.3945, 0.0000, 65.5348, 0.0000, 90.0000, 0.0000)
   17 N..... COMMENT("CCW run start")
   18 N..... SET_FEED_RATE(1000.0000)
   19 N..... STRAIGHT_FEED(352.0090, 0.0000, 317.5438, 0.0000, 45.0000, 0.0000)
   20 N..... STRAIGHT_FEED(100.0000, 0.0000, 421.9293, 0.0000, 0.0000, 0.0000)
   21 N..... COMMENT("CCW run end")
   22 N..... COMMENT("CW run start")
   23 N..... SET_FEED_RATE(1000.0000)
   24 N..... STRAIGHT_FEED(352.0090, 0.0000, 317.5438, 0.0000, 45.0000, 0.0000)
   25 N..... STRAIGHT_FEED(456.3945, 0.0000, 65.5348, 0.0000, 90.0000, 0.0000)
   26 N..... COMMENT("CW run end")
"#;

#[test]
fn a_circle_run_is_its_data_arc_sampled_on_the_circle_at_the_feed() {
    let r = runs(CIRCLE).expect("canonical commands");
    assert_eq!(r.len(), 1, "the feed-in and the overshoot are not the run");
    assert_eq!(r[0].direction, Direction::Ccw);
    let rate = 1000.0;
    let s = r[0].samples(rate);
    // a full turn of 2π·150 mm at 1000 mm/min: 56.549 s
    let seconds = 2.0 * std::f64::consts::PI * 150.0 / (1000.0 / 60.0);
    assert_eq!(s.len(), (seconds * rate).floor() as usize + 1);
    for (k, p) in s.iter().enumerate() {
        let th = k as f64 / rate / seconds * 2.0 * std::f64::consts::PI;
        assert!((p[0] - 150.0 * th.cos()).abs() < 1e-9, "sample {k}: {p:?}");
        assert!((p[1] - 150.0 * th.sin()).abs() < 1e-9, "sample {k}: {p:?}");
        assert_eq!((p[2], p[3], p[4]), (0.0, 0.0, 0.0));
    }
}

#[test]
fn a_pattern_program_gives_its_two_runs_joint_space_interpolated_in_time() {
    let r = runs(PATTERN).expect("canonical commands");
    let dirs: Vec<Direction> = r.iter().map(|x| x.direction).collect();
    assert_eq!(dirs, [Direction::Ccw, Direction::Cw]);
    let rate = 1000.0;
    let s = r[0].samples(rate);
    // each block lasts its X Z chord over the feed; B follows linearly (joint space)
    let chord = |a: [f64; 2], b: [f64; 2]| ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
    let t1 = chord([456.3945, 65.5348], [352.0090, 317.5438]) / (1000.0 / 60.0);
    let t2 = chord([352.0090, 317.5438], [100.0, 421.9293]) / (1000.0 / 60.0);
    assert_eq!(s.len(), ((t1 + t2) * rate).floor() as usize + 1);
    let k = (t1 * rate * 0.5).round() as usize;
    let f = k as f64 / rate / t1;
    let expect = [
        456.3945 + (352.0090 - 456.3945) * f,
        0.0,
        65.5348 + (317.5438 - 65.5348) * f,
        90.0 - 45.0 * f,
        0.0,
    ];
    for (a, b) in s[k].iter().zip(expect) {
        assert!((a - b).abs() < 1e-9, "{:?} vs {expect:?}", s[k]);
    }
    assert_eq!(s[0], [456.3945, 0.0, 65.5348, 90.0, 0.0]);
    let last = s[s.len() - 1];
    assert!(
        last[3].abs() < 45.0 / (t2 * rate) + 1e-9,
        "ends at B 0: {last:?}"
    );
}

#[test]
fn unbalanced_markers_and_feed_moves_without_a_feed_are_refused() {
    let open = "   1 N..... COMMENT(\"CCW run start\")\n   2 N..... SET_FEED_RATE(100.0)\n   3 N..... STRAIGHT_FEED(1, 0, 0, 0, 0, 0)\n";
    assert!(runs(open).unwrap_err().contains("never ends"));
    let wrong = "   1 N..... COMMENT(\"CCW run start\")\n   2 N..... COMMENT(\"CW run end\")\n";
    assert!(runs(wrong).unwrap_err().contains("out of order"));
    let no_feed = "   1 N..... STRAIGHT_FEED(1, 0, 0, 0, 0, 0)\n";
    assert!(runs(no_feed).unwrap_err().contains("without a feed rate"));
}
