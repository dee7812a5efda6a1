//! The model inputs the CNC supplies over CAN (`can_rx`): which model input
//! each one feeds, how long a received value stays valid, and the tool
//! length's latch.
//!
//! # Which model input reads what
//!
//! | model input | source | valid |
//! |---|---|---|
//! | `speed_rpm` ([`SPEED_INPUT`]) | SPINDLE (0x201) speed | [`CncInputs::timeout_ms`] after the last frame carrying it |
//! | `power_kw` ([`POWER_INPUT`]) | SPINDLE (0x201) power | as speed |
//! | a positional output's position (`ValidModel::position_inputs`) | TOOL_POSITION (0x301) position | as speed |
//! | `tool_mm` (`pipeline::TOOL_INPUT`) | TOOL_POSITION (0x301) tool length, or the serial `SetToolLength` | latched: from the first value until the next, never stale by age |
//! | `T<k>` | RTD channel k (`rtd`) | every sample |
//!
//! # Staleness
//!
//! A value received at `t` (the receiving interrupt's millisecond clock) is
//! read as [`Reading::Direct`] by every sample at `t + age` with
//! `age <= timeout_ms`, and as [`Reading::Stale`] after that, or before
//! any value arrived. A frame whose signal is "not available" does not
//! refresh it. A stale input is handled by the pipeline exactly like a
//! faulty sensor: STALE flag, its bit in FaultyChannels, hold, ramp to zero
//! (`supervisor`). With 1 s samples and the default 5 s
//! (`board::CNC_INPUT_TIMEOUT_MS`), the last value received at sample
//! `k` is still used at samples `k+1 .. k+5` and the input is stale from
//! `k+6`.
//!
//! # Tool length
//!
//! The CNC sends it on every tool change (CONTRACT section 5), not
//! periodically, so it does not age: it is latched in the pipeline
//! (`Pipeline::set_tool_length_mm`, the same latch the serial
//! `SetToolLength` command sets, whichever came last wins) until the next
//! value, and `tool_mm` is stale only until the first one. A received tool
//! length waits here ([`CncInputs::take_tool_mm`]) until the sampling task
//! hands it to the pipeline at the next sample.
//!
//! # The position
//!
//! The pipeline feeds a positional output's position input the reference
//! position and sends the output's slope instead (see `pipeline`,
//! "Positional outputs"): the CNC multiplies it by its own, real-time
//! position, which a 1 Hz frame would lag. The position received here is
//! therefore not used by the offsets; it is gathered, timed out and
//! range-checked like the other inputs, ready for a model that needs it.

use embedded_can::Frame;

use crate::can_frames::DecodeError;
use crate::can_rx::{decode_rx, RxMessage};
use crate::hub::Hub;
use crate::offsets::MAX_INPUTS;
use crate::pipeline::{ChannelFault, Reading};

/// Model input name of the spindle speed (a run-file column, CONTRACT section 2).
pub const SPEED_INPUT: &str = "speed_rpm";
/// Model input name of the spindle power.
pub const POWER_INPUT: &str = "power_kw";

/// A periodic CNC signal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CncInput {
    /// Spindle speed, rpm.
    Speed,
    /// Spindle power, kW.
    Power,
    /// The axis position, mm.
    Position,
}

impl CncInput {
    /// The CNC signal that feeds a model input called `name`;
    /// `is_position`: the input is a positional output's position
    /// (`ValidModel::position_inputs`), whatever its name.
    pub fn for_input(name: &str, is_position: bool) -> Option<Self> {
        if is_position {
            Some(Self::Position)
        } else if name == SPEED_INPUT {
            Some(Self::Speed)
        } else if name == POWER_INPUT {
            Some(Self::Power)
        } else {
            None
        }
    }

    /// The largest magnitude a value of this input has on a machine tool;
    /// beyond it (the encoder's saturated code, a wrong scale on the CNC's
    /// side) the value is a sensor fault, not a reading: 200,000 rpm (the
    /// fastest micro-machining spindles run at 150,000), 300 kW (the DBC
    /// encodes up to 327.66), 100 m of travel.
    pub const fn limit(self) -> f64 {
        match self {
            Self::Speed => 200_000.0,
            Self::Power => 300.0,
            Self::Position => 100_000.0,
        }
    }

