//! The run monitor: every sample of a running session passes through it before metrology. It
//! decides whether the sample is used or skipped, keeps the run's accounting
//! ([`RunCounters`]: nothing is lost without being counted) and aborts the run on a fault the
//! fits cannot survive:
//!
//! - **ball bar dropped from the socket**: ΔL jumps by more than [`RunLimits::max_step_um`]
//!   between two consecutive valid samples, or the LVDT stays open / over-range for
//!   [`RunLimits::max_lvdt_fault_samples`] samples in a row → [`AbortReason::LvdtFault`];
//! - **samples lost** (queue overruns upstream) beyond [`RunLimits::lost_allowed`] →
//!   [`AbortReason::Overrun`];
//! - **stopped with too few valid samples** ([`RunLimits::min_used_samples`]) →
//!   [`AbortReason::NotObservable`].
//!
//! Invariants (tested): `seen = used + skipped()`, and the samples the sensors produced during
//! the run are `seen + lost`. Lost samples are counted from the gaps in the sample counter
//! ([`Sample::seq`] counts every sample the pod produced, lost ones included), from the run's
//! first sample on.

use crate::acquisition::{Sample, SampleFlags};

/// Why a run was aborted (CANopen 0x3004 code = the discriminant).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum AbortReason {
    /// Aborted by the CNC or the technician.
    ByCommand = 1,
    /// The LVDT went open or over-range, or ΔL jumped (bar dropped from the socket).
    LvdtFault = 2,
    /// Samples were lost (overrun).
    Overrun = 3,
    /// Too few valid samples, too short an arc, or a degenerate geometry for the pattern: the
    /// run has no results.
    NotObservable = 4,
}

impl AbortReason {
    /// The name (SCPI `SESSion:REASon?`, log metadata): `COMMAND`, `LVDT`, `OVERRUN`,
    /// `UNOBSERVABLE`.
    pub const fn name(self) -> &'static str {
        match self {
            AbortReason::ByCommand => "COMMAND",
            AbortReason::LvdtFault => "LVDT",
            AbortReason::Overrun => "OVERRUN",
            AbortReason::NotObservable => "UNOBSERVABLE",
        }
    }

    /// The reason of a code (1…4).
    pub const fn from_u8(v: u8) -> Option<Self> {
        Some(match v {
            1 => AbortReason::ByCommand,
            2 => AbortReason::LvdtFault,
            3 => AbortReason::Overrun,
            4 => AbortReason::NotObservable,
            _ => return None,
        })
    }

    /// The reason of a name (any letter case).
    pub fn from_name(name: &[u8]) -> Option<Self> {
        [
            AbortReason::ByCommand,
            AbortReason::LvdtFault,
            AbortReason::Overrun,
            AbortReason::NotObservable,
        ]
        .into_iter()
        .find(|r| r.name().as_bytes().eq_ignore_ascii_case(name))
    }
}

/// Limits of the run monitor (defaults: [`RunLimits::DEFAULT`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunLimits {
    /// Largest ΔL change between consecutive valid samples, µm, before the run is taken for a
    /// ball dropped from its socket. Default 100 µm: a ball-bar test sees the machine's errors
    /// (tens of µm), which change along the path by a few µm per 1 ms sample even at a
    /// reversal step; a ball leaving its magnetic cup moves by a fraction of a millimetre at
    /// once. 100 µm is well above the first and well below the LVDT stroke (±1.1 mm with the
    /// default calibration).
    pub max_step_um: f32,
    /// Consecutive LVDT open / over-range samples that abort the run. Default 100 (0.1 s at
    /// 1 kHz): a spike or a short electrical disturbance is skipped and counted, a bar that
    /// has left its socket stays open or at its end stop.
    pub max_lvdt_fault_samples: u32,
    /// Lost samples always tolerated. Default 10.
    pub max_lost_samples: u32,
    /// Lost samples tolerated per 1000 samples produced (seen + lost). Default 10 (1 %): a
    /// lost sample only leaves a 1 ms gap in the angle coverage, but a steady loss means the
    /// compute path cannot keep up and the run is not trustworthy.
    pub max_lost_per_mille: u32,
    /// Fewest used (valid) samples for a run to have results. Default 100.
    pub min_used_samples: u32,
}

impl RunLimits {
    /// The documented defaults (field docs).
    pub const DEFAULT: Self = Self {
        max_step_um: 100.0,
        max_lvdt_fault_samples: 100,
        max_lost_samples: 10,
        max_lost_per_mille: 10,
        min_used_samples: 100,
    };

    /// Lost samples allowed after `produced` samples (seen + lost):
    /// max(`max_lost_samples`, `produced` · `max_lost_per_mille` / 1000).
    pub const fn lost_allowed(&self, produced: u32) -> u32 {
        // [`Self::too_many_lost`] decides the same without the division
        let share = (produced as u64 * self.max_lost_per_mille as u64 / 1000) as u32;
        if share > self.max_lost_samples {
            share
        } else {
            self.max_lost_samples
        }
    }

