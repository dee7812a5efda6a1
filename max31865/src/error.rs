//! The driver's error type.

use core::fmt;

use crate::FaultStatus;

/// Everything a driver call can fail with. `E` is the SPI device's error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Error<E> {
    /// The SPI transfer itself failed.
    Spi(E),
    /// The RTD LSB register's fault bit (D0) was set; this is the Fault
    /// Status register read right after it. Faults stay latched (and every
    /// further reading reports them) until
    /// [`crate::Max31865::clear_fault`].
    Fault(FaultStatus),
    /// A register read back different from what was written: no chip (MISO
    /// stuck at 0x00 or 0xFF), a wiring or SPI-mode fault, or a chip that
    /// reset. `read` is the raw byte; compared bits are documented on
    /// [`crate::Max31865::verify_config`].
    ConfigMismatch {
        /// Register address (read address, 00h..06h).
        register: u8,
        /// Byte the driver wrote.
        wrote: u8,
        /// Byte read back.
        read: u8,
    },
    /// The call needs the other conversion mode (e.g. a 1-shot start while
    /// the chip converts continuously in [`crate::Mode::Auto`]).
    WrongMode,
    /// The fault-detection cycle did not report completion (D3..D2 back to
    /// 00) within the polling budget.
    Timeout,
}

impl<E> From<E> for Error<E> {
    fn from(e: E) -> Self {
        Self::Spi(e)
    }
}

impl<E: fmt::Debug> fmt::Display for Error<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Spi(e) => write!(f, "MAX31865: SPI error: {e:?}"),
            Self::Fault(status) => write!(f, "MAX31865: RTD fault: {status}"),
            Self::ConfigMismatch {
                register,
                wrote,
                read,
            } => write!(
                f,
                "MAX31865: register {register:#04x} wrote {wrote:#04x}, read back {read:#04x} (chip missing or not responding?)"
            ),
            Self::WrongMode => f.write_str("MAX31865: operation not valid in the configured conversion mode"),
            Self::Timeout => f.write_str("MAX31865: fault-detection cycle did not complete"),
        }
    }
}

impl<E: fmt::Debug> core::error::Error for Error<E> {}

#[cfg(feature = "defmt")]
impl<E: defmt::Format> defmt::Format for Error<E> {
    fn format(&self, f: defmt::Formatter<'_>) {
        match self {
            Self::Spi(e) => defmt::write!(f, "MAX31865: SPI error: {}", e),
            Self::Fault(status) => defmt::write!(f, "MAX31865: RTD fault: {}", status),
            Self::ConfigMismatch {
                register,
                wrote,
                read,
            } => defmt::write!(
                f,
                "MAX31865: register {=u8:#04x} wrote {=u8:#04x}, read back {=u8:#04x}",
                register,
                wrote,
                read
            ),
            Self::WrongMode => defmt::write!(f, "MAX31865: wrong conversion mode"),
            Self::Timeout => defmt::write!(f, "MAX31865: fault-detection cycle timeout"),
        }
    }
}
