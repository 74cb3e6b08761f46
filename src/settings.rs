//! Settings persistence: the [`Config`] in two flash slots, power-safe.
//!
//! Each slot is one erase page holding one *record*:
//!
//! | bytes | field |
//! |---|---|
//! | 0..4 | magic `"BPSL"` |
//! | 4..6 | record format version (u16 LE, [`RECORD_VERSION`]) |
//! | 6..8 | payload length (u16 LE, = [`config::ENCODED_LEN`]) |
//! | 8..12 | sequence number (u32 LE, 1 for the first save, +1 per save) |
//! | 12..12+n | payload: [`Config::encode`] (itself versioned and CRC'd) |
//! | 12+n..16+n | CRC-32/ISO-HDLC over bytes 0..12+n (header + payload) |
//! | …[`RECORD_LEN`] | padding to whole double-words, left erased (0xFF), not checked |
//!
//! A save goes to the slot that does **not** hold the newest valid record: erase that page,
//! program the record double-word by double-word from the start, read it back. The CRC sits in
//! the last double-words, so a save cut short at any point leaves a record that fails its CRC
//! (or an erased / half-erased page), and the other slot — untouched — still holds the previous
//! settings. [`load`] takes the valid record with the highest sequence number; the switch from
//! old to new settings is therefore the programming of the new record's last double-word. If
//! no slot is valid (first boot, or both damaged), [`load`] returns the defaults and says so.
//!
//! The flash is abstracted by [`SettingsFlash`] (erase a page, program 8-byte double-words,
//! read), the write and erase granularity of the STM32G4 (RM0440 §3.3.7: 64-bit programming
//! of an erased double-word; §3.3.6: 2 KiB page erase in dual-bank mode). The sequence number
//! cannot wrap in practice (10 000 erase cycles per page are guaranteed, a u32 counts to 4·10⁹);
//! [`store`] refuses a save rather than wrapping.

use crate::config::{self, Config, ConfigError};

/// One of the two settings slots (one erase page each).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Slot {
    /// The first slot.
    A,
    /// The second slot.
    B,
}

impl Slot {
    /// The other slot.
    pub const fn other(self) -> Slot {
        match self {
            Slot::A => Slot::B,
            Slot::B => Slot::A,
        }
    }
    /// 0 for A, 1 for B.
    pub const fn index(self) -> usize {
        match self {
            Slot::A => 0,
            Slot::B => 1,
        }
    }
}

/// The flash the settings live in: two pages, erased to 0xFF, programmed in whole 8-byte
/// double-words that must be erased before they are programmed.
pub trait SettingsFlash {
    /// The driver's error.
    type Error;
    /// Reads `buf.len()` bytes of `slot` from byte `offset` of its page.
    fn read(&mut self, slot: Slot, offset: usize, buf: &mut [u8]) -> Result<(), Self::Error>;
    /// Erases the page of `slot` (all bytes become 0xFF).
    fn erase(&mut self, slot: Slot) -> Result<(), Self::Error>;
    /// Programs the double-word at byte `offset` (a multiple of [`WRITE_SIZE`]) of `slot`.
    fn program(
        &mut self,
        slot: Slot,
        offset: usize,
        dword: &[u8; WRITE_SIZE],
    ) -> Result<(), Self::Error>;
}

/// Programming unit of the flash in bytes (STM32G4: one 64-bit double-word).
pub const WRITE_SIZE: usize = 8;
/// Magic at the start of a record.
pub const RECORD_MAGIC: [u8; 4] = *b"BPSL";
/// Record format version.
pub const RECORD_VERSION: u16 = 1;
/// Header bytes before the payload: magic, version, payload length, sequence.
pub const HEADER_LEN: usize = 4 + 2 + 2 + 4;
/// Byte offset of the record CRC.
pub const CRC_AT: usize = HEADER_LEN + config::ENCODED_LEN;
/// Bytes of a record, padded to whole double-words.
pub const RECORD_LEN: usize = (CRC_AT + 4).div_ceil(WRITE_SIZE) * WRITE_SIZE;

