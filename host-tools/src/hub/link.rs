//! The byte pipe under the protocol: a serial port on the bench, a
//! pseudo-terminal or an in-memory script in tests.

use std::io::{self, Read, Write};
use std::time::Duration;

/// A byte link to the hub with a read timeout.
///
/// `read` waits at most the read timeout for the first byte and returns
/// `Ok(0)` if none came (unlike a file, `Ok(0)` is "nothing yet", not end of
/// file); the session above loops until its own deadline. `write` sends
/// every byte or fails.
pub trait Link: Read + Write {
    /// Sets how long one `read` waits for the first byte.
    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()>;
}
