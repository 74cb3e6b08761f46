//! The application task: it drives the pod ([`Pod`]: the core's [`App`], the CANopen node, the
//! SCPI server, the sample log and the USB sample stream, statics built in place at boot) and
//! wires it to the queues. Per LVDT
//! block: temperature codes, probe edges and the encoder counters go to the application with
//! the block, the node sees the sample's flags; CAN frames and USB bytes go to the node and
//! the server, whose answers go back out; every millisecond the node is polled. It takes no
//! decision of its own: every one is the application's.

use core::cell::UnsafeCell;
use core::mem::MaybeUninit;
use core::sync::atomic::Ordering;

use embassy_futures::select::{Either4, select4};
use embassy_stm32::exti::ExtiInput;
use embassy_stm32::mode::Blocking;
use embassy_time::{Duration, Instant, Ticker};
use static_cell::StaticCell;

use ballpod::acquisition::probe::TriggerOutcome;
use ballpod::app::log::{LOG_CAPACITY, SampleLog};
use ballpod::app::{App, DeviceCounter, Recorder, SettingsRequest};
use ballpod::config::Config;
use ballpod::protocol::canopen::{CanFrame, CanOpenNode};
use ballpod::protocol::scpi::ScpiServer;
use ballpod::protocol::stream::SampleStream;
use ballpod::settings;

use super::settings::SettingsPages;
use super::state::{self, UsbEvent};
use super::{Overruns, diagnostics, lvdt, probe, thermistor};

/// Bytes of the stream's ring (the USB task drains it through `STREAM_TX`).
const STREAM_RING: usize = 2048;
/// How often the device counters are refreshed, ms (the stack scan takes ≈ 0.2 ms).
const DEVICE_COUNTERS_EVERY_MS: u32 = 100;

/// Samples not logged because a log download was in progress (the log is one snapshot while
/// it is downloaded; the stream still has them).
pub static LOG_PAUSED_SAMPLES: Overruns = Overruns::new();

/// Bytes of the application's state ([`App`], in [`Pod`]), for the size report
/// (`.ci/size-report` reads this word from the ELF): 4 bytes of flash.
#[used]
#[unsafe(no_mangle)]
static BALLPOD_APP_STATE_BYTES: u32 = core::mem::size_of::<App>() as u32;

/// What the boot found, for the protocols to report.
pub struct BootReport {
    /// CANopen EMCY (code, reason) of the previous run's end, if it was a fault.
    pub can: Option<(u16, u8)>,
    /// The same for `SYSTem:ERRor?`.
    pub usb: Option<&'static str>,
    /// Why a stored configuration was rejected, if one was (`settings::Loaded::rejected`).
    pub settings_rejected: Option<ballpod::config::ConfigError>,
}

/// Where the application records runs: the log (paused while it is downloaded: the samples it
/// misses are counted; the stream still has them) and the USB stream.
struct Recorders<'a> {
    log: &'a mut SampleLog<LOG_CAPACITY>,
    stream: &'a mut SampleStream<STREAM_RING>,
    log_paused: bool,
}

impl Recorder for Recorders<'_> {
    fn begin_run(&mut self, meta: &ballpod::app::RunMeta) {
        if !self.log_paused {
            self.log.begin_run(meta);
        }
        self.stream.begin_run(meta);
    }
    fn sample(&mut self, s: &ballpod::acquisition::Sample) {
        if self.log_paused {
            LOG_PAUSED_SAMPLES.count();
        } else {
            self.log.sample(s);
        }
        self.stream.sample(s);
    }
    fn touch(&mut self, t: &ballpod::app::Touch) {
        if !self.log_paused {
            self.log.touch(t);
        }
        self.stream.touch(t);
    }
    fn end_run(&mut self, end: &ballpod::app::RunEnd) {
        if !self.log_paused {
            self.log.end_run(end);
        }
        self.stream.end_run(end);
    }
}

/// The pod's state: the application, the log, the stream and the two protocol servers. Each
/// lives in a `static` and is built there in place at boot ([`Pod::new`]): the task's future
/// holds only these references, so neither spawning it nor polling it builds the 50 KiB of
/// state on the stack (book "Performance and memory", §Stack).
pub struct Pod {
    app: &'static mut App,
    log: &'static mut SampleLog<LOG_CAPACITY>,
    stream: &'static mut SampleStream<STREAM_RING>,
    node: &'static mut CanOpenNode,
    scpi: &'static mut ScpiServer,
}

