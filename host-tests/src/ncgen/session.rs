//! The pod's session in the part program: M-codes at the points where the CNC drives the pod,
//! so that the program runs a test with no other client.
//!
//! One table ([`STEPS`]) declares each step: its M-code (from a base, default M150: LinuxCNC's
//! user M-codes are M100–M199), what the LinuxCNC script does and the hand-shake a PLC
//! implements on the other controls (the CANopen writes, then the state it waits for). The
//! program writer ([`super::CircleRun::program_with`]) places them; `ncgen m-codes DIR` writes
//! the LinuxCNC scripts ([`scripts`]) and the set-up a program's `M150 P<n>` applies is the file
//! [`setup_file`] writes (`ballpod-setup-<n>.toml`: the program's `[session]` pattern and
//! `[setup]` fields, as the set-up files the generators read).
//!
//! Why M-codes and not the comments: a PLC sees M-codes (strobe, code), never comments; and
//! LinuxCNC runs a user M-code's program in step with the motion (the moves before it are done,
//! the moves after it wait until it exits), which is when the pod must be armed, started or
//! stopped.

use std::fmt::Write as _;

use ballpod::config::RunTrigger;

/// A step of the session a program drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SessionStep {
    /// Apply set-up `P` (pattern and configuration fields; in pre-operational over CANopen).
    SetUp,
    /// Arm a CCW run of the set-up's pattern.
    ArmCcw,
    /// Arm a CW run.
    ArmCw,
    /// Start the armed run (commanded runs).
    Start,
    /// Stop the running run (commanded runs): its results follow.
    Stop,
    /// Wait until the run is over and its results are published (RESULTS_READY).
    Results,
}

/// What a step is, for the program, the script and the PLC.
#[derive(Clone, Copy, Debug)]
pub struct StepInfo {
    /// The step.
    pub step: SessionStep,
    /// Its M-code, from the base.
    pub offset: u16,
    /// The script's action (its first argument).
    pub action: &'static str,
    /// What it does.
    pub what: &'static str,
    /// The CANopen writes a PLC makes (objects by their EDS names).
    pub writes: &'static str,
    /// What the PLC then waits for before it acknowledges the M-code.
    pub waits_for: &'static str,
}

/// Every step, in M-code order (declared once: the programs, the scripts, the book's table).
pub const STEPS: [StepInfo; 6] = [
    StepInfo {
        step: SessionStep::SetUp,
        offset: 0,
        action: "setup",
        what: "apply set-up P: the pattern and the configuration fields the run needs",
        writes: "NMT enter pre-operational; each `[setup]` field of ballpod-setup-P.toml by name; pattern",
        waits_for: "every SDO write acknowledged (an abort: the field and 0x3006 last_refusal)",
    },
    StepInfo {
        step: SessionStep::ArmCcw,
        offset: 1,
        action: "arm-ccw",
        what: "arm a CCW run",
        writes: "direction = 0; session_command = 1",
        waits_for: "session_state = 1 (ARMED)",
    },
    StepInfo {
        step: SessionStep::ArmCw,
        offset: 2,
        action: "arm-cw",
        what: "arm a CW run",
        writes: "direction = 1; session_command = 1",
        waits_for: "session_state = 1 (ARMED)",
    },
    StepInfo {
        step: SessionStep::Start,
        offset: 3,
        action: "start",
        what: "start the armed run (run_trigger COMMAND)",
        writes: "session_command = 2",
        waits_for: "session_state = 2 (RUNNING)",
    },
    StepInfo {
        step: SessionStep::Stop,
        offset: 4,
        action: "stop",
        what: "stop the run (run_trigger COMMAND)",
        writes: "session_command = 3",
        waits_for: "session_state = 3 (DONE; 4 ABORTED is a fault: abort_reason says why)",
    },
    StepInfo {
        step: SessionStep::Results,
        offset: 5,
        action: "results",
        what: "wait until the run is over and its results are published",
        writes: "—",
        waits_for: "session_state = 3 (DONE) and status_word bit 10 RESULTS_READY",
    },
];

/// The default first M-code (LinuxCNC's user M-codes are M100–M199).
pub const DEFAULT_M_BASE: u16 = 150;

/// How a program drives the pod.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Session {
    /// The first M-code ([`STEPS`] follow it).
    pub m_base: u16,
    /// The set-up's number (`M150 P<n>` applies `ballpod-setup-<n>.toml`).
    pub setup_number: u32,
    /// Who starts and stops the runs: the program's M-codes (COMMAND) or the pod at the
    /// feed-in and the data arc's end (FEED_IN).
    pub trigger: RunTrigger,
}

impl Session {
    /// A session from M-code `m_base` (100 … 194: the six codes stay within LinuxCNC's user
    /// M-codes).
    pub fn new(m_base: u16, setup_number: u32, trigger: RunTrigger) -> Result<Self, String> {
        let last = m_base + STEPS.len() as u16 - 1;
        if !(100..=199).contains(&m_base) || last > 199 {
            return Err(format!(
                "--m-base {m_base}: the six M-codes M{m_base}…M{last} must lie in M100–M199"
            ));
        }
        Ok(Self {
            m_base,
            setup_number,
            trigger,
        })
    }

    /// The M-code word of `step`.
    pub fn m(&self, step: SessionStep) -> u16 {
        let offset = STEPS
            .iter()
            .find(|s| s.step == step)
            .map_or(0, |s| s.offset);
        self.m_base + offset
    }

    /// The block of `step` (`M151`, `M150 P1000`).
    pub fn block(&self, step: SessionStep) -> String {
        match step {
            SessionStep::SetUp => format!("M{} P{}", self.m(step), self.setup_number),
            _ => format!("M{}", self.m(step)),
        }
    }

    /// True when the program starts and stops the runs itself.
    pub fn commanded(&self) -> bool {
        self.trigger == RunTrigger::Command
    }
}

/// A configuration field the run needs and its value, in the field's unit (a choice: its code).
pub type SetupField = (&'static str, f64);

/// The set-up file a program's `M150 P<n>` applies: `[session]` pattern, `[setup]` fields
/// (TOML; the set-up files the generators and `replay` read take it too).
pub fn setup_file(pattern: &str, fields: &[SetupField], comment: &str) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "# {comment}");
    let _ = writeln!(out, "[session]\npattern = \"{pattern}\"\n\n[setup]");
    for (name, value) in fields {
        // the configuration holds f32: its shortest decimal is the value the pod takes
        let _ = writeln!(out, "{name} = {}", *value as f32);
    }
    out
}

/// The scripts LinuxCNC runs for the M-codes (`DIR/M150` … and the python module they call):
/// (file name, text, executable).
pub fn scripts(session_m_base: u16) -> Vec<(String, String, bool)> {
    let mut out = vec![(
        "ballpod_session.py".to_string(),
        include_str!("ballpod_session.py").to_string(),
        false,
    )];
    for s in STEPS {
        let text = format!(
            "#!/bin/sh\n# LinuxCNC user M-code M{m}: {what} (ballpod; `ncgen m-codes`).\n\
             # LinuxCNC passes P and Q as two numbers.\n\
             exec python3 \"$(dirname \"$0\")/ballpod_session.py\" {action} \"$@\"\n",
            m = session_m_base + s.offset,
            what = s.what,
            action = s.action,
        );
        out.push((format!("M{}", session_m_base + s.offset), text, true));
    }
    out
}
