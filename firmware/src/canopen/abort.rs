//! SDO abort codes (CiA 301 §7.2.4.3.17, table 22): the one answer both
//! the dictionary (an entry refusing a write) and the SDO server (a
//! protocol error) give, so it sits apart from either.

use core::fmt;

/// SDO abort codes (CiA 301 §7.2.4.3.17, table 22) the server sends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum SdoAbort {
    /// 0x0503_0000: toggle bit not alternated.
    Toggle,
    /// 0x0504_0001: client/server command specifier not valid or unknown.
    Command,
    /// 0x0601_0002: attempt to write a read-only object.
    ReadOnly,
    /// 0x0602_0000: object does not exist in the object dictionary.
    NoObject,
    /// 0x0604_0043: general parameter incompatibility (a check across entries).
    Incompatible,
    /// 0x0607_0010: data type does not match, length of service parameter does not match.
    Length,
    /// 0x0607_0012: length of service parameter too high.
    LengthTooHigh,
    /// 0x0607_0013: length of service parameter too low.
    LengthTooLow,
    /// 0x0609_0011: subindex does not exist.
    NoSubindex,
    /// 0x0609_0030: invalid value for parameter (download only).
    InvalidValue,
    /// 0x0609_0031: value of parameter written too high.
    ValueTooHigh,
    /// 0x0609_0032: value of parameter written too low.
    ValueTooLow,
    /// 0x0800_0000: general error.
    General,
    /// 0x0800_0020: data cannot be transferred or stored to the application.
    CannotStore,
    /// 0x0800_0022: ... because of the present device state.
    DeviceState,
}

impl SdoAbort {
    /// The abort code on the wire.
    pub const fn code(self) -> u32 {
        match self {
            Self::Toggle => 0x0503_0000,
            Self::Command => 0x0504_0001,
            Self::ReadOnly => 0x0601_0002,
            Self::NoObject => 0x0602_0000,
            Self::Incompatible => 0x0604_0043,
            Self::Length => 0x0607_0010,
            Self::LengthTooHigh => 0x0607_0012,
            Self::LengthTooLow => 0x0607_0013,
            Self::NoSubindex => 0x0609_0011,
            Self::InvalidValue => 0x0609_0030,
            Self::ValueTooHigh => 0x0609_0031,
            Self::ValueTooLow => 0x0609_0032,
            Self::General => 0x0800_0000,
            Self::CannotStore => 0x0800_0020,
            Self::DeviceState => 0x0800_0022,
        }
    }
}

impl fmt::Display for SdoAbort {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let what = match self {
            Self::Toggle => "toggle bit not alternated",
            Self::Command => "command specifier not valid or unknown",
            Self::ReadOnly => "attempt to write a read-only object",
            Self::NoObject => "object does not exist",
            Self::Incompatible => "general parameter incompatibility",
            Self::Length => "length does not match",
            Self::LengthTooHigh => "length too high",
            Self::LengthTooLow => "length too low",
            Self::NoSubindex => "subindex does not exist",
            Self::InvalidValue => "invalid value",
            Self::ValueTooHigh => "value too high",
            Self::ValueTooLow => "value too low",
            Self::General => "general error",
            Self::CannotStore => "data cannot be stored",
            Self::DeviceState => "not in the present device state",
        };
        write!(f, "SDO abort 0x{:08X}: {what}", self.code())
    }
}

impl core::error::Error for SdoAbort {}
