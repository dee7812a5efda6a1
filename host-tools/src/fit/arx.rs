//! MISO ARX models exported as a transfer-function bank (seed 004, Eq. 1-2
//! and the ARX structure its Sec. 2 names), plus the pieces the other
//! dynamic trainers (`tf`, `gain`) share: the CLI options, the sample time,
//! least squares by a tall-skinny QR, TF simulation and step responses.
//!
//! Per target, `A(q) y(k) = sum_i B_i(q) u_i(k - nk) + e(k)` with
//! `A = 1 + a_1 q^-1 + .. + a_na q^-na` and `B_i = b_i0 + .. + b_i,nb-1 q^-(nb-1)`,
//! the same `nb` and `nk` for every input (a search over per-input orders
//! grows as `(orders)^inputs`; a common order keeps it at 27 candidates).
//! The regression runs over the calibration samples of every grid run and
//! never crosses a run boundary. It is solved by QR of `[X | y]` in row
//! blocks (`R` of each block is stacked onto the next), then by SVD of the
//! small column-scaled `R`: never the normal equations.
//!
//! Orders and the ridge penalty are chosen together by **simulation** fit
//! under blocked cross-validation: each run's calibration samples are cut
//! into K contiguous folds (`--search-folds`, default 4); for each fold the
//! candidate is estimated on the other calibration samples (rows whose lags
//! reach into the fold excluded too), free-run from the run's start (the
//! model's own past outputs, never the measured ones) and scored on the fold;
//! the fit is pooled over all folds. Free run from the start is how the hub
//! runs the model. One-step prediction would flatter every candidate: a slow
//! thermal output is almost perfectly predicted by its last sample. Folds
//! rather than one tail segment because a tail (the old default, still
//! `--search-folds 1`) judges a candidate on one operating regime only: on
//! the real run it chose ARX models whose opposing gains on collinear
//! sensors cancelled inside the calibration range and diverged outside it
//! (ch1: -417 % held-out reduction); every fold is a different regime, and
//! such a model fails at least one. Candidates the model core refuses (a
//! pole on or outside the unit circle, in any fold) are discarded; the best
//! is re-estimated on all calibration samples. `na = 0` (a FIR /
//! distributed-lag regression) is a candidate: it is the safe choice when
//! the output's own dynamics cannot be identified from the folds.
//!
//! `--select-inputs forward` chooses the inputs among `--inputs` greedily:
//! each step adds the candidate whose model (full order search, stable only)
//! has the best mean search fit, until `--max-inputs` or a gain below
//! `--min-gain-pct` points. `--ridge` (default `auto`) penalises the
//! column-scaled coefficients; each reduced QR is solved once per penalty,
//! so the joint search costs one pass over the rows per (orders, fold).
//!
//! Export: one TF entry per (input, target), `a = [0; nk] ++ B_i` and
//! `b = A` (the common denominator), so the bank sums to the ARX model.

use super::{channels, outputs, Fitted};
use crate::data::dataset::{Dataset, GridRun, InputForm};
use crate::num::progress::progress;
use anyhow::{anyhow, bail, Result};
use clap::Args;
use model_core::tf::{RealisedTf, TfEntry, TfHistory, MAX_ORDER, MAX_TF_ENTRIES};
use model_core::{Model, Params, ValidModel};
use nalgebra::DMatrix;
use rayon::prelude::*;
use serde_json::{json, Map, Value};
use std::path::PathBuf;
use std::str::FromStr;

/// An inclusive order range given as `MIN..MAX` or a single number.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OrderRange {
    /// Smallest order tried.
    pub min: usize,
    /// Largest order tried.
    pub max: usize,
}

impl FromStr for OrderRange {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let parse = |v: &str| {
            v.trim()
                .parse::<usize>()
                .map_err(|_| format!("\"{s}\" is not an order range like 1..3"))
        };
        let (min, max) = match s.split_once("..") {
            Some((a, b)) => (parse(a)?, parse(b.trim_start_matches('='))?),
            None => (parse(s)?, parse(s)?),
        };
        if min > max || max > MAX_ORDER {
            return Err(format!(
                "order range {s}: need MIN <= MAX <= {MAX_ORDER} (the model core's highest order)"
            ));
        }
        Ok(Self { min, max })
    }
}

impl OrderRange {
    const fn new(min: usize, max: usize) -> Self {
        Self { min, max }
    }
    fn iter(self) -> std::ops::RangeInclusive<usize> {
        self.min..=self.max
    }
}

