//! A bank of SISO transfer functions, each with its own denominator, fitted
//! for simulation: seed 004's model form (Eq. 1-2, `dZ = eps_SP(dT_bearing)
//! + eps_amb(dT_amb)`), one TF per input.
//!
//! Per target: `yhat(k) = sum_i B_i(q)/A_i(q) u_i(k - nk_i)`, minimising the
//! output (simulation) error `sum_k (y(k) - yhat(k))^2` over the calibration
//! samples, every run simulated from its start as the hub will run it. That
//! is non-linear in the `A_i`, so:
//!
//! 1. **Backfitting.** A few rounds over the inputs; each fits a SISO ARX of
//!    the partial residual `y - sum_{j != i} yhat_j` on `u_i` (least squares,
//!    blocked QR), kept only if stable, then simulated.
//! 2. **Levenberg-Marquardt** on all parameters jointly. The Jacobian is
//!    analytic: `d yhat / d b_il = u_i(k - nk - l) / A_i(q)` and
//!    `d yhat / d a_ij = -yhat_i(k - j) / A_i(q)` (two filterings per input);
//!    each step solves `[J; sqrt(lambda) D] d = [r; 0]` from the QR of `[J | r]`
//!    (D: column norms of J). A step that makes any TF unstable (the model
//!    core's own check) or does not lower the cost is rejected and lambda
//!    grows; iterations are bounded (`--lm-iterations`).
//!
//! Orders are chosen per input by one greedy pass: start with every input at
//! the smallest structure, then for each input in turn try every other
//! structure of the ranges with the rest held, keeping a change that raises
//! the simulation fit on the search-validation part (the last
//! `--search-holdout` of each run's calibration samples, simulated from the
//! run's start with parameters fitted on the samples before it).
//!
//! `--select-inputs forward` (shared with `arx`) scores each trial set with
//! every input at the smallest structure of the ranges (the per-input order
//! search, a whole-bank fit per trial, runs only on the selected set).

use super::dynamic::bank::{bank, entry, step_info, StepInfo};
use super::dynamic::grid::{grid_runs, sample_time};
use super::dynamic::options::{DynamicOptions, Selection};
use super::dynamic::orders::{candidates, OrderRange, Orders};
use super::dynamic::select::{
    forward_select, max_selected, sub_grid, Forward, SelectionReport, TrialOrders,
};
use super::dynamic::sim_fit::fit_pct;
use super::dynamic::split::search_split;
use super::{Details, Fitted};
use crate::data::dataset::{Dataset, GridRun};
use crate::num::progress::progress;
use crate::num::tsqr::Tsqr;
use anyhow::{bail, Result};
use model_core::tf::{RealisedTf, TfEntry, MAX_TF_ENTRIES};
use nalgebra::{DMatrix, DVector};
use serde::Serialize;
use std::collections::BTreeMap;

/// Default order ranges of `--model tf` (per input; modest, since the
/// greedy search fits the whole bank for every trial).
const TF_DEFAULTS: [OrderRange; 3] = [
    OrderRange { min: 1, max: 2 },
    OrderRange { min: 1, max: 2 },
    OrderRange { min: 0, max: 1 },
];

/// One SISO TF: `A(q) y(k) = B(q) u(k - nk)`.
#[derive(Clone, Debug)]
pub struct Siso {
    /// Structure.
    pub orders: Orders,
    /// `[1, a_1 .. a_na]`.
    pub den: Vec<f64>,
    /// `[b_0 .. b_nb-1]`.
    pub num: Vec<f64>,
}

impl Siso {
    /// The zero TF of a structure (poles at the origin: stable).
    pub fn zero(orders: Orders) -> Self {
        let mut den = vec![0.0; orders.na + 1];
        den[0] = 1.0;
        Self {
            orders,
            den,
            num: vec![0.0; orders.nb],
        }
    }

    /// TF-entry numerator `[0; nk] ++ B`.
    pub fn entry_num(&self) -> Vec<f64> {
        let mut a = vec![0.0; self.orders.nk];
        a.extend_from_slice(&self.num);
        a
    }

    /// Whether the model core accepts it.
    pub fn stable(&self) -> bool {
        RealisedTf::new(&self.entry_num(), &self.den).is_ok()
    }

    fn n_params(&self) -> usize {
        self.orders.na + self.orders.nb
    }