    const fn index(self) -> usize {
        match self {
            Self::Speed => 0,
            Self::Power => 1,
            Self::Position => 2,
        }
    }
}

/// A value and when it arrived (ms clock).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Stamped {
    value: f64,
    at_ms: u32,
}

/// The CNC's values as last received, with their arrival times.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CncInputs {
    timeout_ms: u32,
    values: [Option<Stamped>; 3],
    tool_mm: Option<f64>,
}

impl CncInputs {
    /// Nothing received yet; values stay valid `timeout_ms` after they arrive.
    pub const fn new(timeout_ms: u32) -> Self {
        Self {
            timeout_ms,
            values: [None; 3],
            tool_mm: None,
        }
    }

    /// How long a received value stays valid, ms.
    pub const fn timeout_ms(&self) -> u32 {
        self.timeout_ms
    }

    /// Stores what a decoded frame carries, received at `now_ms`.
    pub fn receive(&mut self, msg: &RxMessage, now_ms: u32) {
        let mut put = |input: CncInput, value: Option<f64>| {
            if let (Some(value), Some(slot)) = (value, self.values.get_mut(input.index())) {
                *slot = Some(Stamped {
                    value,
                    at_ms: now_ms,
                });
            }
        };
        match msg {
            RxMessage::Spindle(m) => {
                put(CncInput::Speed, m.speed_rpm);
                put(CncInput::Power, m.power_kw);
            }
            RxMessage::ToolPosition(m) => {
                put(CncInput::Position, m.position_mm);
                if m.tool_mm.is_some() {
                    self.tool_mm = m.tool_mm;
                }
            }
        }
    }

    /// Decodes a received frame ([`decode_rx`]) and stores it; a frame
    /// that is not the CNC's changes nothing.
    pub fn on_frame<F: Frame>(&mut self, frame: &F, now_ms: u32) -> Result<(), DecodeError> {
        let msg = decode_rx(frame)?;
        self.receive(&msg, now_ms);
        Ok(())
    }

    /// The tool length received since the last call, for
    /// `Pipeline::set_tool_length_mm` (which latches it).
    pub fn take_tool_mm(&mut self) -> Option<f64> {
        self.tool_mm.take()
    }

    /// `input` at `now_ms`: its last value if it arrived at most
    /// `timeout_ms` ago, else [`Reading::Stale`]; a value beyond the
    /// input's [`CncInput::limit`] is a fault ([`ChannelFault::OutOfRange`]:
    /// held, flagged, ramped as a failed sensor). Frames decode to finite
    /// values.
    pub fn reading(&self, input: CncInput, now_ms: u32) -> Reading {
        match self.values.get(input.index()).copied().flatten() {
            Some(s) if age_ms(now_ms, s.at_ms) <= self.timeout_ms => {
                if s.value.abs() <= input.limit() {
                    Reading::Direct(s.value)
                } else {
                    Reading::Fault(ChannelFault::OutOfRange)
                }
            }
            _ => Reading::Stale,
        }
    }

    /// Forgets values older than the timeout, so that a value far in the
    /// past cannot look recent when the millisecond clock wraps (49.7
    /// days); the sampling task calls it every sample.
    pub fn expire(&mut self, now_ms: u32) {
        for slot in &mut self.values {
            if slot.is_some_and(|s| age_ms(now_ms, s.at_ms) > self.timeout_ms) {
                *slot = None;
            }
        }
    }
}

/// How long ago `at_ms` was at `now_ms` on the wrapping millisecond
/// clock. A stamp up to half the clock's range *after* `now_ms` is 0 ms
/// old: the receive interrupt can stamp a frame between the sampling
/// task's clock read and its lock on the values, and such a frame is new,
/// not 49.7 days old.
fn age_ms(now_ms: u32, at_ms: u32) -> u32 {
    let age = now_ms.wrapping_sub(at_ms);
    if age > u32::MAX / 2 {
        0
    } else {
        age
    }
}

