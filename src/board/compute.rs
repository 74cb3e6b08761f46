//! The application task: it drives the core's pod ([`Pod`]: the application, the CANopen
//! node, the SCPI server, the sample log and the USB sample stream, statics built in place at
//! boot) from the queues, at the priority below acquisition, CAN and USB and above the worker
//! (`board::set_priorities`). Per LVDT block: temperature codes, probe edges and the encoder
//! counters go to the pod with the block; CAN frames and USB bytes go to the pod, whose
//! answers go back out; every millisecond the protocols' timers run. At the end of each turn
//! the pod records, sends the log download and the stream on, and long work — a job, a
//! settings save — goes to the worker (`board::worker`), so no command waits for it. It takes
//! no decision of its own: every one is the core's.
//!
//! The emulated board (`host-tests/emu-board`) builds this file as it is, with its own
//! peripherals behind the same module names (`lvdt`, `probe`, `thermistor`, `encoders`,
//! `diagnostics`, `state`, `worker`, `safety`).

use core::cell::UnsafeCell;
use core::mem::MaybeUninit;
use core::sync::atomic::{AtomicU32, Ordering};

use embassy_futures::select::{Either5, select5};
use embassy_time::{Duration, Instant, Ticker};
use static_cell::{ConstStaticCell, StaticCell};

use ballpod::acquisition::probe::TriggerOutcome;
use ballpod::app::log::{LOG_CAPACITY, SampleLog};
use ballpod::app::{App, JobSlot};
use ballpod::config::Config;
use ballpod::pod::{Block, BootReport, Pod};
use ballpod::protocol::canopen::{CanFrame, CanOpenNode};
use ballpod::protocol::scpi::ScpiServer;
use ballpod::protocol::stream::SampleStream;

use super::state::{self, UsbEvent};
use super::worker::{self, Done, Work};
use super::{block, diagnostics, probe_queue, thermistor};

/// Bytes of the stream's ring (the USB task drains it through `STREAM_TX`).
const STREAM_RING: usize = ballpod::protocol::stream::FIRMWARE_RING_BYTES;
/// How often the device counters are refreshed, ms (the stack scan takes ≈ 0.2 ms).
const DEVICE_COUNTERS_EVERY_MS: u32 = 100;

/// Bytes of the application's state ([`App`], in [`Pod`]), for the size report
/// (`.ci/size-report` reads this word from the ELF): 4 bytes of flash.
#[used]
#[unsafe(no_mangle)]
static BALLPOD_APP_STATE_BYTES: u32 = core::mem::size_of::<App>() as u32;

/// The pod's state: the application, the log, the stream and the two protocol servers, and
/// the slot its jobs run in. Each
/// lives in a `static` and is built there in place at boot ([`Pod::new`]): the task's future
/// holds only these references, so neither spawning it nor polling it builds the 50 KiB of
/// state on the stack (book "Performance and memory", §Stack).
pub struct PodState {
    pod: Pod<'static, LOG_CAPACITY, STREAM_RING>,
    jobs: &'static mut JobSlot,
}

static APP: StaticCell<App> = StaticCell::new();
/// The stream ring, initialised at compile time (all zeros: `.bss`): built by `init` it would be
/// a 5 KiB value in main's frame at boot, the stack's deepest point.
static STREAM: ConstStaticCell<SampleStream<STREAM_RING>> =
    ConstStaticCell::new(SampleStream::new());
static NODE: StaticCell<CanOpenNode> = StaticCell::new();
static SCPI: StaticCell<ScpiServer> = StaticCell::new();
/// The sample log's place, in CCM SRAM (`memory.x`: CPU-only memory, 22 KiB more stack in RAM).
/// Not a `StaticCell`: its taken flag would lie in memory the start-up code does not initialise.
#[unsafe(link_section = ".ccmram.LOG")]
static LOG: Ccm<SampleLog<LOG_CAPACITY>> = Ccm(UnsafeCell::new(MaybeUninit::uninit()));
/// The job slot's place, in CCM SRAM beside the log (a copy of the circle test: 14 KiB).
#[unsafe(link_section = ".ccmram.JOBS")]
static JOBS: Ccm<JobSlot> = Ccm(UnsafeCell::new(MaybeUninit::uninit()));

/// A place in `.ccmram`, which the start-up code leaves as the reset found it.
struct Ccm<T>(UnsafeCell<MaybeUninit<T>>);

// SAFETY: the one reference to each place is taken once, by `PodState::new` (below).
unsafe impl<T> Sync for Ccm<T> {}

