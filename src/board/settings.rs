//! The settings slots in the internal flash: the last two 2 KiB pages of bank 2 (dual-bank
//! mode, RM0440 §3.3.1), driven by embassy-stm32's blocking flash driver behind the core's
//! [`SettingsFlash`] trait. `memory.x` ends the linker's FLASH region 4 KiB early so no code
//! or data can be placed there.
//!
//! **A save cut by a power loss** can leave a double-word half programmed (or a page half
//! erased) with its ECC bits not matching: reading it is a double ECC error, which raises an
//! NMI (FLASH_ECCR.ECCD, RM0440 "Error code correction"). The NMI handler
//! ([`NonMaskableInt`]) records one at these pages and returns; the read that met it
//! fails ([`PagesError::Ecc`]), so the slot is unreadable and the boot goes on with the other
//! slot or the defaults and says so.
//!
//! An erase takes about 22 ms (RM0440 Table 40, t_ERASE max 40 ms) during which the executor
//! runs nothing else: the LVDT DMA rings keep filling and their overruns are counted, so a
//! save during a run shows up as flagged samples, never as silent ones.

use core::sync::atomic::{AtomicU32, Ordering};

use embassy_stm32::flash::{Blocking, FLASH_SIZE, Flash, MAX_ERASE_SIZE};
use embassy_stm32::pac;

use ballpod::settings::{SettingsFlash, Slot, SlotError, StoreError, WRITE_SIZE};

/// Bytes of one slot (one erase page).
pub const SLOT_BYTES: usize = MAX_ERASE_SIZE;
/// Flash offset of slot A (from the start of flash, 0x0800_0000).
pub const SLOT_A_OFFSET: usize = FLASH_SIZE - 2 * SLOT_BYTES;

/// The two settings pages.
pub struct SettingsPages(pub Flash<'static, Blocking>);

/// Why a settings page operation failed.
#[derive(Clone, Copy, Debug, defmt::Format)]
pub enum PagesError {
    /// The flash driver's error.
    Flash(embassy_stm32::flash::Error),
    /// A read met a double ECC error; FLASH_ECCR as the NMI handler found it.
    Ecc(u32),
}

impl From<embassy_stm32::flash::Error> for PagesError {
    fn from(e: embassy_stm32::flash::Error) -> Self {
        Self::Flash(e)
    }
}

/// Whether FLASH_ECCR's failing address — bank 2 if `bank2`, `offset` bytes into the bank
/// (dual-bank mode) — is in a settings page.
pub fn is_settings_address(bank2: bool, offset: u32) -> bool {
    let at = FLASH_SIZE / 2 + offset as usize;
    bank2 && (SLOT_A_OFFSET..FLASH_SIZE).contains(&at)
}

fn base(slot: Slot) -> usize {
    SLOT_A_OFFSET + slot.index() * SLOT_BYTES
}

fn offset(slot: Slot, at: usize, len: usize) -> Result<u32, embassy_stm32::flash::Error> {
    if at + len > SLOT_BYTES {
        return Err(embassy_stm32::flash::Error::Size);
    }
    Ok((base(slot) + at) as u32)
}

impl SettingsFlash for SettingsPages {
    type Error = PagesError;

    fn read(&mut self, slot: Slot, at: usize, buf: &mut [u8]) -> Result<(), Self::Error> {
        let o = offset(slot, at, buf.len())?;
        // an older record is not this read's
        let _ = take_settings_ecc();
        self.0.blocking_read(o, buf)?;
        match take_settings_ecc() {
            Some(eccr) => Err(PagesError::Ecc(eccr)),
            None => Ok(()),
        }
    }

    fn erase(&mut self, slot: Slot) -> Result<(), Self::Error> {
        let o = offset(slot, 0, SLOT_BYTES)?;
        Ok(self.0.blocking_erase(o, o + SLOT_BYTES as u32)?)
    }

    fn program(
        &mut self,
        slot: Slot,
        at: usize,
        dword: &[u8; WRITE_SIZE],
    ) -> Result<(), Self::Error> {
        let o = offset(slot, at, WRITE_SIZE)?;
        Ok(self.0.blocking_write(o, dword)?)
    }
}

// The core's double-word is the G4's programming unit.
const _: () = assert!(WRITE_SIZE == embassy_stm32::flash::WRITE_SIZE);
const _: () = assert!(ballpod::settings::RECORD_LEN <= SLOT_BYTES);

/// FLASH_ECCR of the last double ECC error the NMI handler found at a settings page (0: none
/// since the last [`take_settings_ecc`]).
static SETTINGS_ECC: AtomicU32 = AtomicU32::new(0);

/// The double ECC error met at a settings page since the last call (FLASH_ECCR), if any.
pub fn take_settings_ecc() -> Option<u32> {
    Some(SETTINGS_ECC.swap(0, Ordering::Relaxed)).filter(|&e| e != 0)
}

/// The NMI handler. A double ECC error in flash (FLASH_ECCR.ECCD, RM0440 "Error code
/// correction") at the settings pages — a double-word a power loss cut while it was programmed
/// or erased — is recorded for the read that met it ([`take_settings_ecc`]) and cleared, and
/// the read goes on with wrong data (its slot is then unreadable: [`PagesError::Ecc`]).
/// Any other NMI (an ECC error in the code, the clock security system) is recorded as a fault,
/// `NMI, FLASH_ECCR 0x…`, and resets.
#[cortex_m_rt::exception]
unsafe fn NonMaskableInt() {
    let eccr = pac::FLASH.eccr().read();
    if eccr.eccd() && is_settings_address(eccr.bk_ecc(), eccr.addr_ecc()) {
        // ECCD is cleared by writing 1 (ECCC too, if a corrected error is also flagged)
        pac::FLASH.eccr().modify(|w| w.set_eccd(true));
        SETTINGS_ECC.store(eccr.0, Ordering::Relaxed);
        return;
    }
    super::safety::record_fault_and_reset("NMI, FLASH_ECCR 0x", eccr.0)
}

/// A short name of why a slot was not used (for the boot log; no float formatting).
pub fn slot_reason(r: &Result<ballpod::settings::Record, SlotError>) -> &'static str {
    match r {
        Ok(_) => "valid",
        Err(SlotError::Erased) => "erased",
        Err(SlotError::Read) => "unreadable (flash ECC error)",
        Err(SlotError::BadMagic) => "bad magic",
        Err(SlotError::UnsupportedVersion(_)) => "unsupported version",
        Err(SlotError::BadLength(_)) => "bad length",
        Err(SlotError::BadCrc) => "bad CRC",
        Err(SlotError::Config(_)) => "configuration rejected",
    }
}

/// A short name of why a save failed (for the log; no float formatting).
pub fn store_reason(e: &StoreError<PagesError>) -> &'static str {
    match e {
        StoreError::Config(_) => "configuration rejected",
        StoreError::Erase(_) => "erase failed",
        StoreError::Program { .. } => "program failed",
        StoreError::Verify(_) => "read-back does not decode",
        StoreError::Mismatch => "read-back differs",
        StoreError::SequenceExhausted => "sequence exhausted",
    }
}
