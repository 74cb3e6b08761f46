//! The pod's application in virtual time, as the firmware's tasks run it on the board: a ball
//! bar driven on a circle about the socket (radius = bar length, a known centre offset = the
//! truth) through the sensor models of [`crate::vmt::pod`], the core's acquisition, run
//! monitor (`ballpod::session::run`), circle fit, sample log, CANopen slave and SCPI server.
//!
//! `sim --serve` ([`crate::serve`]) puts it behind TCP ports; the fault-scenario tests drive it
//! directly: frames and bytes in, frames and bytes out, one [`VirtualPod::step`] per sample
//! period, faults injected through [`VirtualPod::sensors`].

use ballpod::acquisition::{MAX_AXES, Sample};
use ballpod::config::Config;
use ballpod::metrology::circle_fit::{CircleFit, CircleFitConfig};
use ballpod::metrology::pattern::{PatternGeometry, Plane, Sensitivity};
use ballpod::protocol::canopen::{BusState, CanFrame, CanOpenNode};
use ballpod::protocol::log::{LogMeta, SampleLog};
use ballpod::protocol::pod::{
    AbortReason, Direction, PodModel, ResultEntry, SessionCommand, SessionState, StatusWord,
};
use ballpod::protocol::scpi::ScpiServer;
use ballpod::session::run::{RunLimits, RunMonitor, Verdict};
use ballpod::settings::{self, Loaded};

use super::pod::{Instrument, Pod};
use crate::flash_model::FlashModel;

/// Samples the simulated pod's log holds: a whole circle at 1 kHz (the firmware keeps 1024 and
/// decimates; the host has the memory to keep every sample, so a replay sees them all).
pub const LOG_CAPACITY: usize = 1 << 17;

/// What the virtual machine and instrument are.
#[derive(Clone, Copy, Debug)]
pub struct VirtualSetup {
    /// Noise seed.
    pub seed: u64,
    /// ADC noise, counts (σ per sample).
    pub noise_counts: f64,
    /// The truth: centre offset of the machine's circle, (x, y) µm.
    pub centre_offset_um: [f64; 2],
    /// Feed rate of the circle, mm/min.
    pub feed_mm_per_min: f64,
}

impl Default for VirtualSetup {
    fn default() -> Self {
        Self {
            seed: 1,
            noise_counts: 1.0,
            centre_offset_um: [5.0, -3.0],
            feed_mm_per_min: 1000.0,
        }
    }
}

/// The virtual machine and the pod's own code running on it; its sample log holds `N` samples
/// (a debug build constructs the log on the stack before boxing it: tests use a small `N`).
pub struct VirtualPod<const N: usize = LOG_CAPACITY> {
    setup: VirtualSetup,
    /// The pod model the protocols read and write.
    pub pod: PodModel,
    /// The pod's peripherals and acquisition; inject sensor faults here.
    pub sensors: Pod,
    fit: CircleFit,
    monitor: RunMonitor,
    log: Box<SampleLog<N>>,
    /// The CANopen slave.
    pub node: CanOpenNode,
    /// The SCPI server of the USB port (pull-mode downloads, as the firmware's).
    pub scpi: ScpiServer,
    /// Virtual time, µs.
    t_us: u64,
    /// Angle of the machine on its circle, rad (0 = +X).
    theta: f64,
    /// Angle turned in the current run, rad.
    turned: f64,
    /// Sample periods still to lose upstream (queue overrun), from the next step on.
    losing: u32,
    last: Option<Sample>,
    /// The two settings pages (`*SAV 0`, CANopen 0x1010); set a power-cut budget here.
    pub flash: FlashModel,
    /// What the boot found in the settings pages.
    boot_settings: Loaded,
    /// Settings saves that failed (power cut, flash fault).
    settings_store_failures: u32,
}

impl<const N: usize> VirtualPod<N> {
    /// A pod with erased settings pages (so the default configuration) on the machine
    /// `setup`, idle at angle 0.
    pub fn new(setup: VirtualSetup) -> Self {
        Self::boot(setup, FlashModel::erased())
    }

    /// A pod booting with the settings pages `flash`: the newest valid record, else the
    /// defaults (as the firmware's `main`).
    pub fn boot(setup: VirtualSetup, mut flash: FlashModel) -> Self {
        let boot_settings = settings::load(&mut flash);
        let config = boot_settings.config;
        let sensors = Self::sensors(&setup, &config, 0.0);
        let mut scpi = ScpiServer::new();
        scpi.set_pull_download(true);
        Self {
            node: CanOpenNode::new(config.can_node_id, 0x0BA1_1000),
            pod: PodModel {
                config,
                ..PodModel::default()
            },
            sensors,
            fit: CircleFit::new(Self::fit_config()),
            monitor: RunMonitor::new(RunLimits::DEFAULT),
            log: Box::new(SampleLog::new()),
            scpi,
            setup,
            t_us: 0,
            theta: 0.0,
            turned: 0.0,
            losing: 0,
            last: None,
            flash,
            boot_settings,
            settings_store_failures: 0,
        }
    }

