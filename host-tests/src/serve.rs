//! `sim --serve`: the simulated pod on loopback TCP, for third-party clients acting as the CNC
//! and the technician's PC (issue 5 items 5 and 6).
//!
//! - CAN as **SLCAN** (Lawicel ASCII) on one port: `python-can`'s `slcan` interface with
//!   `channel='socket://127.0.0.1:PORT'`, and the `canopen` package on top of it, talk to the
//!   core's CANopen slave (`ballpod::protocol::canopen`).
//! - The USB command stream as a raw TCP byte stream on another port, to the core's SCPI server
//!   (`ballpod::protocol::scpi`), e.g. `serial.serial_for_url('socket://127.0.0.1:PORT')`.
//!
//! The pod runs in **virtual time**: a virtual ball bar on a circle about the socket (radius =
//! bar length, a known centre offset = the truth) produces 12-bit LVDT ADC blocks, encoder
//! counters and a thermistor code, which go through the pod's own acquisition, metrology and
//! protocol code at the configured sample rate. Virtual time tracks real time while idle (so
//! heartbeats come at their period) and runs `speed` times faster while a session is running,
//! so a full circle takes seconds; `--realtime` paces it 1:1 throughout.
//!
//! At start the server prints one JSON line on stdout: the two ports and the truth
//! (`{"can_port":…,"usb_port":…,"truth":{…}}`). It stops after `max_seconds` of real time.

