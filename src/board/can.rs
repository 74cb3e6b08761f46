//! FDCAN1 on PB8/PB9 at the configured bit rate: received standard data frames go to the
//! application task (`state::CAN_RX`), the frames its CANopen node sends come back through
//! `state::CAN_TX`, and a change of the controller's error state (error active / passive /
//! bus-off, FDCAN `PSR`) is signalled (`state::CAN_BUS`). The controller recovers from bus-off
//! by itself (embassy-stm32's `automatic_bus_off_recovery`, on by default: the IT0 interrupt
//! clears `CCCR.INIT` and the FDCAN waits for 128 × 11 recessive bits).

use core::num::{NonZeroU8, NonZeroU16};
use core::sync::atomic::{AtomicU32, Ordering};

use embassy_futures::select::{Either4, select4};
use embassy_stm32::can::config::NominalBitTiming;
use embassy_stm32::can::enums::BusErrorMode;
use embassy_stm32::can::{Can, CanConfigurator, OperatingMode, frame::Frame};
use embassy_stm32::{Peri, peripherals};
use embassy_time::{Duration, Timer, with_timeout};
use embedded_can::Id;

use ballpod::config::CanBitrate;
use ballpod::protocol::canopen::{BusState, CanFrame};

use super::{Irqs, state};

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
    cc.set_config(cc.config().set_nominal_bit_timing(nbt));
    cc.start(OperatingMode::NormalOperationMode)
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

/// Moves frames between FDCAN1 and the application task.
#[embassy_executor::task]
pub async fn can_task(mut can: Can<'static>) {
    let mut last_bus = BusState::ErrorActive;
    loop {
        super::safety::check_in(super::safety::Task::Can);
        let bus = bus_state(can.properties().bus_error_mode());
        if bus != last_bus {
            defmt::warn!("CAN bus state {}", bus as u8);
            last_bus = bus;
            state::CAN_BUS.signal(bus);
        }
        // the timer: check in and look at the bus state even while the bus is silent
        let tick = Timer::after_millis(super::safety::CHECK_IN_MS);
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
            Either4::First(Err(_)) | Either4::Third(()) => {}
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
