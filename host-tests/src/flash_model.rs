//! An in-memory model of the STM32G4 flash for the settings slots: two 2 KiB pages, erased to
//! 0xFF, programmed in 8-byte double-words that must be erased first (RM0440 §3.3.7: a
//! program of a non-erased double-word is refused with PROGERR) and that can only clear bits
//! (1 → 0). Power can be cut after any number of **byte steps**: an erase sets one byte to 0xFF
//! per step, a program clears the bits of one byte per step, so a cut leaves a page half erased
//! or a double-word half programmed — the torn states a real power loss can leave.

use ballpod::settings::{SettingsFlash, Slot, WRITE_SIZE};

/// Bytes of one page (STM32G474 in dual-bank mode: 2 KiB).
pub const PAGE_BYTES: usize = 2048;

/// The order in which an erase reaches the bytes of a page (the hardware does not promise one).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EraseOrder {
    /// From the first byte of the page to the last.
    Forward,
    /// From the last byte to the first.
    Backward,
}

/// Why the model refused an operation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlashFault {
    /// Power was cut (this operation was interrupted, or came after the cut).
    PowerCut,
    /// Programming a double-word that is not erased.
    NotErased,
    /// An access outside the page or a program not on a double-word boundary.
    BadAddress,
}

/// Two pages of flash with an optional power-cut budget.
#[derive(Clone, Debug)]
pub struct FlashModel {
    /// The page contents (index 0 = slot A, 1 = slot B).
    pub pages: [[u8; PAGE_BYTES]; 2],
    /// Byte steps left before power is cut (`None`: never).
    pub budget: Option<usize>,
    /// Byte steps done since construction.
    pub steps: usize,
    /// Erase order.
    pub erase_order: EraseOrder,
    /// Erases started.
    pub erases: usize,
    /// Double-word programs started.
    pub programs: usize,
}

impl FlashModel {
    /// Fully erased flash, no power cut.
    pub fn erased() -> Self {
        Self {
            pages: [[0xFF; PAGE_BYTES]; 2],
            budget: None,
            steps: 0,
            erase_order: EraseOrder::Forward,
            erases: 0,
            programs: 0,
        }
    }

    /// The same flash contents after power comes back: no budget, counters at zero.
    pub fn power_on(&self) -> Self {
        Self {
            pages: self.pages,
            erase_order: self.erase_order,
            ..Self::erased()
        }
    }

    /// One byte step; false once the power is cut.
    fn step(&mut self) -> bool {
        match &mut self.budget {
            Some(0) => false,
            Some(n) => {
                *n -= 1;
                self.steps += 1;
                true
            }
            None => {
                self.steps += 1;
                true
            }
        }
    }
}

impl SettingsFlash for FlashModel {
    type Error = FlashFault;

    fn read(&mut self, slot: Slot, offset: usize, buf: &mut [u8]) -> Result<(), FlashFault> {
        let src = self.pages[slot.index()]
            .get(offset..offset + buf.len())
            .ok_or(FlashFault::BadAddress)?;
        buf.copy_from_slice(src);
        Ok(())
    }

    fn erase(&mut self, slot: Slot) -> Result<(), FlashFault> {
        self.erases += 1;
        let order: Vec<usize> = match self.erase_order {
            EraseOrder::Forward => (0..PAGE_BYTES).collect(),
            EraseOrder::Backward => (0..PAGE_BYTES).rev().collect(),
        };
        for i in order {
            if !self.step() {
                return Err(FlashFault::PowerCut);
            }
            self.pages[slot.index()][i] = 0xFF;
        }
        Ok(())
    }

    fn program(
        &mut self,
        slot: Slot,
        offset: usize,
        dword: &[u8; WRITE_SIZE],
    ) -> Result<(), FlashFault> {
        self.programs += 1;
        if !offset.is_multiple_of(WRITE_SIZE) || offset + WRITE_SIZE > PAGE_BYTES {
            return Err(FlashFault::BadAddress);
        }
        let page = &self.pages[slot.index()];
        if page[offset..offset + WRITE_SIZE].iter().any(|&b| b != 0xFF) {
            return Err(FlashFault::NotErased);
        }
        for (k, &b) in dword.iter().enumerate() {
            if !self.step() {
                return Err(FlashFault::PowerCut);
            }
            // Programming only clears bits.
            self.pages[slot.index()][offset + k] &= b;
        }
        Ok(())
    }
}
