//! Model upload over the serial link into the inactive A/B slot, safe
//! against power loss at any point.
//!
//! A slot (one 128 KiB flash sector) holds the blob at offset 0, exactly as
//! `Hub::load` reads it, and a 16-byte [`CommitRecord`] in its last 16
//! bytes. The sequence (spec: `docs/wire-format.md`):
//!
//! 1. `UploadBegin { len, crc32 }`: erase the slot that is *not* running.
//! 2. `UploadChunk`s, strictly in order, written straight to flash, except
//!    the blob's first bytes (its magic), held back in RAM: until commit the
//!    slot holds no blob, so an interrupted upload can never look valid.
//! 3. `UploadCommit`: check the blob where it lies (the flash is
//!    memory-mapped, [`MappedFlash`]; the held-back magic joins it from
//!    RAM, so no 16 KiB copy): the announced CRC, then a decode exactly as
//!    `Hub::load` does (magic, version, length, CRC, kind, body, model
//!    validation; [`Uploader::commit_with`] lets the command task decode it
//!    into the hub it will swap in), and only then write the magic and then
//!    the record, with a generation one above any seen. The command task
//!    swaps that hub in between two samples (`commands`).
//!
//! At boot, the slot whose record and blob are both valid with the highest
//! generation boots ([`select_boot_slot`]: the first of [`boot_order`]
//! that decodes; `firmware::boot` loads them in that order and keeps the
//! first that loads). A power cut before the record is complete leaves a
//! slot with no valid record (its CRC fails), so the old model boots; the
//! running slot is never erased or written. A bare blob in
//! slot A without a record (flashed by a debugger, as before uploads existed)
//! counts as generation 0, so it boots until the first upload (an upload's
//! blob gets its magic only once checked, so this never boots a half-written
//! or refused one).
//!
//! **Erase stalls the CPU.** The F446 has one flash bank: while a 128 KiB
//! sector erases (1 s typical, 2 s max at x32 parallelism; 2 s / 4 s at the
//! x8 that stm32f4xx-hal 0.23 erases with, DS10693) every
//! instruction fetch from flash waits, at every priority. So:
//! call [`Uploader::begin`] from the lowest-priority RTIC task (never from
//! the UART interrupt: that task receives bytes, decodes [`Command`]s and
//! sends them through an `rtic_sync` channel), set `StatusFlags::UPLOADING`
//! first so the CNC sees why frames pause, and feed the watchdog right
//! before: its worst-case timeout (`board::IWDG_TIMEOUT_MIN_MS`, 5.4 s with
//! the 8 s setting) must exceed the worst-case erase
//! (`board::FLASH_SECTOR_ERASE_MAX_MS`, 4 s at x8) plus a feed period,
//! which `board` asserts at compile time. Chunk writes (64 bytes,
//! ~16 us/word) and the commit (reads, one 16-byte write) are short.
//! The committed model is loaded outside the pipeline's lock and exchanged
//! with the running hub under it (`Pipeline::swap_model`), so a sample
//! never sees half a model.

use embedded_storage::nor_flash::{NorFlash, NorFlashError, NorFlashErrorKind};
use model_core::blob::{
    check_frame_split, check_split, crc32, Crc32, HEADER_LEN, MAX_BLOB_LEN, TRAILER_LEN,
};
use model_core::BlobError;

use crate::hub::blob_len;
use crate::layout::{FLASH_BASE, MODEL_A, MODEL_B};
use crate::protocol::{Command, ErrorCode, HubMessage, CHUNK_MAX};

/// Flash whose contents can also be read in place, as the STM32's
/// memory-mapped flash can: the commit checks an uploaded blob where it
/// lies instead of copying it into a blob-sized buffer (16 KiB of RAM).
pub trait MappedFlash: NorFlash {
    /// The whole device; byte `k` is what `read` at offset `k` gives.
    fn mapped(&self) -> &[u8];
}

/// A model slot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Slot {
    /// Sector 6 ([`MODEL_A`]).
    A,
    /// Sector 7 ([`MODEL_B`]).
    B,
}

impl Slot {
    /// "A" or "B", for logs.
    pub const fn name(self) -> &'static str {
        match self {
            Self::A => "A",
            Self::B => "B",
        }
    }

    /// The other slot.
    pub const fn other(self) -> Self {
        match self {
            Self::A => Self::B,
            Self::B => Self::A,
        }
    }
}