    /// `lost` > [`Self::lost_allowed`]`(produced)`, decided without a 64-bit division (per
    /// sample): ⌊x/1000⌋ < L ⇔ x < 1000·L for an integer L.
    pub const fn too_many_lost(&self, lost: u32, produced: u32) -> bool {
        lost > self.max_lost_samples
            && (produced as u64 * self.max_lost_per_mille as u64) < lost as u64 * 1000
    }
}

impl Default for RunLimits {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The accounting of one run (counts of samples). `seen = used + skipped()`; the samples the
/// sensors produced during the run are `seen + lost`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RunCounters {
    /// Samples the run received.
    pub seen: u32,
    /// Samples handed to metrology.
    pub used: u32,
    /// Skipped: LVDT open (open coil, bar unplugged).
    pub skipped_lvdt_open: u32,
    /// Skipped: LVDT over-range (not also open).
    pub skipped_lvdt_over_range: u32,
    /// Skipped: encoder quadrature error (LVDT valid).
    pub skipped_quadrature: u32,
    /// Skipped: a valid-looking sample whose ΔL jumped (the run aborted on it).
    pub skipped_jump: u32,
    /// Skipped: a valid sample on which the lost samples passed the limit (the run aborted).
    pub skipped_overrun: u32,
    /// Samples lost upstream (queue overruns) during the run; never seen: the gaps in the
    /// sample counter after the run's first sample.
    pub lost: u32,
    /// Used samples whose temperature correction used the last good temperature
    /// ([`SampleFlags::TEMPERATURE_FAULT`]).
    pub temperature_faults: u32,
    /// Samples that followed lost ones ([`SampleFlags::OVERRUN`]).
    pub after_overrun: u32,
}

impl RunCounters {
    /// Every counter zero.
    pub const ZERO: Self = Self {
        seen: 0,
        used: 0,
        skipped_lvdt_open: 0,
        skipped_lvdt_over_range: 0,
        skipped_quadrature: 0,
        skipped_jump: 0,
        skipped_overrun: 0,
        lost: 0,
        temperature_faults: 0,
        after_overrun: 0,
    };

    /// Number of counters in [`as_array`](Self::as_array) (CANopen 0x3005, SCPI `SESS:COUN?`).
    pub const LEN: usize = 10;
    /// Their names, in [`as_array`](Self::as_array) order.
    pub const NAMES: [&'static str; Self::LEN] = [
        "seen",
        "used",
        "skipped_lvdt_open",
        "skipped_lvdt_over_range",
        "skipped_quadrature",
        "skipped_jump",
        "skipped_overrun",
        "lost",
        "temperature_faults",
        "after_overrun",
    ];

    /// Samples skipped for any reason.
    pub const fn skipped(&self) -> u32 {
        self.skipped_lvdt_open
            .saturating_add(self.skipped_lvdt_over_range)
            .saturating_add(self.skipped_quadrature)
            .saturating_add(self.skipped_jump)
            .saturating_add(self.skipped_overrun)
    }

    /// The counters in [`NAMES`](Self::NAMES) order.
    pub const fn as_array(&self) -> [u32; Self::LEN] {
        [
            self.seen,
            self.used,
            self.skipped_lvdt_open,
            self.skipped_lvdt_over_range,
            self.skipped_quadrature,
            self.skipped_jump,
            self.skipped_overrun,
            self.lost,
            self.temperature_faults,
            self.after_overrun,
        ]
    }

    /// The counters from their [`as_array`](Self::as_array) form (a log or stream record).
    pub const fn from_array(c: [u32; Self::LEN]) -> Self {
        let [
            seen,
            used,
            lvdt_open,
            over_range,
            quadrature,
            jump,
            overrun,
            lost,
            temp,
            after,
        ] = c;
        Self {
            seen,
            used,
            skipped_lvdt_open: lvdt_open,
            skipped_lvdt_over_range: over_range,
            skipped_quadrature: quadrature,
            skipped_jump: jump,
            skipped_overrun: overrun,
            lost,
            temperature_faults: temp,
            after_overrun: after,
        }
    }
}

/// Why a sample was not handed to metrology.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SkipReason {
    /// LVDT open.
    LvdtOpen,
    /// LVDT over-range.
    LvdtOverRange,
    /// Encoder quadrature error.
    Quadrature,
    /// ΔL jumped (bar dropped from the socket).
    Jump,
    /// Too many samples lost before this one.
    Overrun,
}

/// What the application does with a sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Hand it to metrology.
    Use,
    /// Skip it (counted); the run goes on.
    Skip(SkipReason),
    /// Skip it (counted) and abort the run with this reason.
    Abort(SkipReason, AbortReason),
    /// The run already ended (aborted, or not started): the sample is not part of it and not
    /// counted.
    NotRunning,
}

/// The run monitor (module doc); no allocation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunMonitor {
    limits: RunLimits,
    counters: RunCounters,
    running: bool,
    last_valid_dl_um: Option<f32>,
    lvdt_fault_streak: u32,
    last_seq: Option<u32>,
    abort: Option<AbortReason>,
}