    fn params(&self) -> impl Iterator<Item = f64> + '_ {
        self.den[1..].iter().chain(&self.num).copied()
    }

    fn with_params(&self, p: &[f64]) -> Self {
        let na = self.orders.na;
        let mut den = vec![1.0];
        den.extend_from_slice(&p[..na]);
        Self {
            orders: self.orders,
            den,
            num: p[na..na + self.orders.nb].to_vec(),
        }
    }

    /// Simulates the first `n` samples of `u`, starting in the steady state
    /// of `u(0)` (what the model core does at a run's first sample).
    pub fn simulate(&self, u: &[f64], n: usize) -> Vec<f64> {
        let sd: f64 = self.den.iter().sum();
        let g = if sd.abs() > 1e-12 {
            self.num.iter().sum::<f64>() / sd
        } else {
            0.0
        };
        let u0 = u.first().copied().unwrap_or(0.0);
        let y0 = g * u0;
        let nk = self.orders.nk;
        let mut y = Vec::with_capacity(n);
        for k in 0..n {
            let mut v = 0.0;
            for (l, b) in self.num.iter().enumerate() {
                v += b * k.checked_sub(nk + l).map_or(u0, |i| u[i]);
            }
            for (j, a) in self.den.iter().enumerate().skip(1) {
                v -= a * k.checked_sub(j).map_or(y0, |i| y[i]);
            }
            y.push(v);
        }
        y
    }
}

/// `w = x / A(q)` from a zero state.
fn filter(den: &[f64], x: &[f64]) -> Vec<f64> {
    let mut w: Vec<f64> = Vec::with_capacity(x.len());
    for (k, xk) in x.iter().enumerate() {
        let mut v = *xk;
        for (j, a) in den.iter().enumerate().skip(1) {
            if let Some(i) = k.checked_sub(j) {
                v -= a * w[i];
            }
        }
        w.push(v);
    }
    w
}

/// How the output-error fit of one target went (`output_error` in the
/// report; fields in the JSON's key order).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OeReport {
    /// LM steps accepted.
    #[serde(rename = "lm_accepted")]
    pub accepted: usize,
    /// LM iterations (accepted and rejected trials).
    #[serde(rename = "lm_trials")]
    pub iterations: usize,
    /// LM steps refused because a TF would have become unstable.
    #[serde(rename = "lm_unstable_rejected")]
    pub unstable_rejected: usize,
    /// RMS simulation error after backfitting (target unit).
    #[serde(rename = "rms_after_backfit")]
    pub rms_backfit: f64,
    /// RMS simulation error after Levenberg-Marquardt (target unit).
    #[serde(rename = "rms_after_lm")]
    pub rms_final: f64,
}

/// What `tf` reports (fields in the JSON's key order).
#[derive(Clone, Debug, Serialize)]
pub struct TfDetails {
    /// `--backfit-rounds`.
    pub backfit_rounds: usize,
    /// Model sample time, s.
    pub dt_s: f64,
    /// Unit of the step gains.
    pub gain_unit: &'static str,
    /// `--lm-iterations`.
    pub lm_iterations: usize,
    /// How each target's bank is fitted.
    pub method: &'static str,
    /// How the orders were searched.
    pub search: TfSearch,
    /// Forward input selection (`null` with `--select-inputs off`).
    pub selection: Option<SelectionReport>,
    /// Per target, its search and bank.
    pub targets: BTreeMap<String, TfTarget>,
}

/// How the per-input orders were searched.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TfSearch {
    /// What a trial's score is.
    pub score: &'static str,
    /// `--search-holdout`: the fraction of each run's calibration samples scored.
    pub search_holdout: f64,
    /// The search's strategy.
    pub strategy: &'static str,
}

/// One target's order search and fitted bank.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TfTarget {
    /// Per input, its TF.
    pub inputs: BTreeMap<String, TfTerm>,
    /// How the final output-error fit went.
    pub output_error: OeReport,
    /// The order search.
    pub search: TfTargetSearch,
}

/// One input's TF of a target (the bank's entry).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TfTerm {
    /// Entry numerator `[0; nk] ++ B`.
    pub a: Vec<f64>,
    /// Entry denominator `[1, a_1 .. a_na]`.
    pub b: Vec<f64>,
    /// Its structure.
    pub orders: Orders,
    /// Its step response.
    pub step: StepInfo,
}

