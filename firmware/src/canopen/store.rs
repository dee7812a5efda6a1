//! The settings in flash (object 0x1010 "save"): an append-only log of
//! fixed-size records in a sector of their own (`layout::SETTINGS`, sector
//! 5), the newest valid record wins.
//!
//! Why a log: erasing the 128 KiB sector stalls the CPU for 1-2 s (the
//! F446 has one flash bank, `layout`); appending 128-byte records erases
//! only once every 1024 saves. Why it survives a power cut: a record is
//! valid only if its CRC matches, so a torn write is skipped and the
//! previous record (or the defaults) is used; a cut during the erase that
//! follows a full sector loses the stored settings (defaults at the next
//! boot), which the log makes a once-in-1024-saves risk.
//!
//! Record (little-endian):
//!
//! | bytes | field |
//! |---|---|
//! | 0-3 | magic `TCST` |
//! | 4-7 | sequence number, u32 (first save 1) |
//! | 8-9 | format version, u16 (1) |
//! | 10-11 | payload length, u16 (`settings::ENCODED_LEN`) |
//! | 12-71 | `Settings::encode` |
//! | 72-123 | 0xFF (unwritten) |
//! | 124-127 | CRC-32 (zlib) of bytes 0-123 |

use core::fmt;

use embedded_storage::nor_flash::{NorFlash, NorFlashError, NorFlashErrorKind};
use model_core::blob::crc32;

use super::settings::{Settings, ENCODED_LEN};

/// Bytes per record.
pub const RECORD_LEN: usize = 128;
/// Record magic.
pub const MAGIC: [u8; 4] = *b"TCST";
/// Record format version.
pub const VERSION: u16 = 1;
const PAYLOAD_AT: usize = 12;
const CRC_AT: usize = RECORD_LEN - 4;

const _: () = assert!(PAYLOAD_AT + ENCODED_LEN <= CRC_AT);

/// Why a save failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum StoreError {
    /// Erasing, writing or reading the flash failed.
    Flash(NorFlashErrorKind),
    /// The region is smaller than one record or not erase-aligned.
    Region,
}

impl fmt::Display for StoreError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Flash(k) => write!(f, "settings flash failed: {k}"),
            Self::Region => write!(f, "settings region too small or misaligned"),
        }
    }
}

impl core::error::Error for StoreError {}

fn flash_err<E: NorFlashError>(e: E) -> StoreError {
    StoreError::Flash(e.kind())
}

/// A record's bytes.
pub fn record(seq: u32, settings: &Settings) -> [u8; RECORD_LEN] {
    let mut r = [0xFFu8; RECORD_LEN];
    r[0..4].copy_from_slice(&MAGIC);
    r[4..8].copy_from_slice(&seq.to_le_bytes());
    r[8..10].copy_from_slice(&VERSION.to_le_bytes());
    r[10..12].copy_from_slice(&(ENCODED_LEN as u16).to_le_bytes());
    r[PAYLOAD_AT..PAYLOAD_AT + ENCODED_LEN].copy_from_slice(&settings.encode());
    let crc = crc32(&r[..CRC_AT]);
    r[CRC_AT..].copy_from_slice(&crc.to_le_bytes());
    r
}

/// A record's sequence number and settings, if it is whole and valid
/// (magic, version, length, CRC, and settings that pass `Settings::to_od`).
pub fn parse(r: &[u8]) -> Option<(u32, Settings)> {
    let r: &[u8; RECORD_LEN] = r.get(..RECORD_LEN)?.try_into().ok()?;
    let crc = u32::from_le_bytes([r[124], r[125], r[126], r[127]]);
    if r[0..4] != MAGIC
        || u16::from_le_bytes([r[8], r[9]]) != VERSION
        || usize::from(u16::from_le_bytes([r[10], r[11]])) != ENCODED_LEN
        || crc32(&r[..CRC_AT]) != crc
    {
        return None;
    }
    let payload: &[u8; ENCODED_LEN] = r
        .get(PAYLOAD_AT..PAYLOAD_AT + ENCODED_LEN)?
        .try_into()
        .ok()?;
    let mut s = Settings::decode(payload);
    // A record saved when 0x2007 went down to 100 ms keeps its other
    // settings; its timeout becomes the shortest now allowed.
    s.cnc_timeout_ms = s.cnc_timeout_ms.max(crate::board::CNC_INPUT_TIMEOUT_MIN_MS);
    s.to_od().ok()?;
    Some((u32::from_le_bytes([r[4], r[5], r[6], r[7]]), s))
}

/// The newest valid settings in a region's bytes (memory-mapped at boot),
/// with their sequence number; `None`: nothing stored, use the defaults.
pub fn latest(region: &[u8]) -> Option<(u32, Settings)> {
    region
        .chunks_exact(RECORD_LEN)
        .filter_map(parse)
        .max_by_key(|(seq, _)| *seq)
}

