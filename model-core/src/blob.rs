//! The model blob: what `thermcomp` writes and the hub flashes.
//!
//! ```text
//! offset  size  field
//!      0     4  magic  "TCMB"
//!      4     2  format version, u16 little-endian (written: FORMAT_VERSION;
//!               read: 1 and 2)
//!      6     1  model kind code (1 tf, 2 linear, 3 pcr, 4 bp, 5 arma, 6 fbank)
//!      7     1  reserved, 0
//!      8     4  body length N, u32 little-endian
//!     12     N  body: the `Model` in postcard encoding
//!   12+N     4  CRC-32 (IEEE 802.3, as zlib/PNG) of bytes 0..12+N, u32 LE
//! ```
//!
//! Decoding checks, in order: length, magic, version, declared length, CRC,
//! kind code, body (postcard, with nothing left over), kind agreement, and
//! then [`Model::validate`]. Any failure is a typed [`BlobError`]; no input
//! makes it panic. docs/blob-format.md is the full specification.
//!
//! Version 2 added the optional calibration [`Bounds`](crate::model::Bounds)
//! as the body's last field; a version-1 body (the same fields without it)
//! still decodes, with no bounds. Version 3 added the optional five-point
//! geometry ([`FivePoint`](crate::fivepoint::FivePoint)) after the bounds;
//! a version-2 body still decodes, with none.

use crate::in_place;
use crate::model::{Model, ModelError, ModelKind, ValidModel};

/// Magic bytes at offset 0.
pub const MAGIC: [u8; 4] = *b"TCMB";
/// Blob format written by this code (2: a model may carry bounds; 3: a
/// five-point model carries its tip geometry).
pub const FORMAT_VERSION: u16 = 3;
/// Oldest blob format this code reads (1: no bounds field).
pub const OLDEST_READ_VERSION: u16 = 1;
/// Bytes before the body.
pub const HEADER_LEN: usize = 12;
/// Bytes after the body (the CRC).
pub const TRAILER_LEN: usize = 4;
/// Largest blob accepted: the largest model of every kind fits with room
/// (measured in tests), and a 16 KiB buffer is affordable on the hub.
pub const MAX_BLOB_LEN: usize = 16 * 1024;

/// Why a blob is refused.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum BlobError {
    /// Shorter than a header and trailer.
    TooShort,
    /// Longer than [`MAX_BLOB_LEN`].
    TooLong,
    /// The first four bytes are not `TCMB`: not a model blob.
    BadMagic,
    /// Written by another format version.
    UnsupportedVersion {
        /// The version in the header.
        found: u16,
    },
    /// The header's body length disagrees with the blob's size.
    LengthMismatch {
        /// Body length in the header.
        declared: u32,
        /// Body bytes present.
        actual: u32,
    },
    /// The CRC does not match: the blob was damaged.
    BadCrc {
        /// CRC stored in the blob.
        stored: u32,
        /// CRC of the bytes.
        computed: u32,
    },
    /// The kind code is unknown, or disagrees with the body.
    BadKind {
        /// The code in the header.
        code: u8,
    },
    /// The body is not a valid postcard `Model` (or has trailing bytes).
    Malformed,
    /// The body decodes but the model is invalid.
    Invalid(ModelError),
    /// The output buffer is too small to encode into.
    BufferTooSmall,
}

impl core::fmt::Display for BlobError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::TooShort => write!(f, "too short to be a model blob"),
            Self::TooLong => write!(f, "longer than {MAX_BLOB_LEN} bytes"),
            Self::BadMagic => write!(f, "not a model blob (bad magic)"),
            Self::UnsupportedVersion { found } => write!(
                f,
                "blob format version {found}, this build reads versions {OLDEST_READ_VERSION} to {FORMAT_VERSION}"
            ),
            Self::LengthMismatch { declared, actual } => write!(
                f,
                "header says {declared} body bytes, blob has {actual} (truncated or padded)"
            ),
            Self::BadCrc { stored, computed } => write!(
                f,
                "CRC mismatch (stored {stored:#010x}, computed {computed:#010x}): damaged blob"
            ),
            Self::BadKind { code } => write!(f, "unknown or inconsistent model kind {code}"),
            Self::Malformed => write!(f, "malformed model body"),
            Self::Invalid(e) => write!(f, "invalid model: {e}"),
            Self::BufferTooSmall => write!(f, "buffer too small"),
        }
    }
}

impl core::error::Error for BlobError {}

impl From<ModelError> for BlobError {
    fn from(e: ModelError) -> Self {
        Self::Invalid(e)
    }
}