/// One target's order search: every trial and the best fit.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TfTargetSearch {
    /// The best simulation fit on the search-validation part, %.
    pub best_sim_fit_pct: f64,
    /// Every trial, in the order tried.
    pub table: Vec<TfTableRow>,
}

/// One trial of the order search.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TfTableRow {
    /// Why the fit failed.
    pub note: Option<String>,
    /// Per input, the structure tried.
    pub orders: BTreeMap<String, Orders>,
    /// Simulation fit on the search-validation part, % (`null`: failed or not finite).
    pub sim_fit_pct: Option<f64>,
    /// Whether the fit succeeded.
    pub stable: bool,
}

/// Simulated bank outputs `[run][input][k]` over `..end(run)`.
fn simulate_all(
    models: &[Siso],
    grid: &[GridRun],
    end: &impl Fn(&GridRun) -> usize,
) -> Vec<Vec<Vec<f64>>> {
    grid.iter()
        .map(|g| {
            models
                .iter()
                .zip(&g.x)
                .map(|(m, u)| m.simulate(u, end(g)))
                .collect()
        })
        .collect()
}

fn sse(
    grid: &[GridRun],
    t: usize,
    sims: &[Vec<Vec<f64>>],
    end: &impl Fn(&GridRun) -> usize,
) -> f64 {
    let mut s = 0.0;
    for (g, sim) in grid.iter().zip(sims) {
        for k in 0..end(g) {
            let yhat: f64 = sim.iter().map(|v| v[k]).sum();
            s += (g.y[t][k] - yhat).powi(2);
        }
    }
    s
}

/// Backfitting (the first stage of the output-error fit): each input's
/// transfer function in turn, by least squares on what the others leave of
/// the target, kept only when stable; `sims` follow `models`.
fn backfit(
    models: &mut [Siso],
    sims: &mut [Vec<Vec<f64>>],
    grid: &[GridRun],
    t: usize,
    end: &impl Fn(&GridRun) -> usize,
    rounds: usize,
) -> Result<()> {
    for _ in 0..rounds {
        for i in 0..models.len() {
            let o = models[i].orders;
            let mut ls = Tsqr::new(o.na + o.nb);
            let mut row = vec![0.0; o.na + o.nb];
            for (g, sim) in grid.iter().zip(sims.iter()) {
                let n = end(g);
                let r: Vec<f64> = (0..n)
                    .map(|k| {
                        g.y[t][k]
                            - sim
                                .iter()
                                .enumerate()
                                .filter(|(j, _)| *j != i)
                                .map(|(_, v)| v[k])
                                .sum::<f64>()
                    })
                    .collect();
                let u = &g.x[i];
                for k in o.max_lag()..n {
                    for j in 1..=o.na {
                        row[j - 1] = -r[k - j];
                    }
                    for l in 0..o.nb {
                        row[o.na + l] = u[k - o.nk - l];
                    }
                    ls.push(&row, r[k]);
                }
            }
            let (theta, _) = ls.solve()?;
            let cand = models[i].with_params(&theta);
            if cand.stable() {
                models[i] = cand;
                for (g, sim) in grid.iter().zip(sims.iter_mut()) {
                    sim[i] = models[i].simulate(&g.x[i], end(g));
                }
            }
        }
    }
    Ok(())
}

/// The output error's Jacobian and residual `[J | r]` of target `t` at
/// `models` (simulated outputs `sims`), reduced by blocked QR: each row's
/// derivatives are the inputs and simulated outputs filtered by `1/A`.
fn linearised(
    models: &[Siso],
    sims: &[Vec<Vec<f64>>],
    grid: &[GridRun],
    t: usize,
    end: &impl Fn(&GridRun) -> usize,
) -> Tsqr {
    let p: usize = models.iter().map(Siso::n_params).sum();
    let mut ls = Tsqr::new(p);
    let mut row = vec![0.0; p];
    for (g, sim) in grid.iter().zip(sims) {
        let n = end(g);
        let filtered: Vec<(Vec<f64>, Vec<f64>)> = models
            .iter()
            .zip(&g.x)
            .zip(sim)
            .map(|((m, u), yi)| (filter(&m.den, &u[..n]), filter(&m.den, yi)))
            .collect();
        for k in 0..n {
            let mut c = 0;
            for (m, (wu, wy)) in models.iter().zip(&filtered) {
                for j in 1..=m.orders.na {
                    row[c] = k.checked_sub(j).map_or(0.0, |i| -wy[i]);
                    c += 1;
                }
                for l in 0..m.orders.nb {
                    row[c] = k.checked_sub(m.orders.nk + l).map_or(0.0, |i| wu[i]);
                    c += 1;
                }
            }
            let yhat: f64 = sim.iter().map(|v| v[k]).sum();
            ls.push(&row, g.y[t][k] - yhat);
        }
    }
    ls
}

