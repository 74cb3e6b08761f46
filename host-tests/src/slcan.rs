//! SLCAN (Lawicel ASCII) framing for the simulator's `--serve` mode: the core's codec
//! ([`ballpod::protocol::slcan`], the same the emulated board's CAN port runs) with the host's
//! owned lines and strings.

pub use ballpod::protocol::slcan::{
    BITRATES, MAX_LINE, SlcanCommand, SlcanError, SlcanFrame, parse_line,
};

/// The line (with its CR) that reports a received frame to the host.
pub fn format_frame(f: &SlcanFrame) -> String {
    String::from_utf8_lossy(&ballpod::protocol::slcan::format_frame(f)).into_owned()
}

/// A line of the stream: its bytes, or the marker of a line that was too long.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Line {
    /// A complete line (without CR).
    Bytes(Vec<u8>),
    /// A line longer than [`MAX_LINE`] (dropped).
    TooLong,
}

impl Line {
    /// The command of the line, or why it is none.
    pub fn parse(&self) -> Result<SlcanCommand, SlcanError> {
        match self {
            Line::Bytes(b) => ballpod::protocol::slcan::Line::Bytes(b).parse(),
            Line::TooLong => ballpod::protocol::slcan::Line::TooLong.parse(),
        }
    }
}

/// Splits a byte stream into CR-terminated command lines ([`ballpod::protocol::slcan::LineSplitter`]).
#[derive(Default)]
pub struct LineSplitter(ballpod::protocol::slcan::LineSplitter);

impl LineSplitter {
    /// Feeds bytes; returns the complete lines.
    pub fn push(&mut self, bytes: &[u8]) -> Vec<Line> {
        let mut out = Vec::new();
        self.0.push(bytes, &mut |l| {
            out.push(match l {
                ballpod::protocol::slcan::Line::Bytes(b) => Line::Bytes(b.to_vec()),
                ballpod::protocol::slcan::Line::TooLong => Line::TooLong,
            })
        });
        out
    }
}
