//! SDO server (CiA 301 §7.2.4): expedited and segmented upload and download, with an abort
//! code for every failure. Block transfer is not supported (its command specifiers are
//! answered with abort 0x0504 0001, which makes a master fall back to segmented transfer).
//!
//! A download is applied only when complete and valid: an expedited one at its initiate
//! request, a segmented one at its last segment. A toggle error, a timeout or a length error
//! aborts the transfer and nothing of it is written.

use super::abort::SdoAbort;
use super::nmt::NmtState;
use super::od::{self, CommParams, Entry, MAX_VALUE_LEN};
use crate::app::App;

/// Time the server waits for the next segment of a transfer, µs (then abort 0x0504 0000).
pub const SDO_TIMEOUT_US: u64 = 1_000_000;

/// Client command specifiers (bits 7–5 of byte 0, CiA 301 §7.2.4.3).
const CCS_DOWNLOAD_SEGMENT: u8 = 0;
const CCS_INITIATE_DOWNLOAD: u8 = 1;
const CCS_INITIATE_UPLOAD: u8 = 2;
const CCS_UPLOAD_SEGMENT: u8 = 3;
const CCS_ABORT: u8 = 4;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Transfer {
    Idle,
    Download {
        entry: Entry,
        buf: [u8; MAX_VALUE_LEN],
        len: usize,
        size: usize,
        toggle: u8,
        deadline_us: u64,
    },
    Upload {
        index: u16,
        sub: u8,
        buf: [u8; MAX_VALUE_LEN],
        len: usize,
        pos: usize,
        toggle: u8,
        deadline_us: u64,
    },
}

/// The SDO server: at most one transfer at a time (CiA 301: one SDO channel, 0x1200).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SdoServer {
    transfer: Transfer,
}

impl Default for SdoServer {
    fn default() -> Self {
        Self::new()
    }
}

/// What one request produced: the response payload (always 8 bytes, CiA 301).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SdoOutcome {
    /// Response to send on 0x580 + node-ID (`None` after a client abort).
    pub response: Option<[u8; 8]>,
    /// The aborted transfer's code, if the response is an abort.
    pub abort: Option<SdoAbort>,
}

/// An abort frame (CiA 301 §7.2.4.3.17): cs 0x80, multiplexer, code (LE).
pub fn abort_frame(index: u16, sub: u8, code: SdoAbort) -> [u8; 8] {
    let i = index.to_le_bytes();
    let c = code.code().to_le_bytes();
    [0x80, i[0], i[1], sub, c[0], c[1], c[2], c[3]]
}

fn reply(b0: u8, index: u16, sub: u8, d: [u8; 4]) -> [u8; 8] {
    let i = index.to_le_bytes();
    [b0, i[0], i[1], sub, d[0], d[1], d[2], d[3]]
}

impl SdoServer {
    /// An idle server.
    pub const fn new() -> Self {
        Self {
            transfer: Transfer::Idle,
        }
    }

    /// True while a segmented transfer is in progress.
    pub fn busy(&self) -> bool {
        self.transfer != Transfer::Idle
    }

    /// Drops any transfer (NMT reset / stop).
    pub fn reset(&mut self) {
        self.transfer = Transfer::Idle;
    }

    fn mux(&self) -> (u16, u8) {
        match self.transfer {
            Transfer::Idle => (0, 0),
            Transfer::Download { entry, .. } => (entry.index, entry.sub),
            Transfer::Upload { index, sub, .. } => (index, sub),
        }
    }

    fn abort(&mut self, index: u16, sub: u8, code: SdoAbort) -> SdoOutcome {
        self.transfer = Transfer::Idle;
        SdoOutcome {
            response: Some(abort_frame(index, sub, code)),
            abort: Some(code),
        }
    }

    /// Aborts a transfer whose client went silent for [`SDO_TIMEOUT_US`] (abort 0x0504 0000);
    /// returns the abort frame to send.
    pub fn poll(&mut self, now_us: u64) -> Option<[u8; 8]> {
        let deadline = match self.transfer {
            Transfer::Idle => return None,
            Transfer::Download { deadline_us, .. } | Transfer::Upload { deadline_us, .. } => {
                deadline_us
            }
        };
        if now_us < deadline {
            return None;
        }
        let (index, sub) = self.mux();
        self.abort(index, sub, SdoAbort::Timeout).response
    }