/// CRC-32/ISO-HDLC (reflected polynomial 0xEDB88320, init and xorout
/// 0xFFFFFFFF): the zlib/PNG CRC, so any tool can check a blob.
pub fn crc32(bytes: &[u8]) -> u32 {
    Crc32::new().update(bytes).finish()
}

/// [`crc32`] over bytes that arrive in pieces: the hub checks an upload
/// whose first bytes are still in RAM and the rest in flash, without
/// copying it into one buffer.
#[derive(Clone, Copy, Debug)]
pub struct Crc32(u32);

impl Default for Crc32 {
    fn default() -> Self {
        Self::new()
    }
}

impl Crc32 {
    const TABLE: [u32; 256] = {
        let mut table = [0u32; 256];
        let mut i = 0;
        while i < 256 {
            let mut c = i as u32;
            let mut k = 0;
            while k < 8 {
                c = if c & 1 != 0 {
                    0xEDB8_8320 ^ (c >> 1)
                } else {
                    c >> 1
                };
                k += 1;
            }
            table[i] = c;
            i += 1;
        }
        table
    };

    /// No bytes yet.
    pub const fn new() -> Self {
        Self(0xFFFF_FFFF)
    }

    /// Adds `bytes` after those seen so far.
    #[must_use]
    pub fn update(mut self, bytes: &[u8]) -> Self {
        for b in bytes {
            let idx = usize::from((self.0 as u8) ^ b);
            self.0 = Self::TABLE.get(idx).copied().unwrap_or(0) ^ (self.0 >> 8);
        }
        self
    }

    /// The CRC of every byte added.
    pub fn finish(self) -> u32 {
        !self.0
    }
}

/// The fixed-size fields of a blob, readable without decoding the body.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    /// Format version.
    pub version: u16,
    /// Model kind code.
    pub kind_code: u8,
    /// Body length.
    pub body_len: u32,
    /// Stored CRC.
    pub crc: u32,
}

fn le_u16(b: &[u8], at: usize) -> Option<u16> {
    let s = b.get(at..at + 2)?;
    Some(u16::from_le_bytes([*s.first()?, *s.get(1)?]))
}

fn le_u32(b: &[u8], at: usize) -> Option<u32> {
    let s = b.get(at..at + 4)?;
    Some(u32::from_le_bytes([
        *s.first()?,
        *s.get(1)?,
        *s.get(2)?,
        *s.get(3)?,
    ]))
}

/// Checks framing, version and CRC; returns the header and the body bytes.
pub fn check_frame(bytes: &[u8]) -> Result<(Header, &[u8]), BlobError> {
    check_frame_split(&[], bytes)
}

/// [`check_frame`] of the blob `head ++ tail`, with `head` at most
/// [`HEADER_LEN`] bytes: the body and CRC must lie in `tail`, which is
/// where they are during an upload (the magic is held in RAM until the
/// blob is checked, the rest is already in flash). A longer `head` is
/// refused as [`BlobError::Malformed`].
pub fn check_frame_split<'t>(head: &[u8], tail: &'t [u8]) -> Result<(Header, &'t [u8]), BlobError> {
    let total = head.len().saturating_add(tail.len());
    if total > MAX_BLOB_LEN {
        return Err(BlobError::TooLong);
    }
    if total < HEADER_LEN + TRAILER_LEN {
        return Err(BlobError::TooShort);
    }
    // The header, assembled from both pieces.
    let split = HEADER_LEN
        .checked_sub(head.len())
        .ok_or(BlobError::Malformed)?;
    let mut header = [0u8; HEADER_LEN];
    for (h, b) in header
        .iter_mut()
        .zip(head.iter().chain(tail.get(..split).unwrap_or(&[])))
    {
        *h = *b;
    }
    if header.get(..4) != Some(&MAGIC[..]) {
        return Err(BlobError::BadMagic);
    }
    let version = le_u16(&header, 4).ok_or(BlobError::TooShort)?;
    if !(OLDEST_READ_VERSION..=FORMAT_VERSION).contains(&version) {
        return Err(BlobError::UnsupportedVersion { found: version });
    }
    let kind_code = header.get(6).copied().ok_or(BlobError::TooShort)?;
    let body_len = le_u32(&header, 8).ok_or(BlobError::TooShort)?;
    let actual = total - HEADER_LEN - TRAILER_LEN;
    if usize::try_from(body_len).ok() != Some(actual) {
        return Err(BlobError::LengthMismatch {
            declared: body_len,
            actual: u32::try_from(actual).unwrap_or(u32::MAX),
        });
    }
    let crc_at = split + actual;
    let stored = le_u32(tail, crc_at).ok_or(BlobError::TooShort)?;
    let computed = Crc32::new()
        .update(&header)
        .update(tail.get(split..crc_at).ok_or(BlobError::TooShort)?)
        .finish();
    if stored != computed {
        return Err(BlobError::BadCrc { stored, computed });
    }
    let body = tail.get(split..crc_at).ok_or(BlobError::TooShort)?;
    Ok((
        Header {
            version,
            kind_code,
            body_len,
            crc: stored,
        },
        body,
    ))
}