/// Length of the commit record at the end of a slot.
pub const RECORD_LEN: usize = 16;
/// The record's magic ("TCMC": thermcomp model commit).
pub const RECORD_MAGIC: [u8; 4] = *b"TCMC";

/// Written after a blob has been checked in flash; makes the slot bootable.
///
/// Bytes (little-endian): 0-3 magic `TCMC`, 4-7 generation, 8-11 the blob's
/// own CRC (its last 4 bytes: ties the record to this blob), 12-15 CRC-32 of
/// bytes 0-11 (a torn write never parses).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CommitRecord {
    /// Higher is newer; the first upload is 1 (a bare blob in A counts as 0).
    pub generation: u32,
    /// The committed blob's stored CRC.
    pub blob_crc: u32,
}

impl CommitRecord {
    /// The record's bytes.
    pub fn to_bytes(&self) -> [u8; RECORD_LEN] {
        let mut b = [0u8; RECORD_LEN];
        b[0..4].copy_from_slice(&RECORD_MAGIC);
        b[4..8].copy_from_slice(&self.generation.to_le_bytes());
        b[8..12].copy_from_slice(&self.blob_crc.to_le_bytes());
        let crc = crc32(&b[0..12]);
        b[12..16].copy_from_slice(&crc.to_le_bytes());
        b
    }

    /// Parses a record; `None` if erased, torn or not a record.
    pub fn parse(bytes: &[u8]) -> Option<Self> {
        let b: &[u8; RECORD_LEN] = bytes.try_into().ok()?;
        let word = |i: usize| u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
        if b[0..4] != RECORD_MAGIC || word(12) != crc32(&b[0..12]) {
            return None;
        }
        Some(Self {
            generation: word(4),
            blob_crc: word(8),
        })
    }
}

/// Where the slots are in the [`NorFlash`] the uploader writes (offsets
/// from the start of that flash device).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SlotMap {
    /// Offset of slot A.
    pub a: u32,
    /// Offset of slot B.
    pub b: u32,
    /// Length of each slot (one erase unit or a multiple).
    pub len: u32,
}

impl SlotMap {
    /// The board: stm32f4xx-hal's flash `NorFlash` counts from [`FLASH_BASE`].
    pub const BOARD: Self = Self {
        a: MODEL_A.origin - FLASH_BASE,
        b: MODEL_B.origin - FLASH_BASE,
        len: MODEL_A.len,
    };

    /// Offset of `slot`.
    pub const fn offset(&self, slot: Slot) -> u32 {
        match slot {
            Slot::A => self.a,
            Slot::B => self.b,
        }
    }

    /// Offset of `slot`'s commit record.
    pub const fn record_offset(&self, slot: Slot) -> u32 {
        self.offset(slot) + self.len - RECORD_LEN as u32
    }
}

/// The generation `slot`'s contents boot with, or `None` if they must not
/// boot: needs a valid record whose blob CRC matches a blob that decodes
/// (exactly as `Hub::load`); a bare valid blob in slot A is generation 0.
pub fn slot_generation(slot: Slot, bytes: &[u8]) -> Option<u32> {
    let generation = record_generation(slot, bytes)?;
    decodes(bytes).then_some(generation)
}

/// Whether the blob at the start of a slot's `bytes` decodes and validates
/// (`check_split`, as `Hub::load` decodes it).
fn decodes(bytes: &[u8]) -> bool {
    bytes
        .get(..blob_len(bytes))
        .is_some_and(|blob| check_split(&[], blob).is_ok())
}

/// [`slot_generation`] without decoding the blob's body: the blob's frame
/// is whole (magic, version, length, CRC) and the record names that CRC,
/// or slot A holds a bare framed blob (generation 0). Whether the body
/// decodes and validates is left to the load that follows ([`boot_order`]).
pub fn record_generation(slot: Slot, bytes: &[u8]) -> Option<u32> {
    let blob = bytes.get(..blob_len(bytes))?;
    check_frame_split(&[], blob).ok()?;
    let stored = blob
        .get(blob.len().checked_sub(TRAILER_LEN)?..)
        .and_then(|b| <[u8; 4]>::try_from(b).ok())
        .map(u32::from_le_bytes)?;
    let record = bytes
        .get(bytes.len().checked_sub(RECORD_LEN)?..)
        .and_then(CommitRecord::parse);
    match (record, slot) {
        (Some(r), _) if r.blob_crc == stored => Some(r.generation),
        (None, Slot::A) => Some(0),
        _ => None,
    }
}

