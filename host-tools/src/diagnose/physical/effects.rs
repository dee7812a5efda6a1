//! The candidate effects as the twin's own physics, each with the few
//! parameters a calibration fits together with the machine's factors
//! ([`crate::twin::drive::FittedEffect`]). Every one reuses the twin's model
//! of the effect ([`crate::twin::effects`], the sensor lag of
//! [`crate::twin::sensors`]); what is fitted is its magnitude and timing.
//!
//! | effect | input to the twin | fitted (bounds) |
//! |---|---|---|
//! | `ambient`, logged | the logged `ambient_c` as the ambient boundary | `gain` (0..3) |
//! | `ambient`, not logged | a day cycle `A cos(2 pi (t/1 h - warmest_h) / 24) + drift t` | `day_amplitude_c` (0..10), `warmest_h` (-12..36, after the start), `drift_c_per_h` (-0.5..0.5) |
//! | `coolant`, logged | the logged `coolant_c` as the coolant boundary | `gain` (0..3) |
//! | `coolant`, not logged | the twin's on/off chiller, warming:cooling rates as the machine file's | `amplitude_c` (half band, 0.01..5), `period_s` (0.9..1.1 x the residual's spectral peak), `phase_s` |
//! | `cutting` | heat from the power beyond air cutting ([`crate::diagnose::regime::cutting_excess_kw`]) into shaft and structure (the file's split) and the motor (load losses) | `process_share` (0..1), `load_loss_share` (= 1/eta - 1, 0..1) |
//! | `motor_loss` | extra motor losses `Q_x (1 - n / n_knee)` below the knee | `extra_w_at_zero_rpm` (1..20 000 W), `knee_rpm` (100 .. 1.5 x max_rpm) |
//! | `sensor_lag` | a first-order lag on every temperature sensor on a part | `tau_s` per sensor (1 s .. 4 h) |

use crate::diagnose::candidates::round;
use crate::diagnose::outcome::{Param, Params};
use crate::twin::drive::{Drive, FittedEffect};
use crate::twin::effects::{self, Ambient, Coolant};
use crate::twin::machine::{
    AmbientParams, CoolantParams, CuttingParams, MotorLossParams, Node, N_NODES,
};
use crate::twin::param::ParamDef;
use std::collections::BTreeMap;

/// A candidate effect the diagnosis adds to the twin.
pub trait Candidate: FittedEffect + Send {
    /// The vocabulary name (CONTRACT.md section 3).
    fn name(&self) -> &'static str;
    /// Which form of the effect this is, in words.
    fn model(&self) -> String;
    /// The fitted values `p` with names and units (rounded as printed).
    fn describe(&self, p: &[f64]) -> Params;
}

fn def(name: &'static str, unit: &'static str, lo: f64, hi: f64, log: bool) -> ParamDef {
    ParamDef {
        name,
        unit,
        lo,
        hi,
        log,
    }
}

fn named(pairs: &[(&str, f64)]) -> Params {
    pairs
        .iter()
        .map(|(k, v)| (k.to_string(), Param::Number(round(*v))))
        .collect()
}

/// Which boundary a logged column drives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Boundary {
    /// `ambient_c`.
    Ambient,
    /// `coolant_c`.
    Coolant,
}

/// A logged boundary temperature as the twin's boundary, scaled by a gain
/// (how much of the logged swing the machine sees).
pub struct Logged {
    /// Which boundary.
    pub boundary: Boundary,
    /// Logged value minus its first value, K, every row.
    pub rise_k: Vec<f64>,
}

impl FittedEffect for Logged {
    fn params(&self) -> Vec<ParamDef> {
        vec![def("gain", "x", 0.0, 3.0, false)]
    }
    fn starts(&self) -> Vec<Vec<f64>> {
        vec![vec![1.0], vec![0.5]]
    }
    fn drive(&self, p: &[f64]) -> Drive {
        let v = Some(self.rise_k.iter().map(|x| p[0] * x).collect());
        match self.boundary {
            Boundary::Ambient => Drive {
                ambient_k: v,
                ..Drive::default()
            },
            Boundary::Coolant => Drive {
                coolant_k: v,
                ..Drive::default()
            },
        }
    }
}

impl Candidate for Logged {
    fn name(&self) -> &'static str {
        match self.boundary {
            Boundary::Ambient => "ambient",
            Boundary::Coolant => "coolant",
        }
    }
    fn model(&self) -> String {
        format!(
            "{}_c logged: the log is the twin's {} boundary, times a fitted gain",
            self.name(),
            self.name()
        )
    }
    fn describe(&self, p: &[f64]) -> Params {
        named(&[("gain", p[0])])
    }
}

