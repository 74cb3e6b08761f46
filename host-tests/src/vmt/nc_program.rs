//! A part program as LinuxCNC's task runs it, for the served CNC (`sim --serve --program`):
//! its moves in order at their feeds, and at each user M-code (M100–M199) the M-code's program
//! run in step — the moves before it done, the moves after it waiting until it exits — as
//! LinuxCNC's task does with the executables in `[RS274NGC] USER_M_PATH`.
//!
//! **The interpreter.** The path is LinuxCNC's own interpreter's (`rs274 -g`, [`super::nc_motion`]).
//! The standalone `rs274` does not run user M-codes (task does: it stops at "Unknown m code
//! used"), so each block that is a user M-code alone (`M151`, `M150 P1000`, with optional P
//! and Q words) is handed to it as a message (`(MSG,BALLPOD_USER_M 150 1000 0)`), which the
//! interpreter orders among the moves like the M-code; a user M-code sharing a block with other
//! words is refused (LinuxCNC would run it before the block's motion).
//!
//! **Time.** Feed moves as [`super::nc_motion`] samples them; rapids at [`RAPID_MM_PER_MIN`].
//! The machine starts where the program's rapids before its first feed move leave it (the bar
//! is mounted there).

use super::nc_motion::{Axes6, CanonStep, Move, canon_steps, interpret};

/// The marker of a user M-code in the message text.
const USER_M_MARKER: &str = "BALLPOD_USER_M";
/// The speed of a rapid (`G0`), mm/min (the served machine's; acceleration not modelled).
pub const RAPID_MM_PER_MIN: f64 = 5000.0;

/// The program with each user M-code block as a message that names it (module doc), or the
/// first block where a user M-code shares a block with other words.
pub fn mark_user_m_codes(program: &str) -> Result<String, String> {
    let mut out = String::with_capacity(program.len());
    for (k, line) in program.lines().enumerate() {
        let words: Vec<&str> = line.split_whitespace().collect();
        let user_m = |w: &&str| {
            w.strip_prefix(['M', 'm'])
                .and_then(|n| n.parse::<u16>().ok())
                .filter(|n| (100..=199).contains(n))
        };
        match words.iter().position(|w| user_m(w).is_some()) {
            None => out.push_str(line),
            Some(i) => {
                let code = words.get(i).and_then(user_m).unwrap_or(0);
                let mut pq = [0.0f64; 2];
                for (j, w) in words.iter().enumerate() {
                    if j == i {
                        continue;
                    }
                    let slot = match w.chars().next() {
                        Some('P' | 'p') => 0,
                        Some('Q' | 'q') => 1,
                        _ => {
                            return Err(format!(
                                "line {}: {line}: a user M-code must be alone in its block (with P and Q)",
                                k + 1
                            ));
                        }
                    };
                    pq[slot] = w[1..]
                        .parse()
                        .map_err(|_| format!("line {}: {line}: {w} is not a number", k + 1))?;
                }
                out.push_str(&format!("(MSG,{USER_M_MARKER} {code} {} {})", pq[0], pq[1]));
            }
        }
        out.push('\n');
    }
    Ok(out)
}

/// One step of the program as the task runs it.
#[derive(Clone, Debug, PartialEq)]
enum Event {
    /// A move (a rapid is a straight move at the rapid speed).
    Move(Move),
    /// A user M-code and its P and Q.
    UserM { code: u16, p: f64, q: f64 },
}

/// What the served machine does this sample period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CncStep {
    /// The machine is at `axes` (X, Y, Z mm; B, C degrees), moving in `sense` (+1 CCW, −1 CW,
    /// 0 straight) in its arc's plane.
    At {
        /// Axis positions.
        axes: [f64; 5],
        /// The sense of rotation of the current move.
        sense: f64,
    },
    /// The task runs user M-code `code` with `p` and `q` now; call [`ProgramCnc::resume`]
    /// once it has exited.
    UserM {
        /// The M-code (100–199).
        code: u16,
        /// Its P word (0 if none).
        p: f64,
        /// Its Q word (0 if none).
        q: f64,
    },
    /// The program has ended.
    Done,
}

/// A program being run.
#[derive(Clone, Debug)]
pub struct ProgramCnc {
    events: Vec<Event>,
    next: usize,
    /// Time into the current move, s.
    t_s: f64,
    /// Where the machine is.
    at: Axes6,
    /// A user M-code reported and not yet resumed.
    waiting: bool,
}