/// The slot to boot from, given both slots' bytes (memory-mapped on the
/// board): the bootable one with the highest generation, A on a tie;
/// `None` if neither is bootable (run without a model). The first of
/// [`boot_order`] whose blob decodes, which is what `firmware::boot`
/// loads (without decoding twice).
pub fn select_boot_slot(a: &[u8], b: &[u8]) -> Option<Slot> {
    boot_order(a, b).find(|&s| decodes(if s == Slot::B { b } else { a }))
}

/// The slots worth loading at boot, by their records alone: the highest
/// generation first, A on a tie; those whose record does not allow
/// booting are left out.
pub fn boot_order(a: &[u8], b: &[u8]) -> impl Iterator<Item = Slot> {
    let (ga, gb) = (record_generation(Slot::A, a), record_generation(Slot::B, b));
    let order = match (ga, gb) {
        (Some(ga), Some(gb)) if gb > ga => [(Slot::B, true), (Slot::A, true)],
        _ => [(Slot::A, ga.is_some()), (Slot::B, gb.is_some())],
    };
    order
        .into_iter()
        .filter_map(|(slot, ok)| ok.then_some(slot))
}

/// Why an upload step was refused.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum UploadError {
    /// A chunk or commit with no upload in progress.
    NotUploading,
    /// Blob length outside 16..=`max` (the blob format's limit and the slot).
    BadLength {
        /// Largest length accepted.
        max: u32,
    },
    /// Chunk not at the next offset (out of order, repeated, overlapping).
    OutOfOrder {
        /// The offset expected.
        expected: u32,
    },
    /// Empty chunk, chunk past the announced length, or a chunk other than
    /// the last whose length is not a multiple of the flash write size.
    BadChunk,
    /// Commit before every byte arrived.
    Incomplete {
        /// Bytes received.
        received: u32,
    },
    /// The bytes in flash do not have the CRC announced at `UploadBegin`.
    CrcMismatch {
        /// Announced.
        expected: u32,
        /// Of the bytes read back.
        computed: u32,
    },
    /// The blob does not decode or validate.
    Blob(BlobError),
    /// The flash failed (erase, write, or a read-back that differs).
    Flash(NorFlashErrorKind),
    /// The flash's write size does not divide [`CHUNK_MAX`] and
    /// [`RECORD_LEN`] or is wider than the blob header, or the slot map
    /// does not fit the flash (or its mapped view).
    Unsupported,
    /// Generation counter at `u32::MAX` (4e9 uploads).
    GenerationExhausted,
}

impl core::fmt::Display for UploadError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NotUploading => write!(f, "no upload in progress"),
            Self::BadLength { max } => write!(f, "blob length must be 16..={max} bytes"),
            Self::OutOfOrder { expected } => {
                write!(f, "chunk out of order, expected offset {expected}")
            }
            Self::BadChunk => write!(f, "empty, misaligned or overlong chunk"),
            Self::Incomplete { received } => write!(f, "commit after only {received} bytes"),
            Self::CrcMismatch { expected, computed } => write!(
                f,
                "CRC {computed:#010x} of the uploaded bytes, {expected:#010x} announced"
            ),
            Self::Blob(e) => write!(f, "blob refused: {e}"),
            Self::Flash(e) => write!(f, "flash error: {e:?}"),
            Self::Unsupported => write!(f, "flash geometry not supported"),
            Self::GenerationExhausted => write!(f, "generation counter exhausted"),
        }
    }
}

impl core::error::Error for UploadError {}

/// The wire code of a blob error (`ErrorCode::BadBlob::reason`): the
/// checks in the order `docs/blob-format.md` lists them.
pub fn blob_reason(e: &BlobError) -> u8 {
    match e {
        BlobError::TooShort => 1,
        BlobError::TooLong => 2,
        BlobError::BadMagic => 3,
        BlobError::UnsupportedVersion { .. } => 4,
        BlobError::LengthMismatch { .. } => 5,
        BlobError::BadCrc { .. } => 6,
        BlobError::BadKind { .. } => 7,
        BlobError::Malformed => 8,
        BlobError::Invalid(_) => 9,
        _ => 0,
    }
}