/// A day/night cycle of the ambient air (not logged): the twin's ambient
/// model without doors.
pub struct DayCycle {
    /// Time since the run's start, s, every row.
    pub t_rel_s: Vec<f64>,
}

impl FittedEffect for DayCycle {
    fn params(&self) -> Vec<ParamDef> {
        vec![
            def("day_amplitude_c", "K", 0.0, 10.0, false),
            def("warmest_h", "h", -12.0, 36.0, false),
            def("drift_c_per_h", "K/h", -0.5, 0.5, false),
        ]
    }
    fn starts(&self) -> Vec<Vec<f64>> {
        [0.0, 6.0, 12.0, 18.0]
            .iter()
            .map(|&h| vec![1.0, h, 0.0])
            .collect()
    }
    fn drive(&self, p: &[f64]) -> Drive {
        let params = AmbientParams {
            day_amplitude_c: p[0],
            warmest_clock_h: p[1],
            start_clock_h: 0.0,
            drift_c_per_h: p[2],
            doors_per_day: 0.0,
            door_drop_c: 0.0,
            door_open_s: 0.0,
        };
        let air = Ambient::varying(0.0, &params, 0.0, 0);
        let a0 = air.at(0.0);
        Drive {
            ambient_k: Some(self.t_rel_s.iter().map(|&t| air.at(t) - a0).collect()),
            ..Drive::default()
        }
    }
}

impl Candidate for DayCycle {
    fn name(&self) -> &'static str {
        "ambient"
    }
    fn model(&self) -> String {
        "ambient_c not logged: a 24 h cycle and a drift as the ambient boundary".into()
    }
    fn describe(&self, p: &[f64]) -> Params {
        named(&[
            ("day_amplitude_c", p[0]),
            ("warmest_h_after_start", p[1].rem_euclid(24.0)),
            ("drift_c_per_h", p[2]),
        ])
    }
}

/// The twin's on/off chiller (coolant not logged), its period started from
/// the residual's spectral peak.
pub struct Chiller {
    /// Time since the run's start, s, every row.
    pub t_rel_s: Vec<f64>,
    /// Period to start from, s.
    pub period0_s: f64,
    /// Warming over cooling rate (the machine file's chiller).
    pub warm_over_cool: f64,
}

impl Chiller {
    /// The chiller of half band `amp` (K) and `period_s`.
    fn params_of(&self, amp: f64, period_s: f64) -> CoolantParams {
        // period = 60 band (1/warm + 1/cool) (in min, rates in K/min), band
        // = 2 amp, 1/cool = ratio/warm: warm = 120 amp (1 + ratio) / period.
        let ratio = self.warm_over_cool;
        let warm = 120.0 * amp * (1.0 + ratio) / period_s;
        CoolantParams {
            low_c: -amp,
            high_c: amp,
            warm_c_per_min: warm,
            cool_c_per_min: warm / ratio,
        }
    }
}

impl FittedEffect for Chiller {
    fn params(&self) -> Vec<ParamDef> {
        let p = self.period0_s;
        vec![
            def("amplitude_c", "K", 0.01, 5.0, true),
            def("period_s", "s", 0.9 * p, 1.1 * p, false),
            def("phase_s", "s", -p, 2.0 * p, false),
        ]
    }
    fn starts(&self) -> Vec<Vec<f64>> {
        let p = self.period0_s;
        let mut out = Vec::new();
        for f in [0.98, 0.99, 1.0, 1.01, 1.02] {
            for k in 0..8 {
                out.push(vec![0.5, f * p, k as f64 / 8.0 * p]);
            }
        }
        out
    }
    fn drive(&self, p: &[f64]) -> Drive {
        let mut c = Coolant::cycling(&self.params_of(p[0], p[1]), -p[2]);
        let c0 = c.advance_to(0.0);
        Drive {
            coolant_k: Some(self.t_rel_s.iter().map(|&t| c.advance_to(t) - c0).collect()),
            ..Drive::default()
        }
    }
}

impl Candidate for Chiller {
    fn name(&self) -> &'static str {
        "coolant"
    }
    fn model(&self) -> String {
        format!(
            "coolant_c not logged: an on/off chiller (sawtooth, warming {:.2} x as fast as cooling) as the coolant boundary, period started at the residual's peak {:.0} s",
            self.warm_over_cool, self.period0_s
        )
    }
    fn describe(&self, p: &[f64]) -> Params {
        let c = self.params_of(p[0], p[1]);
        named(&[
            ("amplitude_c", p[0]),
            ("period_s", p[1]),
            // In -period/2 .. period/2: a phase of 0 reads as 0.
            ("phase_s", (p[2] + 0.5 * p[1]).rem_euclid(p[1]) - 0.5 * p[1]),
            ("warm_c_per_min", c.warm_c_per_min),
            ("cool_c_per_min", c.cool_c_per_min),
        ])
    }
}

