//! The compute task: one pod sample per LVDT block through the core's acquisition pipeline;
//! it publishes the live values, passes the samples of a running session through the core's
//! run monitor (an abort for a fault reaches the pod model: CANopen 0x3003/0x3004, SCPI
//! `SESS:STAT?` / `SESS:REAS?`) and logs them, and carries out the session commands the
//! protocol tasks queue.

use core::cell::Cell;

use embassy_stm32::exti::ExtiInput;
use embassy_stm32::mode::Blocking;
use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;

use ballpod::acquisition::probe::{ProbeLatch, TriggerOutcome};
use ballpod::acquisition::{Acquisition, Sample};
use ballpod::config::Config;
use ballpod::protocol::log::LogMeta;
use ballpod::protocol::pod::{PodModel, SessionCommand, SessionState, StatusWord};
use ballpod::session::run::{RunLimits, RunMonitor, Verdict};

use ballpod::settings;

use super::settings::SettingsPages;
use super::{Overruns, encoders, lvdt, probe, state, thermistor};

/// The latest accepted touch point.
pub static LAST_TOUCH: Mutex<CriticalSectionRawMutex, Cell<Option<ProbeLatch>>> =
    Mutex::new(Cell::new(None));

/// Carries out the application side of a session command (the protocol task already applied
/// the state change to the pod model).
fn execute(
    cmd: SessionCommand,
    acq: &mut Acquisition,
    monitor: &mut RunMonitor,
    flash: &mut SettingsPages,
) {
    match cmd {
        SessionCommand::Arm { .. } => {
            if let Some(meta) = state::with_pod(|pod| LogMeta::from_pod(pod)) {
                state::LOG.lock(|log| log.borrow_mut().begin_run(meta));
            }
        }
        SessionCommand::ConfigChanged => {
            // New calibration and scales; the encoder extension restarts (axes need homing).
            if let Some(cfg) = state::with_pod(|pod| pod.config) {
                *acq = Acquisition::new(&cfg, encoders::COUNTER_BITS);
            }
        }
        SessionCommand::StoreSettings => {
            if let Some(cfg) = state::with_pod(|pod| pod.config) {
                save(flash, &cfg);
            }
        }
        SessionCommand::RestoreDefaults => {
            // CiA 301 0x1011: the defaults take effect at the next reset; the running
            // configuration stays until then.
            save(flash, &Config::default());
        }
        SessionCommand::Start => {
            monitor.start(acq.counters.lost_upstream);
            let counters = monitor.counters();
            state::with_pod(|pod| pod.run = counters);
        }
        SessionCommand::Stop => {
            if let Err(reason) = monitor.stop() {
                state::with_pod(|pod| pod.abort_run(reason));
                defmt::warn!("run has no results: {}", reason as u8);
            }
        }
        SessionCommand::Abort | SessionCommand::Reset => monitor.end(),
    }
}

/// Stores a configuration in the next settings slot (logged; on failure the previous
/// settings are still the ones loaded at boot).
fn save(flash: &mut SettingsPages, cfg: &Config) {
    match settings::store(flash, cfg) {
        Ok(s) => defmt::info!(
            "settings stored in slot {}, sequence {}",
            s.slot.index(),
            s.sequence
        ),
        Err(e) => {
            SETTINGS_STORE_FAILURES.count();
            defmt::error!("settings not stored: {}", super::settings::store_reason(&e));
        }
    }
}

/// Saves that failed (driver error or read-back mismatch).
pub static SETTINGS_STORE_FAILURES: Overruns = Overruns::new();

/// Turns each LVDT block, the encoder counters, the probe edges and the temperature into a
/// calibrated sample with the core, and publishes it.
#[embassy_executor::task]
pub async fn compute_task(
    cfg: Config,
    mut acq: Acquisition,
    _encoders: encoders::Encoders,
    probe_in: ExtiInput<'static, Blocking>,
    mut flash: SettingsPages,
) {
    state::POD.lock(|p| {
        *p.borrow_mut() = Some(PodModel {
            config: cfg,
            ..PodModel::default()
        })
    });
    let mut monitor = RunMonitor::new(RunLimits::DEFAULT);
    loop {
        let block = lvdt::BLOCKS.receive().await;
        while let Ok(cmd) = state::COMMANDS.try_receive() {
            execute(cmd, &mut acq, &mut monitor, &mut flash);
        }
        while let Ok(code) = thermistor::CODES.try_receive() {
            if let Err(e) = acq.update_temperature(code) {
                defmt::warn!("thermistor fault {}", defmt::Debug2Format(&e));
            }
        }
        let mut probe_event = false;
        while let Ok(edge) = probe::EDGES.try_receive() {
            if let TriggerOutcome::Accepted(latch) = acq.probe_trigger(edge.t_us, edge.raw) {
                probe_event = true;
                LAST_TOUCH.lock(|c| c.set(Some(latch)));
            }
        }
        // NC contact to ground with pull-up: seated reads low.
        acq.probe.poll(block.t_us, probe_in.is_low());
        let s = acq.sample(
            block.t_us,
            block.reading,
            encoders::raw_counts(),
            super::lost_upstream(),
            probe_event,
        );
        let verdict = monitor.on_sample(&s, acq.counters.lost_upstream);
        publish(&s, verdict, &monitor);
        super::safety::progress();
        if s.seq.is_multiple_of(1000) {
            defmt::info!(
                "sample {} dl={} um flags={=u16:#x}",
                s.seq,
                s.delta_l_um,
                s.flags.0
            );
        }
    }
}

/// Live values for CAN and USB; the run monitor's verdict and counters; every sample the run
/// counted goes into the log (skipped ones too: the log shows their flags). A sample before
/// the compute task has started the monitor is not part of the run: neither counted nor
/// logged.
fn publish(s: &Sample, verdict: Verdict, monitor: &RunMonitor) {
    let counted = verdict != Verdict::NotRunning;
    state::with_pod(|pod| {
        pod.live.sample_counter = s.seq;
        pod.live.delta_l_um = s.delta_l_um;
        pod.live.temp_c = s.temp_c;
        if counted {
            pod.run = monitor.counters();
        }
        if let Verdict::Abort(_, reason) = verdict
            && pod.session == SessionState::Running
        {
            pod.abort_run(reason);
            defmt::warn!("run aborted: reason {}", reason as u8);
        }
        pod.live.status = StatusWord::new(s.flags, pod.session, false);
    });
    if counted {
        if state::download_active() {
            state::LOG_PAUSED_SAMPLES.count();
        } else {
            state::LOG.lock(|log| log.borrow_mut().record(s));
        }
    }
}
