//! The simulated pod: the core's application (`ballpod::app::App`) with the CANopen slave, the
//! SCPI server, the sample log and the USB sample stream, on the sensor model of
//! [`super::sensors`] in virtual time — the firmware's application task with the board
//! replaced by the virtual machine tool. This shell only moves readings, frames and bytes;
//! every decision is the application's.
//!
//! Two ways to drive it:
//! - **by hand** (the simulator's procedures, the scenario rigs, the tests): the caller moves
//!   the machine one sample period at a time ([`VirtualPod::sample_at`]), homes the encoders,
//!   fires probe edges, injects faults through [`VirtualPod::sensors`], and commands the pod
//!   through its protocols or the application;
//! - **served** ([`VirtualPod::step`], behind `sim --serve`): when a client starts a run, the
//!   virtual CNC ([`super::motion`]) moves through the armed pattern with the pod's set-up and
//!   ends the run at the end of its motion.

use ballpod::acquisition::lvdt::BlockReading;
use ballpod::acquisition::probe::TriggerOutcome;
use ballpod::acquisition::{MAX_AXES, Sample};
use ballpod::app::log::{LOG_CAPACITY, SampleLog};
use ballpod::app::{
    App, Command, CommandError, DeviceCounter, DeviceCounters, JobSlot, Pattern, SessionState,
};
use ballpod::config::RunTrigger;
use ballpod::pod::{Block, BootReport, Pod};
use ballpod::protocol::canopen::{BusState, CanFrame, CanOpenNode};
use ballpod::protocol::scpi::ScpiServer;
use ballpod::protocol::stream::SampleStream;
use ballpod::settings::{self, Loaded};

use super::motion::{Motion, ServeTruth};
use super::sensors::{Instrument, Sensors};
use crate::flash_model::FlashModel;
use crate::recording::Recording;

/// The pod's parts of a [`VirtualPod`] as the core's one pod type, borrowed field by field (so
/// the host's recording, flash and job slot stay free beside it).
macro_rules! pod {
    ($vp:expr) => {
        Pod {
            app: &mut $vp.app,
            node: &mut $vp.node,
            scpi: &mut $vp.scpi,
            log: &mut $vp.log,
            stream: &mut $vp.stream,
        }
    };
}

/// The simulated pod's serial number (CANopen 0x1018:4, `*IDN?`).
pub const SERIAL: u32 = 0x0BA1_1000;

/// Bytes of the sample stream's ring (the host drains it every few samples).
pub const STREAM_BYTES: usize = 1 << 18;

/// What the virtual instrument is.
#[derive(Clone, Copy, Debug)]
pub struct VirtualSetup {
    /// Noise seed.
    pub seed: u64,
    /// The instrument (noise, sample rate, faults).
    pub instrument: Instrument,
    /// The serving machine (truth).
    pub truth: ServeTruth,
}

impl Default for VirtualSetup {
    fn default() -> Self {
        Self {
            seed: 1,
            instrument: Instrument::default(),
            truth: ServeTruth::default(),
        }
    }
}

/// The simulated pod (module doc); its log holds `N` records (the firmware's by default).
pub struct VirtualPod<const N: usize = LOG_CAPACITY> {
    setup: VirtualSetup,
    /// The pod's application.
    pub app: App,
    /// The sensors; inject sensor faults here.
    pub sensors: Sensors,
    /// The CANopen slave.
    pub node: CanOpenNode,
    /// The SCPI server of the USB command port (pull-mode downloads, as the firmware's).
    pub scpi: ScpiServer,
    log: Box<SampleLog<N>>,
    stream: Box<SampleStream<STREAM_BYTES>>,
    /// Where the pod's jobs run (here at once, after each turn: virtual time stands still).
    jobs: Box<JobSlot>,
    /// Every run whole, as the host recorded it (the stream's content, never dropped).
    pub recording: Recording,
    /// The two settings pages (`*SAV 0`, CANopen 0x1010); set a power-cut budget here.
    pub flash: FlashModel,
    boot_settings: Loaded,
    /// The served machine's motion of the current run.
    motion: Motion,
    /// PROBE runs served so far (the C position of the next one).
    probe_runs: u32,
    /// The served machine has its motion for the armed or running run.
    serving: bool,
    /// The served program is a self-triggered circle's (the pod ends the run, not the motion).
    self_triggered: bool,
    /// Sample periods still to lose upstream (queue overrun), from the next step on.
    losing: u32,
    /// The probe level (seated) the application sees each period.
    probe_seated: bool,
    /// Where the machine is (the encoders' positions), mm / degrees.
    at: [f64; MAX_AXES],
    last: Option<Sample>,
    /// The protocols' clock, µs (`None`: the sensors' virtual time). `sim --serve` sets real
    /// time here, so heartbeats, SDO timeouts and event timers keep their real periods while
    /// the machine runs faster.
    protocol_us: Option<u64>,
}

