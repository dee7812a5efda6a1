//! The trainer's view of a one-hidden-layer net: one flat parameter vector,
//! data scaled once into matrices, and a batched forward pass, error
//! Jacobian and gradient over all rows at once.
//!
//! `model_core::bp::BpNet::evaluate` runs one sample at a time, as the hub
//! does; training needs the same function over thousands of rows per step,
//! so it is written here again as matrix products. The test in
//! `tests/fit_bp.rs` checks the two against each other on a whole held-out run.
//!
//! Parameter layout (`w`): `w1` (n x m, row-major, as in the blob), `b1` (n),
//! `w2` (q x n, row-major), `b2` (q). Errors are `e = t - o` on the outputs
//! scaled by `mapminmax` to [-1, 1], as MATLAB's `trainlm` forms them.

use model_core::bp::{Activation, BpNet};
use nalgebra::{DMatrix, DVector};

/// Layer sizes: inputs `m`, hidden `n`, outputs `q`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shape {
    /// Inputs.
    pub m: usize,
    /// Hidden neurons.
    pub n: usize,
    /// Outputs.
    pub q: usize,
}

impl Shape {
    /// Number of weights and biases.
    pub fn params(&self) -> usize {
        self.n * self.m + self.n + self.q * self.n + self.q
    }

    /// Offsets of `b1`, `w2`, `b2` in the parameter vector.
    fn offsets(&self) -> (usize, usize, usize) {
        let b1 = self.n * self.m;
        let w2 = b1 + self.n;
        (b1, w2, w2 + self.q * self.n)
    }
}

/// `mapminmax` settings taken from the calibration rows (stored in the blob).
#[derive(Clone, Debug, PartialEq)]
pub struct Scaling {
    /// Input minima.
    pub x_min: Vec<f64>,
    /// Input maxima.
    pub x_max: Vec<f64>,
    /// Target minima.
    pub y_min: Vec<f64>,
    /// Target maxima.
    pub y_max: Vec<f64>,
}

/// Column minima and maxima of row vectors with `width` columns.
fn ranges(rows: &[Vec<f64>], width: usize) -> (Vec<f64>, Vec<f64>) {
    let mut lo = vec![f64::INFINITY; width];
    let mut hi = vec![f64::NEG_INFINITY; width];
    for r in rows {
        for (j, v) in r.iter().enumerate().take(width) {
            lo[j] = lo[j].min(*v);
            hi[j] = hi[j].max(*v);
        }
    }
    (lo, hi)
}

/// `mapminmax` to [-1, 1], with MATLAB's (and `model_core`'s) unit-gain pass
/// of a constant row.
fn scale(v: f64, lo: f64, hi: f64) -> f64 {
    if hi == lo {
        v - lo - 1.0
    } else {
        2.0 * (v - lo) / (hi - lo) - 1.0
    }
}

fn unscale(v: f64, lo: f64, hi: f64) -> f64 {
    if hi == lo {
        v + 1.0 + lo
    } else {
        (v + 1.0) * (hi - lo) / 2.0 + lo
    }
}

impl Scaling {
    /// Minima and maxima of the calibration rows.
    pub fn from_rows(x: &[Vec<f64>], y: &[Vec<f64>], m: usize, q: usize) -> Self {
        let (x_min, x_max) = ranges(x, m);
        let (y_min, y_max) = ranges(y, q);
        Self {
            x_min,
            x_max,
            y_min,
            y_max,
        }
    }

    /// Inputs scaled, one row per sample (N x m).
    pub fn x(&self, rows: &[Vec<f64>]) -> DMatrix<f64> {
        DMatrix::from_fn(rows.len(), self.x_min.len(), |r, i| {
            scale(rows[r][i], self.x_min[i], self.x_max[i])
        })
    }

    /// Targets scaled (N x q).
    pub fn y(&self, rows: &[Vec<f64>]) -> DMatrix<f64> {
        DMatrix::from_fn(rows.len(), self.y_min.len(), |r, k| {
            scale(rows[r][k], self.y_min[k], self.y_max[k])
        })
    }

