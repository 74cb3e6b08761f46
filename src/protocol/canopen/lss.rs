//! Layer Setting Services slave (CiA 305 v3.0): an LSS master sets the pod's node-ID and bit
//! rate over the bus, so two pods, or a pod on a bus that already has its node-ID, need no USB
//! cable first.
//!
//! A transition table over two states (waiting, configuration) with the pod's LSS address
//! (0x1018:1–4: vendor-ID, product code, revision number, serial number). What it implements:
//! - switch state global (cs 0x04) and selective (0x40–0x43, answer 0x44);
//! - configure node-ID (0x11: 1–127, or 0xFF = unconfigured; error 1 otherwise), configure bit
//!   timing (0x13: table 0, the [`CanBitrate`]s; error 1 otherwise), activate bit timing
//!   (0x15: switch after the delay, silent for twice the delay), store configuration (0x17:
//!   error 2 when the pod refuses, e.g. during a run);
//! - inquire identity (0x5A–0x5D) and node-ID (0x5E);
//! - identify remote slave (0x46–0x4B, answer 0x4F), identify non-configured remote slave
//!   (0x4C, answer 0x50), fastscan (0x51, answer 0x4F; a non-configured pod only, as
//!   CANopenNode does).
//!
//! Commands of the configuration state are ignored in the waiting state (no answer), as CiA 305
//! says; nothing a bad request carries changes the pending values. The pending node-ID becomes
//! the active one at NMT reset communication, or — for a pod that had none (0xFF) — when the
//! master switches it back to waiting ([`LssAction::ActivateNodeId`]).
//!
//! Written here rather than taken from a crate for the reason the rest of the stack is
//! ([`super`]): it hands a store to the application, which may refuse it.

use crate::config::CanBitrate;

/// COB-ID of the master's requests.
pub const COB_LSS_MASTER: u16 = 0x7E5;
/// COB-ID of the slave's answers.
pub const COB_LSS_SLAVE: u16 = 0x7E4;
/// The node-ID of a pod that has none: it takes part in LSS only until one is configured.
pub const NODE_ID_UNCONFIGURED: u8 = 0xFF;

/// Command specifiers (CiA 305 v3.0 table 4).
mod cs {
    pub const SWITCH_GLOBAL: u8 = 0x04;
    pub const CONFIGURE_NODE_ID: u8 = 0x11;
    pub const CONFIGURE_BIT_TIMING: u8 = 0x13;
    pub const ACTIVATE_BIT_TIMING: u8 = 0x15;
    pub const STORE_CONFIGURATION: u8 = 0x17;
    pub const SELECTIVE_VENDOR: u8 = 0x40;
    pub const SELECTIVE_SERIAL: u8 = 0x43;
    pub const SELECTIVE_RESPONSE: u8 = 0x44;
    pub const IDENTIFY_VENDOR: u8 = 0x46;
    pub const IDENTIFY_SERIAL_HIGH: u8 = 0x4B;
    pub const IDENTIFY_NON_CONFIGURED: u8 = 0x4C;
    pub const IDENTIFY_SLAVE: u8 = 0x4F;
    pub const IDENTIFY_NON_CONFIGURED_SLAVE: u8 = 0x50;
    pub const FASTSCAN: u8 = 0x51;
    pub const INQUIRE_VENDOR: u8 = 0x5A;
    pub const INQUIRE_SERIAL: u8 = 0x5D;
    pub const INQUIRE_NODE_ID: u8 = 0x5E;
}

/// Error codes of the configure and store answers.
mod error {
    pub const NONE: u8 = 0;
    /// Node-ID out of range / bit timing not supported / store not supported.
    pub const OUT_OF_RANGE: u8 = 1;
    /// Storage media access error (the application refused or could not store).
    pub const STORAGE: u8 = 2;
}

/// The fastscan bit-check value that starts a scan (CiA 305 §3.7.7).
const FASTSCAN_CONFIRM: u8 = 0x80;

/// LSS state of the slave.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LssState {
    /// Waiting: only switch, identify and fastscan requests are taken.
    #[default]
    Waiting,
    /// Configuration: node-ID and bit timing may be configured, stored and inquired.
    Configuration,
}

/// What a request asks of the node beyond its answer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LssAction {
    /// Nothing.
    None,
    /// A pod without a node-ID was switched to waiting with one pending: reset communication
    /// with it (boot-up on the new node-ID).
    ActivateNodeId(u8),
    /// Store the pending node-ID and bit rate in the configuration (the answer's error code
    /// comes from whether the application takes it: [`LssSlave::store_answer`]).
    Store {
        /// The node-ID to store (1–127 or [`NODE_ID_UNCONFIGURED`]).
        node_id: u8,
        /// The bit rate to store, if one was configured.
        bitrate: Option<CanBitrate>,
    },
    /// Switch the controller to `bitrate` after `delay_ms`; send nothing for twice that.
    ActivateBitTiming {
        /// The new bit rate.
        bitrate: CanBitrate,
        /// The switch delay, ms.
        delay_ms: u16,
    },
}

