//! SDO server (CiA 301 §7.2.4): expedited and segmented upload and
//! download of any dictionary entry, abort codes per §7.2.4.3.17.
//!
//! One client at a time on the default SDO channel (0x600 + node id
//! requests, 0x580 + node id responses, object 0x1200). Every request and
//! response is 8 bytes; a request of another length is ignored (CiA 301
//! §7.2.4.3: SDO frames have DLC 8). Block transfer (§7.2.4.3.9ff) is not
//! supported: its request is answered with abort 0x0504_0001, which a
//! client takes as "use segmented". A new initiate request while a
//! segmented transfer is open starts over (the client gave up on the old
//! one); a segment with the wrong toggle bit aborts the transfer.
//!
//! The server checks the protocol and the entry (existence, access,
//! length); the value itself (range, checks across entries, what a write
//! sets off) is the caller's `write` closure, which may abort.

use super::abort::SdoAbort;
use super::od::{self, Dictionary, OBJECTS};

/// Longest value a download can write: every writable entry is a number
/// of at most 4 bytes.
const DOWNLOAD_MAX: usize = 4;

/// A segmented transfer in progress.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Transfer {
    Idle,
    Download {
        pos: usize,
        toggle: bool,
        buf: [u8; DOWNLOAD_MAX],
        len: usize,
        size: Option<usize>,
    },
    Upload {
        pos: usize,
        offset: usize,
        toggle: bool,
    },
}

/// The SDO server's state: the segmented transfer in progress, if any.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SdoServer {
    transfer: Transfer,
}

impl Default for SdoServer {
    fn default() -> Self {
        Self::new()
    }
}

/// An abort response for (index, sub).
pub fn abort_frame(index: u16, sub: u8, abort: SdoAbort) -> [u8; 8] {
    let [i0, i1] = index.to_le_bytes();
    let [c0, c1, c2, c3] = abort.code().to_le_bytes();
    [0x80, i0, i1, sub, c0, c1, c2, c3]
}

fn address(pos: usize) -> (u16, u8) {
    OBJECTS.get(pos).map_or((0, 0), |o| (o.index, o.sub))
}

impl SdoServer {
    /// No transfer open.
    pub const fn new() -> Self {
        Self {
            transfer: Transfer::Idle,
        }
    }

    /// Whether a segmented transfer is open.
    pub fn busy(&self) -> bool {
        self.transfer != Transfer::Idle
    }

    /// Answers one request (`None`: no answer, after a client's abort or a
    /// request that is not 8 bytes). `write(od, pos, raw)` stores a value
    /// the dictionary's own checks accepted ([`Dictionary::check_write`]),
    /// or aborts.
    pub fn on_request(
        &mut self,
        req: &[u8],
        od: &mut Dictionary,
        mut write: impl FnMut(&mut Dictionary, usize, u32) -> Result<(), SdoAbort>,
    ) -> Option<[u8; 8]> {
        let req: [u8; 8] = req.try_into().ok()?;
        let index = u16::from_le_bytes([req[1], req[2]]);
        let sub = req[3];
        let mut commit = |pos: usize, data: &[u8]| -> Result<(), SdoAbort> {
            let raw = od.check_write(pos, data)?;
            write(od, pos, raw)
        };
        let result = match req[0] >> 5 {
            // Initiate download (§7.2.4.3.3).
            1 => self.initiate_download(&req, &mut commit),
            // Download segment (§7.2.4.3.4).
            0 => self.download_segment(&req, &mut commit),
            // Initiate upload (§7.2.4.3.6).
            2 => self.initiate_upload(index, sub, od),
            // Upload segment (§7.2.4.3.7).
            3 => self.upload_segment(&req, od),
            // Abort from the client (§7.2.4.3.17): nothing to answer.
            4 => {
                self.transfer = Transfer::Idle;
                return None;
            }
            _ => Err((index, sub, SdoAbort::Command)),
        };
        Some(match result {
            Ok(resp) => resp,
            Err((index, sub, abort)) => {
                self.transfer = Transfer::Idle;
                abort_frame(index, sub, abort)
            }
        })
    }

    fn initiate_download(
        &mut self,
        req: &[u8; 8],
        commit: &mut impl FnMut(usize, &[u8]) -> Result<(), SdoAbort>,
    ) -> Result<[u8; 8], (u16, u8, SdoAbort)> {
        self.transfer = Transfer::Idle;
        let index = u16::from_le_bytes([req[1], req[2]]);
        let sub = req[3];
        let fail = |a| (index, sub, a);
        let pos = od::find(index, sub).map_err(fail)?;
        let object = OBJECTS.get(pos).ok_or(fail(SdoAbort::NoObject))?;
        if !object.access.writable() {
            return Err(fail(SdoAbort::ReadOnly));
        }
        let expedited = req[0] & 0x02 != 0;
        let sized = req[0] & 0x01 != 0;
        if expedited {
            // n: bytes of d that carry no data, valid when size-indicated;
            // otherwise the entry's own size.
            let len = if sized {
                4 - usize::from((req[0] >> 2) & 0x03)
            } else {
                object.ty.size().min(4)
            };
            let data = req.get(4..4 + len).ok_or(fail(SdoAbort::Length))?;
            commit(pos, data).map_err(fail)?;
        } else {
            let size = if sized {
                let n = u32::from_le_bytes([req[4], req[5], req[6], req[7]]) as usize;
                if n != object.ty.size() {
                    return Err(fail(if n > object.ty.size() {
                        SdoAbort::LengthTooHigh
                    } else {
                        SdoAbort::LengthTooLow
                    }));
                }
                Some(n)
            } else {
                None
            };
            self.transfer = Transfer::Download {
                pos,
                toggle: false,
                buf: [0; DOWNLOAD_MAX],
                len: 0,
                size,
            };
        }
        Ok([0x60, req[1], req[2], sub, 0, 0, 0, 0])
    }

