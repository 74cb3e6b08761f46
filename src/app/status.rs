//! The status word (CANopen 0x2102, SCPI `STATus:OPERation?`): the session's, the jobs', a
//! pending reset's and a failed save's bits, kept between samples, and each sample's own.

use super::job::JobKind;
use super::live_fit::{LIVE_FIT, LIVE_SSM_E};
use super::session::SessionState;
use super::{App, Pattern, SampleFlags, StatusWord};

impl App {
    /// Computes the status word: the bits of the session, the jobs, a pending reset and a
    /// failed save (kept in `status_fixed`), then a sample's ([`Self::update_sample_status`]).
    /// Called wherever one of the former changes: a command, a configuration, a job, a save.
    pub(super) fn update_status(&mut self) {
        let mut fixed = StatusWord::new(SampleFlags::NONE, self.session, 0).0;
        if self.identify_pending || self.job == Some(JobKind::Seed002Identification) {
            fixed |= StatusWord::IDENTIFYING;
        }
        if self.job_pending() {
            // the results are not all there until the job has published them
            fixed = (fixed | StatusWord::COMPUTING) & !StatusWord::RESULTS_READY;
        }
        if self.reset_pending() {
            fixed |= StatusWord::RESET_PENDING;
        }
        if self.settings_failed {
            fixed |= StatusWord::ERROR;
        }
        self.status_fixed = fixed;
        self.update_sample_status();
    }

    /// The status word's bits a sample changes — its flags, [`StatusWord::LIVE_VALID`], a
    /// fault's [`StatusWord::ERROR`] — over the fixed ones (the sample path: ~40 instructions
    /// where the whole word took ~100).
    #[inline(always)]
    pub(super) fn update_sample_status(&mut self) {
        let live_valid = match self.pattern {
            _ if self.session != SessionState::Running => false,
            Pattern::Ssm => self.live.all_valid(LIVE_SSM_E),
            Pattern::Probe => false,
            Pattern::Circle
            | Pattern::Bx
            | Pattern::By
            | Pattern::Cr
            | Pattern::Ca
            | Pattern::Cr2 => self.live.all_valid(LIVE_FIT),
        };
        let mut w = self.status_fixed | (self.last_flags.0 & StatusWord::SAMPLE_FLAGS_MASK);
        if live_valid {
            w |= StatusWord::LIVE_VALID;
        }
        if self
            .last_flags
            .intersects(SampleFlags::INVALID_FOR_METROLOGY.with(SampleFlags::TEMPERATURE_FAULT))
        {
            w |= StatusWord::ERROR;
        }
        self.live.status = StatusWord(w);
    }
}
