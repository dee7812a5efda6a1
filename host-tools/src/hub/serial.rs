//! A serial port as a [`Link`]: the tty opened with std file I/O and set raw
//! (8N1, no flow control, no echo, no line editing) with termios.
//!
//! Reads use the termios timer (`VMIN = 0`, `VTIME` in tenths of a second):
//! a `read` returns as soon as a byte is there, or with 0 bytes after the
//! timeout. The port is opened `O_NONBLOCK` (so `open` never waits for a
//! carrier), `CLOCAL` is set, then `O_NONBLOCK` is cleared again so the timer
//! applies. Linux and other Unixes; no libudev.

use std::fs::{File, OpenOptions};
use std::io::{self, Read, Write};
use std::os::unix::fs::OpenOptionsExt;
use std::path::Path;
use std::time::Duration;

use anyhow::{anyhow, Context, Result};
use nix::errno::Errno;
use nix::fcntl::{fcntl, FcntlArg, OFlag};
use nix::sys::termios::{
    cfmakeraw, cfsetspeed, tcflush, tcgetattr, tcsetattr, BaudRate, ControlFlags, FlushArg,
    InputFlags, SetArg, SpecialCharacterIndices, Termios,
};

use super::link::Link;

/// A raw serial port.
#[derive(Debug)]
pub struct SerialLink {
    file: File,
    termios: Termios,
}

/// The termios constant for a baud rate (the standard rates only).
fn baud_rate(baud: u32) -> Option<BaudRate> {
    Some(match baud {
        9600 => BaudRate::B9600,
        19200 => BaudRate::B19200,
        38400 => BaudRate::B38400,
        57600 => BaudRate::B57600,
        115200 => BaudRate::B115200,
        230400 => BaudRate::B230400,
        460800 => BaudRate::B460800,
        921600 => BaudRate::B921600,
        _ => return None,
    })
}

/// `VTIME` for a timeout: tenths of a second, 0.1 to 25.5 s.
fn vtime(timeout: Duration) -> u8 {
    let ds = timeout.as_millis().div_ceil(100);
    u8::try_from(ds.clamp(1, 255)).unwrap_or(u8::MAX)
}

impl SerialLink {
    /// Opens `path` raw at `baud` (8N1) and drops any bytes already waiting.
    pub fn open(path: &Path, baud: u32) -> Result<Self> {
        let speed = baud_rate(baud).ok_or_else(|| {
            anyhow!("unsupported baud rate {baud} (use 9600, 19200, 38400, 57600, 115200, 230400, 460800 or 921600)")
        })?;
        let file = OpenOptions::new()
            .read(true)
            .write(true)
            .custom_flags((OFlag::O_NOCTTY | OFlag::O_NONBLOCK).bits())
            .open(path)
            .map_err(|e| {
                let hint = if e.kind() == io::ErrorKind::PermissionDenied {
                    " (is your user in the dialout group?)"
                } else {
                    ""
                };
                anyhow!("cannot open {}: {e}{hint}", path.display())
            })?;
        let what = || format!("cannot configure {}", path.display());
        let mut t = tcgetattr(&file).map_err(|e| match e {
            Errno::ENOTTY => anyhow!("{} is not a serial port", path.display()),
            e => anyhow!("{}: {e}", what()),
        })?;
        cfmakeraw(&mut t);
        t.control_flags |= ControlFlags::CLOCAL | ControlFlags::CREAD | ControlFlags::CS8;
        t.control_flags &= !(ControlFlags::CSTOPB | ControlFlags::PARENB | ControlFlags::CRTSCTS);
        t.input_flags &= !(InputFlags::IXON | InputFlags::IXOFF | InputFlags::IXANY);
        t.control_chars[SpecialCharacterIndices::VMIN as usize] = 0;
        t.control_chars[SpecialCharacterIndices::VTIME as usize] = 1;
        cfsetspeed(&mut t, speed).with_context(what)?;
        tcsetattr(&file, SetArg::TCSANOW, &t).with_context(what)?;
        fcntl(&file, FcntlArg::F_SETFL(OFlag::empty())).with_context(what)?;
        tcflush(&file, FlushArg::TCIOFLUSH).with_context(what)?;
        Ok(Self { file, termios: t })
    }
}

impl Read for SerialLink {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        self.file.read(buf)
    }
}

impl Write for SerialLink {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.file.write(buf)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.file.flush()
    }
}

impl Link for SerialLink {
    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()> {
        self.termios.control_chars[SpecialCharacterIndices::VTIME as usize] = vtime(timeout);
        tcsetattr(&self.file, SetArg::TCSANOW, &self.termios).map_err(io::Error::from)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vtime_rounds_up_and_clamps() {
        assert_eq!(vtime(Duration::ZERO), 1);
        assert_eq!(vtime(Duration::from_millis(100)), 1);
        assert_eq!(vtime(Duration::from_millis(101)), 2);
        assert_eq!(vtime(Duration::from_secs(60)), 255);
    }

    #[test]
    fn standard_baud_rates_only() {
        assert_eq!(baud_rate(115200), Some(BaudRate::B115200));
        assert_eq!(baud_rate(115201), None);
    }

    #[test]
    fn a_regular_file_is_not_a_serial_port() {
        let f = std::env::temp_dir().join(format!("thermcomp-not-a-tty-{}", std::process::id()));
        std::fs::write(&f, b"x").unwrap();
        let e = SerialLink::open(&f, 115200).unwrap_err().to_string();
        std::fs::remove_file(&f).unwrap();
        assert!(e.contains("is not a serial port"), "{e}");
    }
}
