//! MacKinnon's response surfaces for the Dickey-Fuller distribution, for
//! the test with a constant (`regression = "c"`) and one series (`N = 1`).
//!
//! * Approximate p-values: MacKinnon, J. G. (1994), "Approximate asymptotic
//!   distribution functions for unit-root and cointegration tests",
//!   *Journal of Business & Economic Statistics* 12, 167-176. The p-value
//!   is `Phi(g(tau))` with `g` a polynomial in the statistic: quadratic below
//!   `TAU_STAR`, cubic above; 0 below `TAU_MIN` and 1 above `TAU_MAX`.
//! * Finite-sample critical values: MacKinnon, J. G. (2010), "Critical
//!   values for cointegration tests", Queen's Economics Department Working
//!   Paper 1227, Table 2: `c(n) = b0 + b1/n + b2/n^2 + b3/n^3`.
//!
//! The numbers are the published coefficients (data, not code), as tabulated
//! with the scalings applied in statsmodels 0.15.0 (`statsmodels.tsa.adfvalues`),
//! whose `adfuller` our tests compare against.

/// Below this statistic the p-value is 0 (MacKinnon 1994, "c", N = 1).
const TAU_MIN: f64 = -18.83;
/// Above this statistic the p-value is 1.
const TAU_MAX: f64 = 2.74;
/// Where the small-p (quadratic) and large-p (cubic) surfaces meet.
const TAU_STAR: f64 = -1.61;
/// Small-p surface, `g = c0 + c1 tau + c2 tau^2` (MacKinnon 1994 Table 3, scaled).
const SMALL_P: [f64; 3] = [2.1659, 1.4412, 0.038269];
/// Large-p surface, `g = c0 + c1 tau + c2 tau^2 + c3 tau^3` (MacKinnon 1994 Table 4, scaled).
const LARGE_P: [f64; 4] = [1.7339, 0.93202, -0.12745, -0.010368];
/// Critical values at 1 %, 5 %, 10 % (MacKinnon 2010 Table 2, "c", N = 1):
/// `[b0, b1, b2, b3]` per level.
const CRIT_2010: [[f64; 4]; 3] = [
    [-3.43035, -6.5393, -16.786, -79.433],
    [-2.86154, -2.8903, -4.234, -40.04],
    [-2.56677, -1.5384, -2.809, 0.0],
];
/// The levels of [`CRIT_2010`], as statsmodels names them.
pub const CRIT_LEVELS: [&str; 3] = ["1%", "5%", "10%"];

fn poly(c: &[f64], x: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, v| acc * x + v)
}

/// Approximate p-value of an ADF statistic (constant, no trend).
pub fn pvalue(tau: f64) -> f64 {
    if tau.is_nan() {
        return f64::NAN;
    }
    if tau > TAU_MAX {
        return 1.0;
    }
    if tau < TAU_MIN {
        return 0.0;
    }
    let g = if tau <= TAU_STAR {
        poly(&SMALL_P, tau)
    } else {
        poly(&LARGE_P, tau)
    };
    normal_cdf(g)
}

/// Critical values at 1 %, 5 % and 10 % for a regression on `nobs` rows.
pub fn critical_values(nobs: usize) -> [f64; 3] {
    let n = nobs as f64;
    CRIT_2010.map(|b| b[0] + b[1] / n + b[2] / (n * n) + b[3] / (n * n * n))
}

/// Standard normal distribution function, to about 1e-15 relative.
pub fn normal_cdf(x: f64) -> f64 {
    0.5 * erfc(-x / std::f64::consts::SQRT_2)
}

/// Complementary error function. For `|t| < 3`: `1 - erf(t)` with the
/// all-positive series `erf(t) = 2/sqrt(pi) e^{-t^2} sum 2^n t^{2n+1} / (2n+1)!!`
/// (no cancellation inside the sum; `erfc(3) = 2.2e-5`, so at most ~5 digits
/// lost in `1 - erf`); beyond, Laplace's continued fraction
/// `erfc(t) = e^{-t^2}/sqrt(pi) / (t + (1/2)/(t + 1/(t + (3/2)/(t + ...))))`,
/// evaluated bottom-up (it converges fast for `t >= 3`).
pub fn erfc(t: f64) -> f64 {
    if t.is_nan() {
        return f64::NAN;
    }
    if t < 0.0 {
        return 2.0 - erfc(-t);
    }
    let inv_sqrt_pi = 1.0 / std::f64::consts::PI.sqrt();
    if t < 3.0 {
        let t2 = t * t;
        let mut term = t;
        let mut sum = t;
        let mut n = 0.0;
        while term > 1e-17 * sum {
            n += 1.0;
            term *= 2.0 * t2 / (2.0 * n + 1.0);
            sum += term;
        }
        1.0 - 2.0 * inv_sqrt_pi * (-t2).exp() * sum
    } else {
        let mut k = t;
        for i in (1..=80).rev() {
            k = t + (f64::from(i) / 2.0) / k;
        }
        inv_sqrt_pi * (-t * t).exp() / k
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_cdf_known_values() {
        // scipy.stats.norm.cdf 1.17.1.
        let cases = [
            (0.0, 0.5),
            (1.0, 0.8413447460685429),
            (-1.959963984540054, 0.025),
            (-3.0, 0.0013498980316300933),
            (-5.0, 2.866515718791933e-07),
            (-6.5, 4.016000583859088e-11),
            (2.5, 0.9937903346742238),
        ];
        for (x, want) in cases {
            let got = normal_cdf(x);
            assert!(((got - want) / want).abs() < 1e-13, "{x}: {got} vs {want}");
        }
    }

    #[test]
    fn pvalue_is_monotone_and_continuous_at_tau_star() {
        let below = pvalue(TAU_STAR - 1e-9);
        let above = pvalue(TAU_STAR + 1e-9);
        // The two published surfaces meet at TAU_STAR to about 1e-4.
        assert!((below - above).abs() < 1e-3, "{below} {above}");
        let mut last = 0.0;
        for i in 0..=200 {
            let p = pvalue(-20.0 + 0.12 * f64::from(i));
            assert!(p >= last);
            last = p;
        }
    }

    #[test]
    fn critical_values_large_sample_limit() {
        let c = critical_values(usize::MAX / 2);
        assert!((c[1] + 2.86154).abs() < 1e-9);
    }
}