/// The place `ccm` zeroed (CCM SRAM holds what the reset left: no read, a struct's padding
/// included, ever meets a word that was never written — a parity error where the SRAM parity
/// option is set).
///
/// # Safety
/// `place` is a `Ccm`'s, and this is the only reference ever taken to it.
unsafe fn zeroed<T>(place: *mut MaybeUninit<T>) -> &'static mut MaybeUninit<T> {
    // SAFETY: the caller's; the place is valid for writes of one `T`.
    let place = unsafe { &mut *place };
    // SAFETY: as above.
    unsafe { place.as_mut_ptr().write_bytes(0, 1) };
    place
}

impl PodState {
    /// The pod with configuration `cfg`, serial number `serial` and what the boot found
    /// (reported by both protocols). Called once, at boot (a second call panics: each cell is
    /// initialised once).
    pub fn new(cfg: Config, serial: u32, boot: BootReport) -> Self {
        // `APP.uninit()` panics on a second call: what follows runs once.
        let app = App::init(APP.uninit(), cfg, super::encoders::COUNTER_BITS);
        // SAFETY: the only references ever taken to these places (this runs once, above).
        let (log, jobs) = unsafe { (zeroed(LOG.0.get()), zeroed(JOBS.0.get())) };
        let log = SampleLog::init(log);
        let jobs = JobSlot::init(jobs);
        let node = NODE.init(CanOpenNode::new(app.config().can_node_id, serial));
        let scpi = SCPI.init(ScpiServer::new());
        let stream = STREAM.take();
        Self {
            pod: Pod::boot(app, node, scpi, log, stream, serial, &boot),
            jobs,
        }
    }
}

/// Runs the pod.
#[embassy_executor::task]
pub async fn compute_task(
    state: PodState,
    _encoders: super::encoders::Encoders,
    probe_in: super::probe::ProbeInput,
) {
    let PodState { mut pod, jobs } = state;
    // the job slot while the pod holds it (`None`: the worker runs its job)
    let mut jobs = Some(jobs);
    // a settings save is with the worker
    let mut storing = false;
    let can_out = &mut |f: CanFrame| {
        if state::CAN_TX.try_send(f).is_err() {
            state::CAN_TX_OVERRUNS.count();
        }
    };
    // a piece of a response goes out whole or not at all (never cut inside): a host that does
    // not read its answers loses whole pieces once the pipe (2 KiB) is full, counted
    let usb_out = &mut |b: &[u8]| {
        if state::USB_TX.free_capacity() < b.len()
            || state::write_all_now(&state::USB_TX, b) < b.len()
        {
            state::USB_TX_OVERRUNS.count();
        }
    };
    let mut ticker = Ticker::every(Duration::from_millis(1));
    let mut ticks = 0u32;
    // what the CAN side was last told: the acceptance filters, the frames lost
    let mut can_filters = None;
    let mut can_rx_lost = 0u32;
    let mut packet = [0u8; state::PACKET];
    loop {
        let event = select5(
            block::BLOCKS.receive(),
            state::CAN_RX.receive(),
            state::USB_RX.receive(),
            ticker.next(),
            worker::DONE.receive(),
        )
        .await;
        // the protocols' clock is the event's time (taken before the wait, a tick would see
        // the end of the turn before it, up to a millisecond stale: heartbeats 1 ms late)
        let now = Instant::now().as_micros();
        let kind = match &event {
            Either5::First(_) => TurnKind::Block,
            Either5::Second(_) => TurnKind::CanFrame,
            Either5::Third(_) => TurnKind::Usb,
            Either5::Fourth(()) => TurnKind::Tick,
            Either5::Fifth(_) => TurnKind::WorkDone,
        };
        match event {
            Either5::First(block) => {
                while let Ok(code) = thermistor::CODES.try_receive() {
                    if pod.on_thermistor(code).is_err() {
                        defmt::warn!("thermistor fault, code {}", code);
                    }
                }
                while let Ok(edge) = probe_queue::EDGES.try_receive() {
                    let o = pod.on_probe_edge(edge.t_us, edge.raw, &mut ());
                    if !matches!(o, TriggerOutcome::Accepted(_)) {
                        defmt::debug!("probe edge rejected");
                    }
                }
                let b = Block {
                    t_us: block.t_us,
                    reading: block.reading,
                    // the encoder counts latched at the block's centre
                    raw: block.raw,
                    lost_total: super::lost_upstream(),
                    probe_seated: super::probe::seated(&probe_in),
                };
                super::before_block(&mut pod, b.t_us);
                pod.on_block(&b, now, &mut (), can_out);
                super::safety::check_in(super::safety::Task::Compute);
            }
            Either5::Second(frame) => pod.on_frame(&frame, now, can_out),
            Either5::Third(UsbEvent::Bytes { data, len }) => {
                pod.on_usb(data.get(..len).unwrap_or(&[]), usb_out);
            }
            Either5::Third(UsbEvent::CommandClosed) => pod.usb_closed(),
            Either5::Third(UsbEvent::StreamOpened) => pod.stream_reader(true),
            Either5::Third(UsbEvent::StreamClosed) => pod.stream_reader(false),
            Either5::Fourth(()) => {
                ticks = ticks.wrapping_add(1);
                if ticks.is_multiple_of(DEVICE_COUNTERS_EVERY_MS) {
                    pod.set_device_counters(diagnostics::device_counters());
                }
                while let Ok(bus) = state::CAN_BUS.try_receive() {
                    pod.on_bus_state(bus, now, can_out);
                }
                let lost = state::CAN_RX_LOST.get();
                if lost != can_rx_lost && pod.on_can_rx_lost(now, can_out) {
                    can_rx_lost = lost;
                }
                let ids = pod.can_accepted_ids();
                if can_filters != Some(ids) {
                    can_filters = Some(ids);
                    state::CAN_FILTERS.signal(ids);
                }
                pod.tick(now, can_out);
                if let Some(rate) = pod.bit_rate_switch(now) {
                    state::CAN_BIT_RATE.signal(rate);
                }
            }
            Either5::Fifth(Done::Job(slot)) => {
                pod.finish_job(slot);
                jobs = Some(slot);
            }
            Either5::Fifth(Done::Stored(ok)) => {
                pod.app.settings_stored(ok);
                storing = false;
            }
        }
        // (the emulated board shows the virtual CNC the session; nothing on the STM32 board)
        super::after_turn(&pod);
        pod.end_of_turn(
            &mut (),
            &mut packet,
            &mut || state::USB_TX.free_capacity(),
            usb_out,
            state::STREAM_TX.free_capacity(),
            // (the stream pulls no more than the room there is)
            &mut |b| {
                let _ = state::write_all_now(&state::STREAM_TX, b);
            },
        );
        // the LVDT task acquires in the mode the configuration names, from the next block
        if let Some(mode) = pod.app.take_lvdt_input() {
            block::MODE.store(mode as u8, Ordering::Relaxed);
        }
        // long work to the worker: the command that asked for it is answered already
        if !storing && let Some(cfg) = pod.settings_to_store() {
            hand_over(Work::Store(cfg));
            storing = true;
        }
        // a firmware update: after a save in progress, once the answer is out
        if !storing && pod.app.take_bootloader_request() {
            restart_into_bootloader().await;
        }
        if let Some(slot) = jobs.take() {
            if pod.start_job(slot) {
                hand_over(Work::Job(slot));
            } else {
                jobs = Some(slot);
            }
        }
        let took = Instant::now().as_micros().saturating_sub(now) as u32;
        if took > LONGEST_TURN_US.load(Ordering::Relaxed) {
            LONGEST_TURN_US.store(took, Ordering::Relaxed);
            LONGEST_TURN_KIND.store(kind as u32, Ordering::Relaxed);
        }
    }
}

