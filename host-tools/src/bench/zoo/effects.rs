//! The unmodelled effects (CONTRACT.md section 3) as the zoo's real
//! machines have them, each scaled by a case's magnitude; the nominal model
//! (the "sim") has none of them.
//!
//! | effect | in the real machine |
//! |---|---|
//! | `ambient` | the room air moves: day cycle, drift, weather ([`super::boundary::Ambient`]) |
//! | `coolant` | an on/off chiller whose period drifts with the machine's load ([`super::boundary::Chiller`]) |
//! | `cutting` | extra shares of the cutting power reach the structure (chips, fluid, tool) |
//! | `motor_loss` | extra motor loss `w exp(-n / n_c)` while turning: worst at low speed |
//! | `sensor_lag` | one or two sensors lose their contact: a long time constant and a bit of the air in their reading |

use super::boundary::{Ambient, Chiller, ChillerSpec, Coolant};
use super::noise::Gauss;
use super::plant::Plant;
use anyhow::{bail, Result};

/// Seed stream of the effect draws (chiller phase, which sensors lag).
const EFFECT_STREAM: u64 = 31;

/// An effect of the vocabulary.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Effect {
    /// Varying room air.
    Ambient,
    /// Cycling chiller.
    Coolant,
    /// Heat from cutting beyond the model's.
    Cutting,
    /// Extra low-speed motor loss.
    MotorLoss,
    /// Sensors in poor contact.
    SensorLag,
}

impl Effect {
    /// The effect of a label (`None` for `none`).
    pub fn from_label(label: &str) -> Result<Option<Effect>> {
        Ok(Some(match label {
            "ambient" => Effect::Ambient,
            "coolant" => Effect::Coolant,
            "cutting" => Effect::Cutting,
            "motor_loss" => Effect::MotorLoss,
            "sensor_lag" => Effect::SensorLag,
            "none" => return Ok(None),
            other => bail!("unknown effect \"{other}\""),
        }))
    }
}

/// Heat the nominal model leaves out.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ExtraHeat {
    /// Extra shares of the cutting power, (node, share).
    pub cut_shares: Vec<(usize, f64)>,
    /// Extra motor loss: (node, W at standstill speed, n_c rpm).
    pub motor: Option<(usize, f64, f64)>,
}

impl ExtraHeat {
    /// Adds the extra heat at `rpm` and `cut_kw` to `q`, W.
    pub fn add_heat_w(&self, rpm: f64, cut_kw: f64, q: &mut [f64]) {
        if rpm.abs() <= 0.0 {
            return;
        }
        for &(i, s) in &self.cut_shares {
            q[i] += s * 1000.0 * cut_kw.max(0.0);
        }
        if let Some((i, w, n_c)) = self.motor {
            q[i] += w * (-rpm.abs() / n_c).exp();
        }
    }
}

/// Sensors in poor contact.
#[derive(Debug, Clone, PartialEq)]
pub struct Lag {
    /// Indices of the lagging sensors.
    pub sensors: Vec<usize>,
    /// Their time constant, s.
    pub tau_s: f64,
    /// Share of the air in their reading.
    pub air_share: f64,
}

/// Everything a run has besides the plant and its inputs.
#[derive(Debug, Clone, PartialEq)]
pub struct Setup {
    /// Room air.
    pub ambient: Ambient,
    /// Coolant supply.
    pub coolant: Coolant,
    /// Heat the nominal model leaves out.
    pub extra: ExtraHeat,
    /// Sensors in poor contact.
    pub lag: Option<Lag>,
}

impl Setup {
    /// The nominal model's: constant air and coolant, nothing extra.
    pub fn nominal(plant: &Plant) -> Setup {
        Setup {
            ambient: Ambient::constant(plant.ambient_c),
            coolant: Coolant::Constant(plant.coolant_c),
            extra: ExtraHeat::default(),
            lag: None,
        }
    }

    /// The real machine's with `effect` at `magnitude` (times the plant's
    /// effect sizes) over a run of `duration_s`.
    pub fn real(
        plant: &Plant,
        effect: Option<Effect>,
        magnitude: f64,
        duration_s: f64,
        seed: u64,
    ) -> Setup {
        let mut s = Setup::nominal(plant);
        let e = &plant.effects;
        let mut g = Gauss::new(seed, EFFECT_STREAM);
        match effect {
            None => {}
            Some(Effect::Ambient) => {
                let mut swing = e.ambient.clone();
                swing.day_amplitude_c *= magnitude;
                swing.drift_c_per_h *= magnitude * g.symmetric().signum();
                swing.weather_c *= magnitude;
                s.ambient = Ambient::varying(plant.ambient_c, swing, duration_s, seed);
            }
            Some(Effect::Coolant) => {
                // A wider band with a smaller tank: the amplitude scales,
                // the period at a given load stays the plant's.
                let spec = ChillerSpec {
                    band_c: e.chiller.band_c * magnitude,
                    tank_j_per_k: e.chiller.tank_j_per_k / magnitude,
                    ..e.chiller.clone()
                };
                s.coolant = Coolant::Cycling(Chiller::new(spec, g.uniform()));
            }
            Some(Effect::Cutting) => {
                s.extra.cut_shares = e
                    .cut_extra
                    .iter()
                    .map(|&(i, v)| (i, v * magnitude))
                    .collect();
            }
            Some(Effect::MotorLoss) => {
                let n_c = e.motor_extra_speed * plant.max_rpm;
                s.extra.motor = Some((e.motor_node, e.motor_extra_w * magnitude, n_c));
            }
            Some(Effect::SensorLag) => s.lag = Some(lag(plant, magnitude, &mut g)),
        }
        s
    }
}

/// One or two of the plant's lag-prone sensors, drawn from `g`.
fn lag(plant: &Plant, magnitude: f64, g: &mut Gauss) -> Lag {
    let e = &plant.effects;
    let mut pool = e.lag_sensors.clone();
    let first = pool.remove(g.below(pool.len()));
    let mut sensors = vec![first];
    if !pool.is_empty() && g.uniform() < 0.5 {
        sensors.push(pool[g.below(pool.len())]);
    }
    sensors.sort_unstable();
    Lag {
        sensors,
        tau_s: e.lag_tau_s * magnitude,
        air_share: e.lag_air_share,
    }
}
