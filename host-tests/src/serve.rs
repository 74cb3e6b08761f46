//! `sim --serve`: the simulated pod on loopback TCP, for third-party clients acting as the CNC
//! and the technician's PC (issue 5 items 5 and 6).
//!
//! - CAN as **SLCAN** (Lawicel ASCII) on one port: `python-can`'s `slcan` interface with
//!   `channel='socket://127.0.0.1:PORT'`, and the `canopen` package on top of it, talk to the
//!   core's CANopen slave (`ballpod::protocol::canopen`).
//! - The USB command port as a raw TCP byte stream on another port, to the core's SCPI server
//!   (`ballpod::protocol::scpi`), e.g. `serial.serial_for_url('socket://127.0.0.1:PORT')` or
//!   PyVISA's `TCPIP::127.0.0.1::PORT::SOCKET`.
//! - The USB sample stream (every sample of every run, the pod's CSV text) on a third port:
//!   connect, and the runs that start from then on arrive whole.
//!
//! The pod runs in **virtual time** ([`crate::vmt::virtual_pod`]): when a client starts a run,
//! the virtual CNC moves through the armed pattern with the pod's configured set-up and ends
//! the run at the end of its motion ([`crate::vmt::motion`]); its sensors produce 12-bit LVDT
//! ADC blocks, encoder counters and a thermistor code, which go through the pod's own
//! application at the configured sample rate. The machine's virtual time tracks real time
//! while idle and runs `speed` times faster while a run is running, so a full circle takes
//! seconds; `--realtime` paces it 1:1 throughout. The protocols run on real time
//! ([`VirtualPod::set_protocol_time`]): heartbeats, SDO timeouts and event timers keep their
//! real periods at any speed.
//!
//! One client per port (a second one is told so and closed); the loop never waits for a client:
//! unread bytes wait in a bounded queue, downloads and the stream are produced only as they
//! are read, and a client that stops reading is cut.
//!
//! At start the server prints one JSON line on stdout: the ports and the truth
//! (`{"can_port":…,"usb_port":…,"stream_port":…,"node_id":…,"truth":{…}}`). It stops after
//! `max_seconds` of real time.
//!
//! **Part programs instead of a client** (`--program FILE … --m-codes DIR`): the served CNC
//! runs the programs one after the other (cycle start `cycle_start_s` after the server is up)
//! as LinuxCNC's task does ([`crate::vmt::nc_program`]) on the machine of the pod's pattern
//! ([`crate::vmt::motion::machine_at`]), and at each user M-code runs `DIR/M<code> P Q` with
//! `BALLPOD_CAN` (or, with `m_codes_via_usb`, `BALLPOD_SCPI`) naming this server's port and
//! `BALLPOD_NODE` the pod's node-ID, the motion waiting until it exits (its output goes to
//! stderr). When the last program ends — or an M-code fails, which stops it — a second JSON
//! line says so: `{"program":"done","user_m_codes":N}` or
//! `{"program":"stopped","reason":"…"}`.

