//! Stationarity and invertibility by construction (Jones 1980; Monahan
//! 1984): an AR polynomial `1 - phi_1 B - ... - phi_p B^p` is stationary if
//! and only if its partial autocorrelations `r_1..r_p` all lie in (-1, 1),
//! and the map between the two is the Durbin-Levinson step
//!
//! ```text
//! phi^(k)_k = r_k,   phi^(k)_j = phi^(k-1)_j - r_k phi^(k-1)_{k-j}   (j < k)
//! ```
//!
//! The optimiser works on unconstrained `u`, with `r = u / sqrt(1 + u^2)`.
//! The MA polynomial `1 + theta_1 B + ...` is invertible iff
//! `1 - (-theta_1) B - ...` is stationary, so `theta = -phi(u)`.

/// Largest `|u|` the optimiser may use (`|r| <= 1 - 5e-9`). A root can
/// still come closer to the unit circle than the blob's 1e-9 margin; the
/// trainer checks the final model and says so if it does.
pub const U_MAX: f64 = 1e4;

/// AR coefficients from partial autocorrelations.
pub fn pacf_to_ar(r: &[f64]) -> Vec<f64> {
    let mut phi: Vec<f64> = Vec::with_capacity(r.len());
    for (k, &rk) in r.iter().enumerate() {
        let prev = phi.clone();
        for j in 0..k {
            phi[j] = prev[j] - rk * prev[k - 1 - j];
        }
        phi.push(rk);
    }
    phi
}

/// Partial autocorrelations of an AR polynomial (the step-down recursion);
/// `None` if it is not stationary (some `|r_k| >= 1`).
pub fn ar_to_pacf(phi: &[f64]) -> Option<Vec<f64>> {
    let mut a = phi.to_vec();
    let mut r = vec![0.0; phi.len()];
    for k in (0..phi.len()).rev() {
        let rk = a[k];
        if rk.is_nan() || rk.abs() >= 1.0 {
            return None;
        }
        r[k] = rk;
        let den = 1.0 - rk * rk;
        let prev = a.clone();
        for j in 0..k {
            a[j] = (prev[j] + rk * prev[k - 1 - j]) / den;
        }
        a.truncate(k);
    }
    Some(r)
}

fn to_r(u: f64) -> f64 {
    let u = u.clamp(-U_MAX, U_MAX);
    u / (1.0 + u * u).sqrt()
}

fn to_u(r: f64) -> f64 {
    (r / (1.0 - r * r).sqrt()).clamp(-U_MAX, U_MAX)
}

/// `(phi, theta)` from the optimiser's unconstrained vector (`p` AR first).
pub fn constrain(u: &[f64], p: usize) -> (Vec<f64>, Vec<f64>) {
    let (a, m) = u.split_at(p.min(u.len()));
    let phi = pacf_to_ar(&a.iter().map(|v| to_r(*v)).collect::<Vec<_>>());
    let theta = pacf_to_ar(&m.iter().map(|v| to_r(*v)).collect::<Vec<_>>())
        .into_iter()
        .map(|v| -v)
        .collect();
    (phi, theta)
}

/// The inverse of [`constrain`]; `None` if `phi` is not stationary or
/// `theta` not invertible.
pub fn unconstrain(phi: &[f64], theta: &[f64]) -> Option<Vec<f64>> {
    let ra = ar_to_pacf(phi)?;
    let rm = ar_to_pacf(&theta.iter().map(|v| -v).collect::<Vec<_>>())?;
    Some(ra.into_iter().chain(rm).map(to_u).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip() {
        let u = [0.3, -1.2, 2.0, 0.7, -0.4];
        let (phi, theta) = constrain(&u, 3);
        let back = unconstrain(&phi, &theta).unwrap();
        for (a, b) in u.iter().zip(&back) {
            assert!((a - b).abs() < 1e-10, "{a} {b}");
        }
    }

    #[test]
    fn ar2_example() {
        // r = (0.5, 0.2): phi_1 = 0.5 - 0.2 * 0.5 = 0.4, phi_2 = 0.2.
        let phi = pacf_to_ar(&[0.5, 0.2]);
        assert!((phi[0] - 0.4).abs() < 1e-15 && (phi[1] - 0.2).abs() < 1e-15);
        assert!(ar_to_pacf(&[1.2]).is_none());
        assert!(ar_to_pacf(&[0.5, 0.6]).is_none()); // 1 - 0.5B - 0.6B^2 has a root inside
    }
}
