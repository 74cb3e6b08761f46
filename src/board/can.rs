//! FDCAN1 on PB8/PB9 at the configured bit rate: received standard data frames go to the
//! application task (`state::CAN_RX`), the frames its CANopen node sends come back through
//! `state::CAN_TX`, and the controller's error states (error active / passive / bus-off, FDCAN
//! `PSR`) go to it in order (`state::CAN_BUS`). The controller recovers from bus-off by itself
//! (embassy-stm32's `automatic_bus_off_recovery`, on by default: the IT0 interrupt clears
//! `CCCR.INIT` and the FDCAN waits for 128 × 11 recessive bits).
//!
//! **Acceptance filters**: only the COB-IDs the node consumes reach the receive FIFO (NMT,
//! SYNC, its SDO request, the LSS master's: `CanOpenNode::accepted_ids`, updated through
//! `state::CAN_FILTERS` when the node-ID or 0x1005 changes); the global filter rejects every
//! other standard, extended and remote frame, so a busy bus of other nodes' traffic never fills
//! the 3-frame FIFO. **Counted in the interrupt** ([`CanEventIsr`], before embassy's handler):
//! a frame lost to a full FIFO (`IR.RF0L`: `state::CAN_RX_LOST`, EMCY 0x8110), every entry into
//! bus-off and error passive however brief ([`BUS_OFF_ENTRIES`], [`ERROR_PASSIVE_ENTRIES`]; a
//! bus-off that recovered between two looks of the task is still reported, entry and
//! recovery).
//!
//! **Who empties the FIFO**: [`can_task`], on the I/O interrupt executor (above the application
//! and the worker; woken by embassy's IT0 handler), not IT0 itself. embassy-stm32's buffered
//! mode would drain the FIFO in IT0, but into a channel whose overflow it drops uncounted; with
//! the filters passing only the node's own frames (a master waits for each SDO answer; SYNC at
//! most every millisecond), three frames in the FIFO outlast any turn of this task, and a frame
//! lost anyway is counted by the hardware's RF0L flag above.

use core::num::{NonZeroU8, NonZeroU16};
use core::sync::atomic::{AtomicU32, Ordering};

use embassy_futures::select::{Either, Either4, select, select4};
use embassy_stm32::can::config::{GlobalFilter, NominalBitTiming};
use embassy_stm32::can::enums::BusErrorMode;
use embassy_stm32::can::filter::{Action, FilterType, StandardFilter};
use embassy_stm32::can::{Can, CanConfigurator, OperatingMode, frame::Frame};
use embassy_stm32::interrupt::typelevel::{FDCAN1_IT0, Handler};
use embassy_stm32::{Peri, pac, peripherals};
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::signal::Signal;
use embassy_time::{Duration, Timer, with_timeout};
use embedded_can::{Id, StandardId};

use ballpod::config::CanBitrate;
use ballpod::protocol::canopen::{BusState, CanFrame};

use super::{Irqs, Overruns, state};

/// Times the controller went bus-off (counted in [`CanEventIsr`]).
pub static BUS_OFF_ENTRIES: Overruns = Overruns::new();
/// Times the controller went error passive (counted in [`CanEventIsr`]).
pub static ERROR_PASSIVE_ENTRIES: Overruns = Overruns::new();
/// A bus-off or error-passive change was seen: the CAN task looks at once.
static BUS_EVENT: Signal<CriticalSectionRawMutex, ()> = Signal::new();

/// FDCAN1 interrupt line 0, bound before embassy's handler (which clears `IR.BO` and the
/// receive and transmit flags it handles): counts a frame lost to a full receive FIFO 0
/// (`IR.RF0L`) and the entries into bus-off (`IR.BO` with `PSR.BO`) and error passive (`IR.EP`
/// with `PSR.EP`), clearing the flags embassy leaves (RF0L, EP).
pub struct CanEventIsr;