/// The bit rate of CiA 305 table 1 (bit timing table 0) index `i`, if the pod supports it.
pub const fn bitrate_of_table_index(i: u8) -> Option<CanBitrate> {
    match i {
        0 => Some(CanBitrate::M1),
        2 => Some(CanBitrate::K500),
        3 => Some(CanBitrate::K250),
        4 => Some(CanBitrate::K125),
        _ => None,
    }
}

/// The LSS slave of one node.
#[derive(Clone, Copy, Debug, Default)]
pub struct LssSlave {
    state: LssState,
    /// 0x1018:1–4.
    address: [u32; 4],
    /// The node-ID a master configured since boot (`None`: the configuration's).
    pending_node_id: Option<u8>,
    pending_bitrate: Option<CanBitrate>,
    /// How many parts of the address the selective switch has matched so far, in order.
    selective_matched: u8,
    /// Which parts of the identify-remote-slave request have matched (bit k: command
    /// 0x46 + k).
    identify_matched: u8,
    /// The fastscan's LSSSub the slave expects next (0–3).
    fastscan_pos: u8,
}

impl LssSlave {
    /// A slave in the waiting state with LSS address `address` (vendor, product, revision,
    /// serial).
    pub const fn new(address: [u32; 4]) -> Self {
        Self {
            state: LssState::Waiting,
            address,
            pending_node_id: None,
            pending_bitrate: None,
            selective_matched: 0,
            identify_matched: 0,
            fastscan_pos: 0,
        }
    }

    /// The node-ID a master configured since boot, if any (taken at reset communication).
    pub fn pending_node_id(&self) -> Option<u8> {
        self.pending_node_id
    }

    /// One request of the master (`data`, 8 bytes) to a node whose active node-ID is `active`:
    /// the answer to send on [`COB_LSS_SLAVE`], if any, and what the node must do.
    pub fn on_request(&mut self, data: &[u8], active: u8) -> (Option<[u8; 8]>, LssAction) {
        let [c, d1, d2, d3, d4, d5, d6, d7] = match <[u8; 8]>::try_from(data) {
            Ok(d) => d,
            Err(_) => return (None, LssAction::None),
        };
        let value = u32::from_le_bytes([d1, d2, d3, d4]);
        let answer = |code: u8, bytes: &[u8]| {
            let mut a = [0u8; 8];
            a[0] = code;
            for (slot, b) in a.iter_mut().skip(1).zip(bytes) {
                *slot = *b;
            }
            Some(a)
        };
        let config = self.state == LssState::Configuration;
        match c {
            cs::SWITCH_GLOBAL => match d1 {
                0 => {
                    self.state = LssState::Waiting;
                    self.selective_matched = 0;
                    if active == NODE_ID_UNCONFIGURED
                        && let Some(id) = self.pending_node_id
                        && id != NODE_ID_UNCONFIGURED
                    {
                        return (None, LssAction::ActivateNodeId(id));
                    }
                }
                1 => self.state = LssState::Configuration,
                _ => {}
            },
            cs::SELECTIVE_VENDOR..=cs::SELECTIVE_SERIAL if !config => {
                let part = c - cs::SELECTIVE_VENDOR;
                let ok = self.part(part) == Some(value);
                // each part in order; a mismatch or a part out of order starts again
                self.selective_matched = if ok && part == self.selective_matched {
                    part + 1
                } else {
                    0
                };
                if self.selective_matched == 4 {
                    self.selective_matched = 0;
                    self.state = LssState::Configuration;
                    return (answer(cs::SELECTIVE_RESPONSE, &[]), LssAction::None);
                }
            }
            cs::CONFIGURE_NODE_ID if config => {
                let ok = (1..=127).contains(&d1) || d1 == NODE_ID_UNCONFIGURED;
                if ok {
                    self.pending_node_id = Some(d1);
                }
                let e = if ok { error::NONE } else { error::OUT_OF_RANGE };
                return (answer(c, &[e]), LssAction::None);
            }
            cs::CONFIGURE_BIT_TIMING if config => {
                let rate = if d1 == 0 {
                    bitrate_of_table_index(d2)
                } else {
                    None
                };
                if rate.is_some() {
                    self.pending_bitrate = rate;
                }
                let e = if rate.is_some() {
                    error::NONE
                } else {
                    error::OUT_OF_RANGE
                };
                return (answer(c, &[e]), LssAction::None);
            }
            cs::ACTIVATE_BIT_TIMING if config => {
                if let Some(bitrate) = self.pending_bitrate {
                    let delay_ms = u16::from_le_bytes([d1, d2]);
                    return (None, LssAction::ActivateBitTiming { bitrate, delay_ms });
                }
            }
            cs::STORE_CONFIGURATION if config => {
                let node_id = self.pending_node_id.unwrap_or(active);
                let store = LssAction::Store {
                    node_id,
                    bitrate: self.pending_bitrate,
                };
                // the answer follows the application's verdict (store_answer)
                return (None, store);
            }
            cs::INQUIRE_VENDOR..=cs::INQUIRE_SERIAL if config => {
                if let Some(v) = self.part(c - cs::INQUIRE_VENDOR) {
                    return (answer(c, &v.to_le_bytes()), LssAction::None);
                }
            }
            cs::INQUIRE_NODE_ID if config => return (answer(c, &[active]), LssAction::None),
            cs::IDENTIFY_VENDOR..=cs::IDENTIFY_SERIAL_HIGH => {
                let k = c - cs::IDENTIFY_VENDOR;
                // vendor, product: equal; then revision and serial, each a low and a high bound
                let matches = match k {
                    0 | 1 => self.part(k) == Some(value),
                    _ if k.is_multiple_of(2) => self.part(1 + k / 2).is_some_and(|p| p >= value),
                    _ => self.part(1 + k / 2).is_some_and(|p| p <= value),
                };
                if k == 0 {
                    self.identify_matched = 0;
                }
                if matches {
                    self.identify_matched |= 1 << k;
                }
                if k == 5 && self.identify_matched == 0b11_1111 {
                    self.identify_matched = 0;
                    return (answer(cs::IDENTIFY_SLAVE, &[]), LssAction::None);
                }
            }
            cs::IDENTIFY_NON_CONFIGURED if active == NODE_ID_UNCONFIGURED && !self.configured() => {
                return (
                    answer(cs::IDENTIFY_NON_CONFIGURED_SLAVE, &[]),
                    LssAction::None,
                );
            }
            cs::FASTSCAN if !config && active == NODE_ID_UNCONFIGURED => {
                return (self.fastscan(value, d5, d6, d7), LssAction::None);
            }
            _ => {}
        }
        (None, LssAction::None)
    }