/// Options of the dynamic trainers (`arx`, `tf`, `gain`) of `thermcomp fit`.
#[derive(Args, Clone, Debug)]
pub struct ArxArgs {
    /// arx, tf: denominator orders tried, MIN..MAX (default arx 1..3, tf 1..2).
    #[arg(long, value_name = "MIN..MAX")]
    pub na: Option<OrderRange>,
    /// arx, tf: numerator lengths tried, MIN..MAX (default arx 1..3, tf 1..2; arx: same for every input).
    #[arg(long, value_name = "MIN..MAX")]
    pub nb: Option<OrderRange>,
    /// arx, tf: input delays tried in samples, MIN..MAX (default arx 0..2, tf 0..1; arx: same for every input).
    #[arg(long, value_name = "MIN..MAX")]
    pub nk: Option<OrderRange>,
    /// arx: order search scores simulation fit by blocked cross-validation over K contiguous folds of each run's calibration samples (1: on the last --search-holdout only, as tf does).
    #[arg(long, default_value_t = 4, value_name = "K")]
    pub search_folds: usize,
    /// arx with --search-folds 1, tf: the search scores simulation fit on the last FRACTION of each run's calibration samples.
    #[arg(long, default_value_t = 0.25, value_name = "FRACTION")]
    pub search_holdout: f64,
    /// arx, tf, arma: model sample time (default: the median sampling step of the first run).
    #[arg(long, value_name = "SECONDS")]
    pub dt_s: Option<f64>,
    /// tf: rounds of SISO ARX backfitting on partial residuals before the joint refinement.
    #[arg(long, default_value_t = 3, value_name = "N")]
    pub backfit_rounds: usize,
    /// tf: Levenberg-Marquardt iteration limit of the joint output-error refinement.
    #[arg(long, default_value_t = 60, value_name = "N")]
    pub lm_iterations: usize,
    /// gain: the TF-bank blob whose spindle part gets a new gain g (seed 004, Eq. 6).
    #[arg(long, value_name = "MODEL.bin")]
    pub gain_from: Option<PathBuf>,
    /// gain: inputs whose TF entries are scaled by g (default: every input but ambient_c).
    #[arg(long, value_delimiter = ',', value_name = "COL,..")]
    pub gain_inputs: Vec<String>,
    /// arx, tf: choose the inputs among --inputs by the search itself (forward: greedy, by simulation fit).
    #[arg(long, value_enum, default_value = "off")]
    pub select_inputs: Selection,
    /// arx, tf: with --select-inputs forward, at most K inputs (also capped by the 16-entry bank).
    #[arg(long, default_value_t = 6, value_name = "K")]
    pub max_inputs: usize,
    /// arx, tf: with --select-inputs forward, stop when the best addition raises the search fit by less than this (percentage points).
    #[arg(long, default_value_t = 1.0, value_name = "POINTS")]
    pub min_gain_pct: f64,
    /// arx: ridge penalty of the least squares: "auto" (default: searched with the orders, by search fit), 0 = none, or a number.
    #[arg(long, default_value = "auto", value_name = "auto|LAMBDA")]
    pub ridge: Ridge,
}

/// How `arx` and `tf` choose their inputs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Selection {
    /// Every `--inputs` column.
    Off,
    /// Greedy forward selection scored by simulation fit on the search-validation part.
    Forward,
}

/// The ridge penalty of `arx` (in the column-scaled basis: every regressor
/// column has unit norm, so the penalty is relative to that).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Ridge {
    /// Chosen from [`RIDGE_GRID`] by simulation fit on the search-validation part.
    Auto,
    /// A fixed penalty (0: plain least squares).
    Fixed(f64),
}

impl FromStr for Ridge {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if s == "auto" {
            return Ok(Self::Auto);
        }
        match s.parse::<f64>() {
            Ok(v) if v.is_finite() && v >= 0.0 => Ok(Self::Fixed(v)),
            _ => Err(format!("--ridge {s}: \"auto\" or a number >= 0")),
        }
    }
}

/// Ridge penalties `auto` tries (0 first: plain least squares wins ties).
pub const RIDGE_GRID: [f64; 7] = [0.0, 1e-7, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2];

/// Default order ranges of `--model arx`.
const ARX_DEFAULTS: [OrderRange; 3] = [
    OrderRange::new(0, 3),
    OrderRange::new(1, 3),
    OrderRange::new(0, 2),
];

/// One candidate structure: denominator order, numerator length, delay.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Orders {
    /// Denominator order (`A` has `na + 1` coefficients).
    pub na: usize,
    /// Numerator length (`B` has `nb` coefficients).
    pub nb: usize,
    /// Input delay in samples.
    pub nk: usize,
}

impl Orders {
    /// Largest lag the structure reaches back.
    pub fn max_lag(self) -> usize {
        self.na.max(self.nk + self.nb.saturating_sub(1))
    }
    /// Whether the model core can hold it.
    pub fn fits_core(self) -> bool {
        self.na <= MAX_ORDER && self.nk + self.nb <= MAX_ORDER + 1 && self.nb >= 1
    }
    /// `{"na":..,"nb":..,"nk":..}`.
    pub fn json(self) -> Value {
        json!({"na": self.na, "nb": self.nb, "nk": self.nk})
    }
}

/// The candidate structures of the given ranges that the model core holds.
pub fn candidates(na: OrderRange, nb: OrderRange, nk: OrderRange) -> Vec<Orders> {
    let mut out = Vec::new();
    for na in na.iter() {
        for nb in nb.iter() {
            for nk in nk.iter() {
                let o = Orders { na, nb, nk };
                if o.fits_core() && nb >= 1 {
                    out.push(o);
                }
            }
        }
    }
    out
}

/// The model sample time: `--dt-s`, else the median step of the first run.
pub fn sample_time(ds: &Dataset, dt_s: Option<f64>) -> Result<f64> {
    let dt = match dt_s {
        Some(dt) => dt,
        None => {
            let t = &ds.runs.first().ok_or_else(|| anyhow!("no runs"))?.t_s;
            let mut steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
            if steps.is_empty() {
                bail!("the first run has fewer than two rows: no sample time (give --dt-s)");
            }
            steps.sort_by(f64::total_cmp);
            steps[steps.len() / 2]
        }
    };
    if !(dt.is_finite() && dt > 0.0) {
        bail!("sample time {dt} s must be positive");
    }
    Ok(dt)
}

/// Resamples to `dt` and says so when a run was not already on that grid.
pub fn grid_runs(ds: &Dataset, dt: f64, kind: &str) -> Result<Vec<GridRun>> {
    for run in &ds.runs {
        let off = run
            .t_s
            .windows(2)
            .any(|w| ((w[1] - w[0]) - dt).abs() > 1e-6 * dt);
        if off {
            eprintln!(
                "note: {kind}: {} is not sampled uniformly at {dt} s; inputs and targets are interpolated linearly onto a {dt} s grid",
                run.name
            );
        }
    }
    let grid = ds.on_grid(dt)?;
    if grid.iter().all(|g| g.calib_end == 0) {
        bail!("{kind}: no calibration samples on the {dt} s grid");
    }
    Ok(grid)
}

