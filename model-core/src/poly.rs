//! Polynomials in the backward shift `q = z^-1`: evaluation, roots, deflation.
//!
//! A discrete transfer function is a ratio of two such polynomials,
//! `c0 + c1 q + ... + cn q^n`. Its poles and zeros are the roots `z` of the
//! matching polynomial in `z`, `c0 z^n + c1 z^(n-1) + ... + cn`, so the same
//! coefficient slice serves both views. Roots are found by the Durand-Kerner
//! (Weierstrass) iteration, which needs no allocation and converges for the
//! low orders used here (at most [`MAX_ORDER`]); a factor `(1 - r q)` is
//! removed by synthetic division.

/// Highest polynomial order whose roots are found: transfer functions
/// (order <= 8) and ARMA's AR/MA polynomials (order <= 10).
pub const MAX_ORDER: usize = 10;

/// A complex number, just enough arithmetic for root finding.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Complex {
    /// Real part.
    pub re: f64,
    /// Imaginary part.
    pub im: f64,
}

impl Complex {
    /// `re + i im`.
    pub const fn new(re: f64, im: f64) -> Self {
        Self { re, im }
    }

    /// Modulus `|z|`, without overflow for large parts.
    pub fn abs(self) -> f64 {
        libm::hypot(self.re, self.im)
    }

    fn add(self, o: Self) -> Self {
        Self::new(self.re + o.re, self.im + o.im)
    }

    fn sub(self, o: Self) -> Self {
        Self::new(self.re - o.re, self.im - o.im)
    }

    fn mul(self, o: Self) -> Self {
        Self::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }

    fn div(self, o: Self) -> Self {
        // Smith's algorithm: avoids overflow/underflow of |o|^2.
        if libm::fabs(o.re) >= libm::fabs(o.im) {
            let r = o.im / o.re;
            let d = o.re + o.im * r;
            Self::new((self.re + self.im * r) / d, (self.im - self.re * r) / d)
        } else {
            let r = o.re / o.im;
            let d = o.re * r + o.im;
            Self::new((self.re * r + self.im) / d, (self.im * r - self.re) / d)
        }
    }
}

/// The roots of one polynomial, at most [`MAX_ORDER`] of them.
#[derive(Clone, Copy, Debug)]
pub struct Roots {
    roots: [Complex; MAX_ORDER],
    len: usize,
}

impl Roots {
    /// The roots found.
    pub fn as_slice(&self) -> &[Complex] {
        self.roots.get(..self.len).unwrap_or(&[])
    }
}

/// Why roots could not be found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RootsError {
    /// More than [`MAX_ORDER`] roots would be needed.
    OrderTooHigh,
    /// A coefficient is NaN or infinite.
    NonFinite,
    /// The iteration did not settle (pathological coefficients).
    NoConvergence,
}

/// Trims exact trailing zeros: `c0 + c1 q + 0 q^2` has order 1.
pub fn trim(coeffs: &[f64]) -> &[f64] {
    let mut end = coeffs.len();
    while end > 0 && coeffs.get(end - 1) == Some(&0.0) {
        end -= 1;
    }
    coeffs.get(..end).unwrap_or(&[])
}

/// `c(1) = sum c_i`: the polynomial at `z = 1` (the steady-state gain factor).
pub fn sum(coeffs: &[f64]) -> f64 {
    coeffs.iter().sum()
}

/// The polynomial at `z = -1` (`q = -1`).
pub fn alternating_sum(coeffs: &[f64]) -> f64 {
    coeffs
        .iter()
        .enumerate()
        .map(|(i, c)| if i % 2 == 0 { *c } else { -*c })
        .sum()
}

/// Sum of absolute coefficients: the scale against which "zero" is judged.
pub fn abs_sum(coeffs: &[f64]) -> f64 {
    coeffs.iter().map(|c| libm::fabs(*c)).sum()
}