impl From<UploadError> for ErrorCode {
    fn from(e: UploadError) -> Self {
        match e {
            UploadError::NotUploading => Self::NotUploading,
            UploadError::BadLength { max } => Self::BadLength { max },
            UploadError::OutOfOrder { expected } => Self::OutOfOrder { expected },
            UploadError::BadChunk => Self::BadChunk,
            UploadError::Incomplete { received } => Self::Incomplete { received },
            UploadError::CrcMismatch { .. } => Self::CrcMismatch,
            UploadError::Blob(b) => Self::BadBlob {
                reason: blob_reason(&b),
            },
            UploadError::Flash(_) => Self::Flash,
            UploadError::Unsupported | UploadError::GenerationExhausted => Self::Unsupported,
        }
    }
}

/// A committed upload: the slot now active (its model is what
/// [`Uploader::commit_with`]'s `load` decoded, or `Hub::reload` of
/// [`Uploader::slot_bytes`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Committed {
    /// The slot written (now the active one).
    pub slot: Slot,
    /// Its generation.
    pub generation: u32,
}

/// The blob's first bytes, held in RAM until commit (the magic, rounded up
/// to the write size; the first chunk must carry them).
const HEAD_LEN: usize = 16;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum State {
    Idle,
    Receiving {
        slot: Slot,
        len: u32,
        crc: u32,
        next: u32,
        generation: u32,
        head: [u8; HEAD_LEN],
    },
}

/// The upload state machine over the board's flash.
#[derive(Debug)]
pub struct Uploader<F> {
    flash: F,
    map: SlotMap,
    active: Option<Slot>,
    state: State,
}

fn flash_err<E: NorFlashError>(e: E) -> UploadError {
    UploadError::Flash(e.kind())
}

impl<F: MappedFlash> Uploader<F> {
    /// An idle uploader; `active` is the slot the running hub was loaded from
    /// ([`select_boot_slot`]'s answer), never written.
    pub fn new(flash: F, map: SlotMap, active: Option<Slot>) -> Self {
        Self {
            flash,
            map,
            active,
            state: State::Idle,
        }
    }

    /// The slot the running model came from.
    pub fn active(&self) -> Option<Slot> {
        self.active
    }

    /// The slot an upload writes: the inactive one (A when none is active).
    pub fn target(&self) -> Slot {
        self.active.map_or(Slot::A, Slot::other)
    }

    /// Whether an upload is in progress (for `StatusFlags::UPLOADING`).
    pub fn is_uploading(&self) -> bool {
        self.state != State::Idle
    }

    /// The flash, for the other writer of its own sector (the CANopen
    /// settings, `canopen::store`), between uploads' steps.
    pub fn flash_mut(&mut self) -> &mut F {
        &mut self.flash
    }

    /// The whole of `slot` as the flash maps it (empty if the map does not
    /// fit the flash): what `Hub::reload` takes after a commit.
    pub fn slot_bytes(&self, slot: Slot) -> &[u8] {
        let at = self.map.offset(slot) as usize;
        self.flash
            .mapped()
            .get(at..at + self.map.len as usize)
            .unwrap_or(&[])
    }

    /// Gives the flash back.
    pub fn into_inner(self) -> F {
        self.flash
    }

    /// Largest blob the slots take: the blob format's limit, less room for
    /// the record and the last write's padding.
    pub fn max_len(&self) -> u32 {
        let room = (self.map.len as usize).saturating_sub(RECORD_LEN + F::WRITE_SIZE);
        u32::try_from(MAX_BLOB_LEN.min(room)).unwrap_or(0)
    }

    fn record(&mut self, slot: Slot) -> Option<CommitRecord> {
        let mut b = [0u8; RECORD_LEN];
        self.flash.read(self.map.record_offset(slot), &mut b).ok()?;
        CommitRecord::parse(&b)
    }