impl RunMonitor {
    /// A monitor with `limits`, no run in progress.
    pub const fn new(limits: RunLimits) -> Self {
        Self {
            limits,
            counters: RunCounters::ZERO,
            running: false,
            last_valid_dl_um: None,
            lvdt_fault_streak: 0,
            last_seq: None,
            abort: None,
        }
    }

    /// The limits in use.
    pub const fn limits(&self) -> &RunLimits {
        &self.limits
    }

    /// The run's accounting so far.
    pub const fn counters(&self) -> RunCounters {
        self.counters
    }

    /// Why the run aborted, if it did.
    pub const fn abort_reason(&self) -> Option<AbortReason> {
        self.abort
    }

    /// True between [`start`](Self::start) and the end of the run (stop, abort).
    pub const fn is_running(&self) -> bool {
        self.running
    }

    /// Starts a run: counters to zero; losses are counted from the run's first sample.
    pub fn start(&mut self) {
        *self = Self::new(self.limits);
        self.running = true;
    }

    /// Ends the run by command (abort): later samples are not counted.
    pub fn end(&mut self) {
        self.running = false;
    }

    /// Classifies the next sample of the run and counts it (a gap in [`Sample::seq`] since the
    /// previous one counts as lost samples).
    pub fn on_sample(&mut self, s: &Sample) -> Verdict {
        if !self.running {
            return Verdict::NotRunning;
        }
        let c = &mut self.counters;
        c.seen = c.seen.saturating_add(1);
        if let Some(prev) = self.last_seq {
            let gap = s.seq.wrapping_sub(prev).wrapping_sub(1);
            // a counter that went backwards (a restarted acquisition) is no loss
            if gap < u32::MAX / 2 {
                c.lost = c.lost.saturating_add(gap);
            }
        }
        self.last_seq = Some(s.seq);
        if s.flags.contains(SampleFlags::OVERRUN) {
            c.after_overrun = c.after_overrun.saturating_add(1);
        }
        let lvdt_bad = s
            .flags
            .intersects(SampleFlags::LVDT_OPEN.with(SampleFlags::LVDT_OVER_RANGE));
        let reason = if s.flags.contains(SampleFlags::LVDT_OPEN) {
            Some(SkipReason::LvdtOpen)
        } else if s.flags.contains(SampleFlags::LVDT_OVER_RANGE) {
            Some(SkipReason::LvdtOverRange)
        } else if s.flags.contains(SampleFlags::QUADRATURE_ERROR) {
            Some(SkipReason::Quadrature)
        } else if !s.delta_l_um.is_finite()
            || self
                .last_valid_dl_um
                .is_some_and(|l| !((s.delta_l_um - l).abs() <= self.limits.max_step_um))
        {
            Some(SkipReason::Jump)
        } else {
            None
        };
        self.lvdt_fault_streak = if lvdt_bad {
            self.lvdt_fault_streak.saturating_add(1)
        } else {
            0
        };
        let produced = c.seen.saturating_add(c.lost);
        let abort = if reason == Some(SkipReason::Jump)
            || self.lvdt_fault_streak >= self.limits.max_lvdt_fault_samples
        {
            Some(AbortReason::LvdtFault)
        } else if self.limits.too_many_lost(c.lost, produced) {
            Some(AbortReason::Overrun)
        } else {
            None
        };
        // a valid sample on which the run aborts for lost samples is not used either
        let reason = match (reason, abort) {
            (None, Some(_)) => Some(SkipReason::Overrun),
            (r, _) => r,
        };
        match reason {
            None => {
                c.used = c.used.saturating_add(1);
                if s.flags.contains(SampleFlags::TEMPERATURE_FAULT) {
                    c.temperature_faults = c.temperature_faults.saturating_add(1);
                }
                self.last_valid_dl_um = Some(s.delta_l_um);
            }
            Some(r) => {
                let n = match r {
                    SkipReason::LvdtOpen => &mut c.skipped_lvdt_open,
                    SkipReason::LvdtOverRange => &mut c.skipped_lvdt_over_range,
                    SkipReason::Quadrature => &mut c.skipped_quadrature,
                    SkipReason::Jump => &mut c.skipped_jump,
                    SkipReason::Overrun => &mut c.skipped_overrun,
                };
                *n = n.saturating_add(1);
            }
        }
        match (reason, abort) {
            (Some(r), Some(a)) => {
                self.running = false;
                self.abort = Some(a);
                Verdict::Abort(r, a)
            }
            (Some(r), None) => Verdict::Skip(r),
            (None, _) => Verdict::Use,
        }
    }

    /// Ends the run normally: `Err(NotObservable)` if fewer than
    /// [`RunLimits::min_used_samples`] samples were used (the run then has no results),
    /// `Err(reason)` if it had already aborted, else `Ok`.
    pub fn stop(&mut self) -> Result<(), AbortReason> {
        self.running = false;
        if let Some(a) = self.abort {
            return Err(a);
        }
        if self.counters.used < self.limits.min_used_samples {
            self.abort = Some(AbortReason::NotObservable);
            return Err(AbortReason::NotObservable);
        }
        Ok(())
    }
}