/// Heat from cutting: the power beyond air cutting, shared out as the
/// twin's cutting effect does.
pub struct Cutting {
    /// Power beyond air cutting, kW, every row.
    pub cut_kw: Vec<f64>,
    /// The machine file's cutting parameters (shaft : structure split).
    pub file: CuttingParams,
}

impl Cutting {
    fn params_of(&self, process: f64, load_loss: f64) -> CuttingParams {
        let total = self.file.to_shaft_share + self.file.to_structure_share;
        let shaft = if total > 0.0 {
            self.file.to_shaft_share / total
        } else {
            0.5
        };
        CuttingParams {
            to_shaft_share: process * shaft,
            to_structure_share: process * (1.0 - shaft),
            motor_efficiency: 1.0 / (1.0 + load_loss),
            ..self.file.clone()
        }
    }
}

impl FittedEffect for Cutting {
    fn params(&self) -> Vec<ParamDef> {
        vec![
            def("process_share", "1", 0.0, 1.0, false),
            def("load_loss_share", "1", 0.0, 1.0, false),
        ]
    }
    fn starts(&self) -> Vec<Vec<f64>> {
        vec![vec![0.08, 0.11], vec![0.02, 0.02], vec![0.3, 0.3]]
    }
    fn drive(&self, p: &[f64]) -> Drive {
        let c = self.params_of(p[0], p[1]);
        Drive {
            heat_w: Some(
                self.cut_kw
                    .iter()
                    .map(|&kw| effects::cutting_heat_w(&c, kw))
                    .collect(),
            ),
            ..Drive::default()
        }
    }
}

impl Candidate for Cutting {
    fn name(&self) -> &'static str {
        "cutting"
    }
    fn model(&self) -> String {
        "power_kw beyond air cutting (20th percentile at each speed) heats shaft and structure (the machine file's split) and the motor (load losses)".into()
    }
    fn describe(&self, p: &[f64]) -> Params {
        let c = self.params_of(p[0], p[1]);
        named(&[
            ("process_share", p[0]),
            ("load_loss_share", p[1]),
            ("to_shaft_share", c.to_shaft_share),
            ("to_structure_share", c.to_structure_share),
            ("motor_efficiency", c.motor_efficiency),
        ])
    }
}

/// Extra motor losses at low speed, as the twin's `motor_loss`.
pub struct MotorLoss {
    /// Spindle speed, rpm, every row.
    pub speed_rpm: Vec<f64>,
    /// The machine's top speed, rpm.
    pub max_rpm: f64,
}

impl FittedEffect for MotorLoss {
    fn params(&self) -> Vec<ParamDef> {
        vec![
            def("extra_w_at_zero_rpm", "W", 1.0, 20_000.0, true),
            def("knee_rpm", "rpm", 100.0, 1.5 * self.max_rpm, true),
        ]
    }
    fn starts(&self) -> Vec<Vec<f64>> {
        [0.2, 0.35, 0.5, 0.75]
            .iter()
            .map(|f| vec![300.0, f * self.max_rpm])
            .collect()
    }
    fn drive(&self, p: &[f64]) -> Drive {
        let m = MotorLossParams {
            extra_w_at_zero_rpm: p[0],
            knee_rpm: p[1],
        };
        let heat = self
            .speed_rpm
            .iter()
            .map(|&n| {
                let mut q = [0.0; N_NODES];
                q[Node::Motor.index()] = effects::motor_extra_w(&m, n);
                q
            })
            .collect();
        Drive {
            heat_w: Some(heat),
            ..Drive::default()
        }
    }
}

impl Candidate for MotorLoss {
    fn name(&self) -> &'static str {
        "motor_loss"
    }
    fn model(&self) -> String {
        "extra motor losses falling linearly from standstill to a knee speed".into()
    }
    fn describe(&self, p: &[f64]) -> Params {
        named(&[("extra_w_at_zero_rpm", p[0]), ("knee_rpm", p[1])])
    }
}

/// A first-order lag on each temperature sensor on a part.
pub struct SensorLag {
    /// Temperature channels (the measured run's order) and whether each
    /// may lag (a sensor on the air or coolant alone does not).
    pub channels: Vec<(String, bool)>,
}

impl SensorLag {
    fn lagging(&self) -> impl Iterator<Item = &str> {
        self.channels.iter().filter(|c| c.1).map(|c| c.0.as_str())
    }
}

