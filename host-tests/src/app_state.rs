//! One text of everything the pod application shows, for tests that compare two pods or a pod
//! before and after a refused request.

use ballpod::app::App;

/// Everything `app` shows — configuration, session, pattern, direction, abort reason, run
/// number, results, live values, run counters, touch points — but the text of its last refusal
/// (a refused request must leave the rest equal). Floats print in Rust's shortest exact form,
/// so equal texts mean bit-equal values (NaN aside, which prints as `NaN`).
pub fn snapshot(app: &App) -> String {
    format!(
        "config {:?}\nsession {:?} pattern {:?} direction {:?} abort {:?} run {}\n\
         results {:?}\nlive {:?}\ncounters {:?}\ntouches {:?}",
        app.config(),
        app.session(),
        app.pattern(),
        app.direction(),
        app.abort_reason(),
        app.run_number(),
        app.results(),
        app.live(),
        app.run_counters(),
        app.touch_points()
    )
}