/// First sample of the search-validation segment of a run with `calib_end`
/// calibration samples (the last `h` of them).
pub fn search_split(calib_end: usize, h: f64) -> usize {
    // Truncation is intended: a whole number of samples.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let n_val = ((calib_end as f64) * h).round() as usize;
    calib_end - n_val.min(calib_end)
}

/// Most folds `--search-folds` takes (one bit each in a row's exclusion mask).
pub const MAX_FOLDS: usize = 64;

/// How the order search scores a candidate, on calibration samples only.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SearchScheme {
    /// Blocked cross-validation: each run's calibration samples cut into
    /// this many contiguous folds; fold `j` of every run is held out at once.
    Folds(usize),
    /// One held-out segment: the last fraction of each run's calibration samples.
    Tail(f64),
}

impl SearchScheme {
    /// From `--search-folds` and `--search-holdout`.
    pub fn from_args(args: &ArxArgs) -> Result<Self> {
        match args.search_folds {
            0 => bail!("--search-folds 0: at least 1"),
            1 => {
                check_holdout(args.search_holdout)?;
                Ok(Self::Tail(args.search_holdout))
            }
            k if k > MAX_FOLDS => bail!("--search-folds {k}: at most {MAX_FOLDS}"),
            k => Ok(Self::Folds(k)),
        }
    }

    /// Number of held-out segments per run.
    pub fn count(self) -> usize {
        match self {
            Self::Folds(k) => k,
            Self::Tail(_) => 1,
        }
    }

    /// Held-out samples `[from, to)` of segment `j` of a run with
    /// `calib_end` calibration samples.
    pub fn segment(self, calib_end: usize, j: usize) -> (usize, usize) {
        match self {
            Self::Folds(k) => (calib_end * j / k, calib_end * (j + 1) / k),
            Self::Tail(h) => (search_split(calib_end, h), calib_end),
        }
    }

    /// Bit `j` set when segment `j` excludes sample `k` from estimation: `k`
    /// is in the segment or its regressors (`lag` samples back) reach into it.
    pub fn excluded_by(self, calib_end: usize, k: usize, lag: usize) -> u64 {
        (0..self.count()).fold(0, |mask, j| {
            let (from, to) = self.segment(calib_end, j);
            if (from..to + lag).contains(&k) {
                mask | 1 << j
            } else {
                mask
            }
        })
    }

    /// For the JSON.
    pub fn json(self) -> Value {
        match self {
            Self::Folds(k) => json!({"scheme": "blocked cross-validation", "folds": k,
                "score": "simulation fit % (free run from each run's start) pooled over the held-out folds; each fold's model estimated on the other calibration samples (regression rows whose lags reach into the fold excluded too)"}),
            Self::Tail(h) => json!({"scheme": "tail", "search_holdout": h,
                "score": "simulation fit % (free run from each run's start) on the last search_holdout of each run's calibration samples"}),
        }
    }
}

/// Checks `--search-holdout`.
pub fn check_holdout(h: f64) -> Result<()> {
    if !(h > 0.0 && h < 1.0) {
        bail!("--search-holdout {h} must be in (0, 1)");
    }
    Ok(())
}

pub use crate::num::tsqr::{Triangle, Tsqr};

/// An ARX model of one target: common denominator and one numerator per input.
#[derive(Clone, Debug)]
pub struct ArxPoly {
    /// Structure.
    pub orders: Orders,
    /// `A`: `[1, a_1 .. a_na]`.
    pub den: Vec<f64>,
    /// `B_i`: `[b_i0 .. b_i,nb-1]` per input.
    pub num: Vec<Vec<f64>>,
}

impl ArxPoly {
    /// The TF-entry numerator of input `i`: `[0; nk] ++ B_i`.
    pub fn entry_num(&self, i: usize) -> Vec<f64> {
        let mut a = vec![0.0; self.orders.nk];
        a.extend_from_slice(&self.num[i]);
        a
    }
}

/// Estimates the ARX model of target `t` on samples `..end(run)` of every run.
pub fn estimate(
    grid: &[GridRun],
    t: usize,
    o: Orders,
    end: impl Fn(&GridRun) -> usize,
) -> Result<ArxPoly> {
    estimate_ridge(grid, t, o, end, 0.0)
}

/// [`estimate`] with a ridge penalty (see [`Tsqr::solve_ridge`]).
pub fn estimate_ridge(
    grid: &[GridRun],
    t: usize,
    o: Orders,
    end: impl Fn(&GridRun) -> usize,
    ridge: f64,
) -> Result<ArxPoly> {
    let tri = regression(grid, t, o, |g, k| k < end(g))?;
    ArxPoly::solve(&tri, o, n_inputs(grid), ridge)
}

fn n_inputs(grid: &[GridRun]) -> usize {
    grid.first().map_or(0, |g| g.x.len())
}

/// The ARX regression of target `t` over the calibration samples of every
/// run, split by [`SearchScheme::excluded_by`]: one accumulator per set of
/// folds that exclude a row, so that each fold's estimate (every piece not
/// excluded by it) costs no further pass over the rows.
fn regression_pieces(
    grid: &[GridRun],
    t: usize,
    o: Orders,
    scheme: SearchScheme,
) -> Vec<(u64, Tsqr)> {
    let p = o.na + n_inputs(grid) * o.nb;
    let mut pieces: Vec<(u64, Tsqr)> = Vec::new();
    let mut row = vec![0.0; p];
    for g in grid {
        let y = &g.y[t];
        for k in o.max_lag()..g.calib_end {
            let mask = scheme.excluded_by(g.calib_end, k, o.max_lag());
            let at = match pieces.iter().position(|(m, _)| *m == mask) {
                Some(i) => i,
                None => {
                    pieces.push((mask, Tsqr::new(p)));
                    pieces.len() - 1
                }
            };
            for j in 1..=o.na {
                row[j - 1] = -y[k - j];
            }
            for (i, u) in g.x.iter().enumerate() {
                for l in 0..o.nb {
                    row[o.na + i * o.nb + l] = u[k - o.nk - l];
                }
            }
            pieces[at].1.push(&row, y[k]);
        }
    }
    for (_, piece) in &mut pieces {
        piece.flush();
    }
    pieces
}

