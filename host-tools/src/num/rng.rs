//! Deterministic pseudo-random numbers (SplitMix64) for the trainers and
//! the thermal twin.
//!
//! Training must give the same blob, and the twin the same run, for the
//! same `--seed` on every machine, so the generator is written out here (Steele, Lea & Flood 2014, the
//! generator Java's `SplittableRandom` uses): 64 bits of state, passes
//! BigCrush, and nothing in it depends on a crate version or the platform.

/// SplitMix64 generator.
#[derive(Clone, Debug)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    /// A generator whose whole output is fixed by `seed`.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform on [0, 1), 53 bits.
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform on [-1, 1): MATLAB's `rands`.
    pub fn symmetric(&mut self) -> f64 {
        2.0 * self.uniform() - 1.0
    }

    /// Uniform integer in `0..n` (`n > 0`).
    pub fn below(&mut self, n: usize) -> usize {
        ((self.uniform() * n as f64) as usize).min(n.saturating_sub(1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reference_values_of_splitmix64() {
        // First outputs for seed 0, as published with the reference C code
        // (and Java's SplittableRandom): exact.
        let mut r = SplitMix64::new(0);
        assert_eq!(r.next_u64(), 0xE220_A839_7B1D_CDAF);
        assert_eq!(r.next_u64(), 0x6E78_9E6A_A1B9_65F4);
    }

    #[test]
    fn uniform_stays_in_range_and_has_the_right_mean() {
        let mut r = SplitMix64::new(7);
        let v: Vec<f64> = (0..20_000).map(|_| r.uniform()).collect();
        assert!(v.iter().all(|u| (0.0..1.0).contains(u)));
        // Mean of 20 000 uniforms: sd 0.29/sqrt(20000) = 0.002; 5 sd.
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        assert!((mean - 0.5).abs() < 0.01, "{mean}");
        assert!((0..1000).all(|_| r.below(3) < 3));
    }
}
