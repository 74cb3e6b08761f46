//! The pod: the application ([`App`]) with its CANopen node, its SCPI server, its sample log and
//! its sample stream — one type for every shell that runs it: the STM32 board, the emulated
//! board and the simulated pod.
//!
//! # Responsibilities
//! - Takes what a shell moves in — an LVDT block with the encoder counts latched at its centre,
//!   probe edges, thermistor codes, CAN frames, USB bytes, the protocols' time — and hands
//!   it to the application and the protocol servers.
//! - Records runs: the log (paused while it is downloaded, the samples it misses counted),
//!   the stream, and a shell's own recorder beside them (the simulator's whole record).
//! - At the end of each turn ([`Pod::end_of_turn`]): the run begins and ends the commands
//!   caused reach the recorders, the log download and the stream go out as far as their
//!   ports take them.
//! - Hands long work to the shell's lowest priority: a job ([`crate::app::job`]:
//!   [`Pod::start_job`] / [`Pod::finish_job`]) and a settings save ([`Pod::settings_to_store`]).
//!
//! The shells configure peripherals and move bytes, samples and time; they take no decision.

use crate::acquisition::lvdt::BlockReading;
use crate::acquisition::probe::TriggerOutcome;
use crate::acquisition::thermal::ThermistorFault;
use crate::acquisition::{MAX_AXES, Sample};
use crate::app::log::SampleLog;
use crate::app::{
    App, DeviceCounter, DeviceCounters, JobSlot, Recorder, RunEnd, RunMeta, SessionState,
    SettingsRequest, Touch,
};
use crate::config::{CanBitrate, Config, ConfigError};
use crate::protocol::canopen::{BusState, CanFrame, CanOpenNode};
use crate::protocol::scpi::ScpiServer;
use crate::protocol::stream::SampleStream;

/// Packets of a log download formatted in one turn, at most (≈ 26 000 Cortex-M4F instructions
/// a packet on average, book "Hardware": four keep a turn near 0.6 ms, so the samples and the
/// heartbeat wait no longer, and at a turn a sample period they still send 256 kB/s at 1 kHz).
pub const DOWNLOAD_PACKETS_PER_TURN: usize = 4;

/// One sample period as a shell hands it over: the LVDT block and what was latched at its
/// centre.
#[derive(Clone, Copy, Debug)]
pub struct Block {
    /// Time at the block's centre, µs since boot.
    pub t_us: u64,
    /// The block's reading in the mode it was acquired in.
    pub reading: BlockReading,
    /// The hardware encoder counters at the block's centre.
    pub raw: [u32; MAX_AXES],
    /// Sample periods lost upstream since boot (ADC ring, block queue).
    pub lost_total: u32,
    /// The probe's stylus is seated (at rest).
    pub probe_seated: bool,
}

/// What the boot found, for the protocols to report.
#[derive(Clone, Copy, Debug, Default)]
pub struct BootReport {
    /// CANopen EMCY (code, reason) of the previous run's end, if it was a fault.
    pub can: Option<(u16, u8)>,
    /// The same for `SYSTem:ERRor?`.
    pub usb: Option<&'static str>,
    /// Why a stored configuration was rejected, if one was (`settings::Loaded::rejected`).
    pub settings_rejected: Option<ConfigError>,
    /// Settings slots that could not be read (`settings::Loaded::unreadable`: a flash ECC
    /// error, a save cut by a power loss).
    pub settings_unreadable: u32,
    /// What is wrong with the chip's option bytes, if anything
    /// ([`crate::boot::OptionBytes::fault`]).
    pub option_bytes: Option<&'static str>,
}

/// The pod's state, each part where its shell keeps it (the firmware: statics built in place,
/// the log in CCM SRAM; the simulated pod: boxes); `LOG` records of log, `STREAM` bytes of
/// stream ring.
pub struct Pod<'a, const LOG: usize, const STREAM: usize> {
    /// The application.
    pub app: &'a mut App,
    /// The CANopen node.
    pub node: &'a mut CanOpenNode,
    /// The SCPI server of the USB command port (pull-mode log downloads).
    pub scpi: &'a mut ScpiServer,
    /// The sample log (`DATA:LOG?`).
    pub log: &'a mut SampleLog<LOG>,
    /// The sample stream of the USB stream port.
    pub stream: &'a mut SampleStream<STREAM>,
}

/// The pod's recorders: the log (paused while it is downloaded), the stream and the shell's.
struct Recorders<'r, const LOG: usize, const STREAM: usize, T> {
    log: &'r mut SampleLog<LOG>,
    log_paused: bool,
    stream: &'r mut SampleStream<STREAM>,
    tee: &'r mut T,
}

