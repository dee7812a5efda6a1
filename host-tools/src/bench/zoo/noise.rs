//! Random numbers for the zoo: Gaussian draws and slow Ornstein-Uhlenbeck
//! wanders (sensor drift, weather), on the crate's SplitMix64.

use crate::num::rng::SplitMix64;

/// A seeded source of uniform and Gaussian numbers.
#[derive(Debug, Clone)]
pub struct Gauss {
    rng: SplitMix64,
    spare: Option<f64>,
}

/// Seed of stream `stream` of a case seed: streams never share numbers.
pub fn stream_seed(seed: u64, stream: u64) -> u64 {
    let mut r = SplitMix64::new(seed ^ stream.wrapping_mul(0xA24B_AED4_963E_E407));
    r.next_u64()
}

impl Gauss {
    /// Stream `stream` of `seed`.
    pub fn new(seed: u64, stream: u64) -> Self {
        Gauss {
            rng: SplitMix64::new(stream_seed(seed, stream)),
            spare: None,
        }
    }

    /// Uniform on [0, 1).
    pub fn uniform(&mut self) -> f64 {
        self.rng.uniform()
    }

    /// Uniform on [-1, 1).
    pub fn symmetric(&mut self) -> f64 {
        self.rng.symmetric()
    }

    /// Uniform integer in `0..n`.
    pub fn below(&mut self, n: usize) -> usize {
        self.rng.below(n)
    }

    /// Standard normal (Box-Muller, both values used).
    pub fn normal(&mut self) -> f64 {
        if let Some(z) = self.spare.take() {
            return z;
        }
        let u1 = (1.0 - self.rng.uniform()).max(f64::MIN_POSITIVE);
        let u2 = self.rng.uniform();
        let r = (-2.0 * u1.ln()).sqrt();
        let a = std::f64::consts::TAU * u2;
        self.spare = Some(r * a.sin());
        r * a.cos()
    }

    /// `n` samples `dt_s` apart of a stationary Ornstein-Uhlenbeck process
    /// with standard deviation `sd` and correlation time `tau_s`, starting
    /// at 0 (a drift that appears during the run).
    pub fn wander(&mut self, n: usize, dt_s: f64, tau_s: f64, sd: f64) -> Vec<f64> {
        let a = (-dt_s / tau_s.max(1e-9)).exp();
        let kick = sd * (1.0 - a * a).sqrt();
        let mut x = 0.0;
        (0..n)
            .map(|_| {
                let v = x;
                x = a * x + kick * self.normal();
                v
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_draws_have_unit_variance_and_wanders_their_sd() {
        // 40 000 draws: sd of the variance estimate ~ sqrt(2/40000) = 0.007;
        // 0.03 is > 4 of them.
        let mut g = Gauss::new(5, 1);
        let v: Vec<f64> = (0..40_000).map(|_| g.normal()).collect();
        let var = v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64;
        assert!((var - 1.0).abs() < 0.03, "{var}");
        // A wander of 200 000 steps at dt = tau/10 has ~10 000 independent
        // stretches: its sd is within 5 % of the asked 0.5.
        let w = g.wander(200_000, 60.0, 600.0, 0.5);
        let sd = (w.iter().map(|x| x * x).sum::<f64>() / w.len() as f64).sqrt();
        assert!((sd - 0.5).abs() < 0.025, "{sd}");
        assert_eq!(w[0], 0.0);
    }
}
