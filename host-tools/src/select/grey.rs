//! Grey cluster grouping and grey correlation (seed 000, "Grey cluster
//! grouping and optimization thermal sensitive points"), plus the
//! dimensionless processings that the weighted method of seed 002 shares.
//!
//! Seed 000's formulas were lost in the text extraction; what follows are the
//! standard definitions of grey system theory that its prose names.
//!
//! # Dimensionless processing ([`dimensionless`])
//!
//! For a sequence `x(1..n)` (seed 000 Eq. 1-3; Liu & Lin, *Grey Systems:
//! Theory and Applications*, Springer 2010, sec. 3.2, "initialing",
//! "averaging" and "interval" operators):
//!
//! - initial value: `x(k) / x(1)`
//! - mean ("equalization"): `x(k) / mean(x)`
//! - interval: `(x(k) - min x) / (max x - min x)`
//!
//! Every run is a sequence of its own: `x(1)`, the mean and the range are
//! taken per run, because each run starts from its own thermal state.
//!
//! # Grey absolute, relative and comprehensive degrees ([`absolute_matrix`], ...)
//!
//! Liu & Lin 2010, sec. 4.3 (the "absolute", "relative" and "synthetic"
//! degrees of grey incidence; seed 000 Eq. 6-8 call them absolute, relative
//! and comprehensive correlation degrees). For equally long sequences with
//! zero-starting-point images `x^0(k) = x(k) - x(1)`:
//!
//! ```text
//! s     = sum_{k=2}^{n-1} x^0(k) + x^0(n) / 2           (trapezoidal area, unit step)
//! eps_ij = (1 + |s_i| + |s_j|) / (1 + |s_i| + |s_j| + |s_i - s_j|)        absolute degree
//! r_ij   = eps_ij of the initial-value images x(k)/x(1)                   relative degree
//! rho_ij = theta eps_ij + (1 - theta) r_ij,  theta = 0.5 by default       comprehensive degree
//! ```
//!
//! `s_i - s_j` is the area of the zero-start image of `x_i - x_j`, since the
//! image and the sum are linear. With several runs, `s` is the sum of the
//! runs' areas. The absolute degree is taken on the raw sequences: the
//! inputs are all temperatures in the same unit, and the zero-start image
//! already removes their different levels (Liu & Lin define it so); the
//! relative degree compares how fast each rises relative to its start.
//! Both are index-based (one step per sample), as in the grey literature.
//!
//! # Grey clustering ([`clusters`])
//!
//! Two variables are joined when `rho_ij >= level`; the clusters are the
//! connected components of that graph (the equivalence classes of its
//! transitive closure; Liu & Lin 2010 sec. 4.6, "grey incidence clustering").
//! Seed 000 used a level of 0.9.
//!
//! # Grey (Deng) correlation with the error ([`deng_coefficients`])
//!
//! Deng's grey relational coefficient (Deng Julong, "Introduction to grey
//! system theory", J. Grey System 1 (1989) 1-24; seed 000 Eq. 9-10), on the
//! dimensionless sequences, target `x_0`, inputs `x_i`:
//!
//! ```text
//! D_i(k)   = |x_0(k) - x_i(k)|,  D_min = min_i min_k D_i(k),  D_max = max_i max_k D_i(k)
//! xi_i(k)  = (D_min + xi D_max) / (D_i(k) + xi D_max),   xi = 0.5
//! gamma_i  = mean_k xi_i(k)
//! ```
//!
//! The typical variable of each cluster is the one with the largest
//! `gamma_i` ([`typical`]).

/// A dimensionless processing of a sequence (seed 000 Eq. 1-3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scale {
    /// `x(k) / x(1)`.
    Initial,
    /// `x(k) / mean(x)`.
    Mean,
    /// `(x(k) - min x) / (max x - min x)`.
    Interval,
    /// The raw values.
    None,
}

impl Scale {
    /// The name used on the command line and in JSON.
    pub fn name(self) -> &'static str {
        match self {
            Scale::Initial => "initial",
            Scale::Mean => "mean",
            Scale::Interval => "interval",
            Scale::None => "none",
        }
    }
}

/// Why a sequence cannot be made dimensionless; `run` is 0-based.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum ScaleError {
    /// Initial-value processing of a run whose first value is 0.
    ZeroInitial {
        /// The run.
        run: usize,
    },
    /// Mean processing of a run whose mean is 0.
    ZeroMean {
        /// The run.
        run: usize,
    },
    /// Interval processing of a constant run.
    Constant {
        /// The run.
        run: usize,
    },
}

