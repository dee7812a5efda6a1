//! The unmodelled effects of CONTRACT.md section 3, each switchable with
//! `--effects` and parameterised in the machine file (`[effects.*]`).
//!
//! | effect | what it changes |
//! |---|---|
//! | `ambient` | `Ta(t) = Ta0 + A cos(2 pi (clock(t) - warmest) / 24 h) + drift t - drop [door open]`; doors open at Poisson times (seeded) |
//! | `coolant` | on/off chiller: the supply warms at `warm` K/min until `high_c`, then cools at `cool` K/min down to `low_c`: a sawtooth of period `(high - low) (1/warm + 1/cool)` |
//! | `cutting` | cutting load `P_cut` (kW) in cycles while the spindle turns (or from a run file's `power_kw`): `share_shaft P_cut` into the shaft, `share_structure P_cut` into the structure, `P_cut (1/eta - 1)` motor load losses into the motor |
//! | `motor_loss` | extra motor losses `Q_x (1 - n / n_knee)` for `0 < n < n_knee` |
//! | `sensor_lag` | first-order lag `tau_s` on the sensors sitting on parts |
//!
//! With every effect off (the nominal twin) ambient and coolant are constant
//! and the spindle only air-cuts.

use super::machine::{AmbientParams, CoolantParams, CuttingParams, MotorLossParams, Node, N_NODES};
use super::rng::{Rng, Stream};
use anyhow::{bail, Result};

/// One effect of the vocabulary.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Effect {
    /// Varying ambient temperature.
    Ambient,
    /// Chiller cycling with hysteresis.
    Coolant,
    /// Heat from cutting under load.
    Cutting,
    /// Extra motor losses at low speed.
    MotorLoss,
    /// Lagging temperature sensors.
    SensorLag,
}

impl Effect {
    /// Every effect, in CONTRACT order.
    pub const ALL: [Effect; 5] = [
        Effect::Ambient,
        Effect::Coolant,
        Effect::Cutting,
        Effect::MotorLoss,
        Effect::SensorLag,
    ];

    /// The vocabulary name.
    pub fn name(self) -> &'static str {
        match self {
            Effect::Ambient => "ambient",
            Effect::Coolant => "coolant",
            Effect::Cutting => "cutting",
            Effect::MotorLoss => "motor_loss",
            Effect::SensorLag => "sensor_lag",
        }
    }
}

/// Which effects are on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct EffectSet([bool; 5]);

impl EffectSet {
    /// No effect: the nominal twin.
    pub fn none() -> Self {
        Self::default()
    }

    /// Parses `a,b,...` (empty or `none` for the nominal twin).
    pub fn parse(list: &str) -> Result<Self> {
        let mut set = Self::none();
        let words: Vec<&str> = list
            .split(',')
            .map(str::trim)
            .filter(|w| !w.is_empty())
            .collect();
        if words.contains(&"none") && words.len() > 1 {
            bail!("--effects {list}: none means the nominal twin, with no other effect");
        }
        for word in words.iter().filter(|w| **w != "none") {
            match Effect::ALL.iter().find(|e| e.name() == *word) {
                Some(e) if set.has(*e) => bail!("--effects {list}: {word} is listed twice"),
                Some(e) => set = set.with(*e),
                None => bail!(
                    "unknown effect \"{word}\" (one of {}, or none)",
                    Effect::ALL.map(Effect::name).join(", ")
                ),
            }
        }
        Ok(set)
    }

    /// This set with `e` on.
    pub fn with(mut self, e: Effect) -> Self {
        self.0[e as usize] = true;
        self
    }

    /// Whether `e` is on.
    pub fn has(&self, e: Effect) -> bool {
        self.0[e as usize]
    }

    /// Names of the effects on.
    pub fn names(&self) -> Vec<&'static str> {
        Effect::ALL
            .into_iter()
            .filter(|e| self.has(*e))
            .map(Effect::name)
            .collect()
    }
}

/// Ambient temperature over a run.
#[derive(Debug, Clone)]
pub struct Ambient {
    base_c: f64,
    p: Option<AmbientParams>,
    /// Door openings, [from, to) in s.
    doors: Vec<(f64, f64)>,
}

impl Ambient {
    /// Constant `base_c` (effect off).
    pub fn constant(base_c: f64) -> Self {
        Ambient {
            base_c,
            p: None,
            doors: Vec::new(),
        }
    }

    /// The varying ambient of a run of `duration_s` (door times seeded).
    pub fn varying(base_c: f64, p: &AmbientParams, duration_s: f64, seed: u64) -> Self {
        let mut doors = Vec::new();
        if p.doors_per_day > 0.0 {
            let mut rng = Rng::new(seed, Stream::Doors);
            let mean_gap_s = 86_400.0 / p.doors_per_day;
            let mut t = rng.exponential(mean_gap_s);
            while t < duration_s {
                doors.push((t, t + p.door_open_s));
                t += p.door_open_s + rng.exponential(mean_gap_s);
            }
        }
        Ambient {
            base_c,
            p: Some(p.clone()),
            doors,
        }
    }

    /// Door openings, [from, to) in s.
    pub fn doors(&self) -> &[(f64, f64)] {
        &self.doors
    }

    /// Ambient temperature at `t_s`, deg C.
    pub fn at(&self, t_s: f64) -> f64 {
        let Some(p) = &self.p else {
            return self.base_c;
        };
        let clock_h = p.start_clock_h + t_s / 3600.0;
        let day = p.day_amplitude_c
            * (std::f64::consts::TAU * (clock_h - p.warmest_clock_h) / 24.0).cos();
        let door = if self.doors.iter().any(|&(a, b)| t_s >= a && t_s < b) {
            p.door_drop_c
        } else {
            0.0
        };
        self.base_c + day + p.drift_c_per_h * t_s / 3600.0 - door
    }
}

