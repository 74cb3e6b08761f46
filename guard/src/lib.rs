//! The guard stage's decision: is the firmware image in flash whole?
//!
//! **Responsibilities.** The layout of the flash that a field update rewrites, the image header
//! the `fw-image` tool seals into a linked firmware ([`seal`]), and the check the guard makes at
//! every reset before it starts the image ([`check`]). The guard (`src/main.rs`) sits in the
//! first 2 KiB page of the STM32G474's flash, which a field update never writes; the image
//! begins at [`APP_BASE`]. An image cut by a power loss during a `dfu-util` download (the G474's
//! ROM bootloader erases, then programs page after page) fails the check, and the guard enters
//! the ROM bootloader instead of starting it, so `dfu-util` can be run again: the update is
//! power-fail safe without a debug probe (book: Hardware, "Updating the firmware").
//!
//! **The header** uses two of the Cortex-M vector table's reserved words (ARMv7-M ARM B1.5.3:
//! entries 7–10 are reserved and never read by the core; cortex-m-rt writes 0 there):
//! word 7 = the image's length in bytes (a multiple of 4, erased flash reads 0xFFFF_FFFF),
//! word 8 = CRC-32/ISO-HDLC (zlib's `crc32`) of the image's `length` bytes with word 8 read as
//! 0. The header lives inside the image, so the ELF a debug probe flashes carries it too.
//!
//! No allocation, no panics: the guard must not fail where the image may be torn.
#![no_std]

/// Start of bank 1 (dual-bank mode, RM0440 §3.3.1): the guard's page.
pub const FLASH_BASE: u32 = 0x0800_0000;
/// Start of the firmware image: the second 2 KiB page of bank 1 (the repository's memory.x).
pub const APP_BASE: u32 = 0x0800_0800;
/// End of the flash an image may occupy: the settings pages (the last two of bank 2) begin here.
pub const APP_LIMIT: u32 = 0x0807_F000;
/// SRAM1 + SRAM2, where the image's initial stack pointer must point (a full-descending stack
/// may start at the end itself).
pub const RAM: core::ops::RangeInclusive<u32> = 0x2000_0000..=0x2001_8000;
/// Vector-table word holding the image length in bytes (the first reserved entry).
pub const LENGTH_WORD: usize = 7;
/// Vector-table word holding the image CRC (the second reserved entry).
pub const CRC_WORD: usize = 8;
/// The shortest image: the header words must be inside it.
pub const MIN_LENGTH: u32 = (CRC_WORD as u32 + 1) * 4;
/// The longest image, bytes.
pub const MAX_LENGTH: u32 = APP_LIMIT - APP_BASE;

/// The STM32 CRC unit's set-up that computes CRC-32/ISO-HDLC over 32-bit words read from
/// little-endian memory (RM0440 §16.4.2 CRC_CR): REV_OUT (bit 7) and REV_IN = 0b11 "bit
/// reversal done by word" (bits 6:5), 32-bit polynomial (POLYSIZE 0), RESET (bit 0) to load
/// [`CRC_INIT`]. The unit's result is then complemented ([`CRC_XOR_OUT`]).
pub const CRC_CR: u32 = (1 << 7) | (0b11 << 5) | 1;
/// CRC_INIT for CRC-32/ISO-HDLC (the register's reset value).
pub const CRC_INIT: u32 = 0xFFFF_FFFF;
/// CRC_POL: the CRC-32 polynomial 0x04C1_1DB7 (the register's reset value).
pub const CRC_POLY: u32 = 0x04C1_1DB7;
/// What the unit's data register is XORed with for the CRC-32/ISO-HDLC value.
pub const CRC_XOR_OUT: u32 = 0xFFFF_FFFF;

/// A CRC-32/ISO-HDLC over 32-bit words, each taken as its four little-endian bytes.
pub trait WordCrc {
    /// Starts a new CRC.
    fn start(&mut self);
    /// Adds one word.
    fn feed(&mut self, word: u32);
    /// The CRC of the words fed since [`WordCrc::start`].
    fn value(&mut self) -> u32;
}

