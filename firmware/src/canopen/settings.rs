//! The settings a PLC may change over SDO (objects 0x1017 and
//! 0x2000-0x2008), as one value: read from the dictionary when 0x1010
//! "save" stores them, written back into it at boot.
//!
//! Settings that shape the pipeline (clamp, slew, hold, ramp, recovery,
//! plausibility window), the node id and the CNC timeout take effect at the
//! next reset (NMT reset node or power cycle) after they were stored: the
//! pipeline is validated once, at boot, and never changes under a running
//! sample (STYLE habit 4). The heartbeat time acts at once (CiA 301
//! §7.5.2.31). A PLC therefore writes, saves (0x1010:01 = "save") and
//! resets the node.
//!
//! Every value is checked by the dictionary entry it comes from (range,
//! `od::Limit`) and across entries by [`cross_check`]; [`Settings::to_od`]
//! runs the same checks on settings read back from flash, so a record that
//! decodes but no longer validates falls back to the defaults.

use super::abort::SdoAbort;
use super::od::{self, Dictionary, OBJECTS};

/// Every stored setting.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// Clamp per output, um (0x2000:1..4).
    pub clamp_um: [f32; 4],
    /// Slew limit per output, um/s (0x2001:1..4).
    pub slew_um_per_s: [f32; 4],
    /// Hold time, s (0x2002).
    pub hold_time_s: f32,
    /// Ramp-to-zero rate, um/s (0x2003).
    pub ramp_um_per_s: f32,
    /// Recovery time, s (0x2004).
    pub recover_time_s: f32,
    /// Plausible temperatures, deg C (0x2005:1, 0x2005:2).
    pub plausible_c: [f32; 2],
    /// Node id, 1..=127 (0x2006).
    pub node_id: u8,
    /// CNC input timeout, ms (0x2007).
    pub cnc_timeout_ms: u32,
    /// Start operational without an NMT master (0x2008).
    pub auto_start: bool,
    /// Producer heartbeat time, ms (0x1017).
    pub heartbeat_ms: u16,
}

/// Bytes of [`Settings::encode`].
pub const ENCODED_LEN: usize = 60;

impl Settings {
    /// The dictionary's defaults (a test checks they agree with `od`).
    pub const DEFAULT: Self = Self {
        clamp_um: [500.0; 4],
        slew_um_per_s: [2.0; 4],
        hold_time_s: 60.0,
        ramp_um_per_s: 1.0,
        recover_time_s: 10.0,
        plausible_c: [-20.0, 120.0],
        node_id: 1,
        cnc_timeout_ms: crate::board::CNC_INPUT_TIMEOUT_MS,
        auto_start: true,
        heartbeat_ms: 1000,
    };

    /// The settings the dictionary holds now.
    pub fn from_od(od: &Dictionary) -> Self {
        let arr = |index| core::array::from_fn(|i| od.get_f32(index, i as u8 + 1));
        Self {
            clamp_um: arr(od::CLAMP),
            slew_um_per_s: arr(od::SLEW),
            hold_time_s: od.get_f32(od::HOLD_TIME, 0),
            ramp_um_per_s: od.get_f32(od::RAMP_RATE, 0),
            recover_time_s: od.get_f32(od::RECOVER_TIME, 0),
            plausible_c: [od.get_f32(od::PLAUSIBLE, 1), od.get_f32(od::PLAUSIBLE, 2)],
            node_id: od.get(od::NODE_ID, 0) as u8,
            cnc_timeout_ms: od.get(od::CNC_TIMEOUT, 0),
            auto_start: od.get(od::AUTO_START, 0) != 0,
            heartbeat_ms: od.get(od::HEARTBEAT_TIME, 0) as u16,
        }
    }

