//! Shared helpers for the cross-crate tests: tolerances, a reproducible
//! random source, and reference implementations written independently of
//! model-core so that "two implementations agree" means something.

/// `|a - b| <= atol + rtol * |b|`, numpy's `isclose`.
pub fn isclose(a: f64, b: f64, rtol: f64, atol: f64) -> bool {
    (a - b).abs() <= atol + rtol * b.abs()
}

/// xorshift64*: small, fast and identical on every platform, so a test's
/// random input is the same in CI as on a developer's machine.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// A generator from a non-zero seed.
    pub fn new(seed: u64) -> Self {
        Self(seed.max(1))
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let x = self.0.wrapping_mul(0x2545_F491_4F6C_DD1D);
        (x >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Standard normal (Box-Muller).
    pub fn normal(&mut self) -> f64 {
        let u1 = self.uniform().max(f64::MIN_POSITIVE);
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

/// A random-walk temperature, deg C: `n` samples starting at `start_c`, steps
/// of standard deviation `step_c`, reflected into `[lo_c, hi_c]` so a day of
/// samples stays in a machine's range.
pub fn random_walk(
    rng: &mut Rng,
    n: usize,
    start_c: f64,
    step_c: f64,
    lo_c: f64,
    hi_c: f64,
) -> Vec<f64> {
    let mut t = start_c;
    (0..n)
        .map(|_| {
            let v = t;
            t += step_c * rng.normal();
            if t > hi_c {
                t = 2.0 * hi_c - t;
            }
            if t < lo_c {
                t = 2.0 * lo_c - t;
            }
            v
        })
        .collect()
}

/// Seed 004 Eq. 1 run exactly as printed, with no cancellation and no
/// normalisation tricks: `b0 y(k) = sum a_i u(k-i) - sum b_j y(k-j)`, zero
/// initial history, in precision `F`. The reference the firmware path is held to.
pub fn direct_form<F>(a: &[f64], b: &[f64], u: &[f64]) -> Vec<f64>
where
    F: Copy
        + From<f32>
        + std::ops::Add<Output = F>
        + std::ops::Sub<Output = F>
        + std::ops::Mul<Output = F>
        + std::ops::Div<Output = F>
        + Into<f64>
        + FromF64,
{
    let a: Vec<F> = a.iter().map(|v| F::from_f64(*v)).collect();
    let b: Vec<F> = b.iter().map(|v| F::from_f64(*v)).collect();
    let u: Vec<F> = u.iter().map(|v| F::from_f64(*v)).collect();
    let zero = F::from(0.0f32);
    let mut y: Vec<F> = Vec::with_capacity(u.len());
    for k in 0..u.len() {
        let mut acc = zero;
        for (i, ai) in a.iter().enumerate() {
            if k >= i {
                acc = acc + *ai * u[k - i];
            }
        }
        for (j, bj) in b.iter().enumerate().skip(1) {
            if k >= j {
                acc = acc - *bj * y[k - j];
            }
        }
        y.push(acc / b[0]);
    }
    y.into_iter().map(Into::into).collect()
}

/// Conversion from f64 for [`direct_form`]'s precisions.
pub trait FromF64 {
    /// Rounds `v` to this precision.
    fn from_f64(v: f64) -> Self;
}

impl FromF64 for f64 {
    fn from_f64(v: f64) -> Self {
        v
    }
}

impl FromF64 for f32 {
    fn from_f64(v: f64) -> Self {
        v as f32
    }
}
