//! Peak stack use of the hub's paths, by painting (`qemu_bench::stack`),
//! for the largest model of each kind (docs/firmware-cost.md, "Stack").
//!
//! The firmware library's own code runs here, as the RTIC tasks call it:
//!
//! * boot (`init`): `firmware::boot::boot`, the function `init` calls:
//!   the pipeline built without a model into its static, the slots'
//!   models loaded into it in place in the order of their commit records
//!   until one loads; once with nothing uploaded, then with each kind's model;
//! * the command task (priority 1): `commands::execute` of an upload's
//!   commit, the costliest command (it decodes the uploaded blob into a
//!   `Hub` on its stack and swaps it into the pipeline), after its begin
//!   and chunks went
//!   through an uploader over RAM standing in for the flash;
//! * the sample task (priority 2): `Pipeline::on_sample`, which can preempt
//!   the command task, so the two depths add up on the board.
//!
//! Built and run by scripts/qemu-bench.sh (QEMU, Cortex-M4 code generation
//! with the firmware's size-first profile).
#![no_std]
#![no_main]

use core::hint::black_box;
use core::mem::MaybeUninit;
use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use firmware::boot::boot;
use firmware::commands::{execute, Event};
use firmware::pipeline::{Pipeline, PipelineConfig, Reading, ValidConfig};
use firmware::protocol::{Command, HubMessage, CHUNK_MAX};
use firmware::ram_flash::RamFlash;
use firmware::upload::{Slot, SlotMap, Uploader};
use model_core::blob::{self, MAX_BLOB_LEN};
use model_core::ModelKind;
use panic_semihosting as _;
use qemu_bench::models::{self, KINDS, WIDE_CHANNELS};
use qemu_bench::stack::peak;

/// Bytes of stack painted below each measurement: far more than any path
/// needs (QEMU's mps2-an386 has 4 MiB of RAM).
const DEPTH: usize = 256 * 1024;
/// One model slot of the stand-in flash: room for the largest blob and the
/// commit record, a whole number of erase units.
const SLOT: u32 = 32 * 1024;
const MAP: SlotMap = SlotMap {
    a: 0,
    b: SLOT,
    len: SLOT,
};
const FLASH_LEN: usize = 2 * SLOT as usize;
/// The stand-in flash: the firmware's test flash over a static buffer.
type Flash = RamFlash<&'static mut [u8]>;

/// Stack bytes of the command and sample paths for one kind's largest
/// model.
struct Depths {
    /// The command task: an upload's commit.
    commit: Option<usize>,
    /// The sample task, ten samples.
    sample: Option<usize>,
}

/// Samples run in the sample task's measurement.
const SAMPLES: usize = 10;

/// Bytes of the buffer on the frame of [`known_frame`].
const KNOWN: usize = 16 * 1024;

/// The method's check: a frame holding a buffer of known size, written
/// through (so the compiler cannot leave it out).
#[inline(never)]
fn known_frame() {
    let buf = [0x5Au8; KNOWN];
    black_box(&buf);
}

fn show(d: Option<usize>) -> heapless::String<16> {
    use core::fmt::Write;
    let mut s = heapless::String::new();
    let _ = match d {
        Some(b) => write!(s, "{}", b),
        None => write!(s, ">= {}", DEPTH),
    };
    s
}

/// Uploads `bytes` up to (not including) the commit; false if a step was
/// refused.
fn upload_up_to_commit(
    pipeline: &mut Pipeline,
    uploader: &mut Uploader<Flash>,
    bytes: &[u8],
) -> bool {
    let begin = Command::UploadBegin {
        len: bytes.len() as u32,
        crc32: blob::crc32(bytes),
    };
    if !matches!(
        execute(pipeline, uploader, || {}, &begin).0,
        HubMessage::Ack(_)
    ) {
        return false;
    }
    bytes.chunks(CHUNK_MAX).enumerate().all(|(i, c)| {
        let Ok(chunk) = heapless::Vec::from_slice(c) else {
            return false;
        };
        let cmd = Command::UploadChunk {
            offset: (i * CHUNK_MAX) as u32,
            bytes: chunk,
        };
        matches!(
            execute(pipeline, uploader, || {}, &cmd).0,
            HubMessage::Ack(_)
        )
    })
}