/// The ARX regression of target `t` over the samples `k` of every run
/// with `keep(run, k)`, reduced by QR.
pub fn regression(
    grid: &[GridRun],
    t: usize,
    o: Orders,
    keep: impl Fn(&GridRun, usize) -> bool,
) -> Result<Triangle> {
    let p = o.na + n_inputs(grid) * o.nb;
    let mut ls = Tsqr::new(p);
    let mut row = vec![0.0; p];
    for g in grid {
        let y = &g.y[t];
        for k in (o.max_lag()..g.calib_end).filter(|&k| keep(g, k)) {
            for j in 1..=o.na {
                row[j - 1] = -y[k - j];
            }
            for (i, u) in g.x.iter().enumerate() {
                for l in 0..o.nb {
                    row[o.na + i * o.nb + l] = u[k - o.nk - l];
                }
            }
            ls.push(&row, y[k]);
        }
    }
    ls.finish()
}

impl ArxPoly {
    /// The model of a reduced regression of [`regression`] with penalty `ridge`.
    pub fn solve(tri: &Triangle, o: Orders, n_in: usize, ridge: f64) -> Result<Self> {
        let (theta, _) = tri.solve(ridge)?;
        let mut den = vec![1.0];
        den.extend_from_slice(&theta[..o.na]);
        let num = (0..n_in)
            .map(|i| theta[o.na + i * o.nb..o.na + (i + 1) * o.nb].to_vec())
            .collect();
        Ok(Self {
            orders: o,
            den,
            num,
        })
    }
}

/// Free-run simulation of a MISO ARX over samples `..to` of `g`, from the
/// steady state of the run's first inputs (what the model core assumes at
/// a run's first sample): the model's own past outputs, never measured ones.
pub fn simulate_arx(m: &ArxPoly, g: &GridRun, to: usize) -> Vec<f64> {
    let o = m.orders;
    let sd: f64 = m.den.iter().sum();
    let y0 = if sd.abs() > 1e-12 {
        m.num
            .iter()
            .zip(&g.x)
            .map(|(b, u)| b.iter().sum::<f64>() * u.first().copied().unwrap_or(0.0))
            .sum::<f64>()
            / sd
    } else {
        0.0
    };
    let mut ys: Vec<f64> = Vec::with_capacity(to);
    for k in 0..to {
        let mut v = 0.0;
        for j in 1..=o.na {
            v -= m.den[j] * k.checked_sub(j).map_or(y0, |i| ys[i]);
        }
        for (i, u) in g.x.iter().enumerate() {
            for (l, b) in m.num[i].iter().enumerate() {
                v += b * k.checked_sub(o.nk + l).map_or(u[0], |i| u[i]);
            }
        }
        ys.push(v);
    }
    ys
}

/// System-identification fit % of `yhat` against `y` (seed 004, Eq. 4).
pub fn fit_pct(pairs: &[(f64, f64)]) -> f64 {
    let n = pairs.len() as f64;
    if pairs.is_empty() {
        return f64::NAN;
    }
    let mean = pairs.iter().map(|p| p.0).sum::<f64>() / n;
    let sse: f64 = pairs.iter().map(|(y, h)| (y - h).powi(2)).sum();
    let sst: f64 = pairs.iter().map(|(y, _)| (y - mean).powi(2)).sum();
    if sst == 0.0 {
        return if sse == 0.0 { 100.0 } else { 0.0 };
    }
    (1.0 - (sse / sst).sqrt()) * 100.0
}

/// A TF-bank model over `ds`'s inputs and targets, validated by the model core.
pub fn bank(ds: &Dataset, dt: f64, entries: Vec<TfEntry>) -> Result<ValidModel> {
    let n = entries.len();
    let bank = heapless::Vec::<TfEntry, MAX_TF_ENTRIES>::from_iter(
        entries.into_iter().take(MAX_TF_ENTRIES),
    );
    if bank.len() != n {
        bail!("{n} TF entries; the model holds at most {MAX_TF_ENTRIES}");
    }
    Model {
        inputs: channels(ds)?,
        outputs: outputs(ds)?,
        dt_s: dt,
        params: Params::Tf(bank),
        bounds: None,
        five_point: None,
    }
    .validate()
    .map_err(|e| anyhow!("{e}"))
}

/// Builds a TF entry (checked sizes).
pub fn entry(output: usize, input: usize, a: &[f64], b: &[f64]) -> Result<TfEntry> {
    Ok(TfEntry {
        output: u8::try_from(output)?,
        input: u8::try_from(input)?,
        a: heapless::Vec::from_slice(a)
            .map_err(|_| anyhow!("numerator above order {MAX_ORDER}"))?,
        b: heapless::Vec::from_slice(b)
            .map_err(|_| anyhow!("denominator above order {MAX_ORDER}"))?,
    })
}

/// Step-response figures of one TF, from its realisation in the model core.
pub fn step_info(a: &[f64], b: &[f64], dt: f64) -> Value {
    let tf = match RealisedTf::new(a, b) {
        Ok(tf) => tf,
        Err(e) => return json!({"error": e.to_string()}),
    };
    let gain = tf.dc_gain();
    json!({
        "gain_per_unit": gain,
        "tau_s": time_constant(&tf, dt),
        "cancelled_pole_zero_pairs": tf.cancelled(),
        "pole_zero_cancellation": tf.cancelled() > 0,
        "poles": poles(tf.denominator()),
    })
}