impl<const LOG: usize, const STREAM: usize, T: Recorder> Recorder
    for Recorders<'_, LOG, STREAM, T>
{
    fn begin_run(&mut self, meta: &RunMeta) {
        if !self.log_paused {
            self.log.begin_run(meta);
        }
        self.stream.begin_run(meta);
        self.tee.begin_run(meta);
    }
    // out of line: inlined, it made the application's per-sample function spill
    #[inline(never)]
    fn sample(&mut self, s: &Sample) {
        if self.log_paused {
            self.log.count_paused();
        } else {
            self.log.sample(s);
        }
        self.stream.sample(s);
        self.tee.sample(s);
    }
    fn touch(&mut self, t: &Touch) {
        if !self.log_paused {
            self.log.touch(t);
        }
        self.stream.touch(t);
        self.tee.touch(t);
    }
    fn end_run(&mut self, end: &RunEnd) {
        if !self.log_paused {
            self.log.end_run(end);
        }
        self.stream.end_run(end);
        self.tee.end_run(end);
    }
}

impl<'a, const LOG: usize, const STREAM: usize> Pod<'a, LOG, STREAM> {
    /// The pod of freshly built parts, set up as at boot: the servers know the serial number
    /// `serial`, the SCPI server pulls downloads, and both protocols report what the boot
    /// found (`boot`).
    pub fn boot(
        app: &'a mut App,
        node: &'a mut CanOpenNode,
        scpi: &'a mut ScpiServer,
        log: &'a mut SampleLog<LOG>,
        stream: &'a mut SampleStream<STREAM>,
        serial: u32,
        boot: &BootReport,
    ) -> Self {
        if let Some((code, reason)) = boot.can {
            node.report_boot_error(code, reason);
        }
        scpi.set_pull_download(true);
        scpi.set_serial(serial);
        if let Some(text) = boot.usb {
            scpi.push_device_error(text);
        }
        if let Some(text) = boot.option_bytes {
            let (code, reason) = crate::boot::OptionBytes::EMCY;
            node.report_boot_error(code, reason);
            scpi.push_device_error(text);
        }
        crate::protocol::report_rejected_settings(boot.settings_rejected, node, scpi);
        crate::protocol::report_unreadable_settings(boot.settings_unreadable, node, scpi);
        app.set_settings_unreadable(boot.settings_unreadable);
        Self {
            app,
            node,
            scpi,
            log,
            stream,
        }
    }