/// Decodes and validates a blob.
pub fn decode(bytes: &[u8]) -> Result<ValidModel, BlobError> {
    decode_split(&[], bytes)
}

/// [`decode`] of the blob `head ++ tail` (see [`check_frame_split`]).
///
/// The model is decoded on this function's stack and returned by value: on
/// the hub, load into a static slot instead
/// ([`crate::ModelSlot::load_split`]).
pub fn decode_split(head: &[u8], tail: &[u8]) -> Result<ValidModel, BlobError> {
    let mut model = Model::placeholder();
    decode_into(head, tail, &mut model)?;
    Ok(model.validate()?)
}

/// Whether the blob `head ++ tail` decodes into a valid model, as
/// [`decode_split`] would; the model is decoded in this function's own
/// frame and dropped with it (a hub checks an upload with it before the
/// upload may boot).
#[inline(never)]
pub fn check_split(head: &[u8], tail: &[u8]) -> Result<(), BlobError> {
    let mut model = Model::placeholder();
    decode_into(head, tail, &mut model)?;
    model.check()?;
    Ok(())
}

/// The framing checks of [`decode_split`], then the body decoded into
/// `place` (in place: `in_place`). The model is not validated; on error
/// `place` holds a partly decoded one.
pub(crate) fn decode_into(head: &[u8], tail: &[u8], place: &mut Model) -> Result<(), BlobError> {
    let (header, body) = check_frame_split(head, tail)?;
    let kind = ModelKind::from_code(header.kind_code).ok_or(BlobError::BadKind {
        code: header.kind_code,
    })?;
    // Format 1 has no bounds and format 2 no five-point geometry: the
    // model's last two fields, or its last (check_frame_split refused
    // every other version).
    let fields = match header.version {
        1 => in_place::FIELDS_V1,
        2 => in_place::FIELDS_V2,
        _ => in_place::FIELDS_NOW,
    };
    in_place::model(body, fields, place).map_err(|_| BlobError::Malformed)?;
    if place.kind() != kind {
        return Err(BlobError::BadKind {
            code: header.kind_code,
        });
    }
    Ok(())
}

/// Encodes a validated model into `buf`; returns the blob's length.
pub fn encode(model: &ValidModel, buf: &mut [u8]) -> Result<usize, BlobError> {
    let body_len = {
        let body = buf.get_mut(HEADER_LEN..).ok_or(BlobError::BufferTooSmall)?;
        postcard::to_slice(model.model(), body)
            .map_err(|_| BlobError::BufferTooSmall)?
            .len()
    };
    let total = HEADER_LEN + body_len + TRAILER_LEN;
    if total > MAX_BLOB_LEN {
        return Err(BlobError::TooLong);
    }
    let head = buf.get_mut(..HEADER_LEN).ok_or(BlobError::BufferTooSmall)?;
    head[..4].copy_from_slice(&MAGIC);
    head[4..6].copy_from_slice(&FORMAT_VERSION.to_le_bytes());
    head[6] = model.kind().code();
    head[7] = 0;
    let len32 = u32::try_from(body_len).map_err(|_| BlobError::TooLong)?;
    head[8..12].copy_from_slice(&len32.to_le_bytes());
    let crc_at = HEADER_LEN + body_len;
    let crc = crc32(buf.get(..crc_at).ok_or(BlobError::BufferTooSmall)?);
    buf.get_mut(crc_at..total)
        .ok_or(BlobError::BufferTooSmall)?
        .copy_from_slice(&crc.to_le_bytes());
    Ok(total)
}

/// Encodes a validated model into a new vector (host side).
#[cfg(feature = "alloc")]
pub fn encode_to_vec(model: &ValidModel) -> Result<alloc::vec::Vec<u8>, BlobError> {
    let mut buf = alloc::vec![0u8; MAX_BLOB_LEN];
    let n = encode(model, &mut buf)?;
    buf.truncate(n);
    Ok(buf)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc32_check_value() {
        // The CRC catalogue's check value for CRC-32/ISO-HDLC.
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    }
}