/// Time for the unit-step response to reach 63.2 % of its final value
/// (simulated on the realised TF, linear interpolation between samples);
/// `None` for a zero gain or when it takes more than ten million samples.
pub fn time_constant(tf: &RealisedTf, dt: f64) -> Option<f64> {
    let gain = tf.dc_gain();
    if gain == 0.0 || !gain.is_finite() {
        return None;
    }
    let target = (1.0 - (-1.0f64).exp()) * gain;
    let mut h = TfHistory::default();
    let mut prev = 0.0;
    for k in 0..10_000_000u32 {
        let y = tf.output(&h, 1.0);
        if (y - target) * gain.signum() >= 0.0 {
            let frac = if k == 0 || y == prev {
                0.0
            } else {
                (target - prev) / (y - prev)
            };
            return Some((f64::from(k) - 1.0 + frac).max(0.0) * dt);
        }
        h.push(1.0, y);
        prev = y;
    }
    None
}

/// Roots of a denominator `[1, d1, ..]` in z (the poles), as `[re, im]`.
fn poles(den: &[f64]) -> Vec<[f64; 2]> {
    let n = den.len().saturating_sub(1);
    if n == 0 {
        return Vec::new();
    }
    // Companion matrix of z^n + d1 z^(n-1) + .. + dn.
    let c = DMatrix::from_fn(n, n, |i, j| {
        if i == 0 {
            -den[j + 1]
        } else if i == j + 1 {
            1.0
        } else {
            0.0
        }
    });
    c.complex_eigenvalues()
        .iter()
        .map(|z| [z.re, z.im])
        .collect()
}

/// One row of an order-search table.
struct SearchRow {
    orders: Orders,
    ridge: f64,
    fit: Vec<Option<f64>>,
    stable: bool,
    note: Option<String>,
}

impl SearchRow {
    /// Mean simulation fit over the targets (`None` if any is missing).
    fn mean(&self) -> Option<f64> {
        let v: Option<Vec<f64>> = self.fit.iter().copied().collect();
        v.map(|v| v.iter().sum::<f64>() / v.len() as f64)
    }
}

/// `ds` restricted to the inputs `idx` (in that order). In the change form
/// the reference is re-taken at the first row where every kept input has a
/// value, as the hub will take it for a model with only those inputs.
pub fn subset(ds: &Dataset, idx: &[usize]) -> Dataset {
    let mut out = ds.clone();
    out.inputs = idx.iter().map(|&i| ds.inputs[i].clone()).collect();
    for run in &mut out.runs {
        let mut x: Vec<Vec<Option<f64>>> = idx.iter().map(|&i| run.x[i].clone()).collect();
        if ds.form == InputForm::Change {
            let n = run.t_s.len();
            if let Some(first) = (0..n).find(|&r| x.iter().all(|c| c[r].is_some())) {
                for c in &mut x {
                    let r0 = c[first].unwrap_or(0.0);
                    for v in c.iter_mut().flatten() {
                        *v -= r0;
                    }
                }
            }
        }
        run.x = x;
    }
    out
}

/// Grid runs with only the inputs `idx`.
pub fn sub_grid(grid: &[GridRun], idx: &[usize]) -> Vec<GridRun> {
    grid.iter()
        .map(|g| GridRun {
            name: g.name.clone(),
            t_s: Vec::new(),
            x: idx.iter().map(|&i| g.x[i].clone()).collect(),
            y: g.y.clone(),
            calib_end: g.calib_end,
        })
        .collect()
}

/// Names only (no rows): enough for [`bank`]'s model-core check.
pub fn names_only(ds: &Dataset, idx: &[usize]) -> Dataset {
    Dataset {
        inputs: idx.iter().map(|&i| ds.inputs[i].clone()).collect(),
        targets: ds.targets.clone(),
        form: ds.form,
        runs: Vec::new(),
    }
}

/// The most inputs forward selection may keep: `--max-inputs`, and the
/// 16-entry bank shared by all targets.
pub fn max_selected(args: &ArxArgs, ds: &Dataset) -> Result<usize> {
    let k = args
        .max_inputs
        .min(MAX_TF_ENTRIES / ds.targets.len().max(1))
        .min(ds.inputs.len());
    if k == 0 {
        bail!("--max-inputs 0 (or more than {MAX_TF_ENTRIES} targets): nothing to select");
    }
    if !(args.min_gain_pct.is_finite() && args.min_gain_pct >= 0.0) {
        bail!("--min-gain-pct {} must be >= 0", args.min_gain_pct);
    }
    Ok(k)
}

/// Greedy forward selection over `ds.inputs`. `score(idx)` returns the
/// search fit (mean over targets) of the model on inputs `idx`, with a JSON
/// note (e.g. the orders), or `None` when no stable model exists. Each step
/// adds the candidate with the best score; it stops at `k_max` inputs or
/// when the best addition gains less than `min_gain` points (the first
/// input is always taken). Returns the chosen indices and the path.
pub fn forward_select(
    ds: &Dataset,
    k_max: usize,
    min_gain: f64,
    what: &str,
    mut score: impl FnMut(&[usize]) -> Option<(f64, Value)>,
) -> Result<(Vec<usize>, Value)> {
    let n = ds.inputs.len();
    let pb = progress((0..k_max).map(|s| n - s).sum(), what);
    let mut chosen: Vec<usize> = Vec::new();
    let mut current: Option<f64> = None;
    let mut path = Vec::new();
    let mut stop = format!("reached {k_max} inputs");
    while chosen.len() < k_max {
        let mut tried = Map::new();
        let mut best: Option<(usize, f64, Value)> = None;
        for c in (0..n).filter(|c| !chosen.contains(c)) {
            pb.inc(1);
            let mut trial = chosen.clone();
            trial.push(c);
            let r = score(&trial);
            tried.insert(ds.inputs[c].clone(), json!(r.as_ref().map(|r| r.0)));
            if let Some((f, note)) = r {
                if best.as_ref().is_none_or(|b| f > b.1) {
                    best = Some((c, f, note));
                }
            }
        }
        let Some((c, f, note)) = best else {
            stop = "no addition gave a stable model".into();
            break;
        };
        let gain = current.map(|cur| f - cur);
        if gain.is_some_and(|g| g < min_gain) {
            stop = format!(
                "best addition {} gains {:.2} points < --min-gain-pct {min_gain}",
                ds.inputs[c],
                gain.unwrap_or(0.0)
            );
            path.push(
                json!({"rejected": ds.inputs[c], "search_fit_pct": f, "gain_pct": gain,
                             "candidates": tried}),
            );
            break;
        }
        chosen.push(c);
        current = Some(f);
        path.push(
            json!({"added": ds.inputs[c], "search_fit_pct": f, "gain_pct": gain,
                         "model": note, "candidates": tried}),
        );
    }
    pb.finish_and_clear();
    if chosen.is_empty() {
        bail!("{what}: no single input gave a stable model");
    }
    let names: Vec<&String> = chosen.iter().map(|&i| &ds.inputs[i]).collect();
    Ok((
        chosen,
        json!({"method": "forward", "candidates": ds.inputs, "selected": names,
               "max_inputs": k_max, "min_gain_pct": min_gain, "stopped": stop, "path": path}),
    ))
}