/// Coolant supply temperature over a run.
#[derive(Debug, Clone)]
pub struct Coolant {
    base_c: f64,
    chiller: Option<Chiller>,
}

/// The on/off chiller's state.
#[derive(Debug, Clone)]
struct Chiller {
    p: CoolantParams,
    temp_c: f64,
    cooling: bool,
    t_s: f64,
}

impl Coolant {
    /// Constant `base_c` (effect off).
    pub fn constant(base_c: f64) -> Self {
        Coolant {
            base_c,
            chiller: None,
        }
    }

    /// A chiller starting mid-band, compressor off, at t = `t0_s`.
    pub fn cycling(p: &CoolantParams, t0_s: f64) -> Self {
        Coolant {
            base_c: 0.5 * (p.low_c + p.high_c),
            chiller: Some(Chiller {
                p: p.clone(),
                temp_c: 0.5 * (p.low_c + p.high_c),
                cooling: false,
                t_s: t0_s,
            }),
        }
    }

    /// The sawtooth period the hysteresis parameters imply, s.
    pub fn period_s(p: &CoolantParams) -> f64 {
        let band = p.high_c - p.low_c;
        60.0 * (band / p.warm_c_per_min + band / p.cool_c_per_min)
    }

    /// Supply temperature at `t_s` (non-decreasing calls), deg C. Switching
    /// instants inside a step are resolved exactly, so the period does not
    /// depend on the sample time.
    pub fn advance_to(&mut self, t_s: f64) -> f64 {
        let Some(c) = &mut self.chiller else {
            return self.base_c;
        };
        let mut left = (t_s - c.t_s).max(0.0);
        while left > 0.0 {
            let (rate, to_switch) = if c.cooling {
                let r = c.p.cool_c_per_min / 60.0;
                (-r, (c.temp_c - c.p.low_c).max(0.0) / r)
            } else {
                let r = c.p.warm_c_per_min / 60.0;
                (r, (c.p.high_c - c.temp_c).max(0.0) / r)
            };
            if to_switch <= left {
                c.temp_c = if c.cooling { c.p.low_c } else { c.p.high_c };
                c.cooling = !c.cooling;
                left -= to_switch;
            } else {
                c.temp_c += rate * left;
                left = 0.0;
            }
        }
        c.t_s = t_s;
        c.temp_c
    }
}

/// Synthetic cutting load at `t_s` for a spindle at `rpm`, kW: `load_kw` for
/// the first `duty` of every cycle while the spindle turns.
pub fn cutting_load_kw(p: &CuttingParams, t_s: f64, rpm: f64) -> f64 {
    if rpm <= 0.0 {
        return 0.0;
    }
    if t_s.rem_euclid(p.cycle_s) < p.duty * p.cycle_s {
        p.load_kw
    } else {
        0.0
    }
}

/// Heat from a cutting load of `cut_kw`, W per node.
pub fn cutting_heat_w(p: &CuttingParams, cut_kw: f64) -> [f64; N_NODES] {
    let mut q = [0.0; N_NODES];
    let w = cut_kw.max(0.0) * 1000.0;
    q[Node::Shaft.index()] = p.to_shaft_share * w;
    q[Node::Structure.index()] = p.to_structure_share * w;
    q[Node::Motor.index()] = w * (1.0 / p.motor_efficiency - 1.0);
    q
}

/// Extra motor losses at `rpm`, W.
pub fn motor_extra_w(p: &MotorLossParams, rpm: f64) -> f64 {
    let n = rpm.abs();
    if n > 0.0 && n < p.knee_rpm {
        p.extra_w_at_zero_rpm * (1.0 - n / p.knee_rpm)
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::twin::machine::Machine;

    #[test]
    fn parse_effects() {
        let s = EffectSet::parse("ambient, sensor_lag").unwrap_or_default();
        assert_eq!(s.names(), ["ambient", "sensor_lag"]);
        assert_eq!(EffectSet::parse("none").ok(), Some(EffectSet::none()));
        let e = EffectSet::parse("ambient,draft")
            .err()
            .map(|e| e.to_string());
        assert!(e.is_some_and(|e| e.contains("unknown effect \"draft\"")));
        // `none` with another effect, or one effect twice, is a
        // contradiction or a typo (`none,ambient` ran with ambient).
        let said = |list: &str| EffectSet::parse(list).err().map(|e| e.to_string());
        assert!(said("none,ambient").is_some_and(|e| e.contains("none means the nominal twin")));
        assert!(said("ambient,ambient").is_some_and(|e| e.contains("ambient is listed twice")));
    }

    #[test]
    fn chiller_period_does_not_depend_on_the_step() {
        let p = Machine::default_machine().effects.coolant;
        let period = Coolant::period_s(&p);
        assert!((period - 1800.0).abs() < 1e-9, "{period}");
        // Sampled every 97 s, the state after exactly 10 periods is back
        // where it started.
        let mut c = Coolant::cycling(&p, 0.0);
        let start = c.advance_to(0.0);
        let mut t = 0.0;
        while t + 97.0 < 10.0 * period {
            t += 97.0;
            c.advance_to(t);
        }
        let end = c.advance_to(10.0 * period);
        assert!((end - start).abs() < 1e-9, "{start} {end}");
    }
}
