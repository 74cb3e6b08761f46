//! Touch-trigger probe: latch bookkeeping, debounce and re-seat lock-out.
//!
//! The firmware latches every encoder count and a time stamp in the EXTI interrupt at the
//! trigger edge and hands them here. A trigger is accepted only when the probe is armed; after
//! it the probe is locked out until it has read "seated" continuously for the re-seat time, so
//! contact bounce (edges within the debounce time) and a second touch without re-seating are
//! counted, never taken as new points.

use super::sample::MAX_AXES;

/// A latched probe trigger: the touch point's axis counts and time.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct ProbeLatch {
    /// Extended encoder counts of every axis at the edge.
    pub counts: [i64; MAX_AXES],
    /// Time of the edge, µs since boot.
    pub t_us: u64,
}

/// Probe state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProbeState {
    /// Ready: the next trigger edge is a touch point.
    Armed,
    /// Triggered at the given time; waiting for the stylus to re-seat.
    LockedOut {
        /// Time of the accepted trigger, µs.
        since_us: u64,
        /// Start of the current continuously-seated stretch, µs (None while deflected).
        seated_since_us: Option<u64>,
    },
}

/// What became of a trigger edge.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TriggerOutcome {
    /// A touch point: the latch is valid.
    Accepted(ProbeLatch),
    /// An edge within the debounce time of the accepted trigger (contact bounce).
    Bounce,
    /// An edge after the debounce time but before re-seat (a missed re-seat: the stylus never
    /// came back, or came back too briefly). The point is rejected.
    NotReseated,
}

/// Debounce and lock-out of the touch-trigger probe, with counters for every rejected edge.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ProbeDebouncer {
    debounce_us: u64,
    reseat_us: u64,
    state: ProbeState,
    /// Touch points accepted.
    pub accepted: u32,
    /// Edges rejected as contact bounce.
    pub bounces: u32,
    /// Edges rejected because the probe had not re-seated.
    pub not_reseated: u32,
}

impl ProbeDebouncer {
    /// The same debouncer (state and counters) with new times.
    pub const fn with_times(mut self, debounce_us: u64, reseat_us: u64) -> Self {
        self.debounce_us = debounce_us;
        self.reseat_us = reseat_us;
        self
    }

    /// A debouncer, armed. `debounce_us`: bounce window after a trigger; `reseat_us`: how long
    /// the stylus must read seated before the next trigger counts.
    pub const fn new(debounce_us: u64, reseat_us: u64) -> Self {
        Self {
            debounce_us,
            reseat_us,
            state: ProbeState::Armed,
            accepted: 0,
            bounces: 0,
            not_reseated: 0,
        }
    }

    /// Current state.
    pub const fn state(&self) -> ProbeState {
        self.state
    }

    /// A trigger edge with its latch.
    pub fn trigger(&mut self, latch: ProbeLatch) -> TriggerOutcome {
        match self.state {
            ProbeState::Armed => {
                self.state = ProbeState::LockedOut {
                    since_us: latch.t_us,
                    seated_since_us: None,
                };
                self.accepted = self.accepted.saturating_add(1);
                TriggerOutcome::Accepted(latch)
            }
            ProbeState::LockedOut { since_us, .. } => {
                if latch.t_us.saturating_sub(since_us) < self.debounce_us {
                    self.bounces = self.bounces.saturating_add(1);
                    TriggerOutcome::Bounce
                } else {
                    self.not_reseated = self.not_reseated.saturating_add(1);
                    // the stylus is deflected again: the seated stretch restarts
                    self.state = ProbeState::LockedOut {
                        since_us,
                        seated_since_us: None,
                    };
                    TriggerOutcome::NotReseated
                }
            }
        }
    }

    /// Periodic poll of the probe input level (`seated` = stylus at rest). Re-arms after the
    /// stylus has been seated continuously for the re-seat time (measured from the first poll
    /// that saw it seated after the debounce window).
    pub fn poll(&mut self, t_us: u64, seated: bool) {
        if let ProbeState::LockedOut {
            since_us,
            seated_since_us,
        } = self.state
        {
            let in_debounce = t_us.saturating_sub(since_us) < self.debounce_us;
            let seated_since_us = match (seated && !in_debounce, seated_since_us) {
                (false, _) => None,
                (true, None) => Some(t_us),
                (true, Some(s)) => Some(s),
            };
            self.state = match seated_since_us {
                Some(s) if t_us.saturating_sub(s) >= self.reseat_us => ProbeState::Armed,
                _ => ProbeState::LockedOut {
                    since_us,
                    seated_since_us,
                },
            };
        }
    }
}