/// Scores orders `o` with every penalty of `lambdas` (one row each): per
/// held-out segment of `scheme`, every target is estimated on the other
/// calibration samples, the bank checked with `check`, free-run from each
/// run's start and its fit pooled over the held-out samples of all segments.
fn eval_orders(
    grid: &[GridRun],
    n_t: usize,
    o: Orders,
    scheme: SearchScheme,
    lambdas: &[f64],
    check: &impl Fn(&[ArxPoly]) -> Result<()>,
) -> Vec<SearchRow> {
    let n_in = n_inputs(grid);
    let p = o.na + n_in * o.nb;
    let mut pairs = vec![vec![Vec::new(); n_t]; lambdas.len()];
    let mut notes: Vec<Option<String>> = vec![None; lambdas.len()];
    let pieces: Vec<Vec<(u64, Tsqr)>> = (0..n_t)
        .map(|t| regression_pieces(grid, t, o, scheme))
        .collect();
    for j in 0..scheme.count() {
        let seg = |g: &GridRun| scheme.segment(g.calib_end, j);
        // Every piece segment j does not exclude (rows whose regressors
        // reach into the segment stay out too).
        let tri: Result<Vec<Triangle>> = pieces
            .iter()
            .map(|ps| {
                let mut ls = Tsqr::new(p);
                for (_, piece) in ps.iter().filter(|(m, _)| m & (1 << j) == 0) {
                    ls.absorb(piece);
                }
                ls.finish()
            })
            .collect();
        let tri = match tri {
            Ok(t) => t,
            Err(e) => {
                for n in notes.iter_mut().filter(|n| n.is_none()) {
                    *n = Some(format!("fold {}: {e}", j + 1));
                }
                break;
            }
        };
        for (l, &lambda) in lambdas.iter().enumerate() {
            if notes[l].is_some() {
                continue;
            }
            let polys = tri
                .iter()
                .map(|tr| ArxPoly::solve(tr, o, n_in, lambda))
                .collect::<Result<Vec<_>>>()
                .and_then(|p| check(&p).map(|()| p));
            let polys = match polys {
                Ok(p) => p,
                Err(e) => {
                    notes[l] = Some(format!("fold {}: {e}", j + 1));
                    continue;
                }
            };
            for (t, p) in polys.iter().enumerate() {
                for g in grid {
                    let (from, to) = seg(g);
                    if from >= to {
                        continue;
                    }
                    let ys = simulate_arx(p, g, to);
                    pairs[l][t].extend(
                        g.y[t][from..to]
                            .iter()
                            .copied()
                            .zip(ys[from..].iter().copied()),
                    );
                }
            }
        }
    }
    lambdas
        .iter()
        .zip(pairs)
        .zip(notes)
        .map(|((&ridge, pairs), note)| {
            let stable = note.is_none();
            let fit = pairs
                .iter()
                .map(|pr| {
                    let f = fit_pct(pr);
                    (stable && f.is_finite()).then_some(f)
                })
                .collect();
            SearchRow {
                orders: o,
                ridge,
                fit,
                stable,
                note,
            }
        })
        .collect()
}