    /// Scaled outputs back to engineering units.
    pub fn unscale_y(&self, o: &DMatrix<f64>) -> Vec<Vec<f64>> {
        (0..o.nrows())
            .map(|r| {
                (0..o.ncols())
                    .map(|k| unscale(o[(r, k)], self.y_min[k], self.y_max[k]))
                    .collect()
            })
            .collect()
    }
}

/// Scaled rows a trainer works on.
#[derive(Clone, Debug)]
pub struct Data {
    /// Inputs (N x m).
    pub x: DMatrix<f64>,
    /// Targets (N x q).
    pub t: DMatrix<f64>,
}

impl Data {
    /// The rows `idx` of `self`.
    pub fn rows(&self, idx: &[usize]) -> Self {
        Self {
            x: self.x.select_rows(idx),
            t: self.t.select_rows(idx),
        }
    }

    /// Number of errors (rows x outputs): MATLAB's divisor of `mse`.
    pub fn errors(&self) -> usize {
        self.t.len()
    }
}

/// Derivative of the hidden transfer function from its output `h`.
fn slope(act: Activation, h: f64) -> f64 {
    match act {
        Activation::Tansig => 1.0 - h * h,
        Activation::Logsig => h * (1.0 - h),
        Activation::Purelin => 1.0,
    }
}

/// Hidden outputs `H` (N x n) and net outputs `O` (N x q), scaled.
pub fn forward(
    shape: Shape,
    act: Activation,
    w: &[f64],
    x: &DMatrix<f64>,
) -> (DMatrix<f64>, DMatrix<f64>) {
    let Shape { m, n, q } = shape;
    let (ob1, ow2, ob2) = shape.offsets();
    let w1 = DMatrix::from_row_slice(n, m, &w[..ob1]);
    let w2 = DMatrix::from_row_slice(q, n, &w[ow2..ob2]);
    let mut h = x * w1.transpose();
    for j in 0..n {
        let b = w[ob1 + j];
        for v in h.column_mut(j).iter_mut() {
            *v = act.apply(*v + b);
        }
    }
    let mut o = &h * w2.transpose();
    for k in 0..q {
        let b = w[ob2 + k];
        o.column_mut(k).iter_mut().for_each(|v| *v += b);
    }
    (h, o)
}

/// Sum of squared scaled errors.
pub fn sse(shape: Shape, act: Activation, w: &[f64], d: &Data) -> f64 {
    let (_, o) = forward(shape, act, w, &d.x);
    (&d.t - o).norm_squared()
}

/// `J^T` (P x Nq, the transpose of the Jacobian of the outputs with respect
/// to the parameters, so each error's column is contiguous) and the errors
/// `e = t - o` (Nq; row `r`, output `k` at `r * q + k`).
pub fn jacobian_t(
    shape: Shape,
    act: Activation,
    w: &[f64],
    d: &Data,
) -> (DMatrix<f64>, DVector<f64>) {
    let Shape { m, n, q } = shape;
    let (ob1, ow2, ob2) = shape.offsets();
    let (h, o) = forward(shape, act, w, &d.x);
    let rows = d.x.nrows();
    let mut jt = DMatrix::zeros(shape.params(), rows * q);
    let mut e = DVector::zeros(rows * q);
    let mut dh = vec![0.0; n];
    for r in 0..rows {
        for (j, s) in dh.iter_mut().enumerate() {
            *s = slope(act, h[(r, j)]);
        }
        for k in 0..q {
            let col = r * q + k;
            e[col] = d.t[(r, k)] - o[(r, k)];
            let mut c = jt.column_mut(col);
            for j in 0..n {
                let g = w[ow2 + k * n + j] * dh[j];
                for i in 0..m {
                    c[j * m + i] = g * d.x[(r, i)];
                }
                c[ob1 + j] = g;
                c[ow2 + k * n + j] = h[(r, j)];
            }
            c[ob2 + k] = 1.0;
        }
    }
    (jt, e)
}