    /// Starts an upload of `len` bytes with zlib CRC `crc32`: erases the
    /// inactive slot (**stalls the CPU 1-2 s**, see the module docs).
    /// Aborts any upload in progress.
    pub fn begin(&mut self, len: u32, crc32: u32) -> Result<(), UploadError> {
        self.state = State::Idle;
        let w = F::WRITE_SIZE;
        let limit = self.flash.capacity().min(self.flash.mapped().len());
        let fits = [self.map.a, self.map.b]
            .iter()
            .all(|&o| (o as usize).saturating_add(self.map.len as usize) <= limit);
        if w == 0
            || !CHUNK_MAX.is_multiple_of(w)
            || !RECORD_LEN.is_multiple_of(w)
            || !HEAD_LEN.is_multiple_of(w)
            || Self::held() > HEADER_LEN
            || !fits
        {
            return Err(UploadError::Unsupported);
        }
        let max = self.max_len();
        if (len as usize) < HEADER_LEN + TRAILER_LEN || len > max {
            return Err(UploadError::BadLength { max });
        }
        let newest = [Slot::A, Slot::B]
            .iter()
            .filter_map(|&s| self.record(s))
            .map(|r| r.generation)
            .max()
            .unwrap_or(0);
        let generation = newest
            .checked_add(1)
            .ok_or(UploadError::GenerationExhausted)?;
        let slot = self.target();
        let from = self.map.offset(slot);
        self.flash
            .erase(from, from + self.map.len)
            .map_err(flash_err)?;
        self.state = State::Receiving {
            slot,
            len,
            crc: crc32,
            next: 0,
            generation,
            head: [0xFF; HEAD_LEN],
        };
        Ok(())
    }

    /// Bytes of the blob's start held back until commit: the 4-byte magic
    /// rounded up to a write unit.
    fn held() -> usize {
        4usize.div_ceil(F::WRITE_SIZE.max(1)) * F::WRITE_SIZE.max(1)
    }

    /// Writes one chunk at `offset`. The first chunk must hold at least 16
    /// bytes (or the whole blob). A refused chunk leaves the upload as it
    /// was (resend from `expected`); a flash failure ends it.
    pub fn chunk(&mut self, offset: u32, bytes: &[u8]) -> Result<(), UploadError> {
        let State::Receiving {
            slot, len, next, ..
        } = self.state
        else {
            return Err(UploadError::NotUploading);
        };
        if offset != next {
            return Err(UploadError::OutOfOrder { expected: next });
        }
        let n = u32::try_from(bytes.len()).map_err(|_| UploadError::BadChunk)?;
        let end = offset.checked_add(n).ok_or(UploadError::BadChunk)?;
        let w = F::WRITE_SIZE;
        if bytes.is_empty() || bytes.len() > CHUNK_MAX || end > len {
            return Err(UploadError::BadChunk);
        }
        if !bytes.len().is_multiple_of(w) && end != len {
            return Err(UploadError::BadChunk);
        }
        let held = Self::held();
        if offset == 0 && bytes.len() < HEAD_LEN.min(len as usize) {
            return Err(UploadError::BadChunk);
        }
        // The last chunk is padded with 0xFF (the erased value) to a whole
        // write unit; `max_len` leaves room for it before the record.
        let mut padded = [0xFFu8; CHUNK_MAX];
        let padded_len = bytes.len().div_ceil(w) * w;
        let out = padded.get_mut(..padded_len).ok_or(UploadError::BadChunk)?;
        out.get_mut(..bytes.len())
            .ok_or(UploadError::BadChunk)?
            .copy_from_slice(bytes);
        // Keep the magic back: the start stays erased until commit.
        let skip = if offset == 0 { held } else { 0 };
        let at = self.map.offset(slot) + offset + skip as u32;
        let rest = out.get(skip..).unwrap_or(&[]);
        if !rest.is_empty() {
            if let Err(e) = self.flash.write(at, rest) {
                self.state = State::Idle;
                return Err(flash_err(e));
            }
        }
        if let State::Receiving { next, head, .. } = &mut self.state {
            if offset == 0 {
                let n = held.min(bytes.len());
                if let (Some(h), Some(b)) = (head.get_mut(..n), bytes.get(..n)) {
                    h.copy_from_slice(b);
                }
            }
            *next = end;
        }
        Ok(())
    }

    /// Checks the uploaded blob in flash and, if good, commits it. Any
    /// refusal but `Incomplete` ends the upload; the running slot stays
    /// active in every case.
    pub fn commit(&mut self) -> Result<Committed, UploadError> {
        self.commit_with(check_split)
    }