    fn recorders<'r, T: Recorder>(
        &'r mut self,
        tee: &'r mut T,
    ) -> (&'r mut App, Recorders<'r, LOG, STREAM, T>) {
        let log_paused = self.scpi.download_pending();
        (
            &mut *self.app,
            Recorders {
                log: &mut *self.log,
                log_paused,
                stream: &mut *self.stream,
                tee,
            },
        )
    }

    /// A thermistor ADC code (12-bit; 0 = shorted, 4095 = open): the bar temperature, °C, or
    /// the fault.
    pub fn on_thermistor(&mut self, code: u16) -> Result<f32, ThermistorFault> {
        self.app.on_thermistor(code)
    }

    /// A probe trigger edge at `t_us` with the encoder counters `raw` latched at it; an
    /// accepted touch of a PROBE run is recorded.
    pub fn on_probe_edge(
        &mut self,
        t_us: u64,
        raw: [u32; MAX_AXES],
        tee: &mut impl Recorder,
    ) -> TriggerOutcome {
        let (app, mut rec) = self.recorders(tee);
        app.on_probe_edge(t_us, raw, &mut rec)
    }

    /// One sample period: the probe level and the block go to the application (the sample is
    /// recorded if a run uses it), the node sees the sample's flags. `now_us` is the
    /// protocols' clock. Returns the sample.
    pub fn on_block(
        &mut self,
        b: &Block,
        now_us: u64,
        tee: &mut impl Recorder,
        can_out: &mut impl FnMut(CanFrame),
    ) -> Sample {
        self.app.on_probe_level(b.t_us, b.probe_seated);
        let (app, mut rec) = self.recorders(tee);
        let s = app.on_raw_sample(b.t_us, b.reading, b.raw, b.lost_total, &mut rec);
        self.node.on_sample(s.flags, now_us, can_out);
        s
    }

    /// A received CAN frame.
    pub fn on_frame(&mut self, frame: &CanFrame, now_us: u64, can_out: &mut impl FnMut(CanFrame)) {
        self.node.on_frame(frame, self.app, now_us, can_out);
    }

    /// The CAN controller lost received frames since the last call (EMCY 0x8110); false: not
    /// reported yet, call again ([`CanOpenNode::on_rx_lost`]).
    pub fn on_can_rx_lost(&mut self, now_us: u64, can_out: &mut impl FnMut(CanFrame)) -> bool {
        self.node.on_rx_lost(now_us, can_out)
    }

    /// The COB-IDs the CANopen node consumes now, for the controller's acceptance filters
    /// ([`CanOpenNode::accepted_ids`]).
    pub fn can_accepted_ids(&self) -> [Option<u16>; 4] {
        self.node.accepted_ids()
    }

    /// The CAN controller's error state changed (bus-off, recovery).
    pub fn on_bus_state(
        &mut self,
        state: BusState,
        now_us: u64,
        can_out: &mut impl FnMut(CanFrame),
    ) {
        self.node.on_bus_state(state, now_us, can_out);
    }

    /// Bytes from the USB host on the command port.
    pub fn on_usb(&mut self, bytes: &[u8], usb_out: &mut impl FnMut(&[u8])) {
        self.scpi.feed(bytes, self.app, self.log, usb_out);
    }

    /// The command port's host went away.
    pub fn usb_closed(&mut self) {
        self.scpi.connection_closed();
    }

    /// A reader opened (`true`) or closed the stream port. A reader that opens while a run is
    /// recorded gets that run's header at once, marked partial if samples of it went before
    /// (a client that connects and arms at once may be taken after the run began).
    pub fn stream_reader(&mut self, open: bool) {
        self.stream.set_enabled(open);
        if let (true, Some((meta, partial))) = (open, self.app.recording()) {
            self.stream.join_run(meta, partial);
        }
    }

    /// The protocols' timers at `now_us` (heartbeat, event timers, SDO timeouts, a log
    /// download nobody reads: [`ScpiServer::watch_download`]): call at least every millisecond.
    pub fn tick(&mut self, now_us: u64, can_out: &mut impl FnMut(CanFrame)) {
        self.node.poll(now_us, self.app, can_out);
        self.scpi.watch_download(now_us);
    }

    /// The bit rate an LSS master activated, once its switch delay has passed: the shell
    /// switches its CAN controller to it ([`CanOpenNode::take_bit_rate_switch`]).
    pub fn bit_rate_switch(&mut self, now_us: u64) -> Option<CanBitrate> {
        self.node.take_bit_rate_switch(now_us)
    }

    /// The device counters: the board's (`board`, what only the shell can see) with the pod's
    /// own (stream lines dropped, samples the log missed during downloads).
    pub fn set_device_counters(&mut self, mut board: DeviceCounters) {
        board.set(
            DeviceCounter::StreamLinesDropped,
            self.stream.dropped_lines(),
        );
        board.set(DeviceCounter::LogPausedSamples, self.log.paused_samples());

        self.app.set_device_counters(board);
    }

    /// The end of a turn (after the frames, bytes or samples just handled): a run the commands
    /// armed or stopped reaches the recorders now, not at the next sample; then the pending log
    /// download goes out through `usb_out`, up to [`DOWNLOAD_PACKETS_PER_TURN`] packets while
    /// `usb_room` says the command port takes a whole `packet`, and the stream's bytes through
    /// `stream_out` as far as `stream_room` says. `packet` is the shell's USB packet buffer.
    pub fn end_of_turn(
        &mut self,
        tee: &mut impl Recorder,
        packet: &mut [u8],
        usb_room: &mut impl FnMut() -> usize,
        usb_out: &mut impl FnMut(&[u8]),
        stream_room: usize,
        stream_out: &mut impl FnMut(&[u8]),
    ) {
        let (app, mut rec) = self.recorders(tee);
        app.flush(&mut rec);
        // (0 bytes: the block's length is being counted, a few lines a pull: the shell goes
        // round its loop, samples first, and counts on at the next turn)
        if self.scpi.download_pending() {
            self.send_download(packet, usb_room, usb_out);
        }
        // at most a packet's worth a turn, straight from the ring; while a run runs only
        // whole packets (the next sample comes within a period: fewer writes, full USB
        // packets), between runs everything
        let pending = self.stream.pending();
        let running = self.app.session() == SessionState::Running;
        if pending >= packet.len() || (pending > 0 && !running) {
            self.stream.drain(stream_room.min(packet.len()), stream_out);
        }
    }

    /// Up to [`DOWNLOAD_PACKETS_PER_TURN`] packets of the pending log download, while the
    /// command port takes a whole `packet` (out of line: the sample path only asks whether a
    /// download is pending).
    #[inline(never)]
    fn send_download(
        &mut self,
        packet: &mut [u8],
        usb_room: &mut impl FnMut() -> usize,
        usb_out: &mut impl FnMut(&[u8]),
    ) {
        for _ in 0..DOWNLOAD_PACKETS_PER_TURN {
            if !(self.scpi.download_pending() && usb_room() >= packet.len()) {
                break;
            }
            let n = self.scpi.pull_download(self.log, packet);
            if n == 0 {
                break;
            }
            usb_out(packet.get(..n).unwrap_or(&[]));
        }
    }

    /// The configuration a client asked to store, once (`*SAV 0`, CANopen 0x1010; the defaults
    /// for 0x1011, to take effect at the next reset). The shell writes it where long work does
    /// no harm and reports with [`App::settings_stored`].
    pub fn settings_to_store(&mut self) -> Option<Config> {
        match self.app.take_settings_request()? {
            SettingsRequest::Store => Some(*self.app.config()),
            SettingsRequest::RestoreDefaults => Some(Config::default()),
        }
    }

    /// Hands the next wanted job to `slot` ([`App::start_job`]).
    pub fn start_job(&mut self, slot: &mut JobSlot) -> bool {
        self.app.start_job(slot)
    }

    /// Takes back a slot whose job ran ([`App::finish_job`]).
    pub fn finish_job(&mut self, slot: &mut JobSlot) {
        self.app.finish_job(slot);
    }
}