    /// Power comes back after a cut (or a reset): the same machine and settings pages, a
    /// fresh boot.
    pub fn power_on(&self) -> Self {
        Self::boot(self.setup, self.flash.power_on())
    }

    /// What the boot found in the settings pages (slot and sequence, or the defaults).
    pub fn boot_settings(&self) -> &Loaded {
        &self.boot_settings
    }

    /// Settings saves that failed (the firmware's `SETTINGS_STORE_FAILURES`).
    pub fn settings_store_failures(&self) -> u32 {
        self.settings_store_failures
    }

    fn save(&mut self, config: &Config) {
        if settings::store(&mut self.flash, config).is_err() {
            self.settings_store_failures += 1;
        }
    }

    /// The virtual instrument for `config` (bar length, sample rate), homed at angle `theta`
    /// on the circle; ADC noise from the set-up, the bar at 20 °C.
    fn sensors(setup: &VirtualSetup, config: &Config, theta: f64) -> Pod {
        let inst = Instrument {
            bar_noise_um: 0.0,
            adc_noise_counts: setup.noise_counts,
            bar_temp_c: 20.0,
            lvdt_nonlinearity_per_um: 0.0,
            sample_rate_hz: f64::from(config.sample_rate_hz),
            ..Instrument::default()
        };
        let mut p = Pod::new(f64::from(config.bar_length_mm), &inst, setup.seed);
        p.reference(&Self::axes(f64::from(config.bar_length_mm), theta));
        p
    }

    /// Commanded axis positions (mm) at angle `theta` on a circle of radius `r_mm`.
    fn axes(r_mm: f64, theta: f64) -> [f64; MAX_AXES] {
        [r_mm * theta.cos(), r_mm * theta.sin(), 0.0, 0.0, 0.0]
    }

    fn fit_config() -> CircleFitConfig {
        CircleFitConfig {
            geometry: PatternGeometry {
                plane: Plane::XY,
                centre_u_mm: 0.0,
                centre_v_mm: 0.0,
                sensitivity: Sensitivity::Outward,
            },
            min_arc_deg: 60.0,
        }
    }

    /// The truth the clients may compare against, as JSON.
    pub fn truth_json(&self) -> String {
        format!(
            "{{\"ecc_x_um\":{},\"ecc_y_um\":{},\"bar_length_mm\":{},\"feed_mm_per_min\":{},\"node_id\":{}}}",
            self.setup.centre_offset_um[0],
            self.setup.centre_offset_um[1],
            self.pod.config.bar_length_mm,
            self.setup.feed_mm_per_min,
            self.pod.config.can_node_id
        )
    }

    /// Virtual time, µs.
    pub fn t_us(&self) -> u64 {
        self.t_us
    }

    /// The sample log.
    pub fn log(&self) -> &SampleLog<N> {
        &self.log
    }

    /// The run monitor (the current / last run's accounting and abort reason).
    pub fn monitor(&self) -> &RunMonitor {
        &self.monitor
    }

    /// The latest sample the sensors delivered.
    pub fn last_sample(&self) -> Option<Sample> {
        self.last
    }

    /// Sample period of the configuration, µs.
    pub fn period_us(&self) -> f64 {
        1e6 / f64::from(self.pod.config.sample_rate_hz)
    }

    /// Carries out the application side of accepted commands (the state change first).
    pub fn execute(&mut self, cmd: SessionCommand) {
        self.pod.apply(cmd);
        match cmd {
            SessionCommand::Arm { .. } => {
                self.fit = CircleFit::new(Self::fit_config());
                self.log.begin_run(LogMeta::from_pod(&self.pod));
                self.pod.results = Default::default();
            }
            SessionCommand::Start => {
                self.turned = 0.0;
                self.monitor.start(self.sensors.counters().lost_upstream);
                self.pod.run = self.monitor.counters();
            }
            SessionCommand::Stop => match self.monitor.stop() {
                Ok(()) => self.publish_results(),
                Err(reason) => self.pod.abort_run(reason),
            },
            SessionCommand::Abort | SessionCommand::Reset => self.monitor.end(),
            SessionCommand::ConfigChanged => {
                // the virtual instrument follows the new bar length and sample rate
                self.sensors = Self::sensors(&self.setup, &self.pod.config, self.theta);
            }
            SessionCommand::StoreSettings => self.save(&self.pod.config.clone()),
            // CiA 301 0x1011: the defaults take effect at the next reset
            SessionCommand::RestoreDefaults => self.save(&Config::default()),
        }
    }

    fn publish_results(&mut self) {
        let Ok(e) = self.fit.estimate() else {
            // too short an arc or degenerate geometry: no results
            self.pod.abort_run(AbortReason::NotObservable);
            return;
        };
        let entry = |value: f32, u: f32| ResultEntry {
            value,
            std_uncertainty: u,
            valid: true,
        };
        if let Some(r) = self.pod.results.get_mut(0..3) {
            r.copy_from_slice(&[
                entry(e.e_um[0], e.u_e_um[0]),
                entry(e.e_um[1], e.u_e_um[1]),
                entry(e.r0_um, e.u_r0_um),
            ]);
        }
    }

