//! Runs that start and stop themselves (`run_trigger = FEED_IN`, `app::trigger`): the
//! simulated pod is driven through an ISO 230-4 circle program as `ncgen circle` writes it —
//! rest at the feed-in point, radial feed-in, the data arc, the overshoot, radial feed-out —
//! on a machine whose ball runs `E_UM` off the socket (the bar reads |p + e − c| − R), sampled
//! at the pod's rate through its encoders and LVDT.
//!
//! - The run starts at the first sample the documented rule names (computed here from the
//!   nominal path: after the tool was ≥ 0.05 mm outside the circle, on the circle within
//!   0.01 mm with a step more along the circle than across it) and ends where it says (the
//!   sample sweeping `circle_arc`, or before the feed-out's first sample).
//! - Its results equal, bit for bit, those of a run a client starts and stops on the same
//!   samples, and the eccentricity is the machine's.
//! - A program without a feed-in never starts a run: the pod stays armed and says why over
//!   CANopen (0x3007, read by an SDO client written here) and SCPI (`SESS:NOTE?`).

use ballpod::acquisition::MAX_AXES;
use ballpod::app::{Command, ResultId, SessionState};
use ballpod::config::RunTrigger;
use ballpod::protocol::canopen::CanFrame;
use ballpod_host::vmt::virtual_pod::{VirtualPod, VirtualSetup};

const R_MM: f64 = 100.0;
/// The machine's error: the ball's offset from the commanded point, µm.
const E_UM: [f64; 2] = [3.0, -2.0];
/// F1000 at 1 kHz: 1/60 mm a sample; the 1 mm feed-in is 60 samples.
const STEP_MM: f64 = 1.0 / 60.0;
const FEED_IN_MM: f64 = 1.0;
const OVERSHOOT_DEG: f64 = 45.0;
const REST: usize = 50;

/// The nominal path of one CCW run, sample by sample (X, Y in mm).
fn path(feed_in: bool) -> Vec<[f64; 2]> {
    path_in(feed_in, 1.0)
}

/// The nominal path of one run turning in `sign` (+1 CCW, −1 CW).
fn path_in(feed_in: bool, sign: f64) -> Vec<[f64; 2]> {
    let mut p = Vec::new();
    let start = if feed_in { R_MM + FEED_IN_MM } else { R_MM };
    for _ in 0..REST {
        p.push([start, 0.0]);
    }
    if feed_in {
        let n = (FEED_IN_MM / STEP_MM).round() as usize;
        for k in 1..=n {
            p.push([start - FEED_IN_MM * k as f64 / n as f64, 0.0]);
        }
    }
    let arc = sign * (360.0 + OVERSHOOT_DEG).to_radians();
    let n = (arc.abs() * R_MM / STEP_MM).ceil() as usize;
    for k in 1..=n {
        let t = arc * k as f64 / n as f64;
        p.push([R_MM * t.cos(), R_MM * t.sin()]);
    }
    let (c, s) = (arc.cos(), arc.sin());
    let m = (FEED_IN_MM / STEP_MM).round() as usize;
    for k in 1..=m {
        let r = R_MM + FEED_IN_MM * k as f64 / m as f64;
        p.push([r * c, r * s]);
    }
    for _ in 0..REST {
        p.push([(R_MM + FEED_IN_MM) * c, (R_MM + FEED_IN_MM) * s]);
    }
    p
}

/// The first and last sample of the data arc by the documented rule, from the nominal path of
/// a CCW run: (start, end) indices, end included; `arc_deg` None = until the feed-out.
fn data_arc(p: &[[f64; 2]], arc_deg: Option<f64>) -> Option<(usize, usize)> {
    data_arc_in(p, arc_deg, 1.0)
}

