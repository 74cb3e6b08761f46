//! ballpod firmware for the NUCLEO-G474RE (STM32G474RE, Cortex-M4F at 170 MHz).
//!
//! Clocks: 24 MHz HSE crystal → PLL → 170 MHz system clock; the FDCAN kernel clock is
//! the 24 MHz HSE itself (every offered CAN bit rate exact); ADC clocks from the system clock;
//! 48 MHz USB from HSI48 with clock recovery.
//! The tasks are in `board/`; the pin table is in the book (`docs/src/hardware.md`).
//!
//! **Priorities** (most urgent first; `board::set_priorities` sets the NVIC):
//! 1. the probe latch (EXTI4) and the LVDT block latch (ADC1's DMA), then the other peripheral
//!    interrupts (DMA, FDCAN, USB, the time driver);
//! 2. the I/O executor (interrupt `UART4`): LVDT demodulation, DAC, thermistor, CAN, USB and
//!    the watchdog tasks — they only move data, so nothing they serve waits for a computation;
//! 3. the pod executor (interrupt `UART5`): the application task (`board::compute`): samples,
//!    commands, protocols;
//! 4. thread mode: the worker (`board::worker`): the application's jobs (the ISO 230-4
//!    figures, the seed 002 identification) and settings saves, preempted by all of the above.
#![no_std]
#![no_main]

mod board;

use embassy_executor::{InterruptExecutor, Spawner};

use board::spawn::spawn;
use embassy_stm32::interrupt;
use embassy_stm32::interrupt::InterruptExt;
use embassy_stm32::time::Hertz;
use embassy_stm32::usb::Driver;
// defmt over RTT; the panic handler is `board::safety::panic` (reason kept across the reset).
use defmt_rtt as _;

use ballpod::protocol::canopen::emcy;

fn clocks() -> embassy_stm32::Config {
    use embassy_stm32::rcc::*;
    let mut config = embassy_stm32::Config::default();
    config.rcc.hse = Some(Hse {
        freq: Hertz(24_000_000),
        mode: HseMode::Oscillator,
    });
    config.rcc.pll = Some(Pll {
        source: PllSource::HSE,
        prediv: PllPreDiv::DIV6,
        mul: PllMul::MUL85,
        divp: None,
        divq: None,
        divr: Some(PllRDiv::DIV2), // 170 MHz system clock
    });
    config.rcc.sys = Sysclk::PLL1_R;
    config.rcc.boost = true;
    config.rcc.hsi48 = Some(Hsi48Config {
        sync_from_usb: true,
    });
    config.rcc.mux.clk48sel = mux::Clk48sel::HSI48;
    // FDCAN from the 24 MHz HSE: every offered bit rate is exact (protocol::canopen::bit_timing;
    // FDCAN_KERNEL_HZ states this clock)
    config.rcc.mux.fdcansel = mux::Fdcansel::HSE;
    config.rcc.mux.adc12sel = mux::Adcsel::SYS;
    config.rcc.mux.adc345sel = mux::Adcsel::SYS;
    // every DMA channel below the two latches (board::set_priorities)
    config.bdma_interrupt_priority = embassy_stm32::interrupt::Priority::P2;
    config
}

/// The I/O executor: acquisition, CAN, USB and the watchdog (priority 2 of the module doc).
static EXECUTOR_IO: InterruptExecutor = InterruptExecutor::new();
/// The pod executor: the application task (priority 3).
static EXECUTOR_POD: InterruptExecutor = InterruptExecutor::new();

#[interrupt]
unsafe fn UART4() {
    // SAFETY: the interrupt is this executor's alone (no UART4 peripheral is used).
    unsafe { EXECUTOR_IO.on_interrupt() }
}

#[interrupt]
unsafe fn UART5() {
    // SAFETY: the interrupt is this executor's alone (no UART5 peripheral is used).
    unsafe { EXECUTOR_POD.on_interrupt() }
}