/// Uploads and commits `kind`'s largest model into `pipeline`, then runs
/// samples on it.
fn measure(
    kind: ModelKind,
    pipeline: &mut Pipeline,
    uploader: &mut Uploader<Flash>,
    buf: &mut [u8],
) -> Option<Depths> {
    let valid = models::build(kind).validate().ok()?;
    let len = blob::encode(&valid, buf).ok()?;
    let bytes = &buf[..len];
    if !upload_up_to_commit(pipeline, uploader, bytes) {
        return None;
    }
    let (swapped, commit) = peak(DEPTH, || {
        let (_, event) = execute(pipeline, uploader, || {}, &Command::UploadCommit);
        matches!(event, Event::Swapped { .. })
    });
    if !swapped {
        hprintln!("error: the {} blob was not committed", kind.name());
        return None;
    }
    // Ten samples: the first after a swap takes first-sample branches
    // (references, filter starts); the deepest of the ten counts.
    let readings = [Reading::Value(20.0); WIDE_CHANNELS];
    let ((), sample) = peak(DEPTH, || {
        for _ in 0..SAMPLES {
            black_box(&pipeline.on_sample(black_box(&readings)));
        }
    });
    Some(Depths { commit, sample })
}

/// Boots the pipeline into `core` from the uploader's slots, as `init`
/// does after a reset: the pipeline, whether a model booted, and the
/// stack it took.
fn boot_from<'a>(
    core: &'a mut MaybeUninit<Pipeline>,
    uploader: &Uploader<Flash>,
) -> (&'a mut Pipeline, bool, Option<usize>) {
    let slots = [uploader.slot_bytes(Slot::A), uploader.slot_bytes(Slot::B)];
    let ((pipeline, active), depth) = peak(DEPTH, || boot(core, config(), slots));
    let booted = active.is_some() && pipeline.hub().model().is_some();
    (pipeline, booted, depth)
}

/// The firmware's default settings, checked.
fn config() -> ValidConfig {
    match PipelineConfig::DEFAULT.checked() {
        Ok(c) => c,
        Err(_) => {
            hprintln!("error: the default pipeline settings were refused");
            qemu_bench::exit(false)
        }
    }
}

#[entry]
fn main() -> ! {
    if cfg!(feature = "stm32f446") {
        // The stand-in flash (64 KiB) and the pipeline live in RAM beside
        // the paint: more than the F446's 128 KiB leaves for a 58 KiB path.
        hprintln!("stack: QEMU only (needs more RAM than the F446 has)");
        qemu_bench::exit(false)
    }
    let Some(cells) = cortex_m::singleton!(: [u8; FLASH_LEN] = [0xFF; FLASH_LEN]) else {
        hprintln!("error: flash buffer already taken");
        qemu_bench::exit(false)
    };
    // The pipeline's static, booted as `init` does, before each kind's
    // upload: the first time with nothing uploaded, then with the model
    // the previous kind committed, and once more after the last.
    let Some(core) = cortex_m::singleton!(: MaybeUninit<Pipeline> = MaybeUninit::uninit()) else {
        hprintln!("error: pipeline static already taken");
        qemu_bench::exit(false)
    };
    // The uploader alternates slots: each kind's commit lands in the one
    // the previous kind's did not.
    let mut uploader = Uploader::new(RamFlash::over(&mut cells[..]), MAP, Some(Slot::A));
    let mut buf = [0u8; MAX_BLOB_LEN];
    hprintln!(
        "stack: peak stack use of the hub's paths, bytes (painted {} B deep)",
        DEPTH
    );
    let ((), known) = peak(DEPTH, known_frame);
    hprintln!(
        "verify: a frame holding {} bytes measures {} bytes",
        KNOWN,
        show(known)
    );
    let mut rows: [Option<Depths>; KINDS.len()] = Default::default();
    let mut boots = [None; KINDS.len()];
    let mut ok = true;
    for (i, kind) in KINDS.into_iter().enumerate() {
        let (pipeline, booted, depth) = boot_from(&mut *core, &uploader);
        match i.checked_sub(1) {
            None => hprintln!("boot without a model: {} bytes", show(depth)),
            Some(prev) => boots[prev] = booted.then_some(depth),
        }
        rows[i] = measure(kind, pipeline, &mut uploader, &mut buf);
    }
    let (_, booted, depth) = boot_from(&mut *core, &uploader);
    boots[KINDS.len() - 1] = booted.then_some(depth);
    hprintln!("| kind | command: upload commit | sample: Pipeline::on_sample | command + sample | boot with it |");
    hprintln!("|---|---|---|---|---|");
    for ((kind, row), boot) in KINDS.into_iter().zip(rows).zip(boots) {
        let (Some(d), Some(boot)) = (row, boot) else {
            hprintln!("error: {} could not be measured", kind.name());
            ok = false;
            continue;
        };
        let both = d.commit.zip(d.sample).map(|(c, s)| c + s);
        hprintln!(
            "| {} | {} | {} | {} | {} |",
            kind.name(),
            show(d.commit),
            show(d.sample),
            show(both),
            show(boot)
        );
    }
    hprintln!("stack: done");
    qemu_bench::exit(ok)
}