    /// A dictionary holding these settings (COB-IDs for their node id),
    /// after every check an SDO download of them would pass.
    pub fn to_od(&self) -> Result<Dictionary, SdoAbort> {
        if !(1..=127).contains(&self.node_id) {
            return Err(SdoAbort::InvalidValue);
        }
        let mut d = Dictionary::new(self.node_id);
        let mut put = |index: u16, sub: u8, bytes: &[u8]| -> Result<(), SdoAbort> {
            let pos = od::find(index, sub)?;
            let raw = d.check_write(pos, bytes)?;
            d.store(pos, raw);
            Ok(())
        };
        for (i, (c, s)) in self.clamp_um.iter().zip(&self.slew_um_per_s).enumerate() {
            put(od::CLAMP, i as u8 + 1, &c.to_le_bytes())?;
            put(od::SLEW, i as u8 + 1, &s.to_le_bytes())?;
        }
        put(od::HOLD_TIME, 0, &self.hold_time_s.to_le_bytes())?;
        put(od::RAMP_RATE, 0, &self.ramp_um_per_s.to_le_bytes())?;
        put(od::RECOVER_TIME, 0, &self.recover_time_s.to_le_bytes())?;
        put(od::PLAUSIBLE, 1, &self.plausible_c[0].to_le_bytes())?;
        put(od::PLAUSIBLE, 2, &self.plausible_c[1].to_le_bytes())?;
        put(od::NODE_ID, 0, &[self.node_id])?;
        put(od::CNC_TIMEOUT, 0, &self.cnc_timeout_ms.to_le_bytes())?;
        put(od::AUTO_START, 0, &[u8::from(self.auto_start)])?;
        put(od::HEARTBEAT_TIME, 0, &self.heartbeat_ms.to_le_bytes())?;
        cross_check(&d)?;
        Ok(d)
    }

    /// Fixed little-endian layout: clamp x4, slew x4, hold, ramp, recovery,
    /// plausible min, max (f32 each, 52 bytes), node id (u8), auto start
    /// (u8), heartbeat (u16), CNC timeout (u32).
    pub fn encode(&self) -> [u8; ENCODED_LEN] {
        let mut out = [0u8; ENCODED_LEN];
        let scalars = [
            self.hold_time_s,
            self.ramp_um_per_s,
            self.recover_time_s,
            self.plausible_c[0],
            self.plausible_c[1],
        ];
        let floats = self
            .clamp_um
            .iter()
            .chain(&self.slew_um_per_s)
            .chain(&scalars);
        for (dst, v) in out.chunks_exact_mut(4).zip(floats) {
            dst.copy_from_slice(&v.to_le_bytes());
        }
        out[52] = self.node_id;
        out[53] = u8::from(self.auto_start);
        out[54..56].copy_from_slice(&self.heartbeat_ms.to_le_bytes());
        out[56..60].copy_from_slice(&self.cnc_timeout_ms.to_le_bytes());
        out
    }

    /// The inverse of [`Settings::encode`] (no range check: see
    /// [`Settings::to_od`]).
    pub fn decode(b: &[u8; ENCODED_LEN]) -> Self {
        let f = |i: usize| f32::from_le_bytes([b[4 * i], b[4 * i + 1], b[4 * i + 2], b[4 * i + 3]]);
        Self {
            clamp_um: [f(0), f(1), f(2), f(3)],
            slew_um_per_s: [f(4), f(5), f(6), f(7)],
            hold_time_s: f(8),
            ramp_um_per_s: f(9),
            recover_time_s: f(10),
            plausible_c: [f(11), f(12)],
            node_id: b[52],
            auto_start: b[53] != 0,
            heartbeat_ms: u16::from_le_bytes([b[54], b[55]]),
            cnc_timeout_ms: u32::from_le_bytes([b[56], b[57], b[58], b[59]]),
        }
    }

    /// The pipeline settings with these clamps, slew limits, hold, ramp,
    /// recovery and plausibility window over `base` (everything else).
    #[cfg(feature = "model")]
    pub fn pipeline_config(
        &self,
        base: crate::pipeline::PipelineConfig,
    ) -> crate::pipeline::PipelineConfig {
        let mut c = base;
        for (i, (clamp, slew)) in self.clamp_um.iter().zip(&self.slew_um_per_s).enumerate() {
            if let Some(v) = c.limiter.clamp_um.get_mut(i) {
                *v = f64::from(*clamp);
            }
            if let Some(v) = c.limiter.slew_um_per_s.get_mut(i) {
                *v = f64::from(*slew);
            }
        }
        c.supervisor.hold_time_s = f64::from(self.hold_time_s);
        c.supervisor.ramp_um_per_s = f64::from(self.ramp_um_per_s);
        c.supervisor.recover_time_s = f64::from(self.recover_time_s);
        c.plausible.min_c = f64::from(self.plausible_c[0]);
        c.plausible.max_c = f64::from(self.plausible_c[1]);
        c
    }
}