/// Appends `settings` to the log in `flash[base..base + len]` (erasing it
/// first if no record slot is left); returns the record's sequence number.
pub fn save<F: NorFlash>(
    flash: &mut F,
    base: u32,
    len: u32,
    settings: &Settings,
) -> Result<u32, StoreError> {
    let n = len as usize / RECORD_LEN;
    if n == 0
        || !(base as usize).is_multiple_of(F::ERASE_SIZE)
        || !(len as usize).is_multiple_of(F::ERASE_SIZE)
    {
        return Err(StoreError::Region);
    }
    let mut newest = 0u32;
    let mut free = None;
    let mut buf = [0u8; RECORD_LEN];
    for i in 0..n {
        let at = base + (i * RECORD_LEN) as u32;
        flash.read(at, &mut buf).map_err(flash_err)?;
        if let Some((seq, _)) = parse(&buf) {
            newest = newest.max(seq);
        } else if free.is_none() && buf.iter().all(|b| *b == 0xFF) {
            free = Some(at);
        }
    }
    let seq = newest.wrapping_add(1);
    let at = match free {
        Some(at) => at,
        None => {
            flash.erase(base, base + len).map_err(flash_err)?;
            base
        }
    };
    flash.write(at, &record(seq, settings)).map_err(flash_err)?;
    Ok(seq)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ram_flash::HeapFlash;

    const LEN: u32 = 4096; // one HeapFlash sector: 32 records

    #[test]
    fn record_bytes() {
        let r = record(7, &Settings::DEFAULT);
        assert_eq!(&r[0..12], b"TCST\x07\x00\x00\x00\x01\x00\x3C\x00");
        assert_eq!(&r[12..16], &500.0f32.to_le_bytes());
        assert!(r[72..124].iter().all(|b| *b == 0xFF));
        assert_eq!(parse(&r), Some((7, Settings::DEFAULT)));
        // One bit off anywhere: refused.
        for i in [0, 5, 20, 100, 127] {
            let mut bad = r;
            bad[i] ^= 0x01;
            assert_eq!(parse(&bad), None, "byte {i}");
        }
    }

    #[test]
    fn a_timeout_below_today_s_minimum_is_raised_not_the_record_dropped() {
        let mut s = Settings::DEFAULT;
        s.hold_time_s = 5.0;
        s.cnc_timeout_ms = 500; // accepted before the minimum was 2 s
        let (_, got) = parse(&record(3, &s)).unwrap();
        assert_eq!(got.hold_time_s, 5.0);
        assert_eq!(got.cnc_timeout_ms, crate::board::CNC_INPUT_TIMEOUT_MIN_MS);
    }

    #[test]
    fn newest_wins_and_a_full_sector_is_erased() {
        let mut flash = HeapFlash::new(2 * LEN as usize);
        assert_eq!(latest(&flash.bytes()[LEN as usize..]), None);
        let mut s = Settings::DEFAULT;
        for i in 0..32u32 {
            s.heartbeat_ms = i as u16;
            assert_eq!(save(&mut flash, LEN, LEN, &s), Ok(i + 1));
        }
        assert_eq!(flash.erases, 0);
        let (seq, got) = latest(&flash.bytes()[LEN as usize..]).unwrap();
        assert_eq!((seq, got.heartbeat_ms), (32, 31));
        // The 33rd save erases the sector and starts over at its start.
        s.heartbeat_ms = 500;
        assert_eq!(save(&mut flash, LEN, LEN, &s), Ok(33));
        assert_eq!(flash.erases, 1);
        assert_eq!(latest(&flash.bytes()[LEN as usize..]), Some((33, s)));
        // The other sector is untouched.
        assert!(flash.bytes()[..LEN as usize].iter().all(|b| *b == 0xFF));
    }

    #[test]
    fn a_torn_write_keeps_the_previous_record() {
        let mut flash = HeapFlash::new(LEN as usize);
        let mut s = Settings::DEFAULT;
        save(&mut flash, 0, LEN, &s).unwrap();
        s.hold_time_s = 5.0;
        flash.budget = Some(40); // power cut 40 bytes into the record
        assert!(save(&mut flash, 0, LEN, &s).is_err());
        assert_eq!(latest(flash.bytes()), Some((1, Settings::DEFAULT)));
        // After the cut the torn slot is skipped, the next one is used.
        flash.budget = None;
        assert_eq!(save(&mut flash, 0, LEN, &s), Ok(2));
        assert_eq!(latest(flash.bytes()), Some((2, s)));
        assert_eq!(save(&mut flash, 100, LEN, &s), Err(StoreError::Region));
    }
}
