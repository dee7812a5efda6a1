//! The file and stdout guards every subcommand shares.
//!
//! - Reads are bounded: a device such as `/dev/zero` or a huge file given by
//!   mistake ends in a one-line error, never in memory growing without end.
//! - An output is never the same file as an input or as another output
//!   ([`check_distinct`]), and is written atomically ([`write_atomic`]): a
//!   temporary file in the same directory, renamed over the target only once
//!   it is complete, so an interrupted run leaves the old file in place.
//! - Results go to stdout through [`print`] and [`print_line`]: a reader that
//!   closes the pipe early (`| head`) ends the command quietly with status 0
//!   (see [`StdoutClosed`]); any other write error (a full disk) is a
//!   one-line error and a non-zero status, never a panic.

use anyhow::{bail, Context, Result};
use std::fmt;
use std::fs::File;
use std::io::{self, Read, Write};
use std::os::unix::fs::{FileTypeExt, MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};

/// Largest text file (spec, machine) read: far above any hand-written TOML
/// (the built-in machine is under 10 KiB), far below what hurts.
pub const MAX_TEXT_LEN: u64 = 1 << 20;

/// Reads at most `limit` bytes of `path`; a longer file is an error naming
/// it. Reads `limit + 1` bytes at most, so a device or a huge file costs no
/// more than that.
pub fn read_capped(path: &Path, limit: u64) -> Result<Vec<u8>> {
    let file = File::open(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut bytes = Vec::new();
    file.take(limit.saturating_add(1))
        .read_to_end(&mut bytes)
        .with_context(|| format!("cannot read {}", path.display()))?;
    if bytes.len() as u64 > limit {
        bail!(
            "{}: larger than {limit} bytes, the most this file kind can be",
            path.display()
        );
    }
    Ok(bytes)
}

/// [`read_capped`] with [`MAX_TEXT_LEN`], as UTF-8 text.
pub fn read_text_capped(path: &Path) -> Result<String> {
    let bytes = read_capped(path, MAX_TEXT_LEN)?;
    String::from_utf8(bytes).map_err(|_| anyhow::anyhow!("{}: not UTF-8 text", path.display()))
}

/// One command-line path: the flag that named it and the path.
#[derive(Clone, Copy)]
pub struct Named<'a> {
    /// The flag as the user typed it, e.g. `--data`.
    pub flag: &'a str,
    /// The path given.
    pub path: &'a Path,
}

/// Shorthand for a [`Named`] path.
pub fn named<'a>(flag: &'a str, path: &'a Path) -> Named<'a> {
    Named { flag, path }
}

/// What makes two paths the same file: device and inode where the file
/// exists, else the canonical parent joined with the file name. `None` for
/// what is not a regular file or a path to be created (a terminal,
/// `/dev/null`): writing there cannot destroy an input.
#[derive(PartialEq, Eq, Debug)]
enum Identity {
    Inode(u64, u64),
    Path(PathBuf),
}

fn identity(path: &Path) -> Option<Identity> {
    match std::fs::metadata(path) {
        Ok(meta) if meta.is_file() => Some(Identity::Inode(meta.dev(), meta.ino())),
        Ok(_) => None,
        Err(_) => {
            let parent = match path.parent() {
                Some(p) if !p.as_os_str().is_empty() => p,
                _ => Path::new("."),
            };
            let dir = parent.canonicalize().ok()?;
            Some(Identity::Path(dir.join(path.file_name()?)))
        }
    }
}

/// Whether `a` and `b` name one existing file (by device and inode).
pub fn same_file(a: &Path, b: &Path) -> bool {
    matches!((identity(a), identity(b)), (Some(x), Some(y)) if x == y)
}

/// Refuses an output that is the same file as an input or as another
/// output, with a one-line error naming both flags and the path.
pub fn check_distinct<'a>(inputs: &[Named<'a>], outputs: &[Named<'a>]) -> Result<()> {
    let ids = |list: &[Named<'_>]| list.iter().map(|n| identity(n.path)).collect::<Vec<_>>();
    let (in_ids, out_ids) = (ids(inputs), ids(outputs));
    for (i, (out, out_id)) in outputs.iter().zip(&out_ids).enumerate() {
        let Some(out_id) = out_id else { continue };
        let clash =
            |(n, id): (&Named<'a>, &Option<Identity>)| (id.as_ref() == Some(out_id)).then_some(*n);
        if let Some(input) = inputs.iter().zip(&in_ids).find_map(clash) {
            bail!(
                "{} {} is the same file as {} {}: refusing to overwrite an input",
                out.flag,
                out.path.display(),
                input.flag,
                input.path.display()
            );
        }
        if let Some(other) = outputs[..i].iter().zip(&out_ids[..i]).find_map(clash) {
            bail!(
                "{} {} is the same file as {} {}: give each output its own file",
                out.flag,
                out.path.display(),
                other.flag,
                other.path.display()
            );
        }
    }
    Ok(())
}

/// The directory `path` would be written in, refused when it does not
/// exist (a command checks its outputs' before the work, and says which).
pub fn dir_of(path: &Path) -> Result<&Path> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        bail!(
            "cannot write {}: there is no directory {}",
            path.display(),
            dir.display()
        );
    }
    Ok(dir)
}