static APP: StaticCell<App> = StaticCell::new();
static STREAM: StaticCell<SampleStream<STREAM_RING>> = StaticCell::new();
static NODE: StaticCell<CanOpenNode> = StaticCell::new();
static SCPI: StaticCell<ScpiServer> = StaticCell::new();
/// The sample log's place, in CCM SRAM (`memory.x`: CPU-only memory, 22 KiB more stack in RAM).
/// Not a `StaticCell`: its taken flag would lie in memory the start-up code does not initialise.
#[unsafe(link_section = ".ccmram.LOG")]
static LOG: Ccm<SampleLog<LOG_CAPACITY>> = Ccm(UnsafeCell::new(MaybeUninit::uninit()));

/// A place in `.ccmram`, which the start-up code leaves as the reset found it.
struct Ccm<T>(UnsafeCell<MaybeUninit<T>>);

// SAFETY: the one reference to the place is taken once, by `Pod::new` (below).
unsafe impl<T> Sync for Ccm<T> {}

impl Pod {
    /// The pod with configuration `cfg`, serial number `serial` and what the boot found
    /// (reported by both protocols). Called once, at boot (a second call panics: each cell is
    /// initialised once).
    pub fn new(cfg: Config, serial: u32, boot: BootReport) -> Self {
        // `APP.uninit()` panics on a second call: what follows runs once.
        let app = App::init(APP.uninit(), cfg, super::encoders::COUNTER_BITS);
        // SAFETY: the only reference ever taken to the log's place (this runs once, above).
        let log = unsafe { &mut *LOG.0.get() };
        // CCM SRAM holds what the reset left: zeroed first, so that no read (a struct's padding
        // included) ever meets a word that was never written (a parity error where the SRAM
        // parity option is set).
        // SAFETY: the place is valid for writes of one `SampleLog`.
        unsafe { log.as_mut_ptr().write_bytes(0, 1) };
        let log = SampleLog::init(log);
        let node = NODE.init(CanOpenNode::new(app.config().can_node_id, serial));
        if let Some((code, reason)) = boot.can {
            node.report_boot_error(code, reason);
        }
        let scpi = SCPI.init(ScpiServer::new());
        scpi.set_pull_download(true);
        scpi.set_serial(serial);
        if let Some(text) = boot.usb {
            scpi.push_device_error(text);
        }
        ballpod::protocol::report_rejected_settings(boot.settings_rejected, node, scpi);
        Self {
            app,
            log,
            stream: STREAM.init(SampleStream::new()),
            node,
            scpi,
        }
    }
}