impl Default for Settings {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Checks across entries (abort 0x0604_0043, general parameter
/// incompatibility): the ramp to zero no faster than any output's slew
/// limit (`PipelineConfig::validate` refuses it too), plausible minimum
/// below maximum.
pub fn cross_check(od: &Dictionary) -> Result<(), SdoAbort> {
    let ramp = od.get_f32(od::RAMP_RATE, 0);
    if (1..=4).any(|sub| ramp > od.get_f32(od::SLEW, sub)) {
        return Err(SdoAbort::Incompatible);
    }
    if od.get_f32(od::PLAUSIBLE, 1) >= od.get_f32(od::PLAUSIBLE, 2) {
        return Err(SdoAbort::Incompatible);
    }
    Ok(())
}

/// Whether the entry at a position of `OBJECTS` is a stored setting.
pub fn is_setting(pos: usize) -> bool {
    OBJECTS.get(pos).is_some_and(|o| {
        o.access.writable()
            && (o.index == od::HEARTBEAT_TIME || (od::CLAMP..=od::AUTO_START).contains(&o.index))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_agree_with_the_dictionary() {
        assert_eq!(Settings::from_od(&Dictionary::new(1)), Settings::DEFAULT);
        assert_eq!(Settings::DEFAULT.to_od(), Ok(Dictionary::new(1)));
    }

    #[test]
    fn encode_round_trips_and_is_little_endian() {
        let mut s = Settings::DEFAULT;
        s.clamp_um[2] = 250.5;
        s.node_id = 0x22;
        s.heartbeat_ms = 0x1234;
        let b = s.encode();
        assert_eq!(&b[0..4], &500.0f32.to_le_bytes());
        assert_eq!(&b[8..12], &250.5f32.to_le_bytes());
        assert_eq!(&b[52..56], &[0x22, 1, 0x34, 0x12]);
        assert_eq!(&b[56..60], &5000u32.to_le_bytes());
        assert_eq!(Settings::decode(&b), s);
    }

    #[test]
    fn bad_settings_are_refused_as_an_sdo_write_would_be() {
        let mut s = Settings::DEFAULT;
        s.ramp_um_per_s = 3.0; // faster than the 2 um/s slew
        assert_eq!(s.to_od(), Err(SdoAbort::Incompatible));
        let mut s = Settings::DEFAULT;
        s.plausible_c = [50.0, 40.0];
        assert_eq!(s.to_od(), Err(SdoAbort::Incompatible));
        let mut s = Settings::DEFAULT;
        s.hold_time_s = f32::NAN;
        assert_eq!(s.to_od(), Err(SdoAbort::InvalidValue));
        let mut s = Settings::DEFAULT;
        s.node_id = 0;
        assert_eq!(s.to_od(), Err(SdoAbort::InvalidValue));
        let mut s = Settings::DEFAULT;
        // One ms under two of the CNC's slowest frame periods: a CNC
        // sending at the documented rate would read stale between frames.
        s.cnc_timeout_ms = 1_999;
        assert_eq!(s.to_od(), Err(SdoAbort::ValueTooLow));
        s.cnc_timeout_ms = 2_000;
        assert!(s.to_od().is_ok());
    }

    #[cfg(feature = "model")]
    #[test]
    fn pipeline_config_takes_the_settings() {
        use crate::pipeline::PipelineConfig;
        assert_eq!(
            Settings::DEFAULT.pipeline_config(PipelineConfig::DEFAULT),
            PipelineConfig::DEFAULT
        );
        let mut s = Settings::DEFAULT;
        s.clamp_um[1] = 100.0;
        s.hold_time_s = 30.0;
        s.plausible_c = [0.0, 60.0];
        let c = s.pipeline_config(PipelineConfig::DEFAULT);
        assert_eq!(c.limiter.clamp_um[1], 100.0);
        assert_eq!(c.supervisor.hold_time_s, 30.0);
        assert_eq!((c.plausible.min_c, c.plausible.max_c), (0.0, 60.0));
        assert_eq!(c.validate(), Ok(()));
    }
}
