//! Temperature sensors of a plant: on a node, between two places (a pad on
//! a casting between the spindle cartridge and the column, an oil-return
//! sensor between a bearing and the supply), or in the air; each behind its
//! own first-order time constant, and in the real machine with white noise
//! and a slow drift.
//!
//! The lag `tau ds/dt = T_site - s` is integrated exactly for a site
//! temperature varying linearly between rows:
//!
//! ```text
//! s(k+1) = a s(k) + (1 - a) T(k) + (T(k+1) - T(k)) (1 - tau (1 - a) / dt),   a = exp(-dt/tau)
//! ```

use super::network::Site;
use super::noise::Gauss;

/// One temperature sensor.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensor {
    /// Where it sits.
    pub at: Site,
    /// Where its reading leans to (the same as `at` for a plain sensor).
    pub toward: Site,
    /// Weight of `toward`: reading `(1 - share) T(at) + share T(toward)`.
    pub share: f64,
    /// First-order time constant, s.
    pub tau_s: f64,
}

/// Noise of a channel in the real machine.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelNoise {
    /// White noise, one sigma (K or um).
    pub white: f64,
    /// Standard deviation of the slow drift (K or um).
    pub drift: f64,
    /// Correlation time of the drift, s.
    pub drift_tau_s: f64,
}

impl Sensor {
    /// A sensor on node `i`.
    pub fn on(i: usize, tau_s: f64) -> Self {
        Sensor {
            at: Site::Node(i),
            toward: Site::Node(i),
            share: 0.0,
            tau_s,
        }
    }

    /// A sensor between `a` and `b`, `share` of the way to `b`.
    pub fn between(a: Site, b: Site, share: f64, tau_s: f64) -> Self {
        Sensor {
            at: a,
            toward: b,
            share,
            tau_s,
        }
    }

    /// A sensor in the room air.
    pub fn air(tau_s: f64) -> Self {
        Sensor::between(Site::Ambient, Site::Ambient, 0.0, tau_s)
    }

    /// Whether this is the air sensor (dropped with the boundary columns
    /// when a machine does not log its surroundings).
    pub fn is_air(&self) -> bool {
        self.at == Site::Ambient && self.toward == Site::Ambient
    }

    /// The temperature at the sensor's place, deg C.
    pub fn site_c(&self, x: &[f64], ta: f64, tc: f64) -> f64 {
        let at = |s: Site| match s {
            Site::Node(i) => x[i],
            Site::Ambient => ta,
            Site::Coolant => tc,
        };
        (1.0 - self.share) * at(self.at) + self.share * at(self.toward)
    }
}

/// `site` (one value per row of `t_s`) seen through a first-order lag of
/// `tau_s`, starting at the site's first value.
pub fn lagged(t_s: &[f64], site: &[f64], tau_s: f64) -> Vec<f64> {
    let mut out = Vec::with_capacity(site.len());
    let Some(&first) = site.first() else {
        return out;
    };
    let mut s = first;
    out.push(s);
    for k in 1..site.len() {
        let dt = t_s[k] - t_s[k - 1];
        if tau_s <= 0.0 || dt <= 0.0 {
            s = site[k];
        } else {
            let a = (-dt / tau_s).exp();
            let slope_w = 1.0 - tau_s * (1.0 - a) / dt;
            s = a * s + (1.0 - a) * site[k - 1] + (site[k] - site[k - 1]) * slope_w;
        }
        out.push(s);
    }
    out
}

/// Adds white noise and a slow drift to `x` (rows `dt_s` apart).
pub fn add_noise(x: &mut [f64], dt_s: f64, noise: &ChannelNoise, g: &mut Gauss) {
    let drift = g.wander(x.len(), dt_s, noise.drift_tau_s, noise.drift);
    for (v, d) in x.iter_mut().zip(drift) {
        *v += d + noise.white * g.normal();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lagged_sensor_follows_a_step_with_its_time_constant() {
        // A step at t = 0 (held from row 1 on): after tau the sensor shows
        // 1 - e^-1 of it. With a first-order hold the step is a 1 s ramp,
        // which delays the response by ~0.5 s: 0.5/600 of the slope e^-1
        // = 3e-4; the bound 1e-3 covers it.
        let t: Vec<f64> = (0..=1200).map(f64::from).collect();
        let site: Vec<f64> = t.iter().map(|&v| if v > 0.0 { 1.0 } else { 0.0 }).collect();
        let s = lagged(&t, &site, 600.0);
        assert!(
            (s[600] - (1.0 - (-1.0f64).exp())).abs() < 1e-3,
            "{}",
            s[600]
        );
        // A ramp is followed with the lag tau once settled: s = T(t - tau).
        let ramp: Vec<f64> = t.iter().map(|&v| 0.01 * v).collect();
        let s = lagged(&t, &ramp, 60.0);
        assert!(
            (s[1200] - 0.01 * (1200.0 - 60.0)).abs() < 1e-6,
            "{}",
            s[1200]
        );
    }

    #[test]
    fn a_sensor_between_two_places_weighs_them() {
        let s = Sensor::between(Site::Node(1), Site::Coolant, 0.25, 10.0);
        assert!((s.site_c(&[0.0, 30.0], 20.0, 18.0) - 27.0).abs() < 1e-12);
        assert!(Sensor::air(60.0).is_air() && !s.is_air());
    }
}