/// Runs the application.
#[embassy_executor::task]
pub async fn compute_task(
    pod: Pod,
    _encoders: super::encoders::Encoders,
    probe_in: ExtiInput<'static, Blocking>,
    mut flash: SettingsPages,
) {
    let Pod {
        app,
        log,
        stream,
        node,
        scpi,
    } = pod;
    let can_out = &mut |f: CanFrame| {
        if state::CAN_TX.try_send(f).is_err() {
            state::CAN_TX_OVERRUNS.count();
        }
    };
    let usb_out = &mut |b: &[u8]| {
        if state::USB_TX.try_write(b).unwrap_or(0) < b.len() {
            state::USB_TX_OVERRUNS.count();
        }
    };
    let mut ticker = Ticker::every(Duration::from_millis(1));
    let mut ticks = 0u32;
    loop {
        let now = Instant::now().as_micros();
        match select4(
            lvdt::BLOCKS.receive(),
            state::CAN_RX.receive(),
            state::USB_RX.receive(),
            ticker.next(),
        )
        .await
        {
            Either4::First(block) => {
                while let Ok(code) = thermistor::CODES.try_receive() {
                    if app.on_thermistor(code).is_err() {
                        defmt::warn!("thermistor fault, code {}", code);
                    }
                }
                let mut rec = Recorders {
                    log_paused: scpi.download_pending(),
                    log: &mut *log,
                    stream: &mut *stream,
                };
                while let Ok(edge) = probe::EDGES.try_receive() {
                    let o = app.on_probe_edge(edge.t_us, edge.raw, &mut rec);
                    if !matches!(o, TriggerOutcome::Accepted(_)) {
                        defmt::debug!("probe edge rejected");
                    }
                }
                // NC contact to ground with pull-up: seated reads low.
                app.on_probe_level(block.t_us, probe_in.is_low());
                // the encoder counts latched at the block's centre (lvdt::BlockLatchIsr)
                let lost = super::lost_upstream();
                let s = app.on_raw_sample(block.t_us, block.reading, block.raw, lost, &mut rec);
                node.on_sample(s.flags, now, can_out);
                super::safety::check_in(super::safety::Task::Compute);
            }
            Either4::Second(frame) => node.on_frame(&frame, app, now, can_out),
            Either4::Third(UsbEvent::Bytes { data, len }) => {
                scpi.feed(data.get(..len).unwrap_or(&[]), app, log, usb_out);
            }
            Either4::Third(UsbEvent::CommandClosed) => scpi.connection_closed(),
            Either4::Third(UsbEvent::StreamOpened) => stream.set_enabled(true),
            Either4::Third(UsbEvent::StreamClosed) => stream.set_enabled(false),
            Either4::Fourth(()) => {
                ticks = ticks.wrapping_add(1);
                // the LVDT task acquires in the mode the configuration names now
                lvdt::MODE.store(app.config().lvdt_input as u8, Ordering::Relaxed);
                if ticks.is_multiple_of(DEVICE_COUNTERS_EVERY_MS) {
                    let mut c = diagnostics::device_counters();
                    c.set(DeviceCounter::StreamLinesDropped, stream.dropped_lines());
                    app.set_device_counters(c);
                }
                if let Some(bus) = state::CAN_BUS.try_take() {
                    node.on_bus_state(bus, now, can_out);
                }
                node.poll(now, app, can_out);
            }
        }
        // A run armed or stopped by the commands just handled is recorded now, not at the
        // next sample.
        app.flush(&mut Recorders {
            log_paused: scpi.download_pending(),
            log: &mut *log,
            stream: &mut *stream,
        });
        // A pulled log download goes out as the command port takes it.
        let mut packet = [0u8; state::PACKET];
        // (0 bytes: the block's length is being counted, a few lines a pull: the task goes round
        // its loop, samples first, and counts on at the next turn)
        while scpi.download_pending() && state::USB_TX.free_capacity() >= state::PACKET {
            let n = scpi.pull_download(log, &mut packet);
            if n == 0 {
                break;
            }
            usb_out(packet.get(..n).unwrap_or(&[]));
        }
        // The stream's text goes out as the stream port takes it.
        let room = state::STREAM_TX.free_capacity().min(packet.len());
        let n = stream.pull(packet.get_mut(..room).unwrap_or(&mut []));
        let _ = state::STREAM_TX.try_write(packet.get(..n).unwrap_or(&[]));
        match app.take_settings_request() {
            Some(SettingsRequest::Store) => {
                let ok = save(&mut flash, app.config());
                app.settings_stored(ok);
            }
            Some(SettingsRequest::RestoreDefaults) => {
                // CiA 301 0x1011: the defaults take effect at the next reset.
                let ok = save(&mut flash, &Config::default());
                app.settings_stored(ok);
            }
            None => {}
        }
        if app.job_pending() {
            // The seed 002 identification: seconds of f64 on the M4 (the queues fill and are
            // counted meanwhile; no run is running: the procedure's last run just ended).
            let t0 = Instant::now();
            app.run_pending_job();
            defmt::info!("identification took {} ms", t0.elapsed().as_millis());
        }
    }
}

/// Stores a configuration in the next settings slot (logged; on failure the previous
/// settings are still the ones loaded at boot). Returns whether it worked.
fn save(flash: &mut SettingsPages, cfg: &Config) -> bool {
    match settings::store(flash, cfg) {
        Ok(s) => {
            defmt::info!(
                "settings stored in slot {}, sequence {}",
                s.slot.index(),
                s.sequence
            );
            true
        }
        Err(e) => {
            defmt::error!("settings not stored: {}", super::settings::store_reason(&e));
            false
        }
    }
}