impl Handler<FDCAN1_IT0> for CanEventIsr {
    unsafe fn on_interrupt() {
        let r = pac::FDCAN1;
        let ir = r.ir().read();
        if ir.rfl(0) {
            r.ir().write(|w| w.set_rfl(0, true));
            state::CAN_RX_LOST.count();
        }
        if ir.bo() || ir.ep() {
            let psr = r.psr().read();
            if ir.bo() && psr.bo() {
                BUS_OFF_ENTRIES.count();
            }
            if ir.ep() {
                r.ir().write(|w| w.set_ep(true));
                if psr.ep() {
                    ERROR_PASSIVE_ENTRIES.count();
                }
            }
            BUS_EVENT.signal(());
        }
    }
}

/// Longest wait for a free transmit buffer, ms (three 8-byte frames at 125 kbit/s take ~3 ms).
pub const TX_WAIT_MS: u64 = 5;

/// Frames received since boot.
pub static RX_FRAMES: AtomicU32 = AtomicU32::new(0);

/// Configures FDCAN1 at `bitrate` and starts it in normal mode. The bit timing is the core's
/// exact one for the 24 MHz HSE kernel clock (`bit_timing`; embassy's `set_bitrate` would
/// unwrap a failed calculation), so no configuration value can panic here.
pub fn start(
    fdcan: Peri<'static, peripherals::FDCAN1>,
    rx: Peri<'static, peripherals::PB8>,
    tx: Peri<'static, peripherals::PB9>,
    bitrate: CanBitrate,
) -> Can<'static> {
    let mut cc = CanConfigurator::new(fdcan, rx, tx, Irqs);
    let t = bitrate.timing();
    let nbt = NominalBitTiming {
        prescaler: NonZeroU16::new(t.prescaler).unwrap_or(NonZeroU16::MIN),
        seg1: NonZeroU8::new(t.seg1).unwrap_or(NonZeroU8::MIN),
        seg2: NonZeroU8::new(t.seg2).unwrap_or(NonZeroU8::MIN),
        sync_jump_width: NonZeroU8::new(t.sync_jump_width).unwrap_or(NonZeroU8::MIN),
    };
    // nothing the filters do not name; every standard frame until the node names its IDs
    // (its first turn, within a millisecond)
    cc.set_config(
        cc.config()
            .set_nominal_bit_timing(nbt)
            .set_global_filter(GlobalFilter::reject_all()),
    );
    cc.properties()
        .set_standard_filter(0.into(), StandardFilter::accept_all_into_fifo0());
    let can = cc.start(OperatingMode::NormalOperationMode);
    // the lost-frame and error-passive interrupts (line 0, as embassy's)
    pac::FDCAN1.ie().modify(|w| {
        w.set_rfle(0, true);
        w.set_epe(true);
    });
    can
}

/// The acceptance filters for `ids` (`CanOpenNode::accepted_ids`): one slot each, into FIFO 0;
/// an empty slot disabled.
fn set_filters(can: &Can<'static>, ids: [Option<u16>; 4]) {
    for (slot, id) in (0u8..).zip(ids) {
        let filter = match id.and_then(StandardId::new) {
            Some(id) => StandardFilter {
                filter: FilterType::DedicatedSingle(id),
                action: Action::StoreInFifo0,
            },
            None => StandardFilter::disable(),
        };
        can.properties().set_standard_filter(slot.into(), filter);
    }
}

/// Switches the running controller to `bitrate` (an LSS master's "activate bit timing", CiA
/// 305): into init mode, the core's exact timing into `NBTP`, out again (RM0440 §44.3.2; the
/// same register steps embassy takes at start — its `Can` has no way back to a configurator).
/// Frames in the transmit buffers stay queued; the node sends nothing during the switch.
fn switch_bit_rate(bitrate: CanBitrate) {
    let r = embassy_stm32::pac::FDCAN1;
    let t = bitrate.timing();
    r.cccr().modify(|w| w.set_init(true));
    while !r.cccr().read().init() {}
    r.cccr().modify(|w| w.set_cce(true));
    r.nbtp().write(|w| {
        w.set_nbrp(t.prescaler.saturating_sub(1));
        w.set_ntseg1(t.seg1.saturating_sub(1));
        w.set_ntseg2(t.seg2.saturating_sub(1));
        w.set_nsjw(t.sync_jump_width.saturating_sub(1));
    });
    r.cccr().modify(|w| w.set_cce(false));
    r.cccr().modify(|w| w.set_init(false));
    while r.cccr().read().init() {}
}