impl std::fmt::Display for ScaleError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ScaleError::ZeroInitial { run } => write!(
                f,
                "run {} starts at 0, so initial-value processing divides by zero",
                run + 1
            ),
            ScaleError::ZeroMean { run } => write!(
                f,
                "run {} has mean 0, so mean processing divides by zero",
                run + 1
            ),
            ScaleError::Constant { run } => write!(
                f,
                "run {} is constant, so interval processing divides by zero",
                run + 1
            ),
        }
    }
}

impl std::error::Error for ScaleError {}

/// The run segments of a concatenated column: `runs` holds each run's
/// length, in order, and they add up to the column's length.
fn segments<'a>(x: &'a [f64], runs: &'a [usize]) -> impl Iterator<Item = &'a [f64]> + 'a {
    runs.iter().scan(0usize, move |start, &len| {
        let s = *start;
        *start += len;
        x.get(s..s + len)
    })
}

/// Applies `scale` to every run of `x` (see the module docs).
pub fn dimensionless(x: &[f64], runs: &[usize], scale: Scale) -> Result<Vec<f64>, ScaleError> {
    let mut out = Vec::with_capacity(x.len());
    for (run, seg) in segments(x, runs).enumerate() {
        if seg.is_empty() {
            continue;
        }
        match scale {
            Scale::None => out.extend_from_slice(seg),
            Scale::Initial => {
                let x1 = seg[0];
                if x1 == 0.0 {
                    return Err(ScaleError::ZeroInitial { run });
                }
                out.extend(seg.iter().map(|v| v / x1));
            }
            Scale::Mean => {
                let mu = seg.iter().sum::<f64>() / seg.len() as f64;
                if mu == 0.0 {
                    return Err(ScaleError::ZeroMean { run });
                }
                out.extend(seg.iter().map(|v| v / mu));
            }
            Scale::Interval => {
                let lo = seg.iter().copied().fold(f64::INFINITY, f64::min);
                let hi = seg.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                if hi <= lo {
                    return Err(ScaleError::Constant { run });
                }
                out.extend(seg.iter().map(|v| (v - lo) / (hi - lo)));
            }
        }
    }
    Ok(out)
}

/// `s`: the area under the zero-starting-point image of `x`, summed over the
/// runs (module docs).
pub fn zero_start_area(x: &[f64], runs: &[usize]) -> f64 {
    segments(x, runs)
        .filter(|seg| seg.len() >= 2)
        .map(|seg| {
            let x1 = seg[0];
            let n = seg.len();
            let inner: f64 = seg[1..n - 1].iter().map(|v| v - x1).sum();
            inner + 0.5 * (seg[n - 1] - x1)
        })
        .sum()
}

/// Grey absolute degree of incidence from the two sequences' areas `s_i`,
/// `s_j` (module docs). Always in (0.5, 1].
pub fn absolute_degree(si: f64, sj: f64) -> f64 {
    let base = 1.0 + si.abs() + sj.abs();
    base / (base + (si - sj).abs())
}

/// Symmetric matrix of [`absolute_degree`] over the columns.
pub fn absolute_matrix(cols: &[Vec<f64>], runs: &[usize]) -> Vec<Vec<f64>> {
    let s: Vec<f64> = cols.iter().map(|c| zero_start_area(c, runs)).collect();
    s.iter()
        .map(|si| s.iter().map(|sj| absolute_degree(*si, *sj)).collect())
        .collect()
}

/// The first run (0-based) of `x` that starts at exactly 0, where
/// initial-value processing `x(k) / x(1)` is undefined; `None` if there is
/// none.
pub fn zero_start_run(x: &[f64], runs: &[usize]) -> Option<usize> {
    segments(x, runs).position(|seg| seg.first() == Some(&0.0))
}

/// Matrix of grey relative degrees: absolute degrees of the `image`
/// images ([`Scale::Initial`] in Liu & Lin; `thermcomp select` passes
/// [`Scale::Interval`] when an input starts at 0, docs/select.md).
/// `Err((j, e))` names the column that has no such image.
pub fn relative_matrix(
    cols: &[Vec<f64>],
    runs: &[usize],
    image: Scale,
) -> Result<Vec<Vec<f64>>, (usize, ScaleError)> {
    let images = cols
        .iter()
        .enumerate()
        .map(|(j, c)| dimensionless(c, runs, image).map_err(|e| (j, e)))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(absolute_matrix(&images, runs))
}

/// `rho = theta eps + (1 - theta) r`, element by element.
pub fn comprehensive_matrix(abs: &[Vec<f64>], rel: &[Vec<f64>], theta: f64) -> Vec<Vec<f64>> {
    abs.iter()
        .zip(rel)
        .map(|(a, r)| {
            a.iter()
                .zip(r)
                .map(|(a, r)| theta * a + (1.0 - theta) * r)
                .collect()
        })
        .collect()
}