    /// A received CAN frame: the slave's answer frames; a session command it accepted is
    /// carried out.
    pub fn can_frame(&mut self, frame: &CanFrame) -> Vec<CanFrame> {
        let mut tx = Vec::new();
        let cmd = self
            .node
            .on_frame(frame, &mut self.pod, self.t_us, &mut |f| tx.push(f));
        if let Some(c) = cmd {
            self.execute(c);
        }
        tx
    }

    /// The CAN controller's error state changed (bus-off, recovery): the slave's frames.
    pub fn bus_state(&mut self, state: BusState) -> Vec<CanFrame> {
        let mut tx = Vec::new();
        self.node
            .on_bus_state(state, self.t_us, &mut |f| tx.push(f));
        tx
    }

    /// Bytes from the USB host: the response bytes (of a `DATA:LOG?` only its block header;
    /// pull the rest with [`pull_download`](Self::pull_download)). Accepted session commands
    /// are carried out.
    pub fn usb(&mut self, bytes: &[u8]) -> Vec<u8> {
        let mut response = Vec::new();
        let cmds = self
            .scpi
            .feed(bytes, &mut self.pod, &*self.log, &mut |b: &[u8]| {
                response.extend_from_slice(b)
            });
        for c in cmds {
            // feed already checked the state; the application side follows
            self.execute(c);
        }
        response
    }

    /// The next at most `max` bytes of a pending log download (empty when none is pending).
    pub fn pull_download(&mut self, max: usize) -> Vec<u8> {
        let mut buf = vec![0u8; max.max(1)];
        let n = self.scpi.pull_download(&*self.log, &mut buf);
        buf.truncate(n);
        buf
    }

    /// The USB host went away (cable pulled, TCP closed).
    pub fn usb_disconnected(&mut self) {
        self.scpi.connection_closed();
    }

    /// The next `n` sample periods' ADC blocks are lost upstream (queue overrun): each later
    /// [`step`](Self::step) loses one instead of delivering a sample.
    pub fn lose_samples(&mut self, n: u32) {
        self.losing = self.losing.saturating_add(n);
    }

    /// One pod sample period of virtual time: the machine moves, the sensors deliver a sample
    /// (or lose it), the run monitor, fit and log take it, the slave sends what is due.
    /// Returns the frames sent.
    pub fn step(&mut self) -> Vec<CanFrame> {
        let mut tx = Vec::new();
        let cfg = self.pod.config;
        let dt_s = 1.0 / f64::from(cfg.sample_rate_hz);
        self.t_us += (dt_s * 1e6).round() as u64;
        let r = f64::from(cfg.bar_length_mm);
        let running = self.pod.session == SessionState::Running;
        if running && self.turned < 2.0 * std::f64::consts::PI {
            let sign = if self.pod.direction == Direction::Cw {
                -1.0
            } else {
                1.0
            };
            let dtheta = self.setup.feed_mm_per_min / 60.0 * dt_s / r;
            self.theta += sign * dtheta;
            self.turned += dtheta;
        }
        if self.losing > 0 {
            self.losing -= 1;
            self.sensors.lose_samples(1);
            self.node.poll(self.t_us, &self.pod, &mut |f| tx.push(f));
            return tx;
        }
        // commanded (encoder) position on the nominal circle; actual ball centre offset by the truth
        let axes = Self::axes(r, self.theta);
        let [ex, ey] = self.setup.centre_offset_um;
        let truth_um = ((axes[0] + ex * 1e-3).hypot(axes[1] + ey * 1e-3) - r) * 1e3;
        let s = self.sensors.sample(truth_um, &axes);
        self.last = Some(s);
        if running {
            let lost = self.sensors.counters().lost_upstream;
            match self.monitor.on_sample(&s, lost) {
                Verdict::Use => {
                    self.fit.update(&s);
                    self.log.record(&s);
                    if let Ok(e) = self.fit.estimate() {
                        self.pod.live.ecc_x_um = e.e_um[0];
                        self.pod.live.ecc_y_um = e.e_um[1];
                        self.pod.live.r0_um = e.r0_um;
                    }
                }
                Verdict::Skip(_) => self.log.record(&s),
                Verdict::Abort(_, reason) => {
                    self.log.record(&s);
                    self.pod.abort_run(reason);
                }
                Verdict::NotRunning => {}
            }
            self.pod.run = self.monitor.counters();
        }
        self.pod.live.sample_counter = s.seq;
        self.pod.live.delta_l_um = s.delta_l_um;
        self.pod.live.temp_c = s.temp_c;
        self.pod.live.status =
            StatusWord::new(s.flags, self.pod.session, self.node.error_register() != 0);
        self.node.on_sample(s.flags, self.t_us, &mut |f| tx.push(f));
        self.node.poll(self.t_us, &self.pod, &mut |f| tx.push(f));
        tx
    }
}
