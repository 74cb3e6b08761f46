//! The binary encoding of a configuration (settings slots, the CAN/USB configuration objects):
//! little-endian, fixed layout, CRC-32; every older version read and migrated. Hand-written
//! rather than serde + postcard: a short loop over [`FIELDS`] that needs no derive machinery
//! in the flash image, and its layout is the one the settings slots document.

use super::table::check;
use super::{AxisName, CanBitrate, Config, ConfigError, FIELDS, FieldType, LvdtInput, MAX_AXES};

/// Magic at the start of an encoded configuration.
pub const MAGIC: [u8; 4] = *b"BPOD";
/// Current encoding version: the newest `since` of the rows (`config/fields.rs`). Versions
/// [`OLDEST_ENCODING_VERSION`] up to this one are read and migrated (the fields added since
/// keep their defaults); version 1 records are not read: the pod boots on the defaults and
/// says so. What each version added is in the rows and in `CHANGELOG.md`.
pub const ENCODING_VERSION: u16 = newest_version();
/// Oldest encoding version read.
pub const OLDEST_ENCODING_VERSION: u16 = 2;

/// The newest `since` of the rows.
// compile-time evaluation only: an index out of bounds is a build error
#[allow(clippy::indexing_slicing)]
const fn newest_version() -> u16 {
    let mut v = OLDEST_ENCODING_VERSION;
    let mut i = 0;
    while i < FIELDS.len() {
        let since = FIELDS[i].field.since();
        if since > v {
            v = since;
        }
        i += 1;
    }
    v
}

/// Bytes of one stored value of `ty`.
const fn type_bytes(ty: FieldType) -> usize {
    match ty {
        FieldType::F32 | FieldType::U32 => 4,
        FieldType::F64 => 8,
        FieldType::U8 => 1,
        FieldType::U16 => 2,
    }
}

/// Payload bytes of encoding `version`: every [`FIELDS`] element that version has, by its
/// type, then the enumerated fields (LVDT input, CAN bit rate, per axis name and reversed flag).
// Evaluated at compile time for each version: an index out of bounds is a build error.
#[allow(clippy::indexing_slicing)]
const fn payload_len(version: u16) -> usize {
    let mut n = 0;
    let mut i = 0;
    while i < FIELDS.len() {
        let r = &FIELDS[i];
        let k = if r.elements == 0 {
            1
        } else {
            r.elements as usize
        };
        if r.field.since() <= version {
            n += k * type_bytes(r.ty);
        }
        i += 1;
    }
    n + 2 + 2 * MAX_AXES
}
/// Payload bytes of the current encoding.
const PAYLOAD: usize = payload_len(ENCODING_VERSION);
/// Total encoded size: magic, version u16, payload length u16, payload, CRC-32.
pub const ENCODED_LEN: usize = 4 + 2 + 2 + PAYLOAD + 4;
/// Versions read.
const VERSIONS: usize = (ENCODING_VERSION - OLDEST_ENCODING_VERSION + 1) as usize;
/// Total size of each encoding read, oldest first (read and migrated; only the last written).
// compile-time evaluation only: an index out of bounds is a build error
#[allow(clippy::indexing_slicing)]
pub const ENCODED_LENS: [usize; VERSIONS] = {
    let mut lens = [0; VERSIONS];
    let mut k = 0;
    while k < VERSIONS {
        lens[k] = 12 + payload_len(OLDEST_ENCODING_VERSION + k as u16);
        k += 1;
    }
    lens
};

/// Little-endian writer over a fixed buffer (never writes past its end).
struct Writer<'a> {
    buf: &'a mut [u8],
    pos: usize,
}

impl Writer<'_> {
    fn put(&mut self, bytes: &[u8]) {
        if let Some(dst) = self.buf.get_mut(self.pos..self.pos + bytes.len()) {
            dst.copy_from_slice(bytes);
        }
        self.pos += bytes.len();
    }
}

/// Little-endian reader (returns zeros past the end; lengths are checked before reading).
struct Reader<'a> {
    buf: &'a [u8],
    pos: usize,
}

impl Reader<'_> {
    fn take<const K: usize>(&mut self) -> [u8; K] {
        let mut out = [0u8; K];
        if let Some(src) = self.buf.get(self.pos..self.pos + K) {
            out.copy_from_slice(src);
        }
        self.pos += K;
        out
    }
    fn u8(&mut self) -> u8 {
        self.take::<1>()[0]
    }
}

