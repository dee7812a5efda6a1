//! What the sample pipeline hands to the emitters (CAN, serial) after every
//! sample: the offsets that go to the CNC, the hub's state and why.
//!
//! The pipeline (`pipeline`) produces a [`Report`]; the frame encoders
//! (`can_frames`, `protocol`) only read it. Offsets in a report are final:
//! spike-filtered inputs, model, fault handling, slew limit and clamp have
//! all been applied, and every value is finite.

use crate::offsets::MAX_OUTPUTS;

/// The hub's compensation state, as the status frame carries it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(u8)]
pub enum HubState {
    /// No valid model in flash: offsets are zero.
    #[default]
    NoModel = 0,
    /// Every input good, offsets follow the model (through the slew limit).
    Running = 1,
    /// A fault: the last good offsets are held (for up to the hold time).
    Holding = 2,
    /// The fault outlasted the hold time: offsets ramp towards zero.
    Ramping = 3,
    /// Offsets have reached zero after a lasting fault.
    Zeroed = 4,
}

impl HubState {
    /// The state's code on the wire.
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The state for a wire code.
    pub const fn from_code(code: u8) -> Option<Self> {
        Some(match code {
            0 => Self::NoModel,
            1 => Self::Running,
            2 => Self::Holding,
            3 => Self::Ramping,
            4 => Self::Zeroed,
            _ => return None,
        })
    }
}

/// Why the offsets are not simply the model's output: one bit per cause,
/// several may be set. The bit positions are part of the wire format (DBC).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StatusFlags(pub u16);

impl StatusFlags {
    /// An RTD channel reported a fault (open, short, out of range, bus error).
    pub const SENSOR_FAULT: u16 = 1 << 0;
    /// A reading was rejected as a spike this sample.
    pub const SPIKE_REJECTED: u16 = 1 << 1;
    /// No fresh reading arrived in time for this sample.
    pub const STALE: u16 = 1 << 2;
    /// The model refused the sample or produced a non-finite output.
    pub const MODEL_FAULT: u16 = 1 << 3;
    /// An offset hit the clamp.
    pub const CLAMPED: u16 = 1 << 4;
    /// An offset was held back by the slew limit.
    pub const SLEW_LIMITED: u16 = 1 << 5;
    /// No valid model is loaded.
    pub const NO_MODEL: u16 = 1 << 6;
    /// A model upload is in progress.
    pub const UPLOADING: u16 = 1 << 7;
    /// A failed input reads good again but has not yet done so for the
    /// recovery time: the offsets stay at (or keep ramping to) zero.
    pub const RECOVERING: u16 = 1 << 8;
    /// The model is evaluated outside the envelope it was fitted on
    /// (inputs beyond their calibrated range): its offsets are
    /// extrapolated. Set by the hub after each good step when an input lies
    /// more than `EXTRAPOLATION_FLAG_AT` of its calibration range outside the
    /// model's envelope (models with bounds: `fit --model auto`).
    pub const EXTRAPOLATING: u16 = 1 << 9;
    /// A temperature on the RTD curve but outside the plausibility window
    /// (default -20..=120 C) was refused (`plausible`).
    pub const IMPLAUSIBLE: u16 = 1 << 10;
    /// A temperature changed faster than a machine can (default 6 K within
    /// 60 s) and is faulty until a window passes without that.
    pub const RATE_OF_CHANGE: u16 = 1 << 11;
    /// A temperature has not changed by one code for the stuck time
    /// (default 1800 s) while another temperature moved by 1 K or more.
    pub const STUCK: u16 = 1 << 12;

    /// Whether every bit of `mask` is set.
    pub const fn has(self, mask: u16) -> bool {
        self.0 & mask == mask
    }

    /// Sets the bits of `mask`.
    pub fn set(&mut self, mask: u16) {
        self.0 |= mask;
    }
}

/// One sample's result.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Report {
    /// Sample counter (wraps).
    pub seq: u32,
    /// Offsets in the model's output order, in the output's unit (um);
    /// entries past `n_outputs` are zero. Final (limited, clamped) and finite.
    pub offsets: [f64; MAX_OUTPUTS],
    /// Thermal slope of each positional output, um/m (zero for the
    /// others), limited like the offsets (see `pipeline`); finite.
    pub slopes_um_per_m: [f64; MAX_OUTPUTS],
    /// Bit `j` set: output `j` is positional (its offset is the value at
    /// the reference position 0 mm; the CNC adds slope x position).
    pub positional: u8,
    /// How many entries of `offsets` are model outputs.
    pub n_outputs: u8,
    /// The compensation state.
    pub state: HubState,
    /// Why the offsets differ from the model's raw output.
    pub flags: StatusFlags,
    /// Bit `i` set: input channel `i` is faulty this sample.
    pub faulty_channels: u32,
}
