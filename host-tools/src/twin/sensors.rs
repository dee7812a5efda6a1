//! Temperature sensors T1..Tn: placed on nodes (or between two of them, or
//! on a boundary), read with Gaussian noise from a seeded PRNG, optionally
//! behind a first-order lag (`sensor_lag`: a sensor in poor thermal contact
//! with the part it sits on).
//!
//! The lag `tau ds/dt = T_site - s` is discretised exactly for a site
//! temperature varying linearly over the step (first-order hold):
//!
//! ```text
//! s(k+1) = a s(k) + (1 - a) T(k) + (T(k+1) - T(k)) (1 - tau (1 - a) / dt),  a = e^(-dt/tau)
//! ```
//!
//! Sensors on the ambient air or the coolant supply do not lag: the effect is
//! about contact with a part.

use super::machine::{SensorSite, Site};
use super::network::State;
use super::rng::{Rng, Stream};

/// The sensors of one run.
#[derive(Debug, Clone)]
pub struct SensorBank {
    sites: Vec<SensorSite>,
    noise_c: f64,
    lag_tau_s: Option<f64>,
    /// Lagged temperatures and the site temperatures they last saw.
    lagged: Vec<(f64, f64)>,
    rng: Rng,
}

/// The temperature at a place.
fn place_c(place: Site, t: &State, ambient_c: f64, coolant_c: f64) -> f64 {
    match place {
        Site::Node(n) => t[n.index()],
        Site::Ambient => ambient_c,
        Site::Coolant => coolant_c,
    }
}

/// Whether a sensor at `s` is on a part (so it can lag).
fn on_part(s: &SensorSite) -> bool {
    matches!(s.node, Site::Node(_)) || matches!(s.toward, Site::Node(_))
}

impl SensorBank {
    /// `sites` read with `noise_c` (one sigma) and, if given, a lag.
    pub fn new(sites: &[SensorSite], noise_c: f64, lag_tau_s: Option<f64>, seed: u64) -> Self {
        SensorBank {
            sites: sites.to_vec(),
            noise_c,
            lag_tau_s,
            lagged: Vec::new(),
            rng: Rng::new(seed, Stream::SensorNoise),
        }
    }

    /// Number of sensors.
    pub fn len(&self) -> usize {
        self.sites.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.sites.is_empty()
    }

    /// True temperature at sensor `i`'s site (no lag, no noise).
    pub fn site_c(&self, i: usize, t: &State, ambient_c: f64, coolant_c: f64) -> f64 {
        let s = &self.sites[i];
        (1.0 - s.share) * place_c(s.node, t, ambient_c, coolant_c)
            + s.share * place_c(s.toward, t, ambient_c, coolant_c)
            + s.offset_c
    }

    /// Reads every sensor into `out` after a step of `dt_s` (ignored on the
    /// first read, which starts the lags at the site temperatures).
    pub fn read(
        &mut self,
        t: &State,
        ambient_c: f64,
        coolant_c: f64,
        dt_s: f64,
        out: &mut Vec<f64>,
    ) {
        out.clear();
        let first = self.lagged.is_empty();
        for i in 0..self.sites.len() {
            let site = self.site_c(i, t, ambient_c, coolant_c);
            let value = match self.lag_tau_s {
                Some(tau) if on_part(&self.sites[i]) => {
                    if first {
                        self.lagged.push((site, site));
                        site
                    } else {
                        let (s, prev) = self.lagged[i];
                        let s = lag_step(s, prev, site, dt_s, tau);
                        self.lagged[i] = (s, site);
                        s
                    }
                }
                _ => {
                    if first {
                        self.lagged.push((site, site));
                    }
                    site
                }
            };
            out.push(value + self.noise_c * self.rng.normal());
        }
    }
}

/// One step of the first-order lag `tau ds/dt = T - s` (module docs): the
/// lagged value `s` and the site temperature `prev` at the step's start, the
/// site temperature `now` at its end, which is `dt_s` later.
pub fn lag_step(s: f64, prev: f64, now: f64, dt_s: f64, tau_s: f64) -> f64 {
    let a = (-dt_s / tau_s).exp();
    // 1 - tau (1 - a) / dt, written to stay accurate for dt << tau.
    let ramp = 1.0 + tau_s / dt_s * (-dt_s / tau_s).exp_m1();
    a * s + (1.0 - a) * prev + (now - prev) * ramp
}

/// The node a site mostly reflects, for labels.
pub fn site_label(s: &SensorSite) -> String {
    let name = |p: Site| match p {
        Site::Node(n) => n.name(),
        Site::Ambient => "ambient",
        Site::Coolant => "coolant",
    };
    if s.share > 0.0 && s.toward != s.node {
        format!(
            "{} ({:.0} % toward {})",
            name(s.node),
            s.share * 100.0,
            name(s.toward)
        )
    } else {
        name(s.node).to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::twin::machine::Node;

    #[test]
    fn lag_of_a_ramp_is_tau_behind() {
        // A ramp r t through a first-order lag settles at r (t - tau).
        let site = SensorSite {
            node: Site::Node(Node::Motor),
            toward: Site::Node(Node::Motor),
            share: 0.0,
            offset_c: 0.0,
        };
        let tau = 600.0;
        let mut bank = SensorBank::new(&[site], 0.0, Some(tau), 1);
        let mut out = Vec::new();
        let (rate, dt) = (1e-3, 7.0);
        let mut t = State::zeros();
        let mut k = 0.0;
        while k * dt < 40.0 * tau {
            t[Node::Motor.index()] = rate * k * dt;
            bank.read(&t, 0.0, 0.0, dt, &mut out);
            k += 1.0;
        }
        let lag_c = t[Node::Motor.index()] - out[0];
        assert!((lag_c - rate * tau).abs() < 1e-9, "{lag_c}");
    }
}