/// Lets the command port's host read what is queued (at most 100 ms), then restarts into the
/// ROM bootloader (`rom_bootloader`).
async fn restart_into_bootloader() -> ! {
    let until = Instant::now() + Duration::from_millis(100);
    while !state::USB_TX.is_empty() && Instant::now() < until {
        embassy_time::Timer::after_millis(1).await;
    }
    embassy_time::Timer::after_millis(10).await;
    super::rom_bootloader::restart_into()
}

/// What a turn of the application task handled.
#[derive(Clone, Copy)]
pub enum TurnKind {
    /// An LVDT block (a sample).
    Block = 1,
    /// A CAN frame.
    CanFrame = 2,
    /// USB bytes or a port opened or closed.
    Usb = 3,
    /// The 1 ms tick (protocol timers, device counters).
    Tick = 4,
    /// The worker handed back a job or a save.
    WorkDone = 5,
}

/// The longest turn of the application task since boot, µs (the block queue holds
/// [`BLOCK_QUEUE`](super::block::BLOCK_QUEUE) blocks: a longer turn, in sample periods, loses
/// blocks).
pub static LONGEST_TURN_US: AtomicU32 = AtomicU32::new(0);
/// Its [`TurnKind`].
pub static LONGEST_TURN_KIND: AtomicU32 = AtomicU32::new(0);

/// Hands `work` to the worker. Its queue holds one job and one save, and the task hands over at
/// most one of each at a time (it waits for the slot and the save to come back first), so the
/// queue always has room.
fn hand_over(work: Work) {
    if worker::WORK.try_send(work).is_err() {
        defmt::error!("worker queue full");
    }
}