impl Config {
    /// Encodes into `out` (which must hold [`ENCODED_LEN`] bytes; returns the bytes written or
    /// `BadLength`). Layout: `"BPOD"`, version u16, payload length u16, payload, CRC-32/ISO-HDLC
    /// of everything before it. Payload: every [`FIELDS`] element in table order as its type
    /// (little-endian f32 / f64 / u8 / u16 / u32; a set-up field that is not set is the f32
    /// NaN), then `lvdt_input`, `can_bitrate`, and per encoder input its axis name and
    /// reversed flag (one byte each).
    pub fn encode(&self, out: &mut [u8]) -> Result<usize, ConfigError> {
        if out.len() < ENCODED_LEN {
            return Err(ConfigError::BadLength {
                len: out.len(),
                expected: ENCODED_LEN,
            });
        }
        let mut w = Writer { buf: out, pos: 0 };
        w.put(&MAGIC);
        w.put(&ENCODING_VERSION.to_le_bytes());
        w.put(&(PAYLOAD as u16).to_le_bytes());
        for row in FIELDS {
            for f in row.fields() {
                let v = self.field_value(f).unwrap_or(f64::NAN);
                match row.ty {
                    FieldType::F32 => w.put(&(v as f32).to_le_bytes()),
                    FieldType::F64 => w.put(&v.to_le_bytes()),
                    FieldType::U8 => w.put(&[v as u8]),
                    FieldType::U16 => w.put(&(v as u16).to_le_bytes()),
                    FieldType::U32 => w.put(&(v as u32).to_le_bytes()),
                }
            }
        }
        w.put(&[self.lvdt_input as u8, self.can_bitrate as u8]);
        for a in &self.axes {
            w.put(&[a.name as u8, u8::from(a.reversed)]);
        }
        let crc_end = w.pos;
        let crc = out.get(..crc_end).map_or(0, crate::num::crc32);
        let mut w = Writer {
            buf: out,
            pos: crc_end,
        };
        w.put(&crc.to_le_bytes());
        Ok(w.pos)
    }

    /// Decodes and validates an encoding. Every check (length, magic, version, CRC, enum
    /// bytes, ranges) must pass; otherwise the error says which failed and nothing is returned.
    /// An older encoding (from [`OLDEST_ENCODING_VERSION`] on, [`ENCODED_LENS`]) is read too: the fields added
    /// since keep their defaults.
    pub fn decode(bytes: &[u8]) -> Result<Config, ConfigError> {
        let mut r = Reader { buf: bytes, pos: 0 };
        if r.take::<4>() != MAGIC {
            return Err(ConfigError::BadMagic);
        }
        let version = u16::from_le_bytes(r.take());
        if !(OLDEST_ENCODING_VERSION..=ENCODING_VERSION).contains(&version) {
            return Err(ConfigError::UnsupportedVersion(version));
        }
        let payload_len = payload_len(version);
        let len = 12 + payload_len;
        if bytes.len() != len {
            return Err(ConfigError::BadLength {
                len: bytes.len(),
                expected: len,
            });
        }
        let payload = usize::from(u16::from_le_bytes(r.take()));
        if payload != payload_len {
            return Err(ConfigError::BadLength {
                len: payload,
                expected: payload_len,
            });
        }
        let crc_at = len - 4;
        let computed = bytes.get(..crc_at).map_or(0, crate::num::crc32);
        let stored = bytes
            .get(crc_at..)
            .and_then(|s| s.try_into().ok())
            .map_or(0, u32::from_le_bytes);
        if stored != computed {
            return Err(ConfigError::BadCrc { stored, computed });
        }
        let mut c = Config::default();
        for row in FIELDS {
            for f in row.fields() {
                if f.since() > version {
                    continue;
                }
                let at = r.pos;
                let v = match row.ty {
                    FieldType::F32 => f64::from(f32::from_le_bytes(r.take())),
                    FieldType::F64 => f64::from_le_bytes(r.take()),
                    FieldType::U8 => f64::from(r.u8()),
                    FieldType::U16 => f64::from(u16::from_le_bytes(r.take())),
                    FieldType::U32 => f64::from(u32::from_le_bytes(r.take())),
                };
                if !row.choices().is_empty() && !(v <= row.max) {
                    return Err(ConfigError::BadEnum { offset: at });
                }
                c.set_field(f, v);
                // a value set_field cannot hold (e.g. beyond an integer's width) fails here
                check(f, v)?;
            }
        }
        let at = r.pos;
        c.lvdt_input = match r.u8() {
            0 => LvdtInput::AcRatiometric,
            1 => LvdtInput::DcConditioner,
            _ => return Err(ConfigError::BadEnum { offset: at }),
        };
        let at = r.pos;
        c.can_bitrate = CanBitrate::from_u8(r.u8()).ok_or(ConfigError::BadEnum { offset: at })?;
        for a in c.axes.iter_mut() {
            let at = r.pos;
            a.name = AxisName::from_u8(r.u8()).ok_or(ConfigError::BadEnum { offset: at })?;
            a.reversed = match r.u8() {
                0 => false,
                1 => true,
                _ => return Err(ConfigError::BadEnum { offset: at + 1 }),
            };
        }
        c.validate()?;
        Ok(c)
    }
}