/// The Levenberg-Marquardt step with damping `lambda` and scaling `d`:
/// the least-squares solution of `[R11; sqrt(lambda) D] delta = [z; 0]`
/// (`None` if the SVD fails).
fn damped_step(
    r11: &DMatrix<f64>,
    z: &DVector<f64>,
    d: &[f64],
    lambda: f64,
) -> Option<DVector<f64>> {
    let (k, p) = (r11.nrows(), d.len());
    let sl = lambda.sqrt();
    let a = DMatrix::from_fn(k + p, p, |i, j| {
        if i < k {
            r11[(i, j)]
        } else if i - k == j {
            sl * d[j]
        } else {
            0.0
        }
    });
    let b = DVector::from_fn(k + p, |i, _| if i < k { z[i] } else { 0.0 });
    let svd = crate::num::decomp::svd(a).ok()?;
    let tol = 1e-13 * svd.singular_values.max();
    svd.solve(&b, tol).ok()
}

/// The bank with all its parameters `theta` (in `models`' order) replaced.
fn with_all_params(models: &[Siso], theta: &[f64]) -> Vec<Siso> {
    let mut off = 0;
    models
        .iter()
        .map(|m| {
            let s = m.with_params(&theta[off..off + m.n_params()]);
            off += m.n_params();
            s
        })
        .collect()
}

/// Fits target `t` on samples `..end(run)` of every run with the given
/// per-input structures: backfitting, then Levenberg-Marquardt.
pub fn fit_target(
    grid: &[GridRun],
    t: usize,
    orders: &[Orders],
    end: impl Fn(&GridRun) -> usize,
    args: &DynamicOptions,
) -> Result<(Vec<Siso>, OeReport)> {
    let mut models: Vec<Siso> = orders.iter().map(|o| Siso::zero(*o)).collect();
    let mut sims = simulate_all(&models, grid, &end);
    backfit(
        &mut models,
        &mut sims,
        grid,
        t,
        &end,
        args.backfit_rounds.max(1),
    )?;
    let n_total: usize = grid.iter().map(&end).sum();
    let rms = |s: f64| (s / n_total.max(1) as f64).sqrt();
    let mut cost = sse(grid, t, &sims, &end);
    let mut report = OeReport {
        rms_backfit: rms(cost),
        rms_final: rms(cost),
        iterations: 0,
        accepted: 0,
        unstable_rejected: 0,
    };
    let p: usize = models.iter().map(Siso::n_params).sum();
    let mut lambda: f64 = 1e-3;
    'outer: while report.accepted < args.lm_iterations && cost > 0.0 {
        let Some((r11, z)) = linearised(&models, &sims, grid, t, &end).triangle() else {
            break;
        };
        let d: Vec<f64> = (0..p).map(|j| r11.column(j).norm().max(1e-300)).collect();
        let theta: Vec<f64> = models.iter().flat_map(Siso::params).collect();
        loop {
            report.iterations += 1;
            if report.iterations > 4 * args.lm_iterations.max(1) || lambda > 1e12 {
                break 'outer;
            }
            let Some(delta) = damped_step(&r11, &z, &d, lambda) else {
                break 'outer;
            };
            let new_theta: Vec<f64> = theta.iter().zip(delta.iter()).map(|(a, b)| a + b).collect();
            let trial = with_all_params(&models, &new_theta);
            if !trial.iter().all(Siso::stable) {
                report.unstable_rejected += 1;
                lambda *= 10.0;
                continue;
            }
            let trial_sims = simulate_all(&trial, grid, &end);
            let trial_cost = sse(grid, t, &trial_sims, &end);
            if trial_cost.is_finite() && trial_cost < cost {
                let gain = (cost - trial_cost) / cost;
                models = trial;
                sims = trial_sims;
                cost = trial_cost;
                report.accepted += 1;
                lambda = (lambda / 10.0).max(1e-12);
                if gain < 1e-10 {
                    break 'outer;
                }
                break;
            }
            lambda *= 10.0;
        }
    }
    report.rms_final = rms(cost);
    Ok((models, report))
}