/// The best stable row of an order search and its mean fit.
fn best_row(table: &[SearchRow]) -> Option<(&SearchRow, f64)> {
    table
        .iter()
        .filter(|r| r.stable)
        .filter_map(|r| r.mean().map(|m| (r, m)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
}

/// Fits `--model arx`.
pub fn fit(ds: &Dataset, args: &ArxArgs) -> Result<Fitted> {
    let scheme = SearchScheme::from_args(args)?;
    let dt = sample_time(ds, args.dt_s)?;
    let [dna, dnb, dnk] = ARX_DEFAULTS;
    let cands = candidates(
        args.na.unwrap_or(dna),
        args.nb.unwrap_or(dnb),
        args.nk.unwrap_or(dnk),
    );
    if cands.is_empty() {
        bail!("arx: no order candidate within the model core's limits");
    }
    if args.select_inputs == Selection::Off {
        return fit_inputs(ds, args, scheme, dt, &cands, Value::Null);
    }
    let k_max = max_selected(args, ds)?;
    let grid = grid_runs(ds, dt, "arx")?;
    let n_t = ds.targets.len();
    let (idx, mut selection) =
        forward_select(ds, k_max, args.min_gain_pct, "arx input selection", |idx| {
            let g = sub_grid(&grid, idx);
            let names = names_only(ds, idx);
            let check = |p: &[ArxPoly]| bank(&names, dt, export(p)?).map(|_| ());
            let table: Vec<SearchRow> = cands
                .iter()
                .flat_map(|&o| eval_orders(&g, n_t, o, scheme, &[0.0], &check))
                .collect();
            best_row(&table).map(|(r, m)| (m, r.orders.json()))
        })?;
    selection["orders_during_selection"] = json!("the full order search at every trial");
    selection["ridge_during_selection"] = json!(0.0);
    fit_inputs(&subset(ds, &idx), args, scheme, dt, &cands, selection)
}

/// Every candidate order at every ridge penalty of `lambdas`, scored by
/// `scheme` (candidates in parallel, rows in grid order).
fn order_search(
    ds: &Dataset,
    grid: &[GridRun],
    dt: f64,
    (cands, lambdas): (&[Orders], &[f64]),
    scheme: SearchScheme,
) -> Vec<SearchRow> {
    let n_t = ds.targets.len();
    let check = |p: &[ArxPoly]| bank(ds, dt, export(p)?).map(|_| ());
    let pb = progress(cands.len(), "arx order search");
    // Candidates are independent: one per core (rayon keeps their order).
    let table: Vec<SearchRow> = cands
        .par_iter()
        .map(|&o| {
            let rows = eval_orders(grid, n_t, o, scheme, lambdas, &check);
            pb.inc(1);
            rows
        })
        .collect::<Vec<_>>()
        .into_iter()
        .flatten()
        .collect();
    pb.finish_and_clear();
    table
}

/// The search row kept, re-estimated on every calibration sample.
struct Refitted<'t> {
    row: &'t SearchRow,
    /// Its mean simulation fit in the search.
    score: f64,
    polys: Vec<ArxPoly>,
    model: ValidModel,
    /// Better rows whose re-estimate was refused, with why.
    refused: Vec<Value>,
}

/// The best stable row of the search, re-estimated on every calibration
/// sample (should that come out unstable, the next).
fn refit_best<'t>(
    ds: &Dataset,
    grid: &[GridRun],
    dt: f64,
    table: &'t [SearchRow],
) -> Result<Refitted<'t>> {
    // Best first; on a tie the smaller penalty (rows are in grid order).
    let mut ranked: Vec<(&SearchRow, f64)> = table
        .iter()
        .filter(|r| r.stable)
        .filter_map(|r| r.mean().map(|m| (r, m)))
        .collect();
    ranked.sort_by(|a, b| b.1.total_cmp(&a.1));
    let mut refused = Vec::new();
    for (row, score) in ranked {
        let polys: Result<Vec<ArxPoly>> = (0..ds.targets.len())
            .map(|t| estimate_ridge(grid, t, row.orders, |g| g.calib_end, row.ridge))
            .collect();
        let polys = polys?;
        match bank(ds, dt, export(&polys)?) {
            Ok(model) => {
                return Ok(Refitted {
                    row,
                    score,
                    polys,
                    model,
                    refused,
                })
            }
            Err(e) => refused.push(
                json!({"orders": row.orders.json(), "ridge": row.ridge, "error": e.to_string()}),
            ),
        }
    }
    bail!("arx: no candidate order gave a stable model (try other --na/--nb/--nk or inputs)");
}

/// The search table as JSON: orders, penalty, fit per target, stability.
fn search_table_json(ds: &Dataset, table: &[SearchRow]) -> Vec<Value> {
    table
        .iter()
        .map(|r| {
            let fits: Map<String, Value> = ds
                .targets
                .iter()
                .zip(&r.fit)
                .map(|(n, f)| (n.clone(), json!(f)))
                .collect();
            json!({"na": r.orders.na, "nb": r.orders.nb, "nk": r.orders.nk, "ridge": r.ridge,
                   "sim_fit_pct": fits, "mean_sim_fit_pct": r.mean(), "stable": r.stable,
                   "note": r.note})
        })
        .collect()
}

/// Each target's equation: its denominator and, per input, the numerator
/// and the entry's step response.
fn equations_json(ds: &Dataset, polys: &[ArxPoly], dt: f64) -> Map<String, Value> {
    let mut per_target = Map::new();
    for (t, p) in polys.iter().enumerate() {
        let mut per_input = Map::new();
        for (i, name) in ds.inputs.iter().enumerate() {
            per_input.insert(
                name.clone(),
                json!({"b": p.num[i], "a_entry": p.entry_num(i),
                       "step": step_info(&p.entry_num(i), &p.den, dt)}),
            );
        }
        per_target.insert(
            ds.targets[t].clone(),
            json!({"denominator": p.den, "inputs": per_input}),
        );
    }
    per_target
}

/// The joint search over orders and ridge penalties, then the final
/// estimate on `ds`'s inputs.
fn fit_inputs(
    ds: &Dataset,
    args: &ArxArgs,
    scheme: SearchScheme,
    dt: f64,
    cands: &[Orders],
    selection: Value,
) -> Result<Fitted> {
    let (n_in, n_t) = (ds.inputs.len(), ds.targets.len());
    if n_in * n_t > MAX_TF_ENTRIES {
        bail!(
            "arx: {n_in} inputs x {n_t} targets = {} TF entries; the model holds at most {MAX_TF_ENTRIES} (choose fewer --inputs, or --select-inputs forward)",
            n_in * n_t
        );
    }
    let grid = grid_runs(ds, dt, "arx")?;
    let lambdas = match args.ridge {
        Ridge::Auto => RIDGE_GRID.to_vec(),
        Ridge::Fixed(v) => vec![v],
    };
    let table = order_search(ds, &grid, dt, (cands, &lambdas), scheme);
    let Refitted {
        row,
        score,
        polys,
        model,
        refused,
    } = refit_best(ds, &grid, dt, &table)?;
    let (orders, ridge) = (row.orders, row.ridge);
    let details = json!({
        "dt_s": dt,
        "selection": selection,
        "search": {
            "validation": scheme.json(),
            "table": search_table_json(ds, &table),
        },
        "ridge": {
            "setting": match args.ridge { Ridge::Auto => json!("auto"), Ridge::Fixed(v) => json!(v) },
            "chosen": ridge,
            "basis": "penalty on the column-scaled coefficients (unit-norm regressor columns)",
        },
        "chosen": {"na": orders.na, "nb": orders.nb, "nk": orders.nk, "mean_sim_fit_pct": score,
                   "ridge": ridge},
        "refused_after_refit": refused,
        "solver": "blocked QR of [X | y], SVD of the column-scaled R (ridge rows appended when > 0)",
        "gain_unit": "target unit per input unit (um/K for temperatures)",
        "equations": equations_json(ds, &polys, dt),
    });
    Ok(Fitted { model, details })
}

