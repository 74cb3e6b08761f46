//! The firmware image a field update writes (`cargo fw-image`): the bytes of the linked ELF's
//! loadable segments from `ballpod_guard::APP_BASE`, as they will stand in flash (gaps and
//! the padding to a whole word 0xFF, erased flash, as a debug probe leaves them), sealed with
//! the guard's header (length, CRC-32: `ballpod_guard::seal`). The header is written back into
//! the ELF too, so the image a probe flashes passes the guard like the one `dfu-util` writes.
use object::elf::{FileHeader32, PT_LOAD};
use object::read::elf::{FileHeader, ProgramHeader};
use object::{Endianness, FileKind};

use ballpod_guard::{APP_BASE, APP_LIMIT, CRC_WORD, LENGTH_WORD, SoftCrc, Verdict};

/// A loadable segment: where it goes in flash and where its bytes are in the file.
#[derive(Clone, Copy, Debug)]
struct Segment {
    /// Physical (load) address.
    address: u32,
    /// Offset of its bytes in the ELF file.
    offset: usize,
    /// Bytes in the file.
    size: usize,
}

/// A sealed image.
#[derive(Debug)]
pub struct Image {
    /// The bytes to place at `APP_BASE` (the `.bin` for `dfu-util`).
    pub bytes: Vec<u8>,
    /// Its CRC-32 (header word 8).
    pub crc: u32,
}

/// Why an ELF does not give an image.
#[derive(Debug, PartialEq, Eq)]
pub enum ImageError {
    /// Not a 32-bit little-endian ELF, or its program headers are unreadable.
    NotElf(String),
    /// A segment loads outside [APP_BASE, APP_LIMIT) (e.g. linked at 0x0800_0000 for a board
    /// without the guard).
    OutsideImageRegion {
        /// Its load address.
        address: u32,
        /// Its size, bytes.
        size: usize,
    },
    /// No segment loads at `APP_BASE`: no vector table there.
    NoVectorTable,
    /// Longer than the flash the guard accepts.
    TooLong(usize),
    /// The sealed image would not pass the guard (its stack pointer or reset vector).
    Refused(ballpod_guard::Refusal),
}

impl std::fmt::Display for ImageError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::NotElf(e) => write!(f, "not a 32-bit little-endian ELF: {e}"),
            Self::OutsideImageRegion { address, size } => write!(
                f,
                "a segment of {size} bytes loads at {address:#010x}, outside the image region \
                 {APP_BASE:#010x}..{APP_LIMIT:#010x} (linked for another layout?)"
            ),
            Self::NoVectorTable => write!(f, "nothing loads at {APP_BASE:#010x}"),
            Self::TooLong(n) => write!(f, "the image is {n} bytes, longer than the flash holds"),
            Self::Refused(r) => write!(f, "the guard would not start this image: {r:?}"),
        }
    }
}

impl std::error::Error for ImageError {}

fn segments(elf: &[u8]) -> Result<Vec<Segment>, ImageError> {
    let bad = |e: object::Error| ImageError::NotElf(e.to_string());
    if FileKind::parse(elf).map_err(bad)? != FileKind::Elf32 {
        return Err(ImageError::NotElf("not ELF32".into()));
    }
    let header = FileHeader32::<Endianness>::parse(elf).map_err(bad)?;
    let endian = header.endian().map_err(bad)?;
    if endian != Endianness::Little {
        return Err(ImageError::NotElf("big-endian".into()));
    }
    let mut out = Vec::new();
    for ph in header.program_headers(endian, elf).map_err(bad)? {
        let size = ph.p_filesz(endian) as usize;
        if ph.p_type(endian) != PT_LOAD || size == 0 {
            continue;
        }
        let address = ph.p_paddr(endian);
        let end = u64::from(address) + size as u64;
        if address < APP_BASE || end > u64::from(APP_LIMIT) {
            return Err(ImageError::OutsideImageRegion { address, size });
        }
        out.push(Segment {
            address,
            offset: ph.p_offset(endian) as usize,
            size,
        });
    }
    Ok(out)
}

/// The sealed image of the ELF `elf` (its loadable segments at their load addresses).
pub fn image_of(elf: &[u8]) -> Result<Image, ImageError> {
    let segs = segments(elf)?;
    if !segs.iter().any(|s| s.address == APP_BASE) {
        return Err(ImageError::NoVectorTable);
    }
    let end = segs
        .iter()
        .map(|s| (s.address - APP_BASE) as usize + s.size)
        .max()
        .unwrap_or(0);
    let mut bytes = vec![0xFF; end.next_multiple_of(4)];
    for s in &segs {
        let from = elf
            .get(s.offset..s.offset + s.size)
            .ok_or_else(|| ImageError::NotElf("a segment ends past the file".into()))?;
        let at = (s.address - APP_BASE) as usize;
        bytes[at..at + s.size].copy_from_slice(from);
    }
    let crc = ballpod_guard::seal(&mut bytes).map_err(|_| ImageError::TooLong(bytes.len()))?;
    // the guard's own check, with the software CRC: what the pod will decide
    let verdict = ballpod_guard::check(
        |i| ballpod_guard::word_at(&bytes, i),
        &mut SoftCrc::default(),
    );
    match verdict {
        Verdict::Start => Ok(Image { bytes, crc }),
        Verdict::Refuse(r) => Err(ImageError::Refused(r)),
    }
}

/// Writes `image`'s header words into the ELF `elf` (in the segment holding the vector table).
pub fn patch_elf(elf: &mut [u8], image: &Image) -> Result<(), ImageError> {
    let segs = segments(elf)?;
    let seg = segs
        .iter()
        .find(|s| s.address == APP_BASE && s.size >= (CRC_WORD + 1) * 4)
        .ok_or(ImageError::NoVectorTable)?;
    for word in [LENGTH_WORD, CRC_WORD] {
        let at = seg.offset + word * 4;
        elf[at..at + 4].copy_from_slice(&image.bytes[word * 4..word * 4 + 4]);
    }
    Ok(())
}