/// [`data_arc`] of a run turning in `sign`.
fn data_arc_in(p: &[[f64; 2]], arc_deg: Option<f64>, sign: f64) -> Option<(usize, usize)> {
    let r = |q: &[f64; 2]| q[0].hypot(q[1]);
    let split = |k: usize| {
        let (a, b) = (p[k - 1], p[k]);
        let u = [b[0] / r(&b), b[1] / r(&b)];
        let d = [b[0] - a[0], b[1] - a[1]];
        // along (in the run's direction), across
        (
            sign * (u[0] * d[1] - u[1] * d[0]),
            (u[0] * d[0] + u[1] * d[1]).abs(),
        )
    };
    let fed_in = p.iter().position(|q| r(q) - R_MM >= 0.05)?;
    let start = (fed_in.max(1)..p.len()).find(|&k| {
        let (along, across) = split(k);
        (r(&p[k]) - R_MM).abs() <= 0.01 && along > across
    })?;
    let mut swept = 0.0;
    for k in start + 1..p.len() {
        let (along, across) = split(k);
        if (r(&p[k]) - R_MM).abs() > 0.01 && across > along.abs() {
            return Some((start, k - 1));
        }
        swept += along / r(&p[k]);
        if arc_deg.is_some_and(|a| swept >= a.to_radians()) {
            return Some((start, k));
        }
    }
    None
}

/// A pod homed at the path's first point, set up for the circle (R 100 about the origin, XY).
fn pod(trigger: RunTrigger, arc_deg: Option<f64>, first: [f64; 2]) -> VirtualPod {
    let mut pod = VirtualPod::new(VirtualSetup::default());
    pod.app
        .configure(|c| {
            let s = &mut c.setup;
            s.circle_centre_mm = [0.0, 0.0, 0.0];
            s.circle_radius_mm = R_MM as f32;
            s.circle_feed_mm_per_min = 1000.0;
            s.run_trigger = trigger;
            s.circle_arc_deg = arc_deg.map_or(f32::NAN, |a| a as f32);
        })
        .expect("set-up");
    pod.home(&axes(first));
    pod
}

fn axes(p: [f64; 2]) -> [f64; MAX_AXES] {
    [p[0], p[1], 0.0, 0.0, 0.0]
}

/// The bar's reading at the nominal point `p`: the ball is `E_UM` off it, µm.
fn dl_um(p: [f64; 2]) -> f64 {
    let q = [p[0] + E_UM[0] * 1e-3, p[1] + E_UM[1] * 1e-3];
    (q[0].hypot(q[1]) - R_MM) * 1e3
}

/// Drives the path: `before(k)` is called before sample k (a client's commands).
fn drive(pod: &mut VirtualPod, p: &[[f64; 2]], mut before: impl FnMut(&mut VirtualPod, usize)) {
    for (k, q) in p.iter().enumerate() {
        before(pod, k);
        pod.sample_at(dl_um(*q), &axes(*q));
    }
}

/// The recorded run's sample count and its samples' first and last X, Y.
fn recorded(pod: &VirtualPod) -> (usize, [f32; 2], [f32; 2]) {
    let run = pod.recording.runs.last().expect("a run was recorded");
    let samples: Vec<_> = run.samples().collect();
    let (a, b) = (samples[0], samples[samples.len() - 1]);
    (
        samples.len(),
        [a.axes[0], a.axes[1]],
        [b.axes[0], b.axes[1]],
    )
}