    /// Handles one request frame payload (`data` as received; CiA 301 requires 8 bytes and a
    /// shorter frame is aborted with 0x0504 0001).
    pub fn on_request(
        &mut self,
        data: &[u8],
        comm: &mut CommParams,
        app: &mut App,
        nmt: NmtState,
        now_us: u64,
    ) -> SdoOutcome {
        let mut d = [0u8; 8];
        for (dst, src) in d.iter_mut().zip(data) {
            *dst = *src;
        }
        let [b0, i0, i1, sub, x0, x1, x2, x3] = d;
        let index = u16::from_le_bytes([i0, i1]);
        let payload = [x0, x1, x2, x3];
        if data.len() != 8 {
            return self.abort(index, sub, SdoAbort::CommandSpecifier);
        }
        let deadline_us = now_us.saturating_add(SDO_TIMEOUT_US);
        match b0 >> 5 {
            CCS_INITIATE_DOWNLOAD => {
                self.initiate_download(b0, index, sub, payload, comm, app, nmt, deadline_us)
            }
            CCS_DOWNLOAD_SEGMENT => self.download_segment(&d, comm, app, nmt, deadline_us),
            CCS_INITIATE_UPLOAD => self.initiate_upload(index, sub, comm, app, deadline_us),
            CCS_UPLOAD_SEGMENT => self.upload_segment(b0, deadline_us),
            CCS_ABORT => {
                self.transfer = Transfer::Idle;
                SdoOutcome {
                    response: None,
                    abort: None,
                }
            }
            // Block upload (5), block download (6) and 7 are not supported.
            _ => {
                let (i, s) = if self.busy() {
                    self.mux()
                } else {
                    (index, sub)
                };
                self.abort(i, s, SdoAbort::CommandSpecifier)
            }
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn initiate_download(
        &mut self,
        b0: u8,
        index: u16,
        sub: u8,
        payload: [u8; 4],
        comm: &mut CommParams,
        app: &mut App,
        nmt: NmtState,
        deadline_us: u64,
    ) -> SdoOutcome {
        // A new initiate request replaces any transfer in progress.
        self.transfer = Transfer::Idle;
        let entry = match od::entry(index, sub) {
            Ok(e) => e,
            Err(code) => return self.abort(index, sub, code),
        };
        if !entry.access.writable() {
            return self.abort(index, sub, SdoAbort::ReadOnly);
        }
        let size = entry.ty.size().unwrap_or(MAX_VALUE_LEN);
        let expedited = b0 & 0x02 != 0;
        let size_indicated = b0 & 0x01 != 0;
        if expedited {
            let len = if size_indicated {
                4 - usize::from((b0 >> 2) & 0x03)
            } else {
                size.min(4)
            };
            if len != size {
                return self.abort(index, sub, SdoAbort::LengthMismatch);
            }
            let data = payload.get(..len).unwrap_or(&[]);
            match od::write(comm, app, nmt, &entry, data) {
                Ok(()) => SdoOutcome {
                    response: Some(reply(0x60, index, sub, [0; 4])),
                    abort: None,
                },
                Err(code) => self.abort(index, sub, code),
            }
        } else {
            if size_indicated && u32::from_le_bytes(payload) as usize != size {
                return self.abort(index, sub, SdoAbort::LengthMismatch);
            }
            self.transfer = Transfer::Download {
                entry,
                buf: [0; MAX_VALUE_LEN],
                len: 0,
                size,
                toggle: 0,
                deadline_us,
            };
            SdoOutcome {
                response: Some(reply(0x60, index, sub, [0; 4])),
                abort: None,
            }
        }
    }

    fn download_segment(
        &mut self,
        d: &[u8; 8],
        comm: &mut CommParams,
        app: &mut App,
        nmt: NmtState,
        deadline: u64,
    ) -> SdoOutcome {
        let b0 = d[0];
        let Transfer::Download {
            entry,
            mut buf,
            len,
            size,
            toggle,
            ..
        } = self.transfer
        else {
            let (i, s) = self.mux();
            return self.abort(i, s, SdoAbort::CommandSpecifier);
        };
        let t = (b0 >> 4) & 1;
        if t != toggle {
            return self.abort(entry.index, entry.sub, SdoAbort::ToggleBit);
        }
        let n = 7 - usize::from((b0 >> 1) & 0x07);
        let last = b0 & 0x01 != 0;
        let new_len = len + n;
        let (Some(dst), Some(src)) = (buf.get_mut(len..new_len), d.get(1..1 + n)) else {
            return self.abort(entry.index, entry.sub, SdoAbort::LengthMismatch);
        };
        if new_len > size {
            return self.abort(entry.index, entry.sub, SdoAbort::LengthMismatch);
        }
        dst.copy_from_slice(src);
        let response = Some([0x20 | t << 4, 0, 0, 0, 0, 0, 0, 0]);
        if !last {
            self.transfer = Transfer::Download {
                entry,
                buf,
                len: new_len,
                size,
                toggle: t ^ 1,
                deadline_us: deadline,
            };
            return SdoOutcome {
                response,
                abort: None,
            };
        }
        if new_len != size {
            return self.abort(entry.index, entry.sub, SdoAbort::LengthMismatch);
        }
        self.transfer = Transfer::Idle;
        match od::write(comm, app, nmt, &entry, buf.get(..new_len).unwrap_or(&[])) {
            Ok(()) => SdoOutcome {
                response,
                abort: None,
            },
            Err(code) => self.abort(entry.index, entry.sub, code),
        }
    }

    fn initiate_upload(
        &mut self,
        index: u16,
        sub: u8,
        comm: &CommParams,
        app: &App,
        deadline_us: u64,
    ) -> SdoOutcome {
        self.transfer = Transfer::Idle;
        let entry = match od::entry(index, sub) {
            Ok(e) => e,
            Err(code) => return self.abort(index, sub, code),
        };
        if !entry.access.readable() {
            return self.abort(index, sub, SdoAbort::WriteOnly);
        }
        let mut buf = [0u8; MAX_VALUE_LEN];
        let len = match od::read(comm, app, entry.var, &mut buf) {
            Ok(n) => n,
            Err(code) => return self.abort(index, sub, code),
        };
        let ok = |response| SdoOutcome {
            response: Some(response),
            abort: None,
        };
        if (1..=4).contains(&len) {
            // Expedited, size indicated: n = 4 − len unused bytes (CiA 301 §7.2.4.3.6).
            let mut d = [0u8; 4];
            for (dst, src) in d.iter_mut().zip(buf.iter().take(len)) {
                *dst = *src;
            }
            let b0 = 0x43 | ((4 - len as u8) << 2);
            return ok(reply(b0, index, sub, d));
        }
        self.transfer = Transfer::Upload {
            index,
            sub,
            buf,
            len,
            pos: 0,
            toggle: 0,
            deadline_us,
        };
        ok(reply(0x41, index, sub, (len as u32).to_le_bytes()))
    }

    fn upload_segment(&mut self, b0: u8, deadline: u64) -> SdoOutcome {
        let Transfer::Upload {
            index,
            sub,
            buf,
            len,
            pos,
            toggle,
            ..
        } = self.transfer
        else {
            let (i, s) = self.mux();
            return self.abort(i, s, SdoAbort::CommandSpecifier);
        };
        let t = (b0 >> 4) & 1;
        if t != toggle {
            return self.abort(index, sub, SdoAbort::ToggleBit);
        }
        let n = (len - pos).min(7);
        let last = pos + n >= len;
        let mut r = [0u8; 8];
        r[0] = t << 4 | ((7 - n as u8) << 1) | u8::from(last);
        for (dst, src) in r.iter_mut().skip(1).zip(buf.iter().skip(pos).take(n)) {
            *dst = *src;
        }
        self.transfer = if last {
            Transfer::Idle
        } else {
            Transfer::Upload {
                index,
                sub,
                buf,
                len,
                pos: pos + n,
                toggle: t ^ 1,
                deadline_us: deadline,
            }
        };
        SdoOutcome {
            response: Some(r),
            abort: None,
        }
    }
}