/// Writes `path` atomically: `fill` writes into a temporary file in the same
/// directory, which is synced and renamed over `path` only when `fill` and
/// the flush succeeded; on any error the temporary file is removed and
/// `path` is untouched. A target that exists but is not a regular file (a
/// device, a FIFO) is written in place, since it cannot be replaced.
pub fn write_atomic<T, F>(path: &Path, fill: F) -> Result<T>
where
    F: FnOnce(&mut dyn Write) -> Result<T>,
{
    let ctx = || format!("cannot write {}", path.display());
    if is_special(path) {
        let mut w = io::BufWriter::new(File::create(path).with_context(ctx)?);
        let value = fill(&mut w)?;
        w.flush().with_context(ctx)?;
        return Ok(value);
    }
    let dir = dir_of(path)?;
    let tmp = tempfile::Builder::new()
        .prefix(".thermcomp-")
        .suffix(".tmp")
        // As `File::create` would make it (0666 less the umask), not the
        // temporary file's private 0600.
        .permissions(std::fs::Permissions::from_mode(0o666))
        .tempfile_in(dir)
        .with_context(ctx)?;
    let mut w = io::BufWriter::new(tmp);
    let value = fill(&mut w)?;
    let tmp = w
        .into_inner()
        .map_err(|e| e.into_error())
        .with_context(ctx)?;
    tmp.as_file().sync_all().with_context(ctx)?;
    tmp.persist(path).map_err(|e| e.error).with_context(ctx)?;
    Ok(value)
}

/// [`write_atomic`] of a byte string.
pub fn write_bytes_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic(path, |w| {
        w.write_all(bytes)
            .with_context(|| format!("cannot write {}", path.display()))
    })
}

fn is_special(path: &Path) -> bool {
    std::fs::metadata(path).is_ok_and(|m| {
        let t = m.file_type();
        t.is_char_device() || t.is_block_device() || t.is_fifo() || t.is_socket()
    })
}

/// The reader of stdout went away (a closed pipe): not a failure of the
/// command. `main` ends quietly with status 0 on it, as a filter whose
/// reader has what it wanted (`thermcomp ... --json | head -c 300`) should.
#[derive(Debug)]
pub struct StdoutClosed;

impl fmt::Display for StdoutClosed {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("stdout was closed")
    }
}

impl std::error::Error for StdoutClosed {}

/// Prints `text` as is on stdout and flushes it. Errors: [`StdoutClosed`]
/// for a closed pipe, else a one-line "cannot write to stdout".
pub fn print(text: &str) -> Result<()> {
    let mut out = io::stdout().lock();
    out.write_all(text.as_bytes())
        .and_then(|()| out.flush())
        .map_err(stdout_error)
}

/// [`print`] followed by a newline.
pub fn print_line(text: &str) -> Result<()> {
    let mut out = io::stdout().lock();
    writeln!(out, "{text}")
        .and_then(|()| out.flush())
        .map_err(stdout_error)
}

fn stdout_error(e: io::Error) -> anyhow::Error {
    if e.kind() == io::ErrorKind::BrokenPipe {
        StdoutClosed.into()
    } else {
        anyhow::anyhow!("cannot write to stdout: {e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_file_through_another_name_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.csv");
        std::fs::write(&a, "x").unwrap();
        let via = dir.path().join(".").join("a.csv");
        let e = check_distinct(&[named("--data", &a)], &[named("--out", &via)]).unwrap_err();
        assert!(
            e.to_string().contains("refusing to overwrite an input"),
            "{e}"
        );
        let b = dir.path().join("b.csv");
        assert!(check_distinct(&[named("--data", &a)], &[named("--out", &b)]).is_ok());
        let e = check_distinct(&[], &[named("--a", &b), named("--b", &b)]).unwrap_err();
        assert!(e.to_string().contains("its own file"), "{e}");
    }

    #[test]
    fn atomic_output_has_the_mode_of_a_created_file() {
        let dir = tempfile::tempdir().unwrap();
        let (plain, atomic) = (dir.path().join("plain"), dir.path().join("atomic"));
        File::create(&plain).unwrap();
        write_bytes_atomic(&atomic, b"x").unwrap();
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode();
        assert_eq!(mode(&atomic), mode(&plain));
        assert_eq!(std::fs::read(&atomic).unwrap(), b"x");
    }

    #[test]
    fn failed_fill_leaves_the_old_file() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.bin");
        std::fs::write(&a, "old").unwrap();
        let r: Result<()> = write_atomic(&a, |w| {
            w.write_all(b"half")?;
            bail!("interrupted")
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read(&a).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }
}
