//! Transmit PDOs: communication and mapping parameters (CiA 301 §7.5.2.35–38) and packing of
//! the mapped values into a frame (CiA 301 §7.2.2).

use super::CanFrame;
use super::od::{self, CommParams, MAX_VALUE_LEN};
use crate::app::App;

/// Number of TPDOs (0x1800–0x1803 / 0x1A00–0x1A03).
pub const TPDO_COUNT: usize = 4;
/// Largest number of objects one TPDO maps (sub-indices 1…8 of 0x1A0n).
pub const MAX_MAPPED: usize = 8;

/// COB-ID bit 31: the PDO does not exist / is not valid (CiA 301 §7.5.2.35, table 70).
pub const COB_ID_INVALID: u32 = 1 << 31;
/// COB-ID bit 30: no RTR allowed on this PDO.
pub const COB_ID_NO_RTR: u32 = 1 << 30;
/// COB-ID bit 29: 29-bit CAN-ID (not supported by this node).
pub const COB_ID_EXTENDED: u32 = 1 << 29;

/// Transmission type 254: event-driven, manufacturer-specific (CiA 301 §7.5.2.35, table 71).
pub const TT_EVENT_MANUFACTURER: u8 = 254;
/// Transmission type 255: event-driven, device-profile specific.
pub const TT_EVENT_PROFILE: u8 = 255;

/// Communication and mapping parameters of one TPDO.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TpdoParams {
    /// COB-ID entry (sub-index 1 of 0x180n): bit 31 invalid, bit 30 no RTR, bits 0–10 CAN-ID.
    pub cob_id: u32,
    /// Transmission type (sub-index 2): 1–240 = every n-th SYNC; 254/255 = event timer.
    pub transmission_type: u8,
    /// Inhibit time (sub-index 3), in units of 100 µs: least time between two event-driven
    /// transmissions.
    pub inhibit_100us: u16,
    /// Event timer (sub-index 5), ms: period of event-driven transmission (0 = off).
    pub event_timer_ms: u16,
    /// Number of mapped objects (sub-index 0 of 0x1A0n).
    pub map_count: u8,
    /// Mapping entries (sub-indices 1…8 of 0x1A0n): index << 16 | sub-index << 8 | bit length.
    pub map: [u32; MAX_MAPPED],
}

impl TpdoParams {
    /// True if bit 31 of the COB-ID is clear (the PDO exists).
    pub const fn is_valid(&self) -> bool {
        self.cob_id & COB_ID_INVALID == 0
    }
    /// The 11-bit CAN-ID of the PDO.
    pub const fn can_id(&self) -> u16 {
        (self.cob_id & 0x7FF) as u16
    }
    /// Total mapped length, bits.
    pub fn mapped_bits(&self) -> u32 {
        self.map
            .iter()
            .take(usize::from(self.map_count))
            .map(|m| m & 0xFF)
            .sum()
    }
}

/// A mapping entry: object `index`:`sub` of `bits` bits.
pub const fn map_entry(index: u16, sub: u8, bits: u8) -> u32 {
    (index as u32) << 16 | (sub as u32) << 8 | bits as u32
}

/// The default parameters of TPDO `n` (0…3) for node `node_id` (pre-defined connection set,
/// CiA 301 §7.3.5: COB-IDs 0x180/0x280/0x380/0x480 + node-ID):
/// - TPDO1: ΔL (0x2100:1, REAL32 µm) + sample counter (0x2101, UNSIGNED32), every SYNC;
/// - TPDO2: eccentricities e_x, e_y (0x2100:5/6, REAL32 µm), every SYNC;
/// - TPDO3: r0 (0x2100:7, REAL32 µm) + status word (0x2102: sample flags, session state,
///   live-valid, error) + live-value validity mask (0x2103), every SYNC;
/// - TPDO4: SSM position errors E_x, E_y (0x2100:2/3, REAL32 µm), every SYNC, disabled
///   (COB-ID bit 31 set) until the master enables it.
pub fn default_tpdo(n: usize, node_id: u8) -> TpdoParams {
    let base = [0x180u32, 0x280, 0x380, 0x480];
    let cob = base.get(n).copied().unwrap_or(0x180) + u32::from(node_id);
    let mut p = TpdoParams {
        cob_id: cob,
        transmission_type: 1,
        inhibit_100us: 0,
        event_timer_ms: 0,
        map_count: 0,
        map: [0; MAX_MAPPED],
    };
    let entries: &[u32] = match n {
        0 => &[map_entry(0x2100, 1, 32), map_entry(0x2101, 0, 32)],
        1 => &[map_entry(0x2100, 5, 32), map_entry(0x2100, 6, 32)],
        2 => &[
            map_entry(0x2100, 7, 32),
            map_entry(0x2102, 0, 16),
            map_entry(0x2103, 0, 16),
        ],
        _ => &[map_entry(0x2100, 2, 32), map_entry(0x2100, 3, 32)],
    };
    for (slot, e) in p.map.iter_mut().zip(entries) {
        *slot = *e;
    }
    p.map_count = entries.len() as u8;
    if n >= 3 {
        p.cob_id |= COB_ID_INVALID;
    }
    p
}

/// Packs the mapped objects of `p` into a frame (CiA 301 §7.2.2: objects in mapping order,
/// each little-endian). Returns `None` if the PDO is invalid or a mapped object can no longer
/// be read (the mapping was checked when written, so this does not happen in practice).
pub fn pack(p: &TpdoParams, comm: &CommParams, app: &App) -> Option<CanFrame> {
    if !p.is_valid() {
        return None;
    }
    let mut data = [0u8; 8];
    let mut len = 0usize;
    for m in p.map.iter().take(usize::from(p.map_count)) {
        let index = (m >> 16) as u16;
        let sub = (m >> 8) as u8;
        let bytes = ((m & 0xFF) / 8) as usize;
        let e = od::entry(index, sub).ok()?;
        let mut buf = [0u8; MAX_VALUE_LEN];
        let n = od::read(comm, app, e.var, &mut buf).ok()?;
        let src = buf.get(..n.min(bytes))?;
        data.get_mut(len..len + src.len())?.copy_from_slice(src);
        len += bytes;
    }
    CanFrame::new(p.can_id(), data.get(..len)?)
}