use std::io::{self, ErrorKind, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::time::{Duration, Instant};

use ballpod::acquisition::MAX_AXES;
use ballpod::config::Config;
use ballpod::metrology::circle_fit::{CircleFit, CircleFitConfig};
use ballpod::metrology::pattern::{PatternGeometry, Plane, Sensitivity};
use ballpod::protocol::canopen::{CanFrame, CanOpenNode};
use ballpod::protocol::log::{LogMeta, SampleLog};
use ballpod::protocol::pod::{
    Direction, PodModel, ResultEntry, SessionCommand, SessionState, StatusWord,
};
use ballpod::protocol::scpi::ScpiServer;

use crate::slcan::{LineSplitter, SlcanCommand, SlcanFrame, format_frame, parse_line};
use crate::vmt::pod::{Instrument, Pod};

/// Options of the serve mode.
#[derive(Clone, Debug)]
pub struct ServeOptions {
    /// SLCAN port (0: any free port).
    pub can_port: u16,
    /// SCPI port (0: any free port).
    pub usb_port: u16,
    /// Pace the running session at real time too (default: `speed` × real time).
    pub realtime: bool,
    /// Virtual-time speed-up while a session runs.
    pub speed: f64,
    /// Noise seed.
    pub seed: u64,
    /// ADC noise, counts (σ per sample).
    pub noise_counts: f64,
    /// Stop after this many seconds of real time.
    pub max_seconds: f64,
    /// The truth: centre offset of the machine's circle, (x, y) µm.
    pub centre_offset_um: [f64; 2],
    /// Feed rate of the circle, mm/min.
    pub feed_mm_per_min: f64,
}

impl Default for ServeOptions {
    fn default() -> Self {
        Self {
            can_port: 0,
            usb_port: 0,
            realtime: false,
            speed: 20.0,
            seed: 1,
            noise_counts: 1.0,
            max_seconds: 600.0,
            centre_offset_um: [5.0, -3.0],
            feed_mm_per_min: 1000.0,
        }
    }
}

/// Samples the simulated pod's log holds: a whole circle at 1 kHz (the firmware keeps 1024 and
/// decimates; the host has the memory to keep every sample, so a replay sees them all).
const SERVE_LOG_CAPACITY: usize = 1 << 17;

/// The virtual machine and the pod's own code running on it.
struct VirtualPod {
    opts: ServeOptions,
    pod: PodModel,
    /// The pod's peripherals and acquisition (the simulator's `vmt::pod`).
    sensors: Pod,
    fit: CircleFit,
    log: Box<SampleLog<SERVE_LOG_CAPACITY>>,
    node: CanOpenNode,
    scpi: ScpiServer,
    /// Virtual time, µs.
    t_us: u64,
    /// Angle of the machine on its circle, rad (0 = +X).
    theta: f64,
    /// Angle turned in the current run, rad.
    turned: f64,
}

impl VirtualPod {
    fn new(opts: ServeOptions) -> Self {
        let config = Config::default();
        let sensors = Self::sensors(&opts, &config, 0.0);
        Self {
            node: CanOpenNode::new(config.can_node_id, 0x0BA1_1000),
            pod: PodModel {
                config,
                ..PodModel::default()
            },
            sensors,
            fit: CircleFit::new(Self::fit_config()),
            log: Box::new(SampleLog::new()),
            scpi: ScpiServer::new(),
            opts,
            t_us: 0,
            theta: 0.0,
            turned: 0.0,
        }
    }

    /// The virtual instrument for `config` (bar length, sample rate), homed at angle `theta`
    /// on the circle; ADC noise from the options, the bar at 20 °C.
    fn sensors(opts: &ServeOptions, config: &Config, theta: f64) -> Pod {
        let inst = Instrument {
            bar_noise_um: 0.0,
            adc_noise_counts: opts.noise_counts,
            bar_temp_c: 20.0,
            lvdt_nonlinearity_per_um: 0.0,
            sample_rate_hz: f64::from(config.sample_rate_hz),
        };
        let mut p = Pod::new(f64::from(config.bar_length_mm), &inst, opts.seed);
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

    /// The truth the clients may compare against.
    fn truth_json(&self) -> String {
        format!(
            "{{\"ecc_x_um\":{},\"ecc_y_um\":{},\"bar_length_mm\":{},\"feed_mm_per_min\":{},\"node_id\":{}}}",
            self.opts.centre_offset_um[0],
            self.opts.centre_offset_um[1],
            self.pod.config.bar_length_mm,
            self.opts.feed_mm_per_min,
            self.pod.config.can_node_id
        )
    }

    /// Carries out the application side of accepted commands (the state change first).
    fn execute(&mut self, cmd: SessionCommand) {
        self.pod.apply(cmd);
        match cmd {
            SessionCommand::Arm { .. } => {
                self.fit = CircleFit::new(Self::fit_config());
                self.log.begin_run(LogMeta::from_pod(&self.pod));
                self.pod.results = Default::default();
            }
            SessionCommand::Start => self.turned = 0.0,
            SessionCommand::Stop => self.publish_results(),
            SessionCommand::ConfigChanged => {
                // the virtual instrument follows the new bar length and sample rate
                self.sensors = Self::sensors(&self.opts, &self.pod.config, self.theta);
            }
            SessionCommand::Abort
            | SessionCommand::Reset
            | SessionCommand::StoreSettings
            | SessionCommand::RestoreDefaults => {}
        }
    }

    fn publish_results(&mut self) {
        if let Ok(e) = self.fit.estimate() {
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
    }

    /// One pod sample period of virtual time.
    fn step(&mut self, out: &mut impl FnMut(CanFrame)) {
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
            let dtheta = self.opts.feed_mm_per_min / 60.0 * dt_s / r;
            self.theta += sign * dtheta;
            self.turned += dtheta;
        }
        // commanded (encoder) position on the nominal circle; actual ball centre offset by the truth
        let axes = Self::axes(r, self.theta);
        let [ex, ey] = self.opts.centre_offset_um;
        let truth_um = ((axes[0] + ex * 1e-3).hypot(axes[1] + ey * 1e-3) - r) * 1e3;
        let s = self.sensors.sample(truth_um, &axes);
        if running {
            self.fit.update(&s);
            self.log.record(&s);
            if let Ok(e) = self.fit.estimate() {
                self.pod.live.ecc_x_um = e.e_um[0];
                self.pod.live.ecc_y_um = e.e_um[1];
                self.pod.live.r0_um = e.r0_um;
            }
        }
        self.pod.live.sample_counter = s.seq;
        self.pod.live.delta_l_um = s.delta_l_um;
        self.pod.live.temp_c = s.temp_c;
        self.pod.live.status =
            StatusWord::new(s.flags, self.pod.session, self.node.error_register() != 0);
        self.node.on_sample(s.flags, self.t_us, out);
        self.node.poll(self.t_us, &self.pod, out);
    }
}

/// One client connection (the newest replaces the previous one).
struct Client {
    stream: Option<TcpStream>,
}

impl Client {
    /// Takes a waiting connection; true if one was taken.
    fn accept(&mut self, listener: &TcpListener) -> bool {
        if let Ok((s, _)) = listener.accept() {
            let _ = s.set_nonblocking(true);
            let _ = s.set_nodelay(true);
            self.stream = Some(s);
            return true;
        }
        false
    }
    /// Bytes waiting from the client (empty if none); a closed connection is dropped.
    fn read(&mut self) -> Vec<u8> {
        let mut out = Vec::new();
        let mut buf = [0u8; 4096];
        while let Some(s) = self.stream.as_mut() {
            match s.read(&mut buf) {
                Ok(0) => self.stream = None,
                Ok(n) => out.extend_from_slice(&buf[..n]),
                Err(e) if e.kind() == ErrorKind::WouldBlock => break,
                Err(_) => self.stream = None,
            }
        }
        out
    }
    fn write(&mut self, bytes: &[u8]) {
        if let Some(s) = self.stream.as_mut() {
            // Loopback: a blocking write of a short burst; a failed write drops the client.
            let _ = s.set_nonblocking(false);
            if s.write_all(bytes).is_err() {
                self.stream = None;
                return;
            }
            let _ = s.set_nonblocking(true);
        }
    }
}

fn to_core(f: &SlcanFrame) -> Option<CanFrame> {
    if f.extended || f.remote {
        return None; // the slave uses 11-bit data frames only
    }
    CanFrame::new(u16::try_from(f.id).ok()?, f.data.get(..usize::from(f.dlc))?)
}

fn to_slcan(f: &CanFrame) -> SlcanFrame {
    let mut data = [0u8; 8];
    let p = f.payload();
    data[..p.len()].copy_from_slice(p);
    SlcanFrame {
        id: u32::from(f.id),
        extended: false,
        remote: false,
        dlc: p.len() as u8,
        data,
    }
}

/// Runs the serve mode until `max_seconds` of real time have passed.
pub fn run(opts: ServeOptions) -> io::Result<()> {
    let can_l = TcpListener::bind(("127.0.0.1", opts.can_port))?;
    let usb_l = TcpListener::bind(("127.0.0.1", opts.usb_port))?;
    can_l.set_nonblocking(true)?;
    usb_l.set_nonblocking(true)?;
    let mut vp = VirtualPod::new(opts.clone());
    println!(
        "{{\"can_port\":{},\"usb_port\":{},\"truth\":{}}}",
        can_l.local_addr()?.port(),
        usb_l.local_addr()?.port(),
        vp.truth_json()
    );
    io::stdout().flush()?;
    let (mut can, mut usb) = (Client { stream: None }, Client { stream: None });
    let mut slcan_lines = LineSplitter::default();
    let mut can_open = false;
    let start = Instant::now();
    let mut last = Instant::now();
    let mut backlog_us = 0.0f64;
    while start.elapsed().as_secs_f64() < opts.max_seconds {
        can.accept(&can_l);
        if usb.accept(&usb_l) {
            // A new technician session: the configuration lock is back on (USB disconnect).
            vp.scpi.connection_closed();
        }
        let mut tx: Vec<CanFrame> = Vec::new();
        // CAN side: SLCAN commands and frames
        let bytes = can.read();
        let mut replies = Vec::new();
        for line in slcan_lines.push(&bytes) {
            match parse_line(&line) {
                Ok(SlcanCommand::Open) | Ok(SlcanCommand::ListenOnly) => {
                    can_open = true;
                    replies.extend_from_slice(b"\r");
                }
                Ok(SlcanCommand::Close) => {
                    can_open = false;
                    replies.extend_from_slice(b"\r");
                }
                Ok(SlcanCommand::Transmit(f)) => {
                    if let Some(frame) = to_core(&f) {
                        let cmd = vp
                            .node
                            .on_frame(&frame, &mut vp.pod, vp.t_us, &mut |f| tx.push(f));
                        if let Some(c) = cmd {
                            vp.execute(c);
                        }
                    }
                    replies.extend_from_slice(if f.extended { b"Z\r" } else { b"z\r" });
                }
                Ok(SlcanCommand::Version) => replies.extend_from_slice(b"V0101\r"),
                Ok(SlcanCommand::SerialNumber) => replies.extend_from_slice(b"NBP01\r"),
                Ok(SlcanCommand::Status) => replies.extend_from_slice(b"F00\r"),
                Ok(_) => replies.extend_from_slice(b"\r"),
                Err(_) => replies.push(0x07),
            }
        }
        // USB side: SCPI
        let was_open = usb.stream.is_some();
        let bytes = usb.read();
        if was_open && usb.stream.is_none() {
            vp.scpi.connection_closed();
        }
        if !bytes.is_empty() {
            let mut response = Vec::new();
            let cmds = vp.scpi.feed(&bytes, &mut vp.pod, &vp.log, &mut |b: &[u8]| {
                response.extend_from_slice(b)
            });
            for c in cmds {
                // feed already checked the state; the application side follows
                vp.execute(c);
            }
            usb.write(&response);
        }
        // virtual time
        let now = Instant::now();
        let dt_us = now.duration_since(last).as_secs_f64() * 1e6;
        last = now;
        let running = vp.pod.session == SessionState::Running;
        let speed = if running && !opts.realtime {
            opts.speed
        } else {
            1.0
        };
        backlog_us = (backlog_us + dt_us * speed).min(200_000.0);
        let period_us = 1e6 / f64::from(vp.pod.config.sample_rate_hz);
        while backlog_us >= period_us {
            backlog_us -= period_us;
            vp.step(&mut |f| tx.push(f));
        }
        if can_open {
            for f in &tx {
                replies.extend_from_slice(format_frame(&to_slcan(f)).as_bytes());
            }
        }
        if !replies.is_empty() {
            can.write(&replies);
        }
        std::thread::sleep(Duration::from_micros(500));
    }
    Ok(())
}