/// Why a slot does not hold a usable record.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SlotError {
    /// The record bytes are all 0xFF (never written, or erased).
    Erased,
    /// The flash driver failed to read the slot: on the pod, a double ECC error — a double-word
    /// whose programming or erase a power loss cut (the NMI handler marks the read failed).
    Read,
    /// The record does not start with [`RECORD_MAGIC`].
    BadMagic,
    /// A record format version this firmware does not read.
    UnsupportedVersion(u16),
    /// The payload length is not that of the current configuration encoding.
    BadLength(u16),
    /// The record CRC does not match (torn write or corruption).
    BadCrc,
    /// The record is intact but its configuration is rejected.
    Config(ConfigError),
}

/// A decoded record.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Record {
    /// Its sequence number.
    pub sequence: u32,
    /// The configuration it holds (validated).
    pub config: Config,
}

/// Decodes one slot's record bytes (at least [`RECORD_LEN`] bytes; more are ignored).
pub fn decode_record(bytes: &[u8]) -> Result<Record, SlotError> {
    let rec = bytes
        .get(..RECORD_LEN)
        .ok_or(SlotError::BadLength(bytes.len() as u16))?;
    if rec.iter().all(|&b| b == 0xFF) {
        return Err(SlotError::Erased);
    }
    let field = |from: usize, to: usize| rec.get(from..to).unwrap_or(&[]);
    if field(0, 4) != RECORD_MAGIC {
        return Err(SlotError::BadMagic);
    }
    let u16_at = |at: usize| field(at, at + 2).try_into().map_or(0, u16::from_le_bytes);
    let u32_at = |at: usize| field(at, at + 4).try_into().map_or(0, u32::from_le_bytes);
    let version = u16_at(4);
    if version != RECORD_VERSION {
        return Err(SlotError::UnsupportedVersion(version));
    }
    let len = u16_at(6);
    // a record of the previous configuration encoding is read and migrated (config::decode)
    if !config::ENCODED_LENS.contains(&usize::from(len)) {
        return Err(SlotError::BadLength(len));
    }
    let crc_at = HEADER_LEN + usize::from(len);
    if u32_at(crc_at) != crate::num::crc32(field(0, crc_at)) {
        return Err(SlotError::BadCrc);
    }
    let config = Config::decode(field(HEADER_LEN, crc_at)).map_err(SlotError::Config)?;
    Ok(Record {
        sequence: u32_at(8),
        config,
    })
}

/// Encodes a record (the padding stays 0xFF, as erased flash).
pub fn encode_record(config: &Config, sequence: u32) -> Result<[u8; RECORD_LEN], ConfigError> {
    let mut rec = [0xFFu8; RECORD_LEN];
    let (head, rest) = rec.split_at_mut(HEADER_LEN);
    let (version, len, seq) = (
        RECORD_VERSION.to_le_bytes(),
        (config::ENCODED_LEN as u16).to_le_bytes(),
        sequence.to_le_bytes(),
    );
    let header = RECORD_MAGIC.iter().chain(&version).chain(&len).chain(&seq);
    for (d, s) in head.iter_mut().zip(header) {
        *d = *s;
    }
    config.encode(rest)?;
    let crc = crate::num::crc32(rec.get(..CRC_AT).unwrap_or(&[]));
    if let Some(dst) = rec.get_mut(CRC_AT..CRC_AT + 4) {
        dst.copy_from_slice(&crc.to_le_bytes());
    }
    Ok(rec)
}

/// What [`load`] found in each slot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlotScan {
    /// Slot A's record or why it is unusable.
    pub a: Result<Record, SlotError>,
    /// Slot B's record or why it is unusable.
    pub b: Result<Record, SlotError>,
}

impl SlotScan {
    /// The valid record with the highest sequence number, and its slot.
    pub fn newest(&self) -> Option<(Slot, &Record)> {
        match (&self.a, &self.b) {
            (Ok(a), Ok(b)) if b.sequence > a.sequence => Some((Slot::B, b)),
            (Ok(a), _) => Some((Slot::A, a)),
            (Err(_), Ok(b)) => Some((Slot::B, b)),
            (Err(_), Err(_)) => None,
        }
    }
}

/// Reads and decodes both slots.
pub fn scan<F: SettingsFlash>(flash: &mut F) -> SlotScan {
    let mut read = |slot| {
        let mut buf = [0u8; RECORD_LEN];
        flash
            .read(slot, 0, &mut buf)
            .map_err(|_| SlotError::Read)
            .and_then(|()| decode_record(&buf))
    };
    SlotScan {
        a: read(Slot::A),
        b: read(Slot::B),
    }
}