/// A software [`WordCrc`] (the `crc` crate), for the host tools and tests.
pub struct SoftCrc(crc::Digest<'static, u32>);

static CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

impl Default for SoftCrc {
    fn default() -> Self {
        Self(CRC32.digest())
    }
}

impl WordCrc for SoftCrc {
    fn start(&mut self) {
        self.0 = CRC32.digest();
    }
    fn feed(&mut self, word: u32) {
        self.0.update(&word.to_le_bytes());
    }
    fn value(&mut self) -> u32 {
        core::mem::replace(&mut self.0, CRC32.digest()).finalize()
    }
}

/// Why the guard does not start the image (it enters the ROM bootloader instead).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refusal {
    /// A read met a double ECC error (a double-word cut while it was programmed).
    Unreadable,
    /// The length word is not a length this flash can hold (erased: 0xFFFF_FFFF; unsealed: 0).
    BadLength(u32),
    /// The initial stack pointer is not in SRAM (an image for another layout, or torn).
    StackOutsideRam(u32),
    /// The reset vector is not Thumb code inside the image (e.g. an image linked at 0x0800_0000).
    ResetOutsideImage(u32),
    /// The CRC over the image does not match its header (a download cut, or flash corrupted).
    CrcMismatch {
        /// CRC in the header.
        stored: u32,
        /// CRC computed over the flash.
        computed: u32,
    },
}

/// The guard's decision.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// The image is whole: start it (its vector table at [`APP_BASE`]).
    Start,
    /// Enter the ROM bootloader.
    Refuse(Refusal),
}

/// Checks the image through `read_word(i)` — the i-th 32-bit word from [`APP_BASE`], `None`
/// where the read met a double ECC error — with `crc`. Reads only inside the length the header
/// states (itself at most [`MAX_LENGTH`]).
pub fn check(mut read_word: impl FnMut(usize) -> Option<u32>, crc: &mut impl WordCrc) -> Verdict {
    match check_words(&mut read_word, crc) {
        Ok(()) => Verdict::Start,
        Err(r) => Verdict::Refuse(r),
    }
}

fn check_words(
    read_word: &mut impl FnMut(usize) -> Option<u32>,
    crc: &mut impl WordCrc,
) -> Result<(), Refusal> {
    let mut word = |i| read_word(i).ok_or(Refusal::Unreadable);
    let length = word(LENGTH_WORD)?;
    if !(MIN_LENGTH..=MAX_LENGTH).contains(&length) || !length.is_multiple_of(4) {
        return Err(Refusal::BadLength(length));
    }
    let stack_pointer = word(0)?;
    if !RAM.contains(&stack_pointer) || !stack_pointer.is_multiple_of(4) {
        return Err(Refusal::StackOutsideRam(stack_pointer));
    }
    let reset_vector = word(1)?;
    let code = APP_BASE..APP_BASE + length;
    if reset_vector & 1 == 0 || !code.contains(&(reset_vector & !1)) {
        return Err(Refusal::ResetOutsideImage(reset_vector));
    }
    let stored = word(CRC_WORD)?;
    crc.start();
    for i in 0..(length / 4) as usize {
        let w = word(i)?;
        crc.feed(if i == CRC_WORD { 0 } else { w });
    }
    let computed = crc.value();
    if computed != stored {
        return Err(Refusal::CrcMismatch { stored, computed });
    }
    Ok(())
}

/// Why an image cannot be sealed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SealError {
    /// Not a multiple of 4 bytes, shorter than the header or longer than [`MAX_LENGTH`].
    BadLength(usize),
}

/// Writes the header into `image` (the bytes to be placed at [`APP_BASE`], padded to a
/// multiple of 4 with 0xFF, erased flash): its length and CRC. Returns the CRC.
pub fn seal(image: &mut [u8]) -> Result<u32, SealError> {
    let length = image.len();
    if !length.is_multiple_of(4) || !(MIN_LENGTH as usize..=MAX_LENGTH as usize).contains(&length) {
        return Err(SealError::BadLength(length));
    }
    let mut put = |word: usize, value: u32| {
        if let Some(b) = image.get_mut(word * 4..word * 4 + 4) {
            b.copy_from_slice(&value.to_le_bytes());
        }
    };
    put(LENGTH_WORD, length as u32);
    put(CRC_WORD, 0);
    let crc = CRC32.checksum(image);
    if let Some(b) = image.get_mut(CRC_WORD * 4..CRC_WORD * 4 + 4) {
        b.copy_from_slice(&crc.to_le_bytes());
    }
    Ok(crc)
}

/// The i-th little-endian word of `bytes`, `None` past its end.
pub fn word_at(bytes: &[u8], i: usize) -> Option<u32> {
    let b: [u8; 4] = bytes.get(i * 4..i * 4 + 4)?.try_into().ok()?;
    Some(u32::from_le_bytes(b))
}
