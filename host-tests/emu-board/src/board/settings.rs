//! The settings pages: two 2 KiB pages of RAM with the STM32G4's flash rules — erased to
//! 0xFF a page at a time, programmed a double-word at a time, only onto an erased double-word
//! (the G4 refuses to program a non-erased one: PROGERR). They are in a section the start-up
//! code leaves alone, so they survive a reset (a watchdog's, a panic's) but not QEMU's exit.

use core::cell::UnsafeCell;

use ballpod::settings::{SettingsFlash, Slot, StoreError, WRITE_SIZE};

/// Bytes of one slot (one erase page).
pub const SLOT_BYTES: usize = 2048;

/// A G4 flash error the emulated pages give.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlashError {
    /// Beyond the slot.
    Size,
    /// Programming a double-word that is not erased.
    Prog,
}

struct Pages(UnsafeCell<[[u8; SLOT_BYTES]; 2]>);
// SAFETY: reached only through the one `SettingsPages` (main, then the worker).
unsafe impl Sync for Pages {}

#[unsafe(link_section = ".uninit.ballpod_settings")]
static PAGES: Pages = Pages(UnsafeCell::new([[0xFF; SLOT_BYTES]; 2]));

/// The two settings pages.
pub struct SettingsPages(());

impl SettingsPages {
    /// The pages (once: boot). `fresh` (a cold start: the region was just made) erases them.
    pub fn take(fresh: bool) -> Self {
        let mut p = Self(());
        if fresh {
            let _ = p.erase(Slot::A);
            let _ = p.erase(Slot::B);
        }
        p
    }

    fn page(&mut self, slot: Slot) -> &mut [u8; SLOT_BYTES] {
        // SAFETY: `self` is the pages' only handle (`take` runs once).
        let pages = unsafe { &mut *PAGES.0.get() };
        &mut pages[slot.index() % 2]
    }
}

impl SettingsFlash for SettingsPages {
    type Error = FlashError;

    fn read(&mut self, slot: Slot, at: usize, buf: &mut [u8]) -> Result<(), Self::Error> {
        let src = self
            .page(slot)
            .get(at..at + buf.len())
            .ok_or(FlashError::Size)?;
        buf.copy_from_slice(src);
        Ok(())
    }

    fn erase(&mut self, slot: Slot) -> Result<(), Self::Error> {
        self.page(slot).fill(0xFF);
        Ok(())
    }

    fn program(
        &mut self,
        slot: Slot,
        at: usize,
        dword: &[u8; WRITE_SIZE],
    ) -> Result<(), Self::Error> {
        if !at.is_multiple_of(WRITE_SIZE) {
            return Err(FlashError::Size);
        }
        let dst = self
            .page(slot)
            .get_mut(at..at + WRITE_SIZE)
            .ok_or(FlashError::Size)?;
        if dst.iter().any(|&b| b != 0xFF) {
            return Err(FlashError::Prog);
        }
        dst.copy_from_slice(dword);
        Ok(())
    }
}

/// A short name of why a save failed.
pub fn store_reason(e: &StoreError<FlashError>) -> &'static str {
    match e {
        StoreError::Config(_) => "configuration rejected",
        StoreError::Erase(_) => "erase failed",
        _ => "program or verify failed",
    }
}