/// Roots `z` of `c0 z^n + ... + cn` (exact leading zeros, i.e. pure delays,
/// and exact trailing zeros are not roots on the unit circle and are skipped).
pub fn roots(coeffs: &[f64]) -> Result<Roots, RootsError> {
    if coeffs.iter().any(|c| !c.is_finite()) {
        return Err(RootsError::NonFinite);
    }
    let trimmed = trim(coeffs);
    let first = trimmed
        .iter()
        .position(|c| *c != 0.0)
        .unwrap_or(trimmed.len());
    let poly = trimmed.get(first..).unwrap_or(&[]);
    let mut out = Roots {
        roots: [Complex::new(0.0, 0.0); MAX_ORDER],
        len: 0,
    };
    let Some((&lead, rest)) = poly.split_first() else {
        return Ok(out);
    };
    let n = rest.len();
    if n > MAX_ORDER {
        return Err(RootsError::OrderTooHigh);
    }
    // Monic coefficients m_1..m_n of z^n + m_1 z^(n-1) + ... + m_n.
    let mut monic = [0.0; MAX_ORDER];
    for (m, c) in monic.iter_mut().zip(rest) {
        *m = c / lead;
    }
    let eval = |z: Complex| {
        let mut acc = Complex::new(1.0, 0.0);
        for m in monic.iter().take(n) {
            acc = acc.mul(z).add(Complex::new(*m, 0.0));
        }
        acc
    };
    // Start points on a circle of the Cauchy bound's radius, off the real axis
    // so conjugate pairs separate (the classic 0.4 + 0.9i seed, scaled).
    let radius = 1.0
        + monic
            .iter()
            .take(n)
            .fold(0.0_f64, |a, m| a.max(libm::fabs(*m)));
    let seed = Complex::new(0.4, 0.9);
    let mut z = [Complex::new(0.0, 0.0); MAX_ORDER];
    let mut p = Complex::new(radius / seed.abs(), 0.0);
    for zi in z.iter_mut().take(n) {
        p = p.mul(seed);
        *zi = p;
    }
    const MAX_ITER: usize = 2000;
    let mut previous = f64::INFINITY;
    for _ in 0..MAX_ITER {
        let mut worst = 0.0_f64;
        for i in 0..n {
            let zi = z[i];
            let mut denom = Complex::new(1.0, 0.0);
            for (j, zj) in z.iter().enumerate().take(n) {
                if j != i {
                    denom = denom.mul(zi.sub(*zj));
                }
            }
            if denom.abs() == 0.0 {
                // Two iterates collided: nudge one apart and go on.
                z[i] = zi.add(Complex::new(1e-12, 1e-12));
                worst = f64::INFINITY;
                continue;
            }
            let step = eval(zi).div(denom);
            z[i] = zi.sub(step);
            worst = worst.max(step.abs() / (1.0 + zi.abs()));
        }
        if worst.is_nan() {
            return Err(RootsError::NoConvergence);
        }
        // Converged: steps at rounding level, or no longer shrinking once
        // small (rounding noise stalls the iteration short of 1e-15 for roots
        // near |z| = 1, and multiple roots only converge linearly).
        if worst < 1e-15 || (worst < 1e-9 && worst > 0.5 * previous) {
            break;
        }
        previous = worst;
    }
    // Multiple roots converge only linearly; accept what the iteration gives
    // (accurate to about sqrt(eps) there) as long as every root is finite.
    if z.iter()
        .take(n)
        .any(|r| !r.re.is_finite() || !r.im.is_finite())
    {
        return Err(RootsError::NoConvergence);
    }
    out.roots = z;
    out.len = n;
    Ok(out)
}

/// Removes the real factor `(1 - r q)` from `coeffs` in place by synthetic
/// division and returns the remainder (zero when `r` was an exact root).
/// The order drops by one; the caller truncates to `len - 1`.
pub fn deflate_real(coeffs: &mut [f64], r: f64) -> f64 {
    let n = coeffs.len();
    if n == 0 {
        return 0.0;
    }
    let mut prev = 0.0;
    for c in coeffs.iter_mut().take(n - 1) {
        *c += r * prev;
        prev = *c;
    }
    let rem = coeffs.get(n - 1).copied().unwrap_or(0.0) + r * prev;
    if let Some(last) = coeffs.get_mut(n - 1) {
        *last = 0.0;
    }
    rem
}