/// The settings loaded at boot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Loaded {
    /// The configuration to run with.
    pub config: Config,
    /// Where it came from: a slot and sequence number, or `None` for the defaults (no slot
    /// held a valid record — the flag to report).
    pub from: Option<(Slot, u32)>,
    /// What each slot held.
    pub scan: SlotScan,
}

impl Loaded {
    /// True when no valid record was found and the defaults are in use.
    pub fn is_defaults(&self) -> bool {
        self.from.is_none()
    }
    /// Slots that could not be read (0–2: [`SlotError::Read`], a flash ECC error on the pod):
    /// the other slot's settings or the defaults are in use, and the pod says so at boot
    /// (`protocol::report_unreadable_settings`).
    pub fn unreadable(&self) -> u32 {
        [&self.scan.a, &self.scan.b]
            .into_iter()
            .filter(|s| matches!(s, Err(SlotError::Read)))
            .count() as u32
    }

    /// Why a slot's record, intact (CRC good), holds a configuration this firmware rejects — a
    /// value the hardware cannot realise, a rule added since it was saved — if one does: the
    /// other slot's settings or the defaults are in use, and the pod says so at boot
    /// (`protocol::report_rejected_settings`).
    pub fn rejected(&self) -> Option<ConfigError> {
        [&self.scan.a, &self.scan.b]
            .into_iter()
            .find_map(|s| match s {
                Err(SlotError::Config(e)) => Some(*e),
                _ => None,
            })
    }
}

/// Loads the newest valid settings, or the defaults (flagged) if neither slot is valid.
/// Never fails.
pub fn load<F: SettingsFlash>(flash: &mut F) -> Loaded {
    let scan = scan(flash);
    match scan.newest() {
        Some((slot, rec)) => Loaded {
            config: rec.config,
            from: Some((slot, rec.sequence)),
            scan,
        },
        None => Loaded {
            config: Config::default(),
            from: None,
            scan,
        },
    }
}

/// Why a save failed (the previous settings are still the ones [`load`] returns).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StoreError<E> {
    /// The configuration does not encode (invalid).
    Config(ConfigError),
    /// The flash driver failed to erase the target page.
    Erase(E),
    /// The flash driver failed to program a double-word at this byte offset.
    Program {
        /// Byte offset in the record.
        offset: usize,
        /// The driver's error.
        error: E,
    },
    /// The record read back does not decode to the stored configuration.
    Verify(SlotError),
    /// The record read back is valid but not the one written.
    Mismatch,
    /// The sequence number would wrap (never reached in the flash's lifetime).
    SequenceExhausted,
}

/// Where a save went.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Stored {
    /// The slot written.
    pub slot: Slot,
    /// The record's sequence number.
    pub sequence: u32,
}

/// Saves `config` into the slot not holding the newest valid record, with the next sequence
/// number (erase, program every double-word in order, read back and compare).
pub fn store<F: SettingsFlash>(
    flash: &mut F,
    config: &Config,
) -> Result<Stored, StoreError<F::Error>> {
    config.validate().map_err(StoreError::Config)?;
    let (slot, sequence) = match scan(flash).newest() {
        Some((s, rec)) => (
            s.other(),
            rec.sequence
                .checked_add(1)
                .ok_or(StoreError::SequenceExhausted)?,
        ),
        None => (Slot::A, 1),
    };
    let rec = encode_record(config, sequence).map_err(StoreError::Config)?;
    flash.erase(slot).map_err(StoreError::Erase)?;
    for (k, chunk) in rec.chunks_exact(WRITE_SIZE).enumerate() {
        let offset = k * WRITE_SIZE;
        let mut dword = [0xFFu8; WRITE_SIZE];
        dword.copy_from_slice(chunk);
        if dword == [0xFF; WRITE_SIZE] {
            continue; // erased already: the padding
        }
        flash
            .program(slot, offset, &dword)
            .map_err(|error| StoreError::Program { offset, error })?;
    }
    let mut back = [0u8; RECORD_LEN];
    flash
        .read(slot, 0, &mut back)
        .map_err(|_| StoreError::Verify(SlotError::Read))?;
    // Byte comparison, not `Config ==`: a set-up field that is not set is NaN, and NaN ≠ NaN.
    match decode_record(&back) {
        Ok(r) if r.sequence == sequence && back == rec => Ok(Stored { slot, sequence }),
        Ok(_) => Err(StoreError::Mismatch),
        Err(e) => Err(StoreError::Verify(e)),
    }
}