/// `J^T e` (minus half the gradient of the SSE) and the SSE, by
/// back-propagation without forming the Jacobian.
pub fn gradient(shape: Shape, act: Activation, w: &[f64], d: &Data) -> (Vec<f64>, f64) {
    let Shape { m, n, q } = shape;
    let (ob1, ow2, ob2) = shape.offsets();
    let (h, o) = forward(shape, act, w, &d.x);
    let e = &d.t - o;
    let w2 = DMatrix::from_row_slice(q, n, &w[ow2..ob2]);
    // delta_hidden (N x n) = (E W2) .* f'(H)
    let mut dh = &e * &w2;
    for (v, hv) in dh.iter_mut().zip(h.iter()) {
        *v *= slope(act, *hv);
    }
    let gw1 = dh.transpose() * &d.x; // n x m
    let gw2 = e.transpose() * &h; // q x n
    let mut g = vec![0.0; shape.params()];
    for j in 0..n {
        for i in 0..m {
            g[j * m + i] = gw1[(j, i)];
        }
        g[ob1 + j] = dh.column(j).sum();
    }
    for k in 0..q {
        for j in 0..n {
            g[ow2 + k * n + j] = gw2[(k, j)];
        }
        g[ob2 + k] = e.column(k).sum();
    }
    (g, e.norm_squared())
}

/// A heapless copy of `x`, or the error that it does not fit.
fn v<const N: usize>(x: &[f64]) -> Result<heapless::Vec<f64, N>, &'static str> {
    heapless::Vec::from_slice(x).map_err(|_| "net exceeds the blob's limits")
}

/// The blob's net: weights as trained, scaling as taken, channels `0..m`
/// and outputs `0..q` in the model's order.
pub fn to_bpnet(
    shape: Shape,
    act: Activation,
    w: &[f64],
    s: &Scaling,
) -> Result<BpNet, &'static str> {
    let (ob1, ow2, ob2) = shape.offsets();
    Ok(BpNet {
        inputs: (0..shape.m)
            .map(|i| u8::try_from(i).map_err(|_| "too many inputs"))
            .collect::<Result<_, _>>()?,
        outputs: (0..shape.q)
            .map(|k| u8::try_from(k).map_err(|_| "too many outputs"))
            .collect::<Result<_, _>>()?,
        hidden_activation: act,
        output_activation: Activation::Purelin,
        w1: v(&w[..ob1])?,
        b1: v(&w[ob1..ow2])?,
        w2: v(&w[ow2..ob2])?,
        b2: v(&w[ob2..])?,
        x_min: v(&s.x_min)?,
        x_max: v(&s.x_max)?,
        y_min: v(&s.y_min)?,
        y_max: v(&s.y_max)?,
    })
}