use std::collections::VecDeque;
use std::io::{self, ErrorKind, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::time::{Duration, Instant};

use ballpod::app::SessionState;
use ballpod::protocol::canopen::CanFrame;

use crate::vmt::motion::machine_at;
use crate::vmt::nc_program::{CncStep, ProgramCnc};
use crate::vmt::sensors::Instrument;
use crate::vmt::virtual_pod::{VirtualPod, VirtualSetup};
use ballpod::protocol::slcan::{LineSplitter, SlcanPort};

/// Options of the serve mode.
#[derive(Clone, Debug)]
pub struct ServeOptions {
    /// SLCAN port (0: any free port).
    pub can_port: u16,
    /// SCPI port (0: any free port).
    pub usb_port: u16,
    /// Sample stream port (0: any free port).
    pub stream_port: u16,
    /// Pace the running session at real time too (default: `speed` × real time).
    pub realtime: bool,
    /// Virtual-time speed-up while a session runs.
    pub speed: f64,
    /// Noise seed.
    pub seed: u64,
    /// Bar noise σ per sample, µm.
    pub bar_noise_um: f64,
    /// Stop after this many seconds of real time.
    pub max_seconds: f64,
    /// The served machine (`--machine`), instead of the default truth's.
    pub machine: Option<crate::vmt::machine::MachineFile>,
    /// The settings the pod boots with, stored in its settings pages (`--set`); `None`: erased
    /// pages, the defaults.
    pub settings: Option<ballpod::config::Config>,
    /// The part programs the served CNC runs one after the other, and the directory of their
    /// user M-codes' programs.
    pub program: Option<(Vec<std::path::PathBuf>, std::path::PathBuf)>,
    /// The operator presses cycle start this long after the server is up, s (time for a
    /// stream reader to connect).
    pub cycle_start_s: f64,
    /// The user M-codes reach the pod over the USB command port (SCPI) instead of CAN.
    pub m_codes_via_usb: bool,
}

impl Default for ServeOptions {
    fn default() -> Self {
        Self {
            can_port: 0,
            usb_port: 0,
            stream_port: 0,
            realtime: false,
            speed: 20.0,
            seed: 1,
            bar_noise_um: 0.2,
            max_seconds: 600.0,
            settings: None,
            program: None,
            cycle_start_s: 1.0,
            m_codes_via_usb: false,
            machine: None,
        }
    }
}

/// The part program the served CNC runs (`--program`), and the user M-code running now.
struct ServedProgram {
    cnc: ProgramCnc,
    /// The programs still to run, in order (the operator loads each and presses cycle start).
    next_files: std::collections::VecDeque<std::path::PathBuf>,
    /// When the operator presses cycle start.
    cycle_start: Instant,
    dir: std::path::PathBuf,
    running: Option<(u16, std::process::Child)>,
    /// This server's SLCAN and USB command ports, and whether the M-codes reach the pod over
    /// the latter.
    ports: (u16, u16),
    via_usb: bool,
    ran: u32,
    over: bool,
}

impl ServedProgram {
    /// True while the machine moves (not at an M-code, not over).
    fn moving(&self) -> bool {
        self.running.is_none() && !self.over && Instant::now() >= self.cycle_start
    }

    /// One sample period: the machine along the program (standing while an M-code runs);
    /// starts the M-code it reaches. Returns the frames the node sent.
    fn step(&mut self, vp: &mut VirtualPod, dt_s: f64) -> Vec<CanFrame> {
        if self.over || self.running.is_some() || Instant::now() < self.cycle_start {
            return at_rest(vp);
        }
        match self.cnc.step(dt_s) {
            CncStep::At { axes, sense } => sample(vp, &axes, sense),
            CncStep::UserM { code, p, q } => {
                let path = self.dir.join(format!("M{code}"));
                let mut command = std::process::Command::new(&path);
                command
                    .arg(format!("{p:.6}"))
                    .arg(format!("{q:.6}"))
                    .stdout(std::process::Stdio::from(io::stderr()));
                // this server's port and the pod's node-ID, as the control's environment would
                let (can, usb) = self.ports;
                if self.via_usb {
                    command.env("BALLPOD_SCPI", format!("socket://127.0.0.1:{usb}"));
                } else {
                    command
                        .env("BALLPOD_CAN", format!("slcan:socket://127.0.0.1:{can}"))
                        .env("BALLPOD_NODE", vp.app.config().can_node_id.to_string());
                }
                let child = command.spawn();
                match child {
                    Ok(c) => self.running = Some((code, c)),
                    Err(e) => self.stop(&format!("M{code}: {}: {e}", path.display())),
                }
                at_rest(vp)
            }
            CncStep::Done => {
                if let Some(next) = self.next_files.pop_front() {
                    // the next program, from where this one left the machine
                    let at = vp.axes_now();
                    match ProgramCnc::load(&next, Some(at)) {
                        Ok(cnc) => self.cnc = cnc,
                        Err(e) => self.stop(&e),
                    }
                    return at_rest(vp);
                }
                self.over = true;
                println!("{{\"program\":\"done\",\"user_m_codes\":{}}}", self.ran);
                let _ = io::stdout().flush();
                at_rest(vp)
            }
        }
    }

    /// Before the sample periods of a loop turn: the program goes on once the running
    /// M-code's program has exited 0, and stops when it failed.
    fn poll_user_m(&mut self) {
        let Some((code, child)) = self.running.as_mut() else {
            return;
        };
        match child.try_wait() {
            Ok(None) => {}
            Ok(Some(status)) => {
                let code = *code;
                self.running = None;
                self.ran += 1;
                if status.success() {
                    self.cnc.resume();
                } else {
                    self.stop(&format!("M{code} exited with {status}"));
                }
            }
            Err(e) => {
                let code = *code;
                self.running = None;
                self.stop(&format!("M{code}: {e}"));
            }
        }
    }

    /// The program stops (an M-code failed): the machine stands.
    fn stop(&mut self, reason: &str) {
        self.over = true;
        eprintln!("serve: the program stops: {reason}");
        let reason = reason.replace('\\', "/").replace('"', "'");
        println!("{{\"program\":\"stopped\",\"reason\":\"{reason}\"}}");
        let _ = io::stdout().flush();
    }
}

/// One sample period with the served machine at `axes` moving in `sense`: the bar of the pod's
/// pattern reads the machine's true ΔL there. Returns the frames the node sent.
fn sample(vp: &mut VirtualPod, axes: &[f64; 5], sense: f64) -> Vec<CanFrame> {
    let cfg = vp.app.running_config();
    // the technician mounted the bar the configuration names (its expansion is modelled on it)
    vp.sensors.set_bar_length(f64::from(cfg.bar_length_mm));
    let pattern = vp.app.pattern();
    let (dl, axes) = match machine_at(vp.truth(), &cfg, pattern, axes, sense) {
        Ok(m) => (m.dl_um, m.axes),
        // nothing set up yet: the bar reads its nominal
        Err(_) => (0.0, *axes),
    };
    vp.sample_at(dl, &axes).1
}

/// One sample period with the served machine standing where it is.
fn at_rest(vp: &mut VirtualPod) -> Vec<CanFrame> {
    let at = vp.axes_now();
    sample(vp, &at, 0.0)
}

/// Bytes a client may have waiting to be read before the pod stops producing for it (a log
/// download or the sample stream waits, as USB flow control makes the firmware wait).
const HIGH_WATER: usize = 1 << 16;
/// Bytes a client may leave unread at most: beyond, it is cut (CAN replies and heartbeats keep
/// coming whether it reads or not).
const MAX_QUEUED: usize = 1 << 20;
/// A client that reads nothing of its waiting bytes for this long is cut (seconds).
const STALL_S: f64 = 10.0;

/// The connection of one port: one client at a time (a second one is told so and closed,
/// never swapped in silently); writes never block the pod — bytes wait in a bounded queue, and
/// a client that stops reading is cut and counted.
struct Client {
    /// Which port (for the messages).
    port: &'static str,
    stream: Option<TcpStream>,
    /// Bytes waiting to be written.
    queue: VecDeque<u8>,
    /// When the queue last drained by a byte or more (or was empty).
    progress: Instant,
    /// Connections refused because the port was taken.
    refused: u32,
    /// Clients cut because they stopped reading.
    cut: u32,
}

impl Client {
    fn new(port: &'static str) -> Self {
        Self {
            port,
            stream: None,
            queue: VecDeque::new(),
            progress: Instant::now(),
            refused: 0,
            cut: 0,
        }
    }

    /// Takes a waiting connection if the port is free; a connection while it is taken gets
    /// `busy` and is closed. True if a new client was taken.
    fn accept(&mut self, listener: &TcpListener, busy: &[u8]) -> bool {
        let mut taken = false;
        while let Ok((mut s, _)) = listener.accept() {
            // a client that has hung up frees the port, even before its close was read
            let mut probe = [0u8; 1];
            if let Some(old) = &self.stream
                && matches!(old.peek(&mut probe), Ok(0))
            {
                self.drop_client();
            }
            if self.stream.is_none() {
                let _ = s.set_nonblocking(true);
                let _ = s.set_nodelay(true);
                self.stream = Some(s);
                self.queue.clear();
                self.progress = Instant::now();
                taken = true;
            } else {
                // a short message into an empty socket buffer does not block
                let _ = s.write_all(busy);
                self.refused += 1;
                eprintln!(
                    "serve: {} port: a second client refused (one at a time)",
                    self.port
                );
            }
        }
        taken
    }

    fn connected(&self) -> bool {
        self.stream.is_some()
    }

    /// Room for more produced bytes (below the high-water mark).
    fn has_room(&self) -> bool {
        self.connected() && self.queue.len() < HIGH_WATER
    }

    /// Bytes waiting from the client (empty if none); a closed connection is dropped.
    fn read(&mut self) -> Vec<u8> {
        let mut out = Vec::new();
        let mut buf = [0u8; 4096];
        while let Some(s) = self.stream.as_mut() {
            match s.read(&mut buf) {
                Ok(0) => self.drop_client(),
                Ok(n) => out.extend_from_slice(&buf[..n]),
                Err(e) if e.kind() == ErrorKind::WouldBlock => break,
                Err(_) => self.drop_client(),
            }
        }
        out
    }

    /// Queues bytes for the client (dropped if none is connected).
    fn send(&mut self, bytes: &[u8]) {
        if self.connected() {
            self.queue.extend(bytes);
        }
    }

    /// Writes what the socket takes now, without waiting; cuts a client that lets its queue
    /// overflow or stall.
    fn flush(&mut self) {
        while let Some(s) = self.stream.as_mut() {
            let (head, _) = self.queue.as_slices();
            if head.is_empty() {
                self.progress = Instant::now();
                return;
            }
            match s.write(head) {
                Ok(0) => break,
                Ok(n) => {
                    self.queue.drain(..n);
                    self.progress = Instant::now();
                }
                Err(e) if e.kind() == ErrorKind::WouldBlock => break,
                Err(_) => {
                    self.drop_client();
                    return;
                }
            }
        }
        if self.connected()
            && (self.queue.len() > MAX_QUEUED || self.progress.elapsed().as_secs_f64() > STALL_S)
        {
            self.cut += 1;
            eprintln!(
                "serve: {} port: client cut ({} bytes unread)",
                self.port,
                self.queue.len()
            );
            self.drop_client();
        }
    }

    fn drop_client(&mut self) {
        self.stream = None;
        self.queue.clear();
    }
}

/// Runs the serve mode until `max_seconds` of real time have passed.
pub fn run(opts: ServeOptions) -> io::Result<()> {
    let can_l = TcpListener::bind(("127.0.0.1", opts.can_port))?;
    let usb_l = TcpListener::bind(("127.0.0.1", opts.usb_port))?;
    let stream_l = TcpListener::bind(("127.0.0.1", opts.stream_port))?;
    can_l.set_nonblocking(true)?;
    usb_l.set_nonblocking(true)?;
    stream_l.set_nonblocking(true)?;
    let mut setup = VirtualSetup {
        seed: opts.seed,
        instrument: Instrument {
            bar_noise_um: opts.bar_noise_um,
            ..Instrument::default()
        },
        ..VirtualSetup::default()
    };
    if let Some(m) = opts.machine {
        setup.truth.machine = m;
    }
    let mut flash = crate::flash_model::FlashModel::erased();
    if let Some(c) = &opts.settings {
        ballpod::settings::store(&mut flash, c)
            .map_err(|e| io::Error::other(format!("--set: the settings were not stored: {e:?}")))?;
    }
    let mut vp: VirtualPod = VirtualPod::boot(setup, flash);
    vp.stream_reader(false);
    let mut program = match &opts.program {
        Some((files, dir)) => {
            let first = files
                .first()
                .ok_or_else(|| io::Error::other("--program: none"))?;
            let cnc = ProgramCnc::load(first, None).map_err(io::Error::other)?;
            // referenced where the bar is mounted: the axes read the program's positions
            vp.home(&cnc.start());
            Some(ServedProgram {
                cnc,
                next_files: files.iter().skip(1).cloned().collect(),
                cycle_start: Instant::now() + Duration::from_secs_f64(opts.cycle_start_s.max(0.0)),
                dir: dir.clone(),
                running: None,
                ports: (can_l.local_addr()?.port(), usb_l.local_addr()?.port()),
                via_usb: opts.m_codes_via_usb,
                ran: 0,
                over: false,
            })
        }
        None => None,
    };
    let truth = serde_json::to_string(vp.truth()).map_err(io::Error::other)?;
    println!(
        "{{\"can_port\":{},\"usb_port\":{},\"stream_port\":{},\"node_id\":{},\"truth\":{truth}}}",
        can_l.local_addr()?.port(),
        usb_l.local_addr()?.port(),
        stream_l.local_addr()?.port(),
        vp.app.config().can_node_id,
    );
    io::stdout().flush()?;
    let (mut can, mut usb) = (Client::new("CAN"), Client::new("USB"));
    let mut stream = Client::new("stream");
    let mut slcan_lines = LineSplitter::default();
    let mut slcan = SlcanPort::default();
    slcan.set_node_bit_rate(vp.app.config().can_bitrate.bits_per_s());
    let start = Instant::now();
    let mut last = Instant::now();
    let mut backlog_us = 0.0f64;
    while start.elapsed().as_secs_f64() < opts.max_seconds {
        // the protocols run on real time whatever the machine's speed
        vp.set_protocol_time(start.elapsed().as_micros() as u64);
        if can.accept(&can_l, b"\x07") {
            slcan_lines = LineSplitter::default();
            slcan.reset();
        }
        if usb.accept(&usb_l, b"port in use by another client\n") {
            // A new technician session: the configuration lock is back on (USB disconnect).
            vp.scpi.connection_closed();
        }
        let mut tx: Vec<CanFrame> = Vec::new();
        // CAN side: SLCAN commands and frames (the core's adapter, as the emulated board's)
        let bytes = can.read();
        let mut replies = Vec::new();
        slcan_lines.push(&bytes, &mut |line| {
            if let Some(frame) = slcan.on_line(line, &mut |r: &[u8]| replies.extend_from_slice(r)) {
                tx.extend(vp.can_frame(&frame));
            }
        });
        // USB side: SCPI
        let was_open = usb.connected();
        let bytes = usb.read();
        if was_open && !usb.connected() {
            vp.usb_disconnected();
        }
        if !bytes.is_empty() {
            let response = vp.usb(&bytes);
            usb.send(&response);
        }
        // A log download is pulled chunk by chunk as the client reads, as the firmware sends
        // USB packets; a client gone mid-download cuts it (counted, reported on the next
        // connection).
        while vp.scpi.download_pending() && usb.has_room() {
            let chunk = vp.pull_download(4096);
            usb.send(&chunk);
        }
        let before_flush = usb.connected();
        usb.flush();
        if before_flush && !usb.connected() {
            // cut for not reading: as a USB disconnect
            vp.usb_disconnected();
        }
        // the sample stream: a new reader gets the runs from now on; what it does not read in
        // time is dropped by the pod's stream ring (counted), never waited for
        if stream.accept(&stream_l, b"# port in use by another reader\n") {
            vp.stream_reader(true);
        }
        if stream.connected() {
            let _ = stream.read();
            if stream.has_room() {
                let bytes = vp.pull_stream(1 << 16);
                stream.send(&bytes);
            }
            stream.flush();
            if !stream.connected() {
                vp.stream_reader(false);
            }
        }
        // virtual time
        let now = Instant::now();
        let dt_us = now.duration_since(last).as_secs_f64() * 1e6;
        last = now;
        // a run running, or the CNC's program of an armed self-triggered run, or the served
        // part program moving (at real time while an M-code's program runs)
        let running = match &program {
            Some(p) => p.moving(),
            None => vp.app.session() == SessionState::Running || vp.moving(),
        };
        let speed = if running && !opts.realtime {
            opts.speed
        } else {
            1.0
        };
        backlog_us = (backlog_us + dt_us * speed).min(200_000.0);
        let period_us = vp.sensors.period_us() as f64;
        if let Some(p) = program.as_mut() {
            p.poll_user_m();
        }
        while backlog_us >= period_us {
            backlog_us -= period_us;
            match program.as_mut() {
                Some(p) => tx.extend(p.step(&mut vp, period_us * 1e-6)),
                None => tx.extend(vp.step()),
            }
        }
        if let Some(rate) = vp.bit_rate_switch() {
            slcan.set_node_bit_rate(rate.bits_per_s());
        }
        if slcan.passes() {
            for f in &tx {
                replies.extend_from_slice(&SlcanPort::frame_line(f));
            }
        }
        can.send(&replies);
        can.flush();
        std::thread::sleep(Duration::from_micros(500));
    }
    eprintln!(
        "serve: clients refused (port taken): CAN {}, USB {}, stream {}; cut (not reading): \
         CAN {}, USB {}, stream {}; stream lines dropped: {}",
        can.refused,
        usb.refused,
        stream.refused,
        can.cut,
        usb.cut,
        stream.cut,
        vp.stream_dropped()
    );
    Ok(())
}