/// Simulation fit % of target `t` on the search-validation part.
fn validation_fit(grid: &[GridRun], t: usize, models: &[Siso], h: f64) -> Option<f64> {
    let mut pairs = Vec::new();
    for g in grid {
        let from = search_split(g.calib_end, h);
        let sims: Vec<Vec<f64>> = models
            .iter()
            .zip(&g.x)
            .map(|(m, u)| m.simulate(u, g.calib_end))
            .collect();
        for k in from..g.calib_end {
            pairs.push((g.y[t][k], sims.iter().map(|v| v[k]).sum()));
        }
    }
    let f = fit_pct(&pairs);
    f.is_finite().then_some(f)
}

/// The order candidates of `args` (tf defaults where unset) and the first,
/// the orders used while inputs are being selected.
fn order_candidates(args: &DynamicOptions) -> Result<(Vec<Orders>, Orders)> {
    let [dna, dnb, dnk] = TF_DEFAULTS;
    let cands = candidates(
        args.na.unwrap_or(dna),
        args.nb.unwrap_or(dnb),
        args.nk.unwrap_or(dnk),
    );
    let Some(&start) = cands.first() else {
        bail!("tf: no order candidate within the model core's limits");
    };
    Ok((cands, start))
}

/// Fits `--model tf` (`args` checked by [`DynamicOptions::check`]).
pub fn fit(ds: &Dataset, args: &DynamicOptions) -> Result<Fitted> {
    if args.select_inputs == Selection::Off {
        return fit_inputs(ds, args, None);
    }
    let dt = sample_time(ds, args.dt_s)?;
    let k_max = max_selected(args, ds)?;
    let grid = grid_runs(ds, dt, "tf")?;
    let (_, start) = order_candidates(args)?;
    let h = args.search_holdout;
    let est_end = |g: &GridRun| search_split(g.calib_end, h);
    let sel = Forward {
        k_max,
        min_gain: args.min_gain_pct,
        what: "tf input selection",
        orders: TrialOrders::Fixed(start),
        ridge: None,
    };
    let (idx, selection) = forward_select(ds, sel, |idx| {
        let g = sub_grid(&grid, idx);
        let orders = vec![start; idx.len()];
        let mut sum = 0.0;
        for t in 0..ds.targets.len() {
            let (models, _) = fit_target(&g, t, &orders, est_end, args).ok()?;
            sum += validation_fit(&g, t, &models, h)?;
        }
        Some((sum / ds.targets.len() as f64, start))
    })?;
    fit_inputs(&ds.with_inputs(&idx), args, Some(selection))
}

/// Target `t`'s greedy per-input order search (every input starts at
/// `start`, then each in turn tries every other structure of `cands`):
/// the structures kept and the search's table.
fn search_orders(
    ds: &Dataset,
    grid: &[GridRun],
    t: usize,
    (cands, start): (&[Orders], Orders),
    args: &DynamicOptions,
    tick: &dyn Fn(),
) -> Result<(Vec<Orders>, TfTargetSearch)> {
    let h = args.search_holdout;
    let est_end = |g: &GridRun| search_split(g.calib_end, h);
    let mut table = Vec::new();
    let mut eval = |orders: &[Orders]| -> Option<f64> {
        tick();
        let (fit, note) = match fit_target(grid, t, orders, est_end, args) {
            Ok((models, _)) => (validation_fit(grid, t, &models, h), None),
            Err(e) => (None, Some(e.to_string())),
        };
        table.push(TfTableRow {
            stable: note.is_none(),
            note,
            orders: ds
                .inputs
                .iter()
                .cloned()
                .zip(orders.iter().copied())
                .collect(),
            sim_fit_pct: fit,
        });
        fit
    };
    let n_in = ds.inputs.len();
    let mut current = vec![start; n_in];
    let mut best = eval(&current);
    for i in 0..n_in {
        for &o in cands {
            if o == current[i] {
                continue;
            }
            let mut trial = current.clone();
            trial[i] = o;
            let f = eval(&trial);
            if let Some(f) = f {
                if best.is_none_or(|b| f > b + 1e-9) {
                    best = Some(f);
                    current = trial;
                }
            }
        }
    }
    let Some(best) = best else {
        bail!("tf: {}: no structure could be fitted", ds.targets[t]);
    };
    let search = TfTargetSearch {
        best_sim_fit_pct: best,
        table,
    };
    Ok((current, search))
}

