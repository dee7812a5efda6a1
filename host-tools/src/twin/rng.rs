//! The twin's seeded streams: the crate's SplitMix64 ([`crate::num::rng`]) with
//! Gaussian (Box–Muller) and exponential draws, so runs are reproducible
//! from `--seed` with no extra dependency and no change between library
//! versions.
//!
//! Each purpose (sensor noise, probe noise, the speed spectrum, door
//! openings) draws from its own stream, so switching an effect on never
//! shifts the noise of another column.

/// Independent streams derived from one seed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stream {
    /// Temperature sensor noise.
    SensorNoise = 1,
    /// Eddy-current probe noise.
    ProbeNoise = 2,
    /// The `spectrum` profile's speeds and durations.
    Spectrum = 3,
    /// Door openings of the `ambient` effect.
    Doors = 4,
    /// The ambient and coolant sensors' noise (the boundary columns).
    BoundaryNoise = 5,
}

use crate::num::rng::SplitMix64;

/// One stream's generator.
#[derive(Debug, Clone)]
pub struct Rng {
    bits: SplitMix64,
    spare: Option<f64>,
}

impl Rng {
    /// The generator for `stream` of `seed`.
    pub fn new(seed: u64, stream: Stream) -> Rng {
        let mut r = Rng {
            bits: SplitMix64::new(seed ^ (stream as u64).wrapping_mul(0xD1B5_4A32_D192_ED03)),
            spare: None,
        };
        // Decorrelate nearby seeds.
        r.next_u64();
        r
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.bits.next_u64()
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        self.bits.uniform()
    }

    /// Uniform index in 0..n (n > 0).
    pub fn below(&mut self, n: usize) -> usize {
        self.bits.below(n)
    }

    /// Standard normal draw.
    pub fn normal(&mut self) -> f64 {
        if let Some(z) = self.spare.take() {
            return z;
        }
        // u1 in (0, 1] so the log is finite.
        let u1 = 1.0 - self.uniform();
        let u2 = self.uniform();
        let r = (-2.0 * u1.ln()).sqrt();
        let (s, c) = (std::f64::consts::TAU * u2).sin_cos();
        self.spare = Some(r * s);
        r * c
    }

    /// Exponential draw with the given mean.
    pub fn exponential(&mut self, mean: f64) -> f64 {
        -mean * (1.0 - self.uniform()).ln()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_has_unit_moments() {
        let mut r = Rng::new(7, Stream::SensorNoise);
        let n = 200_000;
        let v: Vec<f64> = (0..n).map(|_| r.normal()).collect();
        let mean = v.iter().sum::<f64>() / n as f64;
        let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        // 5 standard errors.
        assert!(mean.abs() < 5.0 / (n as f64).sqrt(), "{mean}");
        assert!((var - 1.0).abs() < 5.0 * (2.0 / n as f64).sqrt(), "{var}");
    }

    #[test]
    fn streams_differ() {
        let a = Rng::new(1, Stream::SensorNoise).next_u64();
        let b = Rng::new(1, Stream::ProbeNoise).next_u64();
        assert_ne!(a, b);
    }
}