/// Removes the real quadratic factor `(1 - s q + p q^2)` of a conjugate root
/// pair (`s = 2 Re r`, `p = |r|^2`) in place; the order drops by two.
/// Returns the size of the remainder.
pub fn deflate_quadratic(coeffs: &mut [f64], s: f64, p: f64) -> f64 {
    let n = coeffs.len();
    if n < 3 {
        return coeffs.iter().map(|c| libm::fabs(*c)).sum();
    }
    // c_i = a_i + s c_(i-1) - p c_(i-2), for i = 0..n-3; remainders at n-2, n-1.
    let (mut c1, mut c2) = (0.0, 0.0);
    for c in coeffs.iter_mut().take(n - 2) {
        let v = *c + s * c1 - p * c2;
        *c = v;
        c2 = c1;
        c1 = v;
    }
    let r0 = coeffs.get(n - 2).copied().unwrap_or(0.0) + s * c1 - p * c2;
    let r1 = coeffs.get(n - 1).copied().unwrap_or(0.0) - p * c1;
    for c in coeffs.iter_mut().skip(n - 2) {
        *c = 0.0;
    }
    libm::fabs(r0) + libm::fabs(r1)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn has_root(r: &Roots, re: f64, im: f64, tol: f64) -> bool {
        r.as_slice()
            .iter()
            .any(|z| libm::hypot(z.re - re, z.im - im) < tol)
    }

    #[test]
    fn roots_of_known_polynomials() {
        // (z - 0.5)(z + 0.25)(z^2 - z + 0.5): roots 0.5, -0.25, 0.5 +- 0.5i.
        // Expanded by hand: z^4 - 1.25 z^3 + 0.625 z^2 + 0 z - 0.0625. Tolerance
        // 1e-12: simple roots converge quadratically to machine precision.
        let c = [1.0, -1.25, 0.625, 0.0, -0.0625];
        let r = roots(&c).unwrap();
        assert_eq!(r.as_slice().len(), 4);
        assert!(has_root(&r, 0.5, 0.0, 1e-12));
        assert!(has_root(&r, -0.25, 0.0, 1e-12));
        assert!(has_root(&r, 0.5, 0.5, 1e-12));
        assert!(has_root(&r, 0.5, -0.5, 1e-12));
    }

    #[test]
    fn double_root_found_to_sqrt_eps() {
        // (z - 1)^2: a double root converges linearly; 1e-7 ~ sqrt(eps).
        let r = roots(&[1.0, -2.0, 1.0]).unwrap();
        assert!(r
            .as_slice()
            .iter()
            .all(|z| z.sub(Complex::new(1.0, 0.0)).abs() < 1e-7));
    }

    #[test]
    fn delays_and_zero_roots_are_skipped() {
        // 0 + 0.5 q - 0.25 q^2 + 0 q^3: one root, z = 0.5.
        let r = roots(&[0.0, 0.5, -0.25, 0.0]).unwrap();
        assert_eq!(r.as_slice().len(), 1);
        assert!(has_root(&r, 0.5, 0.0, 1e-14));
    }

    #[test]
    fn deflation_removes_exact_factors() {
        // (1 - q)(1 - 0.9985 q) = 1 - 1.9985 q + 0.9985 q^2.
        let mut c = [1.0, -1.9985, 0.9985];
        let rem = deflate_real(&mut c, 1.0);
        assert!(rem.abs() < 1e-15, "remainder {rem}");
        assert!((c[1] + 0.9985).abs() < 1e-15);
        // (1 - q + 0.5 q^2)(1 - 0.5 q) = 1 - 1.5 q + q^2 - 0.25 q^3.
        let mut c = [1.0, -1.5, 1.0, -0.25];
        let rem = deflate_quadratic(&mut c, 1.0, 0.5);
        assert!(rem < 1e-15);
        assert_eq!(&c[..2], &[1.0, -0.5]);
    }

    #[test]
    fn garbage_is_an_error_not_a_panic() {
        assert_eq!(roots(&[1.0, f64::NAN]).unwrap_err(), RootsError::NonFinite);
        assert_eq!(roots(&[1.0; 12]).unwrap_err(), RootsError::OrderTooHigh);
        assert_eq!(roots(&[]).unwrap().as_slice().len(), 0);
        let _ = roots(&[1e300, -1e-300, 1e300]);
    }
}