impl FittedEffect for SensorLag {
    fn params(&self) -> Vec<ParamDef> {
        self.lagging()
            .map(|_| def("tau_s", "s", 1.0, 14_400.0, true))
            .collect()
    }
    fn starts(&self) -> Vec<Vec<f64>> {
        let n = self.lagging().count();
        [60.0, 300.0, 900.0, 1800.0]
            .iter()
            .map(|&t| vec![t; n])
            .collect()
    }
    fn drive(&self, p: &[f64]) -> Drive {
        let mut taus = p.iter();
        let lags = self
            .channels
            .iter()
            .map(|c| if c.1 { taus.next().copied() } else { None })
            .collect();
        Drive {
            sensor_lag_s: Some(lags),
            ..Drive::default()
        }
    }
}

impl Candidate for SensorLag {
    fn name(&self) -> &'static str {
        "sensor_lag"
    }
    fn model(&self) -> String {
        "a first-order lag on every temperature sensor on a part, one time constant each".into()
    }
    fn describe(&self, p: &[f64]) -> Params {
        let taus: BTreeMap<String, f64> = self
            .lagging()
            .zip(p)
            .map(|(name, t)| (name.to_string(), round(*t)))
            .collect();
        let mut sorted = p.to_vec();
        sorted.sort_by(f64::total_cmp);
        let median = sorted.get(sorted.len() / 2).copied().unwrap_or(f64::NAN);
        let mut m = named(&[("tau_s_median", median)]);
        m.insert("tau_s".into(), Param::Table(taus));
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::twin::machine::Machine;

    #[test]
    fn the_chiller_at_the_files_values_is_the_twins_chiller() {
        // Half band 0.5 K, 1800 s, warming at half the cooling rate: the
        // default machine's chiller, so the drive is the twin's own
        // coolant (a rise above its first value) at phase 0.
        let file = Machine::default_machine().effects.coolant;
        let t: Vec<f64> = (0..500).map(|k| k as f64 * 37.0).collect();
        let c = Chiller {
            t_rel_s: t.clone(),
            period0_s: 1800.0,
            warm_over_cool: file.warm_c_per_min / file.cool_c_per_min,
        };
        let p = c.params_of(0.5, 1800.0);
        assert!((Coolant::period_s(&p) - 1800.0).abs() < 1e-9);
        assert!((p.warm_c_per_min - file.warm_c_per_min).abs() < 1e-12);
        assert!((p.cool_c_per_min - file.cool_c_per_min).abs() < 1e-12);
        let d = c.drive(&[0.5, 1800.0, 0.0]).coolant_k.unwrap_or_default();
        let mut twin = Coolant::cycling(&file, 0.0);
        let t0 = twin.advance_to(0.0);
        for (k, &tk) in t.iter().enumerate() {
            let want = twin.advance_to(tk) - t0;
            assert!((d[k] - want).abs() < 1e-9, "{k}: {} vs {want}", d[k]);
        }
    }

    #[test]
    fn cutting_keeps_the_files_split() {
        let file = Machine::default_machine().effects.cutting;
        let c = Cutting {
            cut_kw: vec![4.0],
            file: file.clone(),
        };
        let p = c.params_of(0.08, 1.0 / file.motor_efficiency - 1.0);
        assert!((p.to_shaft_share - file.to_shaft_share).abs() < 1e-12);
        assert!((p.to_structure_share - file.to_structure_share).abs() < 1e-12);
        assert!((p.motor_efficiency - file.motor_efficiency).abs() < 1e-12);
        let q = c.drive(&[0.08, 1.0 / 9.0]).heat_w.unwrap_or_default();
        // 4 kW: 120 W shaft, 200 W structure, 444 W motor load losses.
        let want = effects::cutting_heat_w(&file, 4.0);
        assert!(q[0].iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-9));
    }

    #[test]
    fn the_day_cycle_peaks_at_the_warmest_hour() {
        let t: Vec<f64> = (0..=24 * 60).map(|k| k as f64 * 60.0).collect();
        let d = DayCycle { t_rel_s: t.clone() }
            .drive(&[1.5, 7.0, 0.0])
            .ambient_k
            .unwrap_or_default();
        let top = (0..d.len()).max_by(|&a, &b| d[a].total_cmp(&d[b]));
        assert_eq!(top.map(|k| t[k] / 3600.0), Some(7.0));
        assert_eq!(d[0], 0.0);
    }

    #[test]
    fn a_sensor_on_the_air_does_not_lag() {
        let lag = SensorLag {
            channels: vec![
                ("T1".into(), true),
                ("T7".into(), false),
                ("T2".into(), true),
            ],
        };
        assert_eq!(lag.params().len(), 2);
        let d = lag.drive(&[600.0, 60.0]);
        assert_eq!(
            (d.lag_s(0), d.lag_s(1), d.lag_s(2)),
            (Some(600.0), None, Some(60.0))
        );
    }
}