/// TF entries of per-target ARX models: input-major within each target.
fn export(polys: &[ArxPoly]) -> Result<Vec<TfEntry>> {
    let mut out = Vec::new();
    for (t, p) in polys.iter().enumerate() {
        for i in 0..p.num.len() {
            out.push(entry(t, i, &p.entry_num(i), &p.den)?);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn folds_partition_the_calibration_samples() {
        // Every calibration sample is held out exactly once, in contiguous
        // folds of near-equal length (uneven counts included).
        for (n, k) in [(5760, 4), (10, 3), (7, 7), (3, 4)] {
            let s = SearchScheme::Folds(k);
            let segs: Vec<(usize, usize)> = (0..s.count()).map(|j| s.segment(n, j)).collect();
            assert_eq!(segs[0].0, 0);
            assert_eq!(segs[k - 1].1, n);
            for w in segs.windows(2) {
                assert_eq!(w[0].1, w[1].0);
            }
            for (a, b) in &segs {
                assert!(b - a <= n.div_ceil(k), "{n} {k}: fold {a}..{b}");
            }
        }
        let tail = SearchScheme::Tail(0.25);
        assert_eq!(tail.count(), 1);
        assert_eq!(tail.segment(100, 0), (75, 100));
    }

    #[test]
    fn fold_estimate_never_sees_the_held_out_fold() {
        // A target that is pure garbage inside fold 2 and a clean FIR of the
        // input elsewhere: the fold-2 model (which must not see the garbage,
        // nor rows whose lags reach into it) recovers the FIR exactly.
        let n = 400;
        let u: Vec<f64> = (0..n).map(|k| ((k * 7919) % 101) as f64 / 10.0).collect();
        let mut y: Vec<f64> = (0..n)
            .map(|k| 2.0 * u[k] - 0.5 * if k > 0 { u[k - 1] } else { u[0] })
            .collect();
        let s = SearchScheme::Folds(4);
        let (from, to) = s.segment(n, 1);
        for (k, v) in y.iter_mut().enumerate().take(to).skip(from) {
            *v = 1e3 * ((k * 31) % 17) as f64;
        }
        let g = GridRun {
            name: "r".into(),
            t_s: Vec::new(),
            x: vec![u],
            y: vec![y],
            calib_end: n,
        };
        let o = Orders {
            na: 1,
            nb: 2,
            nk: 0,
        };
        let mut ls = Tsqr::new(3);
        for (_, piece) in regression_pieces(std::slice::from_ref(&g), 0, o, s)
            .iter()
            .filter(|(m, _)| m & 0b10 == 0)
        {
            ls.absorb(piece);
        }
        let p = ArxPoly::solve(&ls.finish().unwrap(), o, 1, 0.0).unwrap();
        assert!(p.den[1].abs() < 1e-9, "{:?}", p.den);
        assert!((p.num[0][0] - 2.0).abs() < 1e-9 && (p.num[0][1] + 0.5).abs() < 1e-9);
    }

    #[test]
    fn order_ranges_parse() {
        assert_eq!("1..3".parse::<OrderRange>().unwrap(), OrderRange::new(1, 3));
        assert_eq!("2".parse::<OrderRange>().unwrap(), OrderRange::new(2, 2));
        assert!("3..1".parse::<OrderRange>().is_err());
        assert!("0..9".parse::<OrderRange>().is_err());
    }

    #[test]
    fn tsqr_agrees_with_svd_least_squares_across_blocks() {
        // 5000 rows (three blocks), exact y = 2 x0 - 0.5 x1 + 3 x2: recovered
        // to 1e-9 (conditioning of the columns is ~1e2).
        let mut ls = Tsqr::new(3);
        for k in 0..5000 {
            let x = [
                f64::from(k).sin(),
                f64::from(k % 17),
                1.0 + f64::from(k) * 1e-3,
            ];
            ls.push(&x, 2.0 * x[0] - 0.5 * x[1] + 3.0 * x[2]);
        }
        let (b, rss) = ls.solve().unwrap();
        assert!(
            (b[0] - 2.0).abs() < 1e-9 && (b[1] + 0.5).abs() < 1e-9 && (b[2] - 3.0).abs() < 1e-9
        );
        assert!(rss < 1e-12, "{rss}");
    }

    #[test]
    fn first_order_time_constant_is_tau() {
        // ZOH discretisation of K/(tau s + 1), tau = 300 samples: the 63.2 %
        // time is tau within one sample (the response is sampled).
        let p = (-1.0f64 / 300.0).exp();
        let tf = RealisedTf::new(&[0.0, 4.0 * (1.0 - p)], &[1.0, -p]).unwrap();
        let tau = time_constant(&tf, 1.0).unwrap();
        assert!((tau - 300.0).abs() < 1.0, "{tau}");
        assert!((tf.dc_gain() - 4.0).abs() < 1e-12);
    }

    #[test]
    fn fit_pct_of_a_perfect_and_a_mean_model() {
        let y = [1.0, 2.0, 3.0];
        assert_eq!(fit_pct(&y.map(|v| (v, v))), 100.0);
        assert!(fit_pct(&y.map(|v| (v, 2.0))).abs() < 1e-12);
    }
}