/// Connected components of the graph joining `i` and `j` when
/// `sim[i][j] >= level`. Groups are ordered by their first member and list
/// members in ascending order.
pub fn clusters(sim: &[Vec<f64>], level: f64) -> Vec<Vec<usize>> {
    let m = sim.len();
    let mut group = vec![usize::MAX; m];
    let mut out: Vec<Vec<usize>> = Vec::new();
    for start in 0..m {
        if group[start] != usize::MAX {
            continue;
        }
        let g = out.len();
        let mut members = vec![start];
        group[start] = g;
        let mut stack = vec![start];
        while let Some(i) = stack.pop() {
            for j in 0..m {
                if group[j] == usize::MAX && sim[i][j] >= level {
                    group[j] = g;
                    members.push(j);
                    stack.push(j);
                }
            }
        }
        members.sort_unstable();
        out.push(members);
    }
    out
}

/// Deng's grey relational grade of each column with `target` (module docs),
/// distinguishing coefficient `xi`. All sequences have the same length. When
/// every column equals the target, every grade is 1.
pub fn deng_coefficients(target: &[f64], cols: &[Vec<f64>], xi: f64) -> Vec<f64> {
    let delta =
        |c: &Vec<f64>| -> Vec<f64> { target.iter().zip(c).map(|(a, b)| (a - b).abs()).collect() };
    let deltas: Vec<Vec<f64>> = cols.iter().map(delta).collect();
    let all = deltas.iter().flatten().copied();
    let d_min = all.clone().fold(f64::INFINITY, f64::min);
    let d_max = all.fold(0.0, f64::max);
    if d_max == 0.0 {
        return vec![1.0; cols.len()];
    }
    deltas
        .iter()
        .map(|d| {
            let sum: f64 = d
                .iter()
                .map(|v| (d_min + xi * d_max) / (v + xi * d_max))
                .sum();
            sum / d.len() as f64
        })
        .collect()
}

/// The member of each group with the largest `score` (the first on ties).
pub fn typical(groups: &[Vec<usize>], score: &[f64]) -> Vec<usize> {
    groups
        .iter()
        .filter_map(|g| {
            g.iter()
                .copied()
                .reduce(|best, j| if score[j] > score[best] { j } else { best })
        })
        .collect()
}