#[test]
fn a_self_triggered_run_measures_the_data_arc_as_a_commanded_run_does() {
    let p = path(true);
    for arc in [Some(360.0), None] {
        let (start, end) = data_arc(&p, arc).expect("the rule finds the data arc");
        // the rest, the feed-in's 60 samples (the last one at (R, 0)): the arc's first
        // sample is the start
        assert_eq!(start, REST + 60, "{arc:?}");
        let mut auto = pod(RunTrigger::FeedIn, arc, p[0]);
        auto.execute(Command::Arm).expect("arm");
        // the state before sample k is what the samples before it decided: the start is taken
        // at sample `start`, the stop as sample `end + 1` arrives, before it is used
        drive(&mut auto, &p, |pod, k| {
            let want = if k <= start {
                SessionState::Armed
            } else if k <= end + 1 {
                SessionState::Running
            } else {
                SessionState::Done
            };
            assert_eq!(pod.app.session(), want, "before sample {k} ({arc:?})");
        });
        assert_eq!(auto.app.session(), SessionState::Done);
        let (n, first, last) = recorded(&auto);
        assert_eq!(n, end - start + 1, "{arc:?}");
        for (got, want) in [(first, p[start]), (last, p[end])] {
            assert!(
                (f64::from(got[0]) - want[0]).abs() < 1e-3,
                "{got:?} {want:?}"
            );
            assert!(
                (f64::from(got[1]) - want[1]).abs() < 1e-3,
                "{got:?} {want:?}"
            );
        }
        // the same samples, started and stopped by a client
        let mut by_hand = pod(RunTrigger::Command, arc, p[0]);
        by_hand.execute(Command::Arm).expect("arm");
        drive(&mut by_hand, &p, |pod, k| {
            if k == start {
                pod.execute(Command::Start).expect("start");
            }
            if k == end + 1 {
                pod.execute(Command::Stop).expect("stop");
            }
        });
        assert_eq!(recorded(&by_hand).0, n);
        let bits = |pod: &VirtualPod| -> Vec<(u32, u32, bool)> {
            ResultId::ALL
                .iter()
                .map(|&id| {
                    let e = pod.app.results().get(id);
                    (e.value.to_bits(), e.std_uncertainty.to_bits(), e.valid)
                })
                .collect()
        };
        assert_eq!(bits(&auto), bits(&by_hand), "{arc:?}");
        // and the machine's eccentricity comes back (e = ball − commanded)
        let r = auto.app.results();
        for (id, want) in [(ResultId::EccU, E_UM[0]), (ResultId::EccV, E_UM[1])] {
            let e = r.get(id);
            assert!(e.valid, "{id:?}");
            assert!(
                (f64::from(e.value) - want).abs() < 0.05,
                "{id:?} {} vs {want}",
                e.value
            );
        }
        let span = f64::from(r.get(ResultId::Arc).value);
        match arc {
            Some(a) => assert!((a..a + 0.05).contains(&span), "{span}"),
            None => assert!(
                (404.9..405.1).contains(&span),
                "{span}: the overshoot, not the feed-out"
            ),
        }
    }
}

/// A client's START and STOP still work in FEED_IN mode: started by hand on the circle
/// without a feed-in, the run stops itself at the data arc's end.
#[test]
fn a_client_may_start_a_feed_in_run_and_it_still_stops_itself() {
    let p = path(false);
    let mut pod = pod(RunTrigger::FeedIn, Some(330.0), p[0]);
    pod.execute(Command::Arm).expect("arm");
    drive(&mut pod, &p, |pod, k| {
        if k == REST + 1 {
            pod.execute(Command::Start).expect("start");
        }
    });
    assert_eq!(pod.app.session(), SessionState::Done);
    let span = f64::from(pod.app.results().get(ResultId::Arc).value);
    assert!((330.0..330.05).contains(&span), "{span}");
}