    /// [`Uploader::commit`] with `load` as the decode check: it is given
    /// the blob (`head ++ tail`, the held-back magic and the rest in
    /// flash) and must refuse it exactly as `model_core::blob::check_split`
    /// would; it may keep what it decoded (the command task loads the blob
    /// into the hub it then swaps in: one decode per upload).
    pub fn commit_with(
        &mut self,
        load: impl FnOnce(&[u8], &[u8]) -> Result<(), BlobError>,
    ) -> Result<Committed, UploadError> {
        let State::Receiving {
            slot,
            len,
            crc,
            next,
            generation,
            head,
        } = self.state
        else {
            return Err(UploadError::NotUploading);
        };
        if next != len {
            return Err(UploadError::Incomplete { received: next });
        }
        self.state = State::Idle;
        let held = Self::held();
        let head = head.get(..held).ok_or(UploadError::Unsupported)?;
        // The rest of the blob, in place (begin checked the map fits).
        let blob_at = self.map.offset(slot) as usize;
        let tail = self
            .flash
            .mapped()
            .get(blob_at + held..blob_at + len as usize)
            .ok_or(UploadError::Unsupported)?;
        let computed = Crc32::new().update(head).update(tail).finish();
        if computed != crc {
            return Err(UploadError::CrcMismatch {
                expected: crc,
                computed,
            });
        }
        // Exactly these bytes must be one blob (no trailing bytes), then
        // decode as the hub does.
        let (header, _) = check_frame_split(head, tail).map_err(UploadError::Blob)?;
        // Decoded where the caller's model lies, or in check_split's own
        // frame and dropped (docs/firmware-cost.md, "Stack").
        load(head, tail).map_err(UploadError::Blob)?;
        // Checked: now the magic, then the record that makes it bootable.
        let start = self.map.offset(slot);
        self.flash.write(start, head).map_err(flash_err)?;
        let mut back = [0u8; HEAD_LEN];
        let back = back.get_mut(..held).ok_or(UploadError::Unsupported)?;
        self.flash.read(start, back).map_err(flash_err)?;
        if back != head {
            return Err(UploadError::Flash(NorFlashErrorKind::Other));
        }
        let record = CommitRecord {
            generation,
            blob_crc: header.crc,
        }
        .to_bytes();
        let at = self.map.record_offset(slot);
        self.flash.write(at, &record).map_err(flash_err)?;
        let mut back = [0u8; RECORD_LEN];
        self.flash.read(at, &mut back).map_err(flash_err)?;
        if back != record {
            return Err(UploadError::Flash(NorFlashErrorKind::Other));
        }
        self.active = Some(slot);
        Ok(Committed { slot, generation })
    }

    /// Drops the upload in progress (the half-written slot never boots).
    pub fn abort(&mut self) {
        self.state = State::Idle;
    }

    /// Carries out an upload command and gives the reply; `None` for
    /// commands that are not about uploads (`Ping`, `SetToolLength`).
    /// On a successful commit, the [`Committed`] slot.
    pub fn handle(&mut self, command: &Command) -> Option<(HubMessage, Option<Committed>)> {
        self.handle_with(command, check_split)
    }

    /// [`Uploader::handle`] with a commit's decode check done by `load`
    /// ([`Uploader::commit_with`]).
    pub fn handle_with(
        &mut self,
        command: &Command,
        load: impl FnOnce(&[u8], &[u8]) -> Result<(), BlobError>,
    ) -> Option<(HubMessage, Option<Committed>)> {
        let kind = command.kind();
        let result = match command {
            Command::UploadBegin { len, crc32 } => self.begin(*len, *crc32).map(|()| None),
            Command::UploadChunk { offset, bytes } => self.chunk(*offset, bytes).map(|()| None),
            Command::UploadCommit => self.commit_with(load).map(Some),
            Command::UploadAbort => {
                self.abort();
                Ok(None)
            }
            Command::Ping | Command::SetToolLength { .. } => return None,
        };
        Some(match result {
            Ok(committed) => (HubMessage::Ack(kind), committed),
            Err(e) => (
                HubMessage::Nack {
                    command: kind,
                    error: e.into(),
                },
                None,
            ),
        })
    }
}

#[cfg(test)]
mod tests;