/// One sample's readings in `hub`'s model input order: `T<k>` from RTD
/// channel `k - 1` through `read_rtd` (`rtd::gather`), speed, power and a
/// positional output's position from `cnc` at `now_ms` (stale after the
/// timeout), anything else (and `tool_mm`, which the pipeline fills from
/// its latch) [`Reading::Stale`]. Also the temperatures read, for
/// telemetry (NaN where there is none).
pub fn gather(
    hub: &Hub,
    cnc: &CncInputs,
    now_ms: u32,
    read_rtd: impl FnMut(usize) -> Reading,
) -> ([Reading; MAX_INPUTS], [f64; MAX_INPUTS]) {
    let position = hub.model().map_or(0, |m| m.position_inputs());
    let names = hub
        .model()
        .into_iter()
        .flat_map(|m| m.inputs().iter().map(|c| c.name.as_str()));
    crate::rtd::gather(names, read_rtd, |j, name| {
        // j < MAX_INPUTS <= 32 (`rtd::gather` stops there).
        let is_position = j < 32 && position >> j & 1 != 0;
        CncInput::for_input(name, is_position).map_or(Reading::Stale, |i| cnc.reading(i, now_ms))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::can_frames::RawFrame;
    use crate::can_rx::{encode_spindle, encode_tool_position, Spindle, ToolPosition};
    use crate::pipeline::{Pipeline, PipelineConfig, TOOL_INPUT};
    use crate::report::{HubState, StatusFlags};
    use crate::test_util::{hub, name, vec};
    use model_core::linear::{Coef, Linear, LinearOutput};
    use model_core::{Channel, Model, Params, Reference, ValidModel};

    fn spindle(speed: Option<f64>, power: Option<f64>) -> RawFrame {
        encode_spindle(&Spindle {
            speed_rpm: speed,
            power_kw: power,
        })
        .unwrap()
    }

    fn tool(tool_mm: Option<f64>, position_mm: Option<f64>) -> RawFrame {
        encode_tool_position(&ToolPosition {
            tool_mm,
            position_mm,
        })
        .unwrap()
    }

    #[test]
    fn input_names_map_to_cnc_signals() {
        assert_eq!(
            CncInput::for_input("speed_rpm", false),
            Some(CncInput::Speed)
        );
        assert_eq!(
            CncInput::for_input("power_kw", false),
            Some(CncInput::Power)
        );
        assert_eq!(CncInput::for_input("y_mm", true), Some(CncInput::Position));
        assert_eq!(CncInput::for_input("y_mm", false), None);
        assert_eq!(CncInput::for_input(TOOL_INPUT, false), None, "latched");
        assert_eq!(CncInput::for_input("T1", false), None);
    }

    /// Valid through `timeout_ms` after arrival, stale after; a frame with
    /// the signal "not available" does not refresh it; stale before any.
    #[test]
    fn a_value_is_valid_for_the_timeout_then_stale() {
        let mut cnc = CncInputs::new(5_000);
        assert_eq!(cnc.reading(CncInput::Speed, 0), Reading::Stale);
        cnc.on_frame(&spindle(Some(8_000.0), Some(4.0)), 1_000)
            .unwrap();
        assert_eq!(
            cnc.reading(CncInput::Speed, 1_000),
            Reading::Direct(8_000.0)
        );
        assert_eq!(cnc.reading(CncInput::Power, 6_000), Reading::Direct(4.0));
        assert_eq!(cnc.reading(CncInput::Speed, 6_001), Reading::Stale);
        // Power not available from 3 s: speed refreshed, power ages.
        cnc.on_frame(&spindle(Some(9_000.0), None), 3_000).unwrap();
        assert_eq!(
            cnc.reading(CncInput::Speed, 8_000),
            Reading::Direct(9_000.0)
        );
        assert_eq!(cnc.reading(CncInput::Power, 6_001), Reading::Stale);
        assert_eq!(cnc.reading(CncInput::Position, 3_000), Reading::Stale);
        // 1 s samples: the last frame at sample k serves k+1..k+5.
        let fresh = (4..12)
            .filter(|s| cnc.reading(CncInput::Speed, s * 1_000) != Reading::Stale)
            .count();
        assert_eq!(fresh, 5, "samples 4..=8 s");
        // Other frames are refused and change nothing.
        let before = cnc;
        let f = RawFrame::new(embedded_can::StandardId::new(0x181).unwrap(), &[0; 8]).unwrap();
        assert_eq!(cnc.on_frame(&f, 3_500), Err(DecodeError::UnknownId));
        assert_eq!(cnc, before);
    }

    /// The encoder's saturated codes and other values no machine has are
    /// faults, not readings; the largest plausible ones pass.
    #[test]
    fn a_value_beyond_the_input_s_limit_is_a_fault() {
        let mut cnc = CncInputs::new(5_000);
        cnc.on_frame(&spindle(Some(21_474_836.46), Some(327.66)), 0)
            .unwrap();
        let fault = Reading::Fault(ChannelFault::OutOfRange);
        assert_eq!(cnc.reading(CncInput::Speed, 0), fault);
        assert_eq!(cnc.reading(CncInput::Power, 0), fault);
        cnc.on_frame(&spindle(Some(-200_000.0), Some(300.0)), 0)
            .unwrap();
        assert_eq!(cnc.reading(CncInput::Speed, 0), Reading::Direct(-200_000.0));
        assert_eq!(cnc.reading(CncInput::Power, 0), Reading::Direct(300.0));
        cnc.on_frame(&tool(None, Some(-100_000.5)), 0).unwrap();
        assert_eq!(cnc.reading(CncInput::Position, 0), fault);
    }

    /// A frame the receive interrupt stamped 1 ms after the clock the
    /// sampling task read (between its read and its lock) is fresh: it
    /// used to count as 2^32 - 1 ms old and be forgotten.
    #[test]
    fn a_frame_stamped_just_after_the_sample_s_clock_is_fresh() {
        let mut cnc = CncInputs::new(5_000);
        cnc.on_frame(&spindle(Some(7_000.0), None), 10_001).unwrap();
        cnc.expire(10_000);
        assert_eq!(
            cnc.reading(CncInput::Speed, 10_000),
            Reading::Direct(7_000.0)
        );
        assert_eq!(
            cnc.reading(CncInput::Speed, 15_001),
            Reading::Direct(7_000.0)
        );
        assert_eq!(cnc.reading(CncInput::Speed, 15_002), Reading::Stale);
    }

    #[test]
    fn expiry_survives_the_clock_wrapping() {
        let mut cnc = CncInputs::new(5_000);
        cnc.on_frame(&tool(None, Some(250.0)), u32::MAX - 1_000)
            .unwrap();
        assert_eq!(
            cnc.reading(CncInput::Position, 3_000),
            Reading::Direct(250.0)
        );
        cnc.expire(3_000);
        assert_eq!(
            cnc.reading(CncInput::Position, 3_000),
            Reading::Direct(250.0)
        );
        cnc.expire(4_000);
        assert_eq!(cnc.reading(CncInput::Position, 4_000), Reading::Stale);
        // 2^32 ms later it would look fresh again had it not been expired.
        assert_eq!(
            cnc.reading(CncInput::Position, u32::MAX - 1_000),
            Reading::Stale
        );
    }

    /// dz_um = 10 * (T1 - 20) + 0.001 * speed_rpm + 2 * tool_mm.
    fn model() -> ValidModel {
        let ch = |n: &str, reference| Channel {
            name: name(n),
            reference,
        };
        Model {
            inputs: vec(&[
                ch("T1", Reference::Value(20.0)),
                ch(SPEED_INPUT, Reference::Absolute),
                ch(TOOL_INPUT, Reference::Absolute),
            ]),
            outputs: vec(&[name("dz_um")]),
            dt_s: 0.0,
            params: Params::Linear(Linear {
                outputs: vec(&[LinearOutput {
                    output: 0,
                    intercept: 0.0,
                    coef: vec(&[
                        Coef {
                            channel: 0,
                            value: 10.0,
                        },
                        Coef {
                            channel: 1,
                            value: 0.001,
                        },
                        Coef {
                            channel: 2,
                            value: 2.0,
                        },
                    ]),
                    position: None,
                }]),
            }),
            bounds: None,
            five_point: None,
        }
        .validate()
        .unwrap()
    }

    /// One board sample: the tool length received goes to the pipeline's
    /// latch, the readings are gathered, the pipeline runs.
    fn sample(p: &mut Pipeline, cnc: &mut CncInputs, now_ms: u32) -> crate::report::Report {
        if let Some(mm) = cnc.take_tool_mm() {
            p.set_tool_length_mm(mm).unwrap();
        }
        cnc.expire(now_ms);
        let (r, t) = gather(p.hub(), cnc, now_ms, |k| {
            assert_eq!(k, 0);
            Reading::Value(20.0)
        });
        assert_eq!(t[0], 20.0);
        p.on_sample(&r[..3])
    }

    /// Tool length: stale before the first frame, then latched for good
    /// (no timeout); the next frame or the serial command replaces it.
    /// Speed: follows the frames; the faulty-channel bit names it once
    /// stale; hold then ramp as for a failed sensor.
    #[test]
    fn tool_latches_speed_times_out_and_the_pipeline_holds() {
        let mut p = Pipeline::new(hub(&model()), PipelineConfig::DEFAULT).unwrap();
        let mut cnc = CncInputs::new(5_000);
        cnc.on_frame(&spindle(Some(1_000.0), None), 0).unwrap();
        let r = sample(&mut p, &mut cnc, 0);
        assert_eq!(r.faulty_channels, 0b100, "no tool length yet");
        assert!(r.flags.has(StatusFlags::STALE));

        cnc.on_frame(&tool(Some(0.5), None), 500).unwrap();
        // 1 + 1 = 2 um: within one slew step.
        for s in 1..=3u32 {
            cnc.on_frame(&spindle(Some(1_000.0), None), s * 1_000)
                .unwrap();
            let r = sample(&mut p, &mut cnc, s * 1_000);
            assert_eq!((r.state, r.faulty_channels), (HubState::Running, 0));
            assert!((r.offsets[0] - 2.0).abs() < 1e-9, "{r:?}");
        }
        assert_eq!(p.tool_length_mm(), Some(0.5));
        // The serial command sets the same latch; a later frame replaces it.
        p.set_tool_length_mm(0.75).unwrap();
        let r = sample(&mut p, &mut cnc, 4_000);
        assert!((r.offsets[0] - 2.5).abs() < 1e-9, "{r:?}");
        // Speed frames stop after 3 s: used through 8 s, stale from 9 s.
        for s in 5..=8u32 {
            let r = sample(&mut p, &mut cnc, s * 1_000);
            assert_eq!(r.state, HubState::Running, "{s}");
        }
        let hold = p.config().supervisor.hold_time_s as u32;
        for s in 9..9 + hold {
            let r = sample(&mut p, &mut cnc, s * 1_000);
            assert_eq!(r.state, HubState::Holding, "{s}");
            assert_eq!(r.faulty_channels, 0b010, "speed_rpm is input 1");
            assert!(r.flags.has(StatusFlags::STALE));
            assert!((r.offsets[0] - 2.5).abs() < 1e-9);
        }
        let r = sample(&mut p, &mut cnc, (9 + hold) * 1_000);
        assert_eq!(r.state, HubState::Ramping);
        // The tool length never aged: hours later it still holds.
        assert_eq!(p.tool_length_mm(), Some(0.75));
        cnc.on_frame(&tool(Some(100.0), None), 7_200_000).unwrap();
        sample(&mut p, &mut cnc, 7_200_000);
        assert_eq!(p.tool_length_mm(), Some(100.0));
        // A frame without a tool length leaves the latch alone.
        cnc.on_frame(&tool(None, Some(5.0)), 7_201_000).unwrap();
        assert_eq!(cnc.take_tool_mm(), None);
    }

    #[test]
    fn gather_feeds_the_position_input_from_the_position_signal() {
        let mut cnc = CncInputs::new(5_000);
        cnc.on_frame(&tool(Some(10.0), Some(321.5)), 0).unwrap();
        cnc.on_frame(&spindle(Some(500.0), Some(1.25)), 0).unwrap();
        let h = hub(&model());
        let (r, _) = gather(&h, &cnc, 100, |_| Reading::Value(21.0));
        assert_eq!(
            r[..3],
            [Reading::Value(21.0), Reading::Direct(500.0), Reading::Stale]
        );
        assert_eq!(cnc.reading(CncInput::Position, 100), Reading::Direct(321.5));
    }
}