/// Runs a blob's net over rows of model inputs (channel order) with this
/// module's batched pass: the trainer's side of the "two implementations
/// agree" test. Only purelin-output nets with inputs `0..m` in order, as
/// `fit` writes them; `None` otherwise.
pub fn predict_rows(net: &BpNet, rows: &[Vec<f64>]) -> Option<Vec<Vec<f64>>> {
    let (m, q) = (net.inputs.len(), net.outputs.len());
    let ordered = net
        .inputs
        .iter()
        .enumerate()
        .all(|(i, c)| usize::from(*c) == i);
    if !ordered || net.output_activation != Activation::Purelin || !net.shapes_agree() {
        return None;
    }
    let shape = Shape {
        m,
        n: net.hidden(),
        q,
    };
    let w: Vec<f64> = [&net.w1[..], &net.b1[..], &net.w2[..], &net.b2[..]].concat();
    let s = Scaling {
        x_min: net.x_min.to_vec(),
        x_max: net.x_max.to_vec(),
        y_min: net.y_min.to_vec(),
        y_max: net.y_max.to_vec(),
    };
    let (_, o) = forward(shape, net.hidden_activation, &w, &s.x(rows));
    Some(s.unscale_y(&o))
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::num::rng::SplitMix64;

    /// A small random problem: `rows` x 3 inputs in [-1, 1], 2 targets.
    pub(crate) fn toy(rows: usize, seed: u64) -> Data {
        let mut r = SplitMix64::new(seed);
        let x = DMatrix::from_fn(rows, 3, |_, _| r.symmetric());
        let t = DMatrix::from_fn(rows, 2, |i, k| {
            (x[(i, 0)] * 2.0).sin() * 0.5 + x[(i, 1)] * x[(i, 2)] * 0.3 - 0.2 * k as f64
        });
        Data { x, t }
    }

    #[test]
    fn jacobian_matches_central_differences() {
        // Central differences with step 1e-6 are accurate to ~1e-10 here
        // (third derivatives O(1)), so 1e-6 relative (of the column's
        // largest entry) leaves room for rounding only.
        for act in [Activation::Tansig, Activation::Logsig] {
            let shape = Shape { m: 3, n: 4, q: 2 };
            let d = toy(7, 3);
            let mut r = SplitMix64::new(5);
            let w: Vec<f64> = (0..shape.params()).map(|_| r.symmetric()).collect();
            let (jt, e) = jacobian_t(shape, act, &w, &d);
            let (_, o) = forward(shape, act, &w, &d.x);
            for (col, ev) in e.iter().enumerate() {
                let (rr, k) = (col / 2, col % 2);
                assert!((ev - (d.t[(rr, k)] - o[(rr, k)])).abs() < 1e-15);
            }
            let step = 1e-6;
            for p in 0..shape.params() {
                let (mut wp, mut wm) = (w.clone(), w.clone());
                wp[p] += step;
                wm[p] -= step;
                let (_, op) = forward(shape, act, &wp, &d.x);
                let (_, om) = forward(shape, act, &wm, &d.x);
                let fd: Vec<f64> = op
                    .transpose()
                    .iter()
                    .zip(om.transpose().iter())
                    .map(|(a, b)| (a - b) / (2.0 * step))
                    .collect();
                let scale = fd.iter().fold(1e-3_f64, |a, v| a.max(v.abs()));
                for (col, f) in fd.iter().enumerate() {
                    let a = jt[(p, col)];
                    assert!(
                        (a - f).abs() <= 1e-6 * scale,
                        "{act:?} p {p} col {col}: {a} vs {f}"
                    );
                }
            }
            // The back-propagated gradient is J^T e (same sums, other order: 1e-12).
            let (g, s) = gradient(shape, act, &w, &d);
            let jte = &jt * &e;
            for (a, b) in g.iter().zip(jte.iter()) {
                assert!((a - b).abs() < 1e-12 * (1.0 + b.abs()));
            }
            assert!((s - e.norm_squared()).abs() < 1e-12);
        }
    }

    #[test]
    fn batched_pass_matches_model_core_sample_by_sample() {
        // Same arithmetic in another order: agreement to 1e-12 (engineering units ~10).
        let shape = Shape { m: 3, n: 5, q: 2 };
        let mut r = SplitMix64::new(11);
        let w: Vec<f64> = (0..shape.params()).map(|_| r.symmetric()).collect();
        let x: Vec<Vec<f64>> = (0..20)
            .map(|_| (0..3).map(|_| 20.0 + 5.0 * r.symmetric()).collect())
            .collect();
        let y: Vec<Vec<f64>> = (0..20)
            .map(|_| vec![10.0 * r.symmetric(), r.uniform()])
            .collect();
        let s = Scaling::from_rows(&x, &y, 3, 2);
        let net = to_bpnet(shape, Activation::Logsig, &w, &s).unwrap();
        let ours = predict_rows(&net, &x).unwrap();
        for (row, want) in x.iter().zip(&ours) {
            net.evaluate(row, |k, v| {
                assert!((v - want[usize::from(k)]).abs() < 1e-12);
            });
        }
    }
}