/// Target `t`'s bank with structures `orders`, fitted on every calibration
/// sample: its report, its TF entries appended to `entries`.
fn fit_bank_target(
    ds: &Dataset,
    grid: &[GridRun],
    t: usize,
    (orders, search): (&[Orders], TfTargetSearch),
    (args, dt): (&DynamicOptions, f64),
    entries: &mut Vec<TfEntry>,
) -> Result<TfTarget> {
    let (models, report) = fit_target(grid, t, orders, |g| g.calib_end, args)?;
    let mut inputs = BTreeMap::new();
    for (i, (m, name)) in models.iter().zip(&ds.inputs).enumerate() {
        entries.push(entry(t, i, &m.entry_num(), &m.den)?);
        let term = TfTerm {
            a: m.entry_num(),
            b: m.den.clone(),
            orders: m.orders,
            step: step_info(&m.entry_num(), &m.den, dt),
        };
        inputs.insert(name.clone(), term);
    }
    Ok(TfTarget {
        inputs,
        output_error: report,
        search,
    })
}

/// The per-input order search and the final fit on `ds`'s inputs.
fn fit_inputs(
    ds: &Dataset,
    args: &DynamicOptions,
    selection: Option<SelectionReport>,
) -> Result<Fitted> {
    let dt = sample_time(ds, args.dt_s)?;
    let (n_in, n_t) = (ds.inputs.len(), ds.targets.len());
    if n_in * n_t > MAX_TF_ENTRIES {
        bail!(
            "tf: {n_in} inputs x {n_t} targets = {} TF entries; the model holds at most {MAX_TF_ENTRIES} (choose fewer --inputs)",
            n_in * n_t
        );
    }
    let grid = grid_runs(ds, dt, "tf")?;
    let (cands, start) = order_candidates(args)?;
    let pb = progress(n_t * (1 + n_in * (cands.len() - 1)), "tf order search");
    let mut entries = Vec::new();
    let mut targets = BTreeMap::new();
    for (t, target) in ds.targets.iter().enumerate() {
        let (orders, search) = search_orders(ds, &grid, t, (&cands, start), args, &|| pb.inc(1))?;
        let report = fit_bank_target(ds, &grid, t, (&orders, search), (args, dt), &mut entries)?;
        targets.insert(target.clone(), report);
    }
    pb.finish_and_clear();
    let model =
        bank(ds, dt, entries).map_err(|e| anyhow::anyhow!("tf: fitted model refused: {e}"))?;
    let details = TfDetails {
        backfit_rounds: args.backfit_rounds,
        dt_s: dt,
        gain_unit: "target unit per input unit (um/K for temperatures)",
        lm_iterations: args.lm_iterations,
        method: "per-input SISO TFs, SISO ARX backfitting then Levenberg-Marquardt on the simulation error",
        search: TfSearch {
            score: "simulation fit % from each run's start, scored on the last search_holdout of its calibration samples",
            search_holdout: args.search_holdout,
            strategy: "greedy, one pass over the inputs",
        },
        selection,
        targets,
    };
    Ok(Fitted {
        model,
        details: Details::Tf(Box::new(details)),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn simulate_matches_the_model_core() {
        // y(k) = 0.9 y(k-1) + 0.3 u(k-1) from the steady state of u(0) = 2:
        // the model core's realisation gives the same sequence to 1e-12.
        let m = Siso {
            orders: Orders {
                na: 1,
                nb: 1,
                nk: 1,
            },
            den: vec![1.0, -0.9],
            num: vec![0.3],
        };
        let u: Vec<f64> = (0..50).map(|k| 2.0 + f64::from(k).sin()).collect();
        let y = m.simulate(&u, u.len());
        let tf = RealisedTf::new(&m.entry_num(), &m.den).unwrap();
        let mut h = tf.steady_state(u[0]);
        for (k, uk) in u.iter().enumerate() {
            let yk = tf.output(&h, *uk);
            assert!((yk - y[k]).abs() < 1e-12, "{k}: {yk} vs {}", y[k]);
            h.push(*uk, yk);
        }
    }
}