/// Every non-empty subset of `0..k` (2^k - 1 of them), by size, then
/// lexicographically.
pub fn combinations(k: usize) -> Vec<Vec<usize>> {
    let mut out = Vec::with_capacity((1usize << k).saturating_sub(1));
    for size in 1..=k {
        let mut idx: Vec<usize> = (0..size).collect();
        loop {
            out.push(idx.clone());
            // Next combination in lexicographic order.
            let Some(pos) = (0..size).rev().find(|&p| idx[p] < k - size + p) else {
                break;
            };
            idx[pos] += 1;
            for p in pos + 1..size {
                idx[p] = idx[p - 1] + 1;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Tolerance for the hand-worked cases: a few roundings of O(1) values.
    const TOL: f64 = 1e-14;

    fn near(a: f64, b: f64) -> bool {
        (a - b).abs() <= TOL
    }

    #[test]
    fn dimensionless_processings() {
        let x = [2.0, 4.0, 6.0];
        assert_eq!(
            dimensionless(&x, &[3], Scale::Initial).unwrap(),
            [1.0, 2.0, 3.0]
        );
        assert_eq!(
            dimensionless(&x, &[3], Scale::Mean).unwrap(),
            [0.5, 1.0, 1.5]
        );
        assert_eq!(
            dimensionless(&x, &[3], Scale::Interval).unwrap(),
            [0.0, 0.5, 1.0]
        );
        assert_eq!(dimensionless(&x, &[3], Scale::None).unwrap(), x);
        // Per run: the second run starts over.
        assert_eq!(
            dimensionless(&[2.0, 4.0, 5.0, 10.0], &[2, 2], Scale::Initial).unwrap(),
            [1.0, 2.0, 1.0, 2.0]
        );
        assert_eq!(
            dimensionless(&[1.0, 2.0, 0.0, 1.0], &[2, 2], Scale::Initial),
            Err(ScaleError::ZeroInitial { run: 1 })
        );
        assert_eq!(
            dimensionless(&[1.0, -1.0], &[2], Scale::Mean),
            Err(ScaleError::ZeroMean { run: 0 })
        );
        assert_eq!(
            dimensionless(&[3.0, 3.0], &[2], Scale::Interval),
            Err(ScaleError::Constant { run: 0 })
        );
    }

    #[test]
    fn absolute_relative_comprehensive_by_hand() {
        // X0 = (1, 2, 4, 3): image (0, 1, 3, 2), s0 = 1 + 3 + 2/2 = 5.
        // X1 = (2, 2, 3, 5): image (0, 0, 1, 3), s1 = 0 + 1 + 3/2 = 2.5.
        // eps = (1 + 5 + 2.5) / (1 + 5 + 2.5 + 2.5) = 8.5 / 11.
        let x0 = vec![1.0, 2.0, 4.0, 3.0];
        let x1 = vec![2.0, 2.0, 3.0, 5.0];
        assert!(near(zero_start_area(&x0, &[4]), 5.0));
        assert!(near(zero_start_area(&x1, &[4]), 2.5));
        let cols = [x0, x1];
        let abs = absolute_matrix(&cols, &[4]);
        assert!(near(abs[0][1], 8.5 / 11.0) && abs[1][0] == abs[0][1]);
        assert_eq!(abs[0][0], 1.0);
        // Initial-value images: X0 unchanged (x(1) = 1), X1 / 2 = (1, 1,
        // 1.5, 2.5): image (0, 0, 0.5, 1.5), s = 0.5 + 0.75 = 1.25;
        // r = 7.25 / (7.25 + 3.75) = 7.25 / 11.
        let rel = relative_matrix(&cols, &[4], Scale::Initial).unwrap();
        assert!(near(rel[0][1], 7.25 / 11.0));
        let rho = comprehensive_matrix(&abs, &rel, 0.5);
        assert!(near(rho[0][1], 15.75 / 22.0));
        // Two runs: areas add. (1, 2) then (4, 3): 0.5 + (-0.5) = 0.
        assert!(near(zero_start_area(&[1.0, 2.0, 4.0, 3.0], &[2, 2]), 0.0));
    }

    #[test]
    fn zero_start_runs_are_found() {
        assert_eq!(zero_start_run(&[1.0, 0.0, 2.0, 3.0], &[2, 2]), None);
        assert_eq!(zero_start_run(&[1.0, 2.0, 0.0, 3.0], &[2, 2]), Some(1));
        assert_eq!(zero_start_run(&[0.0, 2.0, 0.0, 3.0], &[2, 2]), Some(0));
        // -0.0 == 0.0: a zeroed channel written as "-0" starts at 0 too.
        assert_eq!(zero_start_run(&[-0.0, 2.0], &[2]), Some(0));
    }

    #[test]
    fn clusters_are_connected_components() {
        // 0-1 and 1-2 above the level, 3 alone: {0, 1, 2}, {3} (0 and 2 are
        // joined through 1 although rho_02 is below the level).
        let s = vec![
            vec![1.0, 0.95, 0.5, 0.1],
            vec![0.95, 1.0, 0.91, 0.2],
            vec![0.5, 0.91, 1.0, 0.3],
            vec![0.1, 0.2, 0.3, 1.0],
        ];
        assert_eq!(clusters(&s, 0.9), vec![vec![0, 1, 2], vec![3]]);
        assert_eq!(clusters(&s, 0.92), vec![vec![0, 1], vec![2], vec![3]]);
        assert_eq!(clusters(&s, 0.0), vec![vec![0, 1, 2, 3]]);
    }

    #[test]
    fn deng_by_hand() {
        // x0 = (1, 1, 1); x1 = (1, 2, 3): D = (0, 1, 2); x2 = (1, 1.5, 1):
        // D = (0, 0.5, 0). D_min = 0, D_max = 2, xi D_max = 1:
        // gamma1 = (1 + 1/2 + 1/3) / 3 = 11/18, gamma2 = (1 + 2/3 + 1) / 3 = 8/9.
        let g = deng_coefficients(
            &[1.0, 1.0, 1.0],
            &[vec![1.0, 2.0, 3.0], vec![1.0, 1.5, 1.0]],
            0.5,
        );
        assert!(near(g[0], 11.0 / 18.0) && near(g[1], 8.0 / 9.0), "{g:?}");
        assert_eq!(typical(&[vec![0, 1]], &g), vec![1]);
    }

    #[test]
    fn combinations_count_and_order() {
        assert_eq!(
            combinations(3),
            vec![
                vec![0],
                vec![1],
                vec![2],
                vec![0, 1],
                vec![0, 2],
                vec![1, 2],
                vec![0, 1, 2]
            ]
        );
        assert_eq!(combinations(12).len(), 4095);
        assert!(combinations(0).is_empty());
    }
}