/// The core's view of the controller's fault-confinement state.
fn bus_state(mode: BusErrorMode) -> BusState {
    match mode {
        BusErrorMode::ErrorActive => BusState::ErrorActive,
        BusErrorMode::ErrorPassive => BusState::ErrorPassive,
        BusErrorMode::BusOff => BusState::BusOff,
    }
}

fn to_core(frame: &Frame) -> Option<CanFrame> {
    // The slave uses 11-bit data frames only; RTR and 29-bit frames are not for it.
    match frame.id() {
        Id::Standard(id) if !frame.header().rtr() => CanFrame::new(id.as_raw(), frame.data()),
        _ => None,
    }
}

/// Sends the application task the states since the last look: the interrupt's counts of
/// bus-off and error-passive entries say what `PSR` alone could miss (a bus-off recovered
/// between two looks: bus-off, then the state now).
fn report_bus(can: &Can<'static>, last: &mut (BusState, u32, u32)) {
    let now = bus_state(can.properties().bus_error_mode());
    let (bus_off, passive) = (BUS_OFF_ENTRIES.get(), ERROR_PASSIVE_ENTRIES.get());
    let (was, seen_off, seen_passive) = *last;
    let mut states = heapless::Vec::<BusState, 3>::new();
    if passive != seen_passive && was == BusState::ErrorActive && now == BusState::ErrorActive {
        let _ = states.push(BusState::ErrorPassive);
    }
    if bus_off != seen_off && was != BusState::BusOff && now != BusState::BusOff {
        let _ = states.push(BusState::BusOff);
    }
    if states.last().copied().unwrap_or(was) != now {
        let _ = states.push(now);
    }
    for s in states {
        defmt::warn!("CAN bus state {}", s as u8);
        if state::CAN_BUS.try_send(s).is_err() {
            // the application task, which drains them every millisecond, is four behind
            state::CAN_RX_OVERRUNS.count();
        }
    }
    *last = (now, bus_off, passive);
}

/// Moves frames between FDCAN1 and the application task.
#[embassy_executor::task]
pub async fn can_task(mut can: Can<'static>) {
    let mut last = (BusState::ErrorActive, 0, 0);
    loop {
        super::safety::check_in(super::safety::Task::Can);
        report_bus(&can, &mut last);
        if let Some(ids) = state::CAN_FILTERS.try_take() {
            set_filters(&can, ids);
        }
        // the timer: check in and look at the bus state even while the bus is silent; a bus
        // event or new filters end the wait at once
        let tick = select(
            Timer::after_millis(super::safety::CHECK_IN_MS),
            select(BUS_EVENT.wait(), state::CAN_FILTERS.wait()),
        );
        let switch = state::CAN_BIT_RATE.wait();
        match select4(can.read(), state::CAN_TX.receive(), tick, switch).await {
            Either4::First(Ok(env)) => {
                RX_FRAMES.fetch_add(1, Ordering::Relaxed);
                if let Some(frame) = to_core(&env.frame)
                    && state::CAN_RX.try_send(frame).is_err()
                {
                    state::CAN_RX_OVERRUNS.count();
                }
            }
            Either4::First(Err(_)) => {}
            Either4::Third(Either::First(()) | Either::Second(Either::First(()))) => {}
            Either4::Third(Either::Second(Either::Second(ids))) => set_filters(&can, ids),
            Either4::Fourth(rate) => {
                defmt::info!("CAN bit rate {} (LSS)", rate.bits_per_s());
                switch_bit_rate(rate);
            }
            Either4::Second(f) => {
                // Never wait long for a transmit buffer: with no other node on the bus nothing
                // acknowledges, the FDCAN retries for ever (error passive, not bus-off) and a
                // plain `write().await` would stop reception too. A frame that cannot be
                // queued in time is dropped and counted.
                if let Ok(frame) = Frame::new_standard(f.id, f.payload()) {
                    match with_timeout(Duration::from_millis(TX_WAIT_MS), can.write(&frame)).await {
                        Ok(None) => {}
                        // a queued frame replaced by this one, or no buffer in time
                        Ok(Some(_)) | Err(_) => state::CAN_TX_DROPPED.count(),
                    }
                }
            }
        }
    }
}
