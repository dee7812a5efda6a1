//! The real machine is never the nominal model: every thermal parameter of
//! the plant is multiplied by `1 + u`, `u` uniform in +-`pct` % and drawn
//! per parameter from the case's seed. That includes the parameters whose
//! error looks most like an effect: the motor's idle, iron, low-speed and
//! load losses (like `motor_loss`), the bearing and churning heat, the
//! cutting shares (like `cutting`), every heat capacity and conductance
//! (to the air: like `ambient`; to the coolant: like `coolant`), the sensor
//! time constants (like `sensor_lag`) and the expansion coefficients.

use super::noise::Gauss;
use super::plant::Plant;

/// Seed stream of the mismatch.
const MISMATCH_STREAM: u64 = 41;

/// One drawn parameter: its name and the factor applied.
#[derive(Debug, Clone, PartialEq)]
pub struct Factor {
    /// Parameter, e.g. `motor[0].low_speed_w`.
    pub name: String,
    /// Factor applied (real / nominal).
    pub factor: f64,
}

/// Draws factors and applies them, recording each.
struct Drawer {
    g: Gauss,
    pct: f64,
    drawn: Vec<Factor>,
}

impl Drawer {
    fn apply(&mut self, name: String, v: &mut f64) {
        let factor = 1.0 + self.pct / 100.0 * self.g.symmetric();
        *v *= factor;
        self.drawn.push(Factor { name, factor });
    }
}

/// `plant` with every parameter off by up to +-`pct` %, and the factors.
pub fn mismatched(plant: &Plant, pct: f64, seed: u64) -> (Plant, Vec<Factor>) {
    let mut p = plant.clone();
    let mut d = Drawer {
        g: Gauss::new(seed, MISMATCH_STREAM),
        pct,
        drawn: Vec::new(),
    };
    for n in &mut p.net.nodes {
        d.apply(format!("{}.c_j_per_k", n.name), &mut n.c_j_per_k);
        d.apply(
            format!("{}.g_ambient_w_per_k", n.name),
            &mut n.g_ambient_w_per_k,
        );
        d.apply(
            format!("{}.g_coolant_w_per_k", n.name),
            &mut n.g_coolant_w_per_k,
        );
    }
    for l in &mut p.net.links {
        d.apply(format!("link {}-{}", l.a, l.b), &mut l.g_w_per_k);
    }
    for (k, f) in p.laws.friction.iter_mut().enumerate() {
        d.apply(format!("friction[{k}].w_at_ref"), &mut f.w_at_ref);
    }
    for (k, m) in p.laws.motors.iter_mut().enumerate() {
        d.apply(format!("motor[{k}].idle_w"), &mut m.idle_w);
        d.apply(format!("motor[{k}].iron_w_at_ref"), &mut m.iron_w_at_ref);
        d.apply(format!("motor[{k}].low_speed_w"), &mut m.low_speed_w);
        d.apply(format!("motor[{k}].load_w_per_kw"), &mut m.load_w_per_kw);
    }
    for (k, c) in p.laws.cutting.iter_mut().enumerate() {
        d.apply(format!("cutting[{k}]"), &mut c.1);
    }
    for a in &mut p.axes {
        for (k, c) in a.um_per_k.iter_mut().enumerate() {
            d.apply(format!("{}[{k}]", a.name), c);
        }
    }
    for (k, s) in p.sensors.iter_mut().enumerate() {
        d.apply(format!("T{}.tau_s", k + 1), &mut s.tau_s);
    }
    (p, d.drawn)
}

#[cfg(test)]
mod tests {
    use super::super::catalogue;
    use super::*;

    #[test]
    fn mismatch_stays_within_its_band_and_covers_the_effect_like_parameters() {
        let p = catalogue::plant("b").unwrap();
        let (m, f) = mismatched(&p, 10.0, 7);
        // Every factor within +-10 % (uniform draws, so strictly inside).
        assert!(f.iter().all(|x| (x.factor - 1.0).abs() <= 0.1), "{f:?}");
        // ... and they do use the band: with ~70 draws the widest is near 10 %.
        let widest = f.iter().map(|x| (x.factor - 1.0).abs()).fold(0.0, f64::max);
        assert!(widest > 0.08, "{widest}");
        for name in [
            "motor[0].low_speed_w",
            "friction[0].w_at_ref",
            "jacket.g_coolant_w_per_k",
            "column.c_j_per_k",
            "link 4-6",
        ] {
            assert!(f.iter().any(|x| x.name == name), "{name}");
        }
        let ratio = m.laws.motors[0].low_speed_w / p.laws.motors[0].low_speed_w;
        assert!((0.9..=1.1).contains(&ratio) && ratio != 1.0, "{ratio}");
        // Zero mismatch is the nominal plant; another seed, other factors.
        assert_eq!(mismatched(&p, 0.0, 7).0, p);
        assert_ne!(mismatched(&p, 10.0, 8).0, m);
    }
}