    fn download_segment(
        &mut self,
        req: &[u8; 8],
        commit: &mut impl FnMut(usize, &[u8]) -> Result<(), SdoAbort>,
    ) -> Result<[u8; 8], (u16, u8, SdoAbort)> {
        let Transfer::Download {
            pos,
            toggle,
            mut buf,
            len,
            size,
        } = self.transfer
        else {
            let index = u16::from_le_bytes([req[1], req[2]]);
            return Err((index, req[3], SdoAbort::Command));
        };
        let (index, sub) = address(pos);
        let fail = |a| (index, sub, a);
        let t = req[0] & 0x10 != 0;
        if t != toggle {
            return Err(fail(SdoAbort::Toggle));
        }
        let n = usize::from((req[0] >> 1) & 0x07);
        let last = req[0] & 0x01 != 0;
        let data = req.get(1..8 - n).unwrap_or(&[]);
        let end = len + data.len();
        buf.get_mut(len..end)
            .ok_or(fail(SdoAbort::LengthTooHigh))?
            .copy_from_slice(data);
        if last {
            if size.is_some_and(|s| s != end) {
                return Err(fail(SdoAbort::Length));
            }
            self.transfer = Transfer::Idle;
            commit(pos, buf.get(..end).unwrap_or(&[])).map_err(fail)?;
        } else {
            self.transfer = Transfer::Download {
                pos,
                toggle: !toggle,
                buf,
                len: end,
                size,
            };
        }
        Ok([0x20 | (u8::from(t) << 4), 0, 0, 0, 0, 0, 0, 0])
    }

    fn initiate_upload(
        &mut self,
        index: u16,
        sub: u8,
        od: &Dictionary,
    ) -> Result<[u8; 8], (u16, u8, SdoAbort)> {
        self.transfer = Transfer::Idle;
        let pos = od::find(index, sub).map_err(|a| (index, sub, a))?;
        let value = od.bytes(pos);
        let bytes = value.as_bytes();
        let [i0, i1] = index.to_le_bytes();
        let mut resp = [0u8, i0, i1, sub, 0, 0, 0, 0];
        if bytes.len() <= 4 {
            // Expedited, size indicated: n = 4 - len bytes of d unused.
            let n = u8::try_from(4 - bytes.len()).unwrap_or(0);
            resp[0] = 0x43 | (n << 2);
            if let Some(d) = resp.get_mut(4..4 + bytes.len()) {
                d.copy_from_slice(bytes);
            }
        } else {
            resp[0] = 0x41;
            let size = u32::try_from(bytes.len()).unwrap_or(u32::MAX);
            resp[4..8].copy_from_slice(&size.to_le_bytes());
            self.transfer = Transfer::Upload {
                pos,
                offset: 0,
                toggle: false,
            };
        }
        Ok(resp)
    }

    fn upload_segment(
        &mut self,
        req: &[u8; 8],
        od: &Dictionary,
    ) -> Result<[u8; 8], (u16, u8, SdoAbort)> {
        let Transfer::Upload {
            pos,
            offset,
            toggle,
        } = self.transfer
        else {
            let index = u16::from_le_bytes([req[1], req[2]]);
            return Err((index, req[3], SdoAbort::Command));
        };
        let (index, sub) = address(pos);
        let t = req[0] & 0x10 != 0;
        if t != toggle {
            return Err((index, sub, SdoAbort::Toggle));
        }
        let value = od.bytes(pos);
        let rest = value.as_bytes().get(offset..).unwrap_or(&[]);
        let chunk = rest.get(..rest.len().min(7)).unwrap_or(&[]);
        let last = chunk.len() == rest.len();
        let n = u8::try_from(7 - chunk.len()).unwrap_or(0);
        let mut resp = [0u8; 8];
        resp[0] = (u8::from(t) << 4) | (n << 1) | u8::from(last);
        if let Some(d) = resp.get_mut(1..1 + chunk.len()) {
            d.copy_from_slice(chunk);
        }
        self.transfer = if last {
            Transfer::Idle
        } else {
            Transfer::Upload {
                pos,
                offset: offset + chunk.len(),
                toggle: !toggle,
            }
        };
        Ok(resp)
    }
}

#[cfg(test)]
mod tests;