    /// One fastscan step (CiA 305 §3.7.7): `bit_check` 0x80 restarts; otherwise the bits of
    /// `id` above `bit_check` are compared with address part `sub`, and the slave answers if
    /// they match, then expects part `next`; the last part's full match ends in the
    /// configuration state.
    fn fastscan(&mut self, id: u32, bit_check: u8, sub: u8, next: u8) -> Option<[u8; 8]> {
        if sub > 3 || next > 3 {
            return None;
        }
        let ack = if bit_check == FASTSCAN_CONFIRM {
            self.fastscan_pos = 0;
            true
        } else if bit_check <= 31 && sub == self.fastscan_pos {
            let mask = u32::MAX << bit_check;
            let ok = self.part(sub).is_some_and(|p| p & mask == id & mask);
            if ok {
                self.fastscan_pos = next;
                if bit_check == 0 && next < sub {
                    self.state = LssState::Configuration;
                }
            }
            ok
        } else {
            false
        };
        ack.then(|| {
            let mut a = [0u8; 8];
            a[0] = cs::IDENTIFY_SLAVE;
            a
        })
    }

    /// True when a master configured a node-ID since boot (not [`NODE_ID_UNCONFIGURED`]).
    fn configured(&self) -> bool {
        self.pending_node_id
            .is_some_and(|p| p != NODE_ID_UNCONFIGURED)
    }

    /// Part `k` of the LSS address (0 vendor … 3 serial).
    fn part(&self, k: u8) -> Option<u32> {
        self.address.get(usize::from(k)).copied()
    }

    /// The answer to a store request the application took (`stored`) or refused.
    pub fn store_answer(stored: bool) -> [u8; 8] {
        let mut a = [0u8; 8];
        a[0] = cs::STORE_CONFIGURATION;
        a[1] = if stored { error::NONE } else { error::STORAGE };
        a
    }

    /// Reset communication: the pending values were taken (or dropped); the slave stays in
    /// its LSS state, as CiA 305 says.
    pub fn reset_communication(&mut self) {
        self.pending_node_id = None;
        self.fastscan_pos = 0;
    }
}
