//! The work of one hub sample, in the pieces the bench times.
//!
//! 1. [`Sample::temperatures`]: 16 raw MAX31865 codes to temperatures
//!    (`RtdChannel::MAX31865_PT100.temperature_c`: ratiometric resistance,
//!    fault classification, inverse Callendar-Van Dusen).
//! 2. `ValidModel::step` on those temperatures.
//! 3. [`encode_frame`]: a stand-in for the frame encoder (the outputs as
//!    f32 plus a status byte, postcard-serialised into a buffer). The
//!    firmware's `can_frames` encoders are not timed here (the firmware
//!    library is linked since the `stack` binary needs it; this stand-in
//!    keeps the figures comparable with the earlier rounds').

use crate::models::{CHANNELS, OUTPUTS};
use model_core::rtd::{Rtd, RtdChannel, RtdCode};
use serde::Serialize;

/// The offsets frame the hub sends per sample (stand-in): three axis
/// offsets, the hottest channel, and flags.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Frame {
    /// X offset, um.
    pub dx_um: f32,
    /// Y offset, um.
    pub dy_um: f32,
    /// Z offset, um.
    pub dz_um: f32,
    /// Hottest channel, C.
    pub t_max_c: f32,
    /// Bit 0: model ran; bit 1: a channel faulted; bit 2: step refused.
    pub flags: u8,
}

/// Room for a frame: 4 f32 (4 bytes each in postcard) and a varint u8 (1-2).
pub const FRAME_BUF: usize = 32;

/// Raw codes of one sample and where the temperatures go.
pub struct Sample {
    /// One MAX31865 code per channel.
    pub codes: [RtdCode; CHANNELS],
}

impl Sample {
    /// Codes for a warm machine: 22.0 C on channel 0 rising by 0.7 C per
    /// channel (all above 0 C, where the inverse CVD is closed-form),
    /// plus `offset_c`.
    pub fn warm(offset_c: f64) -> Self {
        let ch = RtdChannel::MAX31865_PT100;
        let mut codes = [RtdCode(0); CHANNELS];
        for (i, c) in codes.iter_mut().enumerate() {
            let t = 22.0 + 0.7 * i as f64 + offset_c;
            let r = Rtd::PT100.resistance_ohm(t).unwrap_or(100.0);
            *c = ch.adc.code_for_resistance(r).unwrap_or(RtdCode(0));
        }
        Self { codes }
    }

    /// Step 1: codes to temperatures; returns whether any channel faulted
    /// (a faulted channel reads NaN, which `step` then refuses).
    #[inline(never)]
    pub fn temperatures(&self, t_c: &mut [f64; CHANNELS]) -> bool {
        let ch = RtdChannel::MAX31865_PT100;
        let mut fault = false;
        for (t, code) in t_c.iter_mut().zip(&self.codes) {
            *t = match ch.temperature_c(*code) {
                Ok(v) => v,
                Err(_) => {
                    fault = true;
                    f64::NAN
                }
            };
        }
        fault
    }
}

/// Step 3: the outputs and status into a frame, serialised; returns its
/// length in bytes (0 if the buffer were too small, which it is not).
#[inline(never)]
pub fn encode_frame(
    out: &[f64; OUTPUTS],
    t_c: &[f64; CHANNELS],
    flags: u8,
    buf: &mut [u8; FRAME_BUF],
) -> usize {
    let t_max_c = t_c.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let frame = Frame {
        dx_um: out[0] as f32,
        dy_um: out[1] as f32,
        dz_um: out[2] as f32,
        t_max_c: t_max_c as f32,
        flags,
    };
    postcard::to_slice(&frame, buf).map_or(0, |b| b.len())
}
