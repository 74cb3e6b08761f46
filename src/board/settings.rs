//! The settings slots in the internal flash: the last two 2 KiB pages of bank 2 (dual-bank
//! mode, RM0440 §3.3.1), driven by embassy-stm32's blocking flash driver behind the core's
//! [`SettingsFlash`] trait. `memory.x` ends the linker's FLASH region 4 KiB early so no code
//! or data can be placed there.
//!
//! An erase takes about 22 ms (RM0440 Table 40, t_ERASE max 40 ms) during which the executor
//! runs nothing else: the LVDT DMA rings keep filling and their overruns are counted, so a
//! save during a run shows up as flagged samples, never as silent ones.

use embassy_stm32::flash::{Blocking, FLASH_SIZE, Flash, MAX_ERASE_SIZE};

use ballpod::settings::{SettingsFlash, Slot, SlotError, StoreError, WRITE_SIZE};

/// Bytes of one slot (one erase page).
pub const SLOT_BYTES: usize = MAX_ERASE_SIZE;
/// Flash offset of slot A (from the start of flash, 0x0800_0000).
pub const SLOT_A_OFFSET: usize = FLASH_SIZE - 2 * SLOT_BYTES;

/// The two settings pages.
pub struct SettingsPages(pub Flash<'static, Blocking>);

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
    type Error = embassy_stm32::flash::Error;

    fn read(&mut self, slot: Slot, at: usize, buf: &mut [u8]) -> Result<(), Self::Error> {
        let o = offset(slot, at, buf.len())?;
        self.0.blocking_read(o, buf)
    }

    fn erase(&mut self, slot: Slot) -> Result<(), Self::Error> {
        let o = offset(slot, 0, SLOT_BYTES)?;
        self.0.blocking_erase(o, o + SLOT_BYTES as u32)
    }

    fn program(
        &mut self,
        slot: Slot,
        at: usize,
        dword: &[u8; WRITE_SIZE],
    ) -> Result<(), Self::Error> {
        let o = offset(slot, at, WRITE_SIZE)?;
        self.0.blocking_write(o, dword)
    }
}

// The core's double-word is the G4's programming unit.
const _: () = assert!(WRITE_SIZE == embassy_stm32::flash::WRITE_SIZE);
const _: () = assert!(ballpod::settings::RECORD_LEN <= SLOT_BYTES);

/// A short name of why a slot was not used (for the boot log; no float formatting).
pub fn slot_reason(r: &Result<ballpod::settings::Record, SlotError>) -> &'static str {
    match r {
        Ok(_) => "valid",
        Err(SlotError::Erased) => "erased",
        Err(SlotError::Read) => "read error",
        Err(SlotError::BadMagic) => "bad magic",
        Err(SlotError::UnsupportedVersion(_)) => "unsupported version",
        Err(SlotError::BadLength(_)) => "bad length",
        Err(SlotError::BadCrc) => "bad CRC",
        Err(SlotError::Config(_)) => "configuration rejected",
    }
}

/// A short name of why a save failed (for the log; no float formatting).
pub fn store_reason(e: &StoreError<embassy_stm32::flash::Error>) -> &'static str {
    match e {
        StoreError::Config(_) => "configuration rejected",
        StoreError::Erase(_) => "erase failed",
        StoreError::Program { .. } => "program failed",
        StoreError::Verify(_) => "read-back does not decode",
        StoreError::Mismatch => "read-back differs",
        StoreError::SequenceExhausted => "sequence exhausted",
    }
}
