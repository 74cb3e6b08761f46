//! The session commands and requests: each checked against the session table
//! ([`super::session`]) and carried out; a refused one changes nothing and is kept for
//! `last_refusal`.

use super::run::AbortReason;
use super::session::{self, Command, CommandError, Needs, SessionState, SettingsRequest};
use super::{App, Direction, Pattern, Pending, ResultId, RunEnd, RunEstimator};
use crate::config::LvdtInput;

impl App {
    /// Selects the pattern of the next run (not while a run is armed or running).
    pub fn set_pattern(&mut self, p: Pattern) -> Result<(), CommandError> {
        if !self.idle() {
            return self.refuse(CommandError::Busy);
        }
        self.pattern = p;
        Ok(())
    }

    /// Selects the direction of the next run (not while a run is armed or running).
    pub fn set_direction(&mut self, d: Direction) -> Result<(), CommandError> {
        if !self.idle() {
            return self.refuse(CommandError::Busy);
        }
        self.direction = d;
        Ok(())
    }

    /// Carries out a session command, or refuses it (nothing changes; the reason is kept for
    /// [`last_refusal`](Self::last_refusal)).
    pub fn execute(&mut self, cmd: Command) -> Result<(), CommandError> {
        let r = self.execute_inner(cmd);
        self.update_status();
        r
    }

    /// The command's action, once the session table admits it ([`session::admit`]).
    pub(super) fn execute_inner(&mut self, cmd: Command) -> Result<(), CommandError> {
        if let Err(e) = session::admit(cmd, self.session) {
            return self.refuse(e);
        }
        match cmd {
            Command::Arm => return self.arm(),
            Command::Start => self.begin_running(),
            Command::Stop => self.stop(),
            Command::Abort => self.abort(AbortReason::ByCommand),
            Command::Clear => self.clear_procedures(),
            Command::Reset => {
                if !self.idle() {
                    self.abort(AbortReason::ByCommand);
                }
                self.clear_procedures();
                self.session = SessionState::Idle;
                self.abort_reason = None;
            }
            Command::StoreSettings => self.settings_request = Some(SettingsRequest::Store),
            Command::RestoreDefaults => {
                self.settings_request = Some(SettingsRequest::RestoreDefaults);
            }
        }
        Ok(())
    }

    /// A client asks to update the firmware: the shell restarts the pod into the STM32's ROM
    /// bootloader (USB DFU, `dfu-util`; book: Hardware, "Updating the firmware") once a
    /// settings save in progress has ended. Not while a run is armed or running, nor while a
    /// job computes (its result would be lost with the restart).
    pub fn request_bootloader(&mut self) -> Result<(), CommandError> {
        if !self.idle() {
            return self.refuse(CommandError::Busy);
        }
        if self.job.is_some() {
            return self.refuse(CommandError::WrongState(Needs::NoComputation));
        }
        self.bootloader_request = true;
        Ok(())
    }

    /// The LVDT input mode the board must acquire in, once after start and once after each
    /// configuration change that changes it (taken once; the firmware's LVDT task demodulates
    /// in this mode from its next block on).
    pub fn take_lvdt_input(&mut self) -> Option<LvdtInput> {
        self.lvdt_input_change.take()
    }

    /// The ROM bootloader was asked for ([`App::request_bootloader`]; taken once).
    pub fn take_bootloader_request(&mut self) -> bool {
        core::mem::take(&mut self.bootloader_request)
    }

    /// The settings the shell is asked to store (taken once).
    pub fn take_settings_request(&mut self) -> Option<SettingsRequest> {
        self.settings_request.take()
    }

    /// The shell reports how a settings save went (a failure sets the status word's error bit
    /// until the next successful save, and is counted).
    pub fn settings_stored(&mut self, ok: bool) {
        self.settings_failed = !ok;
        if !ok {
            self.settings_failures = self.settings_failures.saturating_add(1);
        }
        self.update_status();
    }

    pub(super) fn clear_procedures(&mut self) {
        self.circle.clear();
        self.planes.clear();
        self.sweep.clear();
        self.spikes.clear();
        self.seed002_begun = false;
        self.seed002_epoch = self.seed002_epoch.wrapping_add(1);
        self.identify_pending = false;
        self.figures_requests = [None; 2];
        self.two_step.clear();
        self.spheres.clear();
        self.spheres_epoch = self.spheres_epoch.wrapping_add(1);
        self.probe_requests = [false; 2];
        self.estimator = RunEstimator::None;
        self.results.clear_all();
        self.procedure_note = None;
    }

    /// The armed run starts (a client's START or the trigger).
    pub(super) fn begin_running(&mut self) {
        self.session = SessionState::Running;
        self.monitor.start();
        if let Some(t) = self.trigger.as_mut() {
            t.started();
            self.procedure_note = None;
        }
    }
    pub(super) fn queue(&mut self, p: Pending) {
        if self.pending.is_full() {
            // only runs without a single sample can pile up here: the oldest goes
            self.pending.pop_front();
        }
        let _ = self.pending.push_back(p);
    }

    pub(super) fn end_run(&mut self, abort: Option<AbortReason>) {
        self.queue(Pending::End(RunEnd {
            run: self.meta.run,
            abort,
            counters: self.monitor.counters(),
        }));
    }

    pub(super) fn abort(&mut self, reason: AbortReason) {
        self.monitor.end();
        self.session = SessionState::Aborted;
        self.abort_reason = Some(reason);
        self.results.clear(ResultId::EccU, ResultId::Arc);
        self.end_run(Some(reason));
    }
}