/// SDO upload of a visible string (expedited or segmented, CiA 301 §7.2.4.3).
fn sdo_text(pod: &mut VirtualPod, index: u16) -> String {
    let node = u16::from(pod.app.config().can_node_id);
    let (rx, tx) = (0x600 + node, 0x580 + node);
    let mut ask = |data: [u8; 8]| -> [u8; 8] {
        let out: Vec<CanFrame> = pod
            .can_frame(&CanFrame::new(rx, &data).unwrap())
            .into_iter()
            .filter(|f| f.id == tx)
            .collect();
        assert_eq!(out.len(), 1);
        out[0].data[..8].try_into().unwrap()
    };
    let i = index.to_le_bytes();
    let r = ask([0x40, i[0], i[1], 0, 0, 0, 0, 0]);
    assert_eq!(r[0] & 0xE0, 0x40, "upload response {r:?}");
    if r[0] & 0x02 != 0 {
        let n = if r[0] & 0x01 != 0 {
            4 - usize::from((r[0] >> 2) & 3)
        } else {
            4
        };
        return String::from_utf8(r[4..4 + n].to_vec()).unwrap();
    }
    let size = u32::from_le_bytes(r[4..8].try_into().unwrap()) as usize;
    let mut bytes = Vec::new();
    let mut toggle = 0u8;
    loop {
        let s = ask([0x60 | toggle << 4, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(s[0] & 0x10, toggle << 4, "toggle");
        let unused = usize::from((s[0] >> 1) & 7);
        bytes.extend_from_slice(&s[1..8 - unused]);
        if s[0] & 1 != 0 {
            break;
        }
        toggle ^= 1;
    }
    assert_eq!(bytes.len(), size);
    String::from_utf8(bytes).unwrap()
}

/// The program's feed-in missing (the tool starts on the circle): the run never starts, the
/// pod stays armed and both protocols say why; once the tool has been outside the circle the
/// note moves on to the data arc.
#[test]
fn without_a_feed_in_the_run_never_starts_and_the_pod_says_why() {
    let p = path(false);
    assert_eq!(data_arc(&p, Some(360.0)), None, "the rule starts nothing");
    let mut pod = pod(RunTrigger::FeedIn, Some(360.0), p[0]);
    let scpi = |pod: &mut VirtualPod, line: &str| {
        String::from_utf8(pod.usb(format!("{line}\n").as_bytes())).unwrap()
    };
    assert_eq!(scpi(&mut pod, "SESS:ARM;*OPC?").trim(), "1");
    // the rest on the circle, the data arc and the overshoot (the feed-out would go outside)
    let on_circle = p.len() - REST - (FEED_IN_MM / STEP_MM).round() as usize;
    drive(&mut pod, &p[..on_circle], |_, _| {});
    assert_eq!(pod.app.session(), SessionState::Armed);
    assert!(
        pod.recording
            .runs
            .iter()
            .all(|r| r.samples().next().is_none())
    );
    let why = "FEED_IN: waiting for the feed-in";
    assert_eq!(sdo_text(&mut pod, 0x3007), why);
    assert_eq!(scpi(&mut pod, "SESS:NOTE?").trim(), format!("\"{why}\""));
    // the tool goes out beyond the feed-in distance: fed in, waiting for the data arc
    let out = [R_MM + 0.2, 0.0];
    pod.sample_at(dl_um(out), &axes(out));
    assert_eq!(
        sdo_text(&mut pod, 0x3007),
        "FEED_IN: fed in, waiting for the data arc"
    );
    // an abort ends the wait
    pod.execute(Command::Abort).expect("abort");
    assert_eq!(pod.app.session(), SessionState::Aborted);
}

/// A CW run triggers the same way, turning the other way; the CW direction armed on a CCW
/// program never starts (the note says it was fed in and waits for the data arc).
#[test]
fn a_cw_run_starts_and_stops_itself_and_the_wrong_direction_waits() {
    use ballpod::app::Direction;
    let p = path_in(true, -1.0);
    let (start, end) = data_arc_in(&p, Some(360.0), -1.0).expect("the rule finds the data arc");
    assert_eq!(start, REST + 60);
    let mut cw = pod(RunTrigger::FeedIn, Some(360.0), p[0]);
    cw.app.set_direction(Direction::Cw).unwrap();
    cw.execute(Command::Arm).expect("arm");
    drive(&mut cw, &p, |_, _| {});
    assert_eq!(cw.app.session(), SessionState::Done);
    assert_eq!(recorded(&cw).0, end - start + 1);
    let span = f64::from(cw.app.results().get(ResultId::Arc).value);
    assert!((360.0..360.05).contains(&span), "{span}");
    // armed CW, the program runs CCW: fed in, never started
    let ccw = path(true);
    let mut wrong = pod(RunTrigger::FeedIn, Some(360.0), ccw[0]);
    wrong.app.set_direction(Direction::Cw).unwrap();
    wrong.execute(Command::Arm).expect("arm");
    let on_circle = ccw.len() - REST - (FEED_IN_MM / STEP_MM).round() as usize;
    drive(&mut wrong, &ccw[..on_circle], |_, _| {});
    assert_eq!(wrong.app.session(), SessionState::Armed);
    let note = wrong.app.procedure_note().expect("a note").text();
    assert_eq!(note, ("FEED_IN: fed in, waiting for the data arc", ""));
}
