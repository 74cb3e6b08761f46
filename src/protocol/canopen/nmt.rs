//! NMT slave state machine (CiA 301 §7.3.2) and the heartbeat / boot-up protocol (§7.2.8.3).

/// NMT state of the node (CiA 301 §7.3.2.2, figure 48). The discriminant is the state byte of
/// the heartbeat frame (CiA 301 table 35).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(u8)]
pub enum NmtState {
    /// Initialising: left at once with the boot-up message (heartbeat byte 0x00).
    #[default]
    Initialising = 0x00,
    /// Stopped: only NMT and heartbeat (0x04).
    Stopped = 0x04,
    /// Operational: SDO, SYNC, PDO, EMCY (0x05).
    Operational = 0x05,
    /// Pre-operational: SDO, SYNC, EMCY, no PDO (0x7F). Configuration is written here.
    PreOperational = 0x7F,
}

impl NmtState {
    /// The heartbeat state byte.
    pub const fn heartbeat_byte(self) -> u8 {
        self as u8
    }
    /// True if the SDO server answers (pre-operational and operational, CiA 301 table 86).
    pub const fn sdo_allowed(self) -> bool {
        matches!(self, Self::PreOperational | Self::Operational)
    }
    /// True if PDOs are sent (operational only).
    pub const fn pdo_allowed(self) -> bool {
        matches!(self, Self::Operational)
    }
}

/// NMT node-control command specifiers (CiA 301 §7.2.8.3.1, byte 0 of COB-ID 0x000).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NmtCommand {
    /// 0x01 start remote node → operational.
    Start,
    /// 0x02 stop remote node → stopped.
    Stop,
    /// 0x80 enter pre-operational.
    EnterPreOperational,
    /// 0x81 reset node (application and communication).
    ResetNode,
    /// 0x82 reset communication.
    ResetCommunication,
}

impl NmtCommand {
    /// Decodes a command specifier (`None` for an unknown one, which the node ignores).
    pub const fn from_cs(cs: u8) -> Option<Self> {
        Some(match cs {
            0x01 => Self::Start,
            0x02 => Self::Stop,
            0x80 => Self::EnterPreOperational,
            0x81 => Self::ResetNode,
            0x82 => Self::ResetCommunication,
            _ => return None,
        })
    }
}
