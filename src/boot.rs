//! What a boot finds about the previous run and the chip: the firmware reads the registers,
//! this module says what they mean and what the protocols report (the same for every shell).
//!
//! - [`ResetCause`]: the reset flags of RCC_CSR (RM0440 §7.4.30), read and cleared once at
//!   boot. A panic or a HardFault leaves its own record in retained RAM (the firmware's
//!   `board::safety`) and is reported from it; of the flags, only a watchdog reset and a
//!   low-power reset are faults.
//! - [`OptionBytes`]: the user option bytes of FLASH_OPTR (RM0440, flash option register)
//!   the firmware depends on — dual-bank flash (DBANK = 1: the settings pages are the last two 2 KiB pages of bank
//!   2, and the flash driver refuses a single-bank chip) and BOOT0 from the option bit
//!   (nSWBOOT0 = 0, nBOOT0 = 1: PB8 is the CAN receiver's RX, which a transceiver may hold
//!   high at power-up; taken as BOOT0 it would start the ROM bootloader instead).

use crate::protocol::canopen::emcy;

/// Why the MCU last reset, from RCC_CSR's flags (the first that applies, in this order).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResetCause {
    /// The independent watchdog expired (IWDGRSTF): a task stopped checking in, or the core
    /// locked up (the G474 does not reset on a lockup; the watchdog does).
    Watchdog,
    /// The window watchdog (WWDGRSTF; the firmware does not start it).
    WindowWatchdog,
    /// Entering Stop, Standby or Shutdown with the option bytes' reset on entry (LPWRRSTF;
    /// the firmware never enters them).
    LowPower,
    /// A software reset (SFTRSTF: the panic and HardFault handlers, a requested reset).
    Software,
    /// Power-on or a brown-out (BORRSTF: the G474 sets the same flag for both).
    PowerOnOrBrownOut,
    /// The reset pin (PINRSTF alone: the button or a debugger).
    Pin,
    /// Reloading the option bytes (OBLRSTF).
    OptionByteLoad,
    /// No flag set (a reset the flags do not record).
    Unknown,
}

/// RCC_CSR's reset flags (RM0440 §7.4.30), bit numbers.
mod csr {
    pub const OBLRSTF: u32 = 25;
    pub const PINRSTF: u32 = 26;
    pub const BORRSTF: u32 = 27;
    pub const SFTRSTF: u32 = 28;
    pub const IWDGRSTF: u32 = 29;
    pub const WWDGRSTF: u32 = 30;
    pub const LPWRRSTF: u32 = 31;
}

impl ResetCause {
    /// The cause RCC_CSR's value `csr` records. A watchdog or software reset also sets
    /// PINRSTF (the reset drives the pin) and a power-on BORRSTF and PINRSTF, so the flags are
    /// taken from the most specific: the watchdogs, low power, software, power, pin, option
    /// byte load.
    pub fn from_rcc_csr(csr: u32) -> Self {
        let set = |bit: u32| csr & (1 << bit) != 0;
        if set(csr::IWDGRSTF) {
            Self::Watchdog
        } else if set(csr::WWDGRSTF) {
            Self::WindowWatchdog
        } else if set(csr::LPWRRSTF) {
            Self::LowPower
        } else if set(csr::SFTRSTF) {
            Self::Software
        } else if set(csr::BORRSTF) {
            Self::PowerOnOrBrownOut
        } else if set(csr::PINRSTF) {
            Self::Pin
        } else if set(csr::OBLRSTF) {
            Self::OptionByteLoad
        } else {
            Self::Unknown
        }
    }

    /// The cause in words (boot log).
    pub const fn text(self) -> &'static str {
        match self {
            Self::Watchdog => "watchdog reset",
            Self::WindowWatchdog => "window watchdog reset",
            Self::LowPower => "low-power reset",
            Self::Software => "software reset",
            Self::PowerOnOrBrownOut => "power-on or brown-out",
            Self::Pin => "reset pin",
            Self::OptionByteLoad => "option byte load",
            Self::Unknown => "reset of unknown cause",
        }
    }

    /// What the protocols report when the cause is a fault (the previous run did not end as
    /// asked): the EMCY code and manufacturer byte 3, and the `SYSTem:ERRor?` text.
    pub const fn fault(self) -> Option<(u16, u8, &'static str)> {
        match self {
            Self::Watchdog | Self::WindowWatchdog => {
                Some((emcy::SOFTWARE_ERROR, emcy::REASON_WATCHDOG, self.text()))
            }
            Self::LowPower => Some((
                emcy::DEVICE_HARDWARE,
                emcy::REASON_LOW_POWER_RESET,
                self.text(),
            )),
            Self::Software
            | Self::PowerOnOrBrownOut
            | Self::Pin
            | Self::OptionByteLoad
            | Self::Unknown => None,
        }
    }
}

/// FLASH_OPTR, the user option bytes as loaded (RM0440, flash option register).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OptionBytes(pub u32);

/// FLASH_OPTR bit numbers.
mod optr {
    pub const DBANK: u32 = 22;
    pub const N_SWBOOT0: u32 = 26;
    pub const N_BOOT0: u32 = 27;
}

impl OptionBytes {
    const fn bit(self, n: u32) -> bool {
        self.0 & (1 << n) != 0
    }

    /// Dual-bank flash (DBANK = 1), as the firmware is built for.
    pub const fn dual_bank(self) -> bool {
        self.bit(optr::DBANK)
    }

    /// BOOT0 is read from the PB8 pin (nSWBOOT0 = 1), the CAN receiver's RX.
    pub const fn boot0_from_pin(self) -> bool {
        self.bit(optr::N_SWBOOT0)
    }

    /// With BOOT0 from the option bit, whether it selects the main flash (nBOOT0 = 1; with
    /// nBOOT0 = 0 the next power-up starts the ROM bootloader).
    pub const fn boots_from_flash(self) -> bool {
        self.bit(optr::N_BOOT0)
    }

    /// What is wrong for this firmware, the most serious first, with how to set it (the
    /// book's hardware page gives the commands): `None` when the option bytes are right.
    pub const fn fault(self) -> Option<&'static str> {
        if !self.dual_bank() {
            Some(
                "option bytes: DBANK = 0 (single bank): settings not read or stored; set DBANK = 1",
            )
        } else if self.boot0_from_pin() {
            Some("option bytes: nSWBOOT0 = 1: BOOT0 is PB8 (CAN RX); set nSWBOOT0 = 0, nBOOT0 = 1")
        } else if !self.boots_from_flash() {
            Some(
                "option bytes: nBOOT0 = 0: the next power-up starts the ROM bootloader; set nBOOT0 = 1",
            )
        } else {
            None
        }
    }

    /// The EMCY of [`OptionBytes::fault`]: code and manufacturer byte 3.
    pub const EMCY: (u16, u8) = (emcy::DEVICE_HARDWARE, emcy::REASON_OPTION_BYTES);
}