#[embassy_executor::main]
async fn main(spawner: Spawner) {
    // Before anything is set up: the ROM bootloader, if the last run asked for it (a field
    // update, `SYSTem:BOOTloader`).
    board::rom_bootloader::enter_if_asked();
    let p = embassy_stm32::init(clocks());
    board::diagnostics::start_cycle_counter();
    // The watchdog first: a boot that hangs reading the flash is reset, not stuck.
    let dog = board::watchdog::start(p.IWDG);
    // Why the previous run ended: a panic or HardFault record in retained RAM, else the reset
    // flags (a watchdog or low-power reset is a fault; power-on, the pin, a software reset are
    // not).
    let cause = board::watchdog::take_reset_cause();
    defmt::info!("reset: {}", cause.text());
    let (can_report, usb_report) = match board::safety::take_reset_report() {
        Some(board::safety::ResetReport::Panic(text)) => {
            defmt::error!("previous run ended in a {}", text);
            (Some((emcy::SOFTWARE_ERROR, emcy::REASON_PANIC)), Some(text))
        }
        Some(board::safety::ResetReport::HardFault(text)) => {
            defmt::error!("previous run ended in a {}", text);
            (
                Some((emcy::SOFTWARE_ERROR, emcy::REASON_HARD_FAULT)),
                Some(text),
            )
        }
        None => match cause.fault() {
            Some((code, reason, text)) => {
                defmt::error!("previous run ended by a {}", text);
                (Some((code, reason)), Some(text))
            }
            None => (None, None),
        },
    };
    // The option bytes this firmware depends on (the flash driver panics on a single-bank
    // chip: without DBANK the settings pages are not touched, the defaults run and it is said).
    let option_bytes = ballpod::boot::OptionBytes(embassy_stm32::pac::FLASH.optr().read().0);
    if let Some(fault) = option_bytes.fault() {
        defmt::error!("{}", fault);
    }
    // The stored settings (newest valid slot), or the defaults if no slot holds valid ones.
    let (cfg, settings_rejected, settings_unreadable, flash) = if option_bytes.dual_bank() {
        let mut flash =
            board::settings::SettingsPages(embassy_stm32::flash::Flash::new_blocking(p.FLASH));
        let loaded = ballpod::settings::load(&mut flash);
        match loaded.from {
            Some((slot, seq)) => defmt::info!("settings: slot {} sequence {}", slot.index(), seq),
            None => defmt::warn!(
                "settings: no valid slot ({}, {}), defaults in use",
                board::settings::slot_reason(&loaded.scan.a),
                board::settings::slot_reason(&loaded.scan.b)
            ),
        }
        (
            loaded.config,
            loaded.rejected(),
            loaded.unreadable(),
            Some(flash),
        )
    } else {
        (ballpod::config::Config::default(), None, 0, None)
    };
    defmt::info!(
        "ballpod up: bar {} mm, node {}",
        cfg.bar_length_mm,
        cfg.can_node_id
    );

    let encoders = board::encoders::Encoders::new(board::encoders::EncoderPeripherals {
        e1: (p.TIM1, p.PA8, p.PA9),
        e2: (p.TIM3, p.PA6, p.PA7),
        e3: (p.TIM4, p.PB6, p.PB7),
        e4: (p.TIM2, p.PA15, p.PB3),
        e5: (p.TIM5, p.PB2, p.PC12),
    });
    let probe_in = board::probe::input(p.PB4, p.EXTI4);

    let (dac, ring_a, ring_b) = board::lvdt::start(
        board::lvdt::LvdtPeripherals {
            tim6: p.TIM6,
            dac: (p.DAC1, p.DMA1_CH1, p.PA4),
            adc_a: (p.ADC1, p.DMA1_CH2, p.PA0),
            adc_b: (p.ADC2, p.DMA1_CH3, p.PA1),
        },
        &cfg,
    );
    let can = board::can::start(p.FDCAN1, p.PB8, p.PB9, cfg.can_bitrate);
    let usb = Driver::new(p.USB, board::Irqs, p.PA12, p.PA11);
    board::set_priorities();

    let boot = ballpod::pod::BootReport {
        can: can_report,
        usb: usb_report,
        settings_rejected,
        settings_unreadable,
        option_bytes: option_bytes.fault(),
    };
    let pod = board::compute::PodState::new(cfg, device_serial(), boot);
    interrupt::UART4.set_priority(board::IO_EXECUTOR_PRIORITY);
    interrupt::UART5.set_priority(board::POD_EXECUTOR_PRIORITY);
    let io = EXECUTOR_IO.start(interrupt::UART4);
    let pod_spawner = EXECUTOR_POD.start(interrupt::UART5);
    spawn(
        &pod_spawner,
        "compute",
        board::compute::compute_task(pod, encoders, probe_in),
    );
    spawn(&spawner, "worker", board::worker::worker_task(flash));
    spawn(
        &io,
        "lvdt",
        board::lvdt::lvdt_task(
            ring_a,
            ring_b,
            board::block::block_len(&cfg),
            board::block::block_period_us(&cfg),
        ),
    );
    spawn(&io, "dac", board::lvdt::dac_task(dac));
    spawn(
        &io,
        "thermistor",
        board::thermistor::thermistor_task(p.ADC3, p.PB0),
    );
    spawn(&io, "can", board::can::can_task(can));
    spawn(&io, "usb", board::usb::usb_task(usb, device_serial()));
    spawn(&io, "watchdog", board::watchdog::watchdog_task(dog));
}

/// The pod's serial number for CANopen 0x1018:4: a CRC-32 of the STM32's 96-bit unique device ID
/// (RM0440 §48.1, at 0x1FFF_7590).
fn device_serial() -> u32 {
    let uid = embassy_stm32::uid::uid();
    ballpod::num::crc32(&uid)
}
