//! A zoo plant: its network, heat laws, sensors, displacement axes, noise
//! and the sizes of the unmodelled effects it can show.

use super::boundary::{AmbientSwing, ChillerSpec};
use super::laws::HeatLaws;
use super::network::{Network, Site};
use super::sensors::{ChannelNoise, Sensor};
use anyhow::{bail, Result};
use serde::Serialize;

/// A displacement channel: a linear combination of node temperature rises.
#[derive(Debug, Clone, PartialEq)]
pub struct Axis {
    /// Column name (`dz_um`, `dx_um`, `dy_um`).
    pub name: &'static str,
    /// Displacement per kelvin of each node's rise, um/K.
    pub um_per_k: Vec<f64>,
}

/// Noise of the real machine's channels.
#[derive(Debug, Clone, PartialEq)]
pub struct PlantNoise {
    /// Temperature sensors, K.
    pub temp: ChannelNoise,
    /// Displacements, um.
    pub disp: ChannelNoise,
    /// Logged spindle power, one sigma, kW.
    pub power_kw: f64,
    /// Logged ambient and coolant temperatures, one sigma, K.
    pub boundary_c: f64,
}

/// Sizes of the effects at magnitude 1 (a case scales them).
#[derive(Debug, Clone, PartialEq)]
pub struct EffectSizes {
    /// How the room air moves (`ambient`).
    pub ambient: AmbientSwing,
    /// The chiller (`coolant`).
    pub chiller: ChillerSpec,
    /// Extra shares of the cutting power into nodes (`cutting`).
    pub cut_extra: Vec<(usize, f64)>,
    /// Node of the extra motor loss (`motor_loss`).
    pub motor_node: usize,
    /// Extra motor loss at standstill speed, W: `w exp(-n / n_c)` while turning.
    pub motor_extra_w: f64,
    /// `n_c` of the extra motor loss as a fraction of top speed.
    pub motor_extra_speed: f64,
    /// Sensors that can lose their contact (indices into the plant's sensors).
    pub lag_sensors: Vec<usize>,
    /// Time constant of a sensor in poor contact, s.
    pub lag_tau_s: f64,
    /// Share of the air in what a sensor in poor contact reads.
    pub lag_air_share: f64,
}

/// A plant of the zoo.
#[derive(Debug, Clone, PartialEq)]
pub struct Plant {
    /// Short id (`a`, `b`, ...).
    pub id: &'static str,
    /// What the machine is.
    pub name: &'static str,
    /// Top spindle speed, rpm.
    pub max_rpm: f64,
    /// Largest cutting load of its profiles, kW.
    pub cut_max_kw: f64,
    /// Air-cutting spindle power `a1 x + a2 x^2`, `x = n / max_rpm`, kW.
    pub air_kw: [f64; 2],
    /// Nominal room air, deg C.
    pub ambient_c: f64,
    /// Nominal coolant supply, deg C.
    pub coolant_c: f64,
    /// The thermal network.
    pub net: Network,
    /// Heat laws.
    pub laws: HeatLaws,
    /// Temperature sensors T1, T2, ... in this order (the air sensor last).
    pub sensors: Vec<Sensor>,
    /// Displacement channels.
    pub axes: Vec<Axis>,
    /// Noise of the real machine.
    pub noise: PlantNoise,
    /// Effect sizes.
    pub effects: EffectSizes,
}

/// What the plant table of docs/gap-benchmark.md shows.
#[derive(Debug, Clone, Serialize)]
pub struct PlantFacts {
    /// Id.
    pub id: String,
    /// What the machine is.
    pub name: String,
    /// Node names.
    pub nodes: Vec<String>,
    /// Number of links.
    pub links: usize,
    /// Speed exponents of the friction laws.
    pub friction_exponents: Vec<f64>,
    /// Number of motors.
    pub motors: usize,
    /// Temperature sensors (the air sensor included).
    pub sensors: usize,
    /// Sensor time constants, s.
    pub sensor_taus_s: Vec<f64>,
    /// Displacement channels.
    pub axes: Vec<String>,
    /// Top speed, rpm.
    pub max_rpm: f64,
    /// Slowest and fastest time constant of the network, s.
    pub tau_range_s: (f64, f64),
}

impl Plant {
    /// Air-cutting spindle power at `rpm`, kW.
    pub fn air_power_kw(&self, rpm: f64) -> f64 {
        let x = (rpm.abs() / self.max_rpm).min(1.5);
        self.air_kw[0] * x + self.air_kw[1] * x * x
    }

    /// Checks the network, the laws, the sensors and the axes.
    pub fn check(&self) -> Result<()> {
        self.net.check()?;
        self.laws.check(self.net.len())?;
        let n = self.net.len();
        let site_ok = |s: Site| !matches!(s, Site::Node(i) if i >= n);
        for (k, s) in self.sensors.iter().enumerate() {
            if !site_ok(s.at)
                || !site_ok(s.toward)
                || !(0.0..=1.0).contains(&s.share)
                || s.tau_s < 0.0
            {
                bail!("plant {}: sensor T{} is misplaced", self.id, k + 1);
            }
        }
        if self.sensors.iter().filter(|s| s.is_air()).count() > 1
            || self
                .sensors
                .iter()
                .take(self.sensors.len().saturating_sub(1))
                .any(Sensor::is_air)
        {
            bail!(
                "plant {}: at most one air sensor, and it comes last",
                self.id
            );
        }
        if self.axes.iter().any(|a| a.um_per_k.len() != n) || self.axes.is_empty() {
            bail!(
                "plant {}: every axis needs one coefficient per node",
                self.id
            );
        }
        let e = &self.effects;
        if e.motor_node >= n || e.lag_sensors.iter().any(|&i| i >= self.sensors.len()) {
            bail!(
                "plant {}: effect sizes name a missing node or sensor",
                self.id
            );
        }
        Ok(())
    }

    /// The plant's structure in figures.
    pub fn facts(&self) -> PlantFacts {
        let taus = self.net.time_constants_s();
        PlantFacts {
            id: self.id.to_string(),
            name: self.name.to_string(),
            nodes: self.net.nodes.iter().map(|n| n.name.to_string()).collect(),
            links: self.net.links.len(),
            friction_exponents: self.laws.friction.iter().map(|f| f.exponent).collect(),
            motors: self.laws.motors.len(),
            sensors: self.sensors.len(),
            sensor_taus_s: self.sensors.iter().map(|s| s.tau_s).collect(),
            axes: self.axes.iter().map(|a| a.name.to_string()).collect(),
            max_rpm: self.max_rpm,
            tau_range_s: (
                taus.first().copied().unwrap_or(0.0).round(),
                taus.last().copied().unwrap_or(0.0).round(),
            ),
        }
    }
}
