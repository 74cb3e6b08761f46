//! An in-memory model of the STM32G4 flash for the settings slots: two 2 KiB pages, erased to
//! 0xFF, programmed in 8-byte double-words that must be erased first (RM0440 §3.3.7: a
//! program of a non-erased double-word is refused with PROGERR) and that can only clear bits
//! (1 → 0). Power can be cut after any number of **byte steps**: an erase sets one byte to 0xFF
//! per step, a program clears the bits of one byte per step, so a cut leaves a page half erased
//! or a double-word half programmed — the torn states a real power loss can leave.
//!
//! Each double-word carries ECC bits written with it (RM0440 "Error code correction"): a
//! double-word whose erase or program was cut part-way has data and ECC that disagree, and
//! reading any byte of it is a double ECC error — on the pod an NMI, which the firmware turns
//! into a failed read ([`FlashFault::Ecc`]). An erase or a complete program makes it whole.

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
    /// A read met a double-word whose erase or program a power cut left part-way.
    Ecc,
}

/// Double-words of one page.
const DWORDS: usize = PAGE_BYTES / WRITE_SIZE;

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
    /// Double-words left part-way by a power cut (data and ECC disagree), per page.
    pub torn: [[bool; DWORDS]; 2],
    /// Reads that met a torn double-word.
    pub ecc_reads: usize,
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
            torn: [[false; DWORDS]; 2],
            ecc_reads: 0,
        }
    }

    /// The same flash contents after power comes back: no budget, counters at zero.
    pub fn power_on(&self) -> Self {
        Self {
            pages: self.pages,
            erase_order: self.erase_order,
            torn: self.torn,
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
        let dwords = offset / WRITE_SIZE..(offset + buf.len()).div_ceil(WRITE_SIZE);
        if self.torn[slot.index()][dwords].contains(&true) {
            self.ecc_reads += 1;
            return Err(FlashFault::Ecc);
        }
        buf.copy_from_slice(src);
        Ok(())
    }

    fn erase(&mut self, slot: Slot) -> Result<(), FlashFault> {
        self.erases += 1;
        let order: Vec<usize> = match self.erase_order {
            EraseOrder::Forward => (0..PAGE_BYTES).collect(),
            EraseOrder::Backward => (0..PAGE_BYTES).rev().collect(),
        };
        // both orders reach the double-words one after the other
        for (done, i) in order.into_iter().enumerate() {
            if !self.step() {
                if done % WRITE_SIZE != 0 {
                    // byte i's double-word is erased part-way
                    self.torn[slot.index()][i / WRITE_SIZE] = true;
                }
                return Err(FlashFault::PowerCut);
            }
            self.pages[slot.index()][i] = 0xFF;
            if (done + 1) % WRITE_SIZE == 0 {
                self.torn[slot.index()][i / WRITE_SIZE] = false;
            }
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
        let d = offset / WRITE_SIZE;
        if page[offset..offset + WRITE_SIZE].iter().any(|&b| b != 0xFF)
            || self.torn[slot.index()][d]
        {
            return Err(FlashFault::NotErased);
        }
        for (k, &b) in dword.iter().enumerate() {
            if !self.step() {
                // cut part-way: the ECC bits do not match what was written
                self.torn[slot.index()][d] = k != 0;
                return Err(FlashFault::PowerCut);
            }
            // Programming only clears bits.
            self.pages[slot.index()][offset + k] &= b;
        }
        Ok(())
    }
}
