//! The two matrix decompositions the numerics use, made safe for any
//! input: the SVD and the symmetric eigen-decomposition, each refusing
//! non-finite entries and capped in iterations, so that a bad design ends
//! in a one-line error rather than a loop or a panic inside nalgebra.

use anyhow::{anyhow, bail, Result};
use nalgebra::{DMatrix, Dyn, SymmetricEigen, SVD};

/// Iteration cap of [`svd`] for a matrix whose smaller side is `k`: LAPACK's
/// bidiagonal QR allows 6 sweeps per singular value pair (`MAXITR = 6`,
/// dbdsqr), so `6 k^2` is generous for any data that converges at all.
fn svd_max_iterations(k: usize) -> usize {
    6 * k.max(1) * k.max(1) + 100
}

/// The eigen-decomposition of the symmetric matrix `a`, refusing
/// non-finite entries and capped in iterations like [`svd`].
pub fn symmetric_eigen(a: DMatrix<f64>) -> Result<SymmetricEigen<f64, Dyn>> {
    if a.iter().any(|v| !v.is_finite()) {
        bail!("eigen-decomposition: a non-finite entry (inputs too large?)");
    }
    let cap = svd_max_iterations(a.nrows());
    a.try_symmetric_eigen(f64::EPSILON, cap)
        .ok_or_else(|| anyhow!("eigen-decomposition: no convergence in {cap} iterations"))
}

/// The SVD of `a` (U and V computed), refusing non-finite entries and capped
/// in iterations, so that it ends with an error where nalgebra's `svd()`
/// would loop forever or panic on a NaN singular value. Singular values come
/// unordered: the callers only take their maximum and solve.
pub fn svd(a: DMatrix<f64>) -> Result<SVD<f64, Dyn, Dyn>> {
    // nalgebra panics on an empty matrix (no live column: every input
    // zero on the fit rows).
    if a.is_empty() {
        bail!("least squares: no column carries anything (every input is zero on the fit rows)");
    }
    if let Some(i) = a.iter().position(|v| !v.is_finite()) {
        bail!(
            "least squares: column {} of the scaled design matrix has a non-finite value (inputs too large?)",
            i / a.nrows().max(1) + 1
        );
    }
    let cap = svd_max_iterations(a.nrows().min(a.ncols()));
    let svd = a
        .try_svd_unordered(true, true, f64::EPSILON, cap)
        .ok_or_else(|| anyhow!("least squares: the SVD did not converge in {cap} iterations"))?;
    if svd.singular_values.iter().any(|v| !v.is_finite()) {
        bail!("least squares: the SVD gave non-finite singular values (inputs too large?)");
    }
    Ok(svd)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// nalgebra panics on an empty matrix; the wrapper says why instead.
    #[test]
    fn an_empty_matrix_is_an_error_not_a_panic() {
        for (r, c) in [(0, 3), (3, 0), (0, 0)] {
            let e = svd(DMatrix::zeros(r, c)).unwrap_err().to_string();
            assert!(e.contains("no column carries anything"), "{r}x{c}: {e}");
        }
    }
}
