//! Heat laws of the zoo's plants: the heat, W, that spindle speed `n` and
//! cutting power put into the nodes.
//!
//! ```text
//! friction (bearings, gear churning, belts):  Q = w_ref (n / n_ref)^p (1 + kappa max(0, T_node - T_outer))
//! motor, while turning:                        Q = s [idle + iron (n / n_ref)^e + low max(0, 1 - n/knee)^2 + l P_cut]
//! cutting (tool, chips, fluid):                Q_i = share_i P_cut
//! ```
//!
//! `p` goes from 1 (grease-lubricated rolling bearings, belts) to 2 (oil
//! shear in hydrodynamic bearings, churning); `kappa` is the thermally
//! induced preload of a bearing whose inner ring runs hotter than its
//! housing (a state-dependent law, hence RK4); `low` is the motor's own
//! low-speed inefficiency, part of the nominal model; `s` the share of the
//! motor's losses that reaches the node (the rest goes to a fan or the air).

use anyhow::{bail, Result};

/// A friction law `w_ref (n/n_ref)^p`, optionally with preload feedback.
#[derive(Debug, Clone, PartialEq)]
pub struct Friction {
    /// Node the heat goes into.
    pub node: usize,
    /// Heat at the reference speed, W.
    pub w_at_ref: f64,
    /// Speed exponent `p` (1..2).
    pub exponent: f64,
    /// Relative heat increase per kelvin of `T_node - T_outer`, 1/K.
    pub preload_per_k: f64,
    /// The housing node of the preload feedback.
    pub outer: Option<usize>,
}

/// Losses of a motor.
#[derive(Debug, Clone, PartialEq)]
pub struct Motor {
    /// Node the losses go into.
    pub node: usize,
    /// Share of the losses that reaches the node.
    pub share: f64,
    /// Losses while turning at any speed, W.
    pub idle_w: f64,
    /// Iron losses at the reference speed, W.
    pub iron_w_at_ref: f64,
    /// Speed exponent of the iron losses.
    pub iron_exponent: f64,
    /// Extra loss at standstill speed of the nominal low-speed inefficiency, W.
    pub low_speed_w: f64,
    /// Speed above which the low-speed inefficiency is gone, rpm.
    pub knee_rpm: f64,
    /// Load losses per kW of cutting power, W/kW.
    pub load_w_per_kw: f64,
}

/// Every heat law of a plant.
#[derive(Debug, Clone, PartialEq)]
pub struct HeatLaws {
    /// Reference speed of the friction and iron laws, rpm.
    pub ref_rpm: f64,
    /// Friction laws.
    pub friction: Vec<Friction>,
    /// Motors.
    pub motors: Vec<Motor>,
    /// Share of the cutting power into each listed node.
    pub cutting: Vec<(usize, f64)>,
}

impl Friction {
    /// Heat at `rpm` with node temperatures `x`, W.
    pub fn heat_w(&self, rpm: f64, ref_rpm: f64, x: &[f64]) -> f64 {
        let n = rpm.abs() / ref_rpm;
        if n <= 0.0 {
            return 0.0;
        }
        let feedback = self
            .outer
            .map_or(0.0, |o| self.preload_per_k * (x[self.node] - x[o]).max(0.0));
        self.w_at_ref * n.powf(self.exponent) * (1.0 + feedback)
    }
}

impl Motor {
    /// Heat into the node at `rpm` and cutting power `cut_kw`, W.
    pub fn heat_w(&self, rpm: f64, ref_rpm: f64, cut_kw: f64) -> f64 {
        let n = rpm.abs();
        if n <= 0.0 {
            return 0.0;
        }
        let low = (1.0 - n / self.knee_rpm).max(0.0);
        let w = self.idle_w
            + self.iron_w_at_ref * (n / ref_rpm).powf(self.iron_exponent)
            + self.low_speed_w * low * low
            + self.load_w_per_kw * cut_kw.max(0.0);
        self.share * w
    }
}

impl HeatLaws {
    /// Adds the heat of every law at `rpm`, `cut_kw` and state `x` to `q`, W.
    pub fn add_heat_w(&self, rpm: f64, cut_kw: f64, x: &[f64], q: &mut [f64]) {
        for f in &self.friction {
            q[f.node] += f.heat_w(rpm, self.ref_rpm, x);
        }
        for m in &self.motors {
            q[m.node] += m.heat_w(rpm, self.ref_rpm, cut_kw);
        }
        if rpm.abs() > 0.0 {
            for &(node, share) in &self.cutting {
                q[node] += share * 1000.0 * cut_kw.max(0.0);
            }
        }
    }

    /// Checks node indices and signs for a network of `n` nodes.
    pub fn check(&self, n: usize) -> Result<()> {
        if !(self.ref_rpm.is_finite() && self.ref_rpm > 0.0) {
            bail!("heat laws: reference speed must be > 0");
        }
        for f in &self.friction {
            let outer_ok = f.outer.is_none_or(|o| o < n);
            if f.node >= n || !outer_ok || !(1.0..=2.0).contains(&f.exponent) || f.w_at_ref < 0.0 {
                bail!(
                    "friction law on node {}: bad node, exponent (1..2) or heat",
                    f.node
                );
            }
        }
        for m in &self.motors {
            if m.node >= n || !(0.0..=1.0).contains(&m.share) || m.knee_rpm <= 0.0 {
                bail!("motor on node {}: bad node, share or knee", m.node);
            }
        }
        if self
            .cutting
            .iter()
            .any(|&(i, s)| i >= n || !(0.0..=1.0).contains(&s))
        {
            bail!("cutting shares: bad node or share");
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn friction_follows_its_speed_exponent() {
        // Q(2n)/Q(n) = 2^p exactly (no preload): log2 of the ratio is p to
        // rounding (1e-12).
        for p in [1.0, 1.3, 1.7, 2.0] {
            let f = Friction {
                node: 0,
                w_at_ref: 200.0,
                exponent: p,
                preload_per_k: 0.0,
                outer: None,
            };
            let r = f.heat_w(6000.0, 10_000.0, &[0.0]) / f.heat_w(3000.0, 10_000.0, &[0.0]);
            assert!((r.log2() - p).abs() < 1e-12, "{p}: {r}");
        }
    }

    #[test]
    fn preload_raises_bearing_heat_with_the_ring_difference() {
        let f = Friction {
            node: 0,
            w_at_ref: 100.0,
            exponent: 1.5,
            preload_per_k: 0.02,
            outer: Some(1),
        };
        let cold = f.heat_w(10_000.0, 10_000.0, &[20.0, 20.0]);
        let hot = f.heat_w(10_000.0, 10_000.0, &[30.0, 25.0]);
        assert!(
            (cold - 100.0).abs() < 1e-12 && (hot - 110.0).abs() < 1e-9,
            "{cold} {hot}"
        );
    }

    #[test]
    fn motor_is_less_efficient_at_low_speed() {
        let m = Motor {
            node: 0,
            share: 1.0,
            idle_w: 100.0,
            iron_w_at_ref: 0.0,
            iron_exponent: 1.5,
            low_speed_w: 200.0,
            knee_rpm: 3000.0,
            load_w_per_kw: 0.0,
        };
        assert_eq!(m.heat_w(0.0, 10_000.0, 0.0), 0.0);
        assert!((m.heat_w(1500.0, 10_000.0, 0.0) - 150.0).abs() < 1e-9);
        assert!((m.heat_w(6000.0, 10_000.0, 0.0) - 100.0).abs() < 1e-9);
    }
}