impl<const N: usize> VirtualPod<N> {
    /// A pod with erased settings pages (so the default configuration) on the machine `setup`.
    pub fn new(setup: VirtualSetup) -> Self {
        Self::boot(setup, FlashModel::erased())
    }

    /// A pod booting with the settings pages `flash`: the newest valid record, else the
    /// defaults, and a stored configuration it rejects or a slot it cannot read reported (as the
    /// firmware's `main`).
    pub fn boot(setup: VirtualSetup, mut flash: FlashModel) -> Self {
        let boot_settings = settings::load(&mut flash);
        let config = boot_settings.config;
        let sensors = Sensors::new(
            f64::from(config.bar_length_mm),
            &setup.instrument,
            setup.seed,
        );
        let mut app = App::new(config, [16; MAX_AXES]);
        let mut scpi = ScpiServer::new();
        let mut stream = Box::new(SampleStream::new());
        stream.set_enabled(true);
        let mut node = CanOpenNode::new(app.config().can_node_id, SERIAL);
        let mut log = Box::new(SampleLog::new());
        let boot = BootReport {
            settings_rejected: boot_settings.rejected(),
            settings_unreadable: boot_settings.unreadable(),
            ..BootReport::default()
        };
        Pod::boot(
            &mut app,
            &mut node,
            &mut scpi,
            &mut *log,
            &mut *stream,
            SERIAL,
            &boot,
        );
        Self {
            node,
            app,
            sensors,
            scpi,
            log,
            stream,
            jobs: Box::new(JobSlot::new()),
            recording: Recording::default(),
            flash,
            boot_settings,
            motion: Motion::none(),
            probe_runs: 0,
            serving: false,
            self_triggered: false,
            losing: 0,
            probe_seated: true,
            at: [0.0; MAX_AXES],
            last: None,
            protocol_us: None,
            setup,
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

    /// The truth of the served machine.
    pub fn truth(&self) -> &ServeTruth {
        &self.setup.truth
    }

    /// The sample log (what `DATA:LOG?` downloads).
    pub fn log(&self) -> &SampleLog<N> {
        &self.log
    }

    /// The latest sample.
    pub fn last_sample(&self) -> Option<Sample> {
        self.last
    }

    /// Virtual time of the next sample, µs.
    pub fn t_us(&self) -> u64 {
        self.sensors.t_us()
    }

    /// Sample period of the configuration, µs.
    pub fn period_us(&self) -> f64 {
        1e6 / f64::from(self.app.running_config().sample_rate_hz)
    }

    /// The settings the application asked to store, stored (as the firmware's task does).
    /// A session command given to the application directly (as the protocols do), then what
    /// the firmware does after commands: the run's begin or end reaches the recorders now.
    pub fn execute(&mut self, cmd: Command) -> Result<(), CommandError> {
        let r = self.app.execute(cmd);
        self.after_commands();
        r
    }

    /// The pod's parts as the one pod type of the core.
    fn pod(&mut self) -> Pod<'_, N, STREAM_BYTES> {
        pod!(self)
    }

    /// What the firmware does at the end of a turn (the core's [`Pod::end_of_turn`]): records
    /// a run the commands armed or stopped, stores the settings asked for, runs the jobs
    /// wanted (here at once: the firmware runs them at its lowest priority). The log download
    /// and the stream stay for the host to pull.
    fn after_commands(&mut self) {
        let mut pod = pod!(self);
        pod.end_of_turn(
            &mut self.recording,
            &mut [],
            &mut || 0,
            &mut |_| {},
            0,
            &mut |_| {},
        );
        if let Some(cfg) = pod.settings_to_store() {
            let ok = settings::store(&mut self.flash, &cfg).is_ok();
            pod.app.settings_stored(ok);
        }
        if pod.app.take_bootloader_request() {
            // (the firmware restarts into the STM32's ROM bootloader here)
            eprintln!(
                "SYST:BOOT: the simulated pod has no ROM bootloader to restart into; it goes on"
            );
        }
        pod.app.run_jobs(&mut self.jobs);
    }

    // ------------------------------------------------------------------ by hand

    /// Homes the encoders at `axes` (mm / degrees).
    pub fn home(&mut self, axes: &[f64; MAX_AXES]) {
        let (raw, pos) = self.sensors.reference(axes);
        self.app.reference_axes(raw, pos);
        self.at = *axes;
    }

    /// A probe trigger edge now, the encoders latched at `axes` (where the machine is at the
    /// edge); an accepted touch of a PROBE run is kept and recorded.
    pub fn probe_edge_at(&mut self, axes: &[f64; MAX_AXES]) -> TriggerOutcome {
        let (t, raw) = self.sensors.probe_edge(axes);
        let mut pod = pod!(self);
        pod.on_probe_edge(t, raw, &mut self.recording)
    }

    /// The probe stylus level from the next sample on (`true` = seated, at rest).
    pub fn set_probe_seated(&mut self, seated: bool) {
        self.probe_seated = seated;
    }

    /// The next `n` sample periods' ADC blocks are lost upstream (queue overrun): the next
    /// sample comes `n` periods later and carries `OVERRUN`.
    pub fn lose_samples(&mut self, n: u32) {
        self.losing = self.losing.saturating_add(n);
    }

    /// One sample period with the machine at `axes` (mm / degrees) and the true bar-length
    /// deviation `dl_um` (µm): the sensors read, the application processes the sample, the
    /// CANopen node sees its flags and is polled. Returns the sample (`None` if the period was
    /// lost upstream) and the frames the node sent.
    pub fn sample_at(
        &mut self,
        dl_um: f64,
        axes: &[f64; MAX_AXES],
    ) -> (Option<Sample>, Vec<CanFrame>) {
        let mut tx = Vec::new();
        self.at = *axes;
        if self.losing > 0 {
            self.losing -= 1;
            self.sensors.lose_samples(1);
            self.app.set_device_counters(self.device_counters());
            let now = self.proto_us();
            self.pod().tick(now, &mut |f| tx.push(f));
            return (None, tx);
        }
        let r = self.sensors.read(dl_um, axes);
        let now = self.proto_us();
        let counters = self.device_counters();
        let mut pod = pod!(self);
        if let Some(code) = r.thermistor {
            let _ = pod.on_thermistor(code);
        }
        pod.set_device_counters(counters);
        let block = Block {
            t_us: r.t_us,
            reading: BlockReading::Ac(r.lvdt),
            raw: r.raw,
            lost_total: r.lost_total,
            probe_seated: self.probe_seated,
        };
        let s = pod.on_block(&block, now, &mut self.recording, &mut |f| tx.push(f));
        pod.tick(now, &mut |f| tx.push(f));
        self.last = Some(s);
        self.after_commands();
        (Some(s), tx)
    }

    /// Where the machine is (X, Y, Z mm; B, C degrees).
    pub fn axes_now(&self) -> [f64; MAX_AXES] {
        self.at
    }

    /// The device counters this pod has: the periods lost upstream (as `adc_blocks_lost`),
    /// the stream's dropped lines, the samples the log missed during downloads; its queues
    /// drop nothing and its watchdog, DAC, interrupts and stack are not modelled (0, or
    /// [`NOT_MEASURED`](ballpod::app::device::NOT_MEASURED) for the two figures).
    pub fn device_counters(&self) -> DeviceCounters {
        let mut c = DeviceCounters::START;
        c.set(DeviceCounter::AdcBlocksLost, self.sensors.lost_total());
        c.set(
            DeviceCounter::StreamLinesDropped,
            self.stream.dropped_lines(),
        );
        c.set(DeviceCounter::LogPausedSamples, self.log.paused_samples());
        c
    }

    /// A thermistor ADC code from the thermistor task (12-bit; 0 = shorted, 4095 = open).
    pub fn thermistor(&mut self, code: u16) {
        let _ = self.pod().on_thermistor(code);
    }

    /// Runs the protocols (CANopen timers) on this clock from now on, µs, instead of the
    /// sensors' virtual time; it must not go back.
    pub fn set_protocol_time(&mut self, t_us: u64) {
        self.protocol_us = Some(t_us.max(self.protocol_us.unwrap_or(0)));
    }

    /// The protocols' time now, µs.
    fn proto_us(&self) -> u64 {
        self.protocol_us.unwrap_or_else(|| self.sensors.t_us())
    }

    // ------------------------------------------------------------------ served

    /// One sample period of the served machine: a run that started gets the virtual CNC's
    /// motion of its pattern, which ends the run when it is over; a CIRCLE run armed with
    /// `run_trigger = FEED_IN` gets the CNC's part program at once (feed-in, data arc,
    /// overshoot, feed-out: [`Motion::plan_feed_in`]) and the pod starts and ends the run
    /// itself; otherwise the machine stands still. Returns the frames the node sent.
    pub fn step(&mut self) -> Vec<CanFrame> {
        let session = self.app.session();
        let running = session == SessionState::Running;
        // the sample rate the pod runs with, not a value pending until reset
        let cfg = self.app.running_config();
        let self_triggered = session == SessionState::Armed
            && self.app.pattern() == Pattern::Circle
            && cfg.setup.run_trigger == RunTrigger::FeedIn;
        if !(running || session == SessionState::Armed) {
            self.serving = false;
        }
        if (running || self_triggered) && !self.serving {
            // the technician mounted the bar the configuration names (as `cargo sim` swaps
            // bars between procedures): its expansion is modelled on that length
            self.sensors.set_bar_length(f64::from(cfg.bar_length_mm));
            let direction = self.app.direction();
            let planned = Motion::plan_run(
                &self.setup.truth,
                &cfg,
                self.app.pattern(),
                direction,
                self_triggered,
                self.probe_runs,
            );
            match planned {
                Ok(m) => {
                    if self.app.pattern() == Pattern::Probe {
                        self.probe_runs += 1;
                    }
                    if let Some(start) = m.start() {
                        self.home(&start);
                    }
                    self.motion = m;
                }
                Err(_) => self.motion = Motion::none(),
            }
            self.serving = true;
            self.self_triggered = self_triggered;
        }
        let (dl, axes) = match self.serving.then(|| self.motion.next_step()).flatten() {
            Some(m) => {
                if let Some(edge) = m.edge {
                    self.probe_edge_at(&edge);
                }
                self.probe_seated = m.seated;
                (m.dl_um, m.axes)
            }
            None => {
                if running && !self.self_triggered {
                    // the part program's last block: the run ends with the motion
                    let _ = self.execute(Command::Stop);
                    self.serving = false;
                }
                (0.0, self.at)
            }
        };
        self.sample_at(dl, &axes).1
    }

    /// True while the served machine runs a part program (a run's motion, or the program of
    /// an armed self-triggered circle).
    pub fn moving(&self) -> bool {
        self.serving && self.motion.remaining() > 0
    }

    // ------------------------------------------------------------------ protocols

    /// A received CAN frame: the slave's answer frames.
    pub fn can_frame(&mut self, frame: &CanFrame) -> Vec<CanFrame> {
        let mut tx = Vec::new();
        let now = self.proto_us();
        self.pod().on_frame(frame, now, &mut |f| tx.push(f));
        self.after_commands();
        tx
    }

    /// The bit rate an LSS master activated, once its switch delay has passed
    /// ([`ballpod::pod::Pod::bit_rate_switch`]).
    pub fn bit_rate_switch(&mut self) -> Option<ballpod::config::CanBitrate> {
        let now = self.proto_us();
        self.pod().bit_rate_switch(now)
    }

    /// The CAN controller's error state changed (bus-off, recovery): the slave's frames.
    pub fn bus_state(&mut self, state: BusState) -> Vec<CanFrame> {
        let mut tx = Vec::new();
        let now = self.proto_us();
        self.pod().on_bus_state(state, now, &mut |f| tx.push(f));
        tx
    }

    /// Bytes from the USB host on the command port: the response bytes (of a `DATA:LOG?` only
    /// its block header, once counted as the firmware counts it, pull by pull; pull the rest
    /// with [`pull_download`](Self::pull_download)).
    pub fn usb(&mut self, bytes: &[u8]) -> Vec<u8> {
        let mut response = Vec::new();
        self.pod()
            .on_usb(bytes, &mut |b: &[u8]| response.extend_from_slice(b));
        let mut header = [0u8; 64];
        while self.scpi.download_header_pending() {
            let n = self.scpi.pull_download(&*self.log, &mut header);
            response.extend_from_slice(&header[..n]);
        }
        self.after_commands();
        response
    }

    /// The next at most `max` bytes of a pending log download (empty when none is pending).
    pub fn pull_download(&mut self, max: usize) -> Vec<u8> {
        let mut buf = vec![0u8; max.max(1)];
        let n = self.scpi.pull_download(&*self.log, &mut buf);
        buf.truncate(n);
        buf
    }

    /// The USB host went away from the command port (cable pulled, TCP closed).
    pub fn usb_disconnected(&mut self) {
        self.pod().usb_closed();
    }

    /// A reader opened (`true`) or closed the stream port.
    pub fn stream_reader(&mut self, connected: bool) {
        self.pod().stream_reader(connected);
    }

    /// The next at most `max` bytes of the sample stream.
    pub fn pull_stream(&mut self, max: usize) -> Vec<u8> {
        let mut out = Vec::new();
        self.stream.drain(max, &mut |b| out.extend_from_slice(b));
        out
    }

    /// Stream lines dropped because the ring was full.
    pub fn stream_dropped(&self) -> u32 {
        self.stream.dropped_lines()
    }
}