impl ProgramCnc {
    /// The program in `path` through LinuxCNC's interpreter (module doc), the machine where its
    /// first rapids leave it (`from` `None`: the bar is mounted there), or at `from` (X, Y, Z
    /// mm; B, C degrees: where the previous program left it), from where its rapids move it.
    pub fn load(path: &std::path::Path, from: Option<[f64; 5]>) -> Result<Self, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let marked = mark_user_m_codes(&text)?;
        let tmp = std::env::temp_dir().join(format!(
            "ballpod-program-{}-{}.ngc",
            std::process::id(),
            path.file_stem().map_or("p".into(), |s| s.to_string_lossy())
        ));
        std::fs::write(&tmp, marked).map_err(|e| format!("{}: {e}", tmp.display()))?;
        let canon = interpret(&tmp);
        let _ = std::fs::remove_file(&tmp);
        Self::from_canon(&canon?, from)
    }

    /// The program of the canonical commands `canon` (`rs274 -g` output of a marked program),
    /// the machine at `from` or where the first rapids leave it ([`load`](Self::load)).
    pub fn from_canon(canon: &str, from: Option<[f64; 5]>) -> Result<Self, String> {
        let mut events = Vec::new();
        let from6 = from.map(|[x, y, z, b, c]| [x, y, z, 0.0, b, c]);
        let mut start: Option<Axes6> = from6;
        let mut at = from6.unwrap_or([0.0; 6]);
        for step in canon_steps(canon)? {
            match step {
                CanonStep::Traverse { to, .. } => {
                    // (from where the machine is: the interpreter starts at its origin)
                    if start.is_some() {
                        events.push(Event::Move(Move::Line {
                            from: at,
                            to,
                            feed: RAPID_MM_PER_MIN,
                        }));
                    }
                    at = to;
                }
                CanonStep::Feed(m) => {
                    start.get_or_insert(at);
                    at = m.end();
                    events.push(Event::Move(m));
                }
                CanonStep::Message(text) => {
                    if let Some(rest) = text.strip_prefix(USER_M_MARKER) {
                        let v: Vec<f64> = rest
                            .split_whitespace()
                            .map(|x| x.parse().map_err(|_| format!("marker {text:?}")))
                            .collect::<Result<_, _>>()?;
                        let [code, p, q] = v[..] else {
                            return Err(format!("marker {text:?}"));
                        };
                        events.push(Event::UserM {
                            code: code as u16,
                            p,
                            q,
                        });
                    }
                }
                CanonStep::Comment(_) => {}
            }
        }
        // without `from`, the rapids before the first feed move are not run: the machine starts
        // where they end
        let at = start.unwrap_or(at);
        Ok(Self {
            events,
            next: 0,
            t_s: 0.0,
            at,
            waiting: false,
        })
    }

    /// Where the machine starts (X, Y, Z mm; B, C degrees).
    pub fn start(&self) -> [f64; 5] {
        five(&self.at)
    }

    /// The next sample period `dt_s` on: the machine's position, a user M-code to run (the
    /// machine stands still until [`resume`](Self::resume)), or the end.
    pub fn step(&mut self, dt_s: f64) -> CncStep {
        if self.waiting {
            return CncStep::At {
                axes: five(&self.at),
                sense: 0.0,
            };
        }
        let mut dt = dt_s;
        loop {
            match self.events.get(self.next) {
                None => return CncStep::Done,
                Some(Event::UserM { code, p, q }) => {
                    self.waiting = true;
                    return CncStep::UserM {
                        code: *code,
                        p: *p,
                        q: *q,
                    };
                }
                Some(Event::Move(m)) => {
                    let dur = m.seconds();
                    if self.t_s + dt <= dur && dur > 0.0 {
                        self.t_s += dt;
                        self.at = m.at(self.t_s / dur);
                        return CncStep::At {
                            axes: five(&self.at),
                            sense: m.sense(),
                        };
                    }
                    // the rest of this period goes into the next move; before an M-code or
                    // the program's end the machine is at this move's end first
                    dt -= (dur - self.t_s).max(0.0);
                    let sense = m.sense();
                    self.at = m.end();
                    self.t_s = 0.0;
                    self.next += 1;
                    if !matches!(self.events.get(self.next), Some(Event::Move(_))) {
                        return CncStep::At {
                            axes: five(&self.at),
                            sense,
                        };
                    }
                }
            }
        }
    }

    /// The user M-code's program exited: the program goes on.
    pub fn resume(&mut self) {
        if self.waiting {
            self.waiting = false;
            self.next += 1;
        }
    }
}

/// The pod's five inputs of a canonical position (A is not one of them).
fn five(p: &Axes6) -> [f64; 5] {
    [p[0], p[1], p[2], p[4], p[5]]
}
