//! MISO ARX models exported as a transfer-function bank (seed 004, Eq. 1-2
//! and the ARX structure its Sec. 2 names). What it shares with the other
//! dynamic trainers (`tf`, `gain`: options, orders, sample time, search
//! split, input selection, the bank) is in [`super::dynamic`]; least squares
//! by blocked QR in [`crate::num::tsqr`].
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

use super::dynamic::bank::{bank, entry, step_info, StepInfo};
use super::dynamic::grid::{grid_runs, sample_time};
use super::dynamic::options::{DynamicOptions, Ridge, Selection};
use super::dynamic::orders::{candidates, OrderRange, Orders};
use super::dynamic::select::{
    forward_select, max_selected, names_only, sub_grid, Forward, SelectionReport, TrialOrders,
};
use super::dynamic::sim_fit::fit_pct;
use super::dynamic::split::{SchemeReport, SearchScheme};
use super::{Details, Fitted};
use crate::data::dataset::{Dataset, GridRun};
use crate::num::progress::progress;
use crate::num::tsqr::{Triangle, Tsqr};
use anyhow::{bail, Result};
use model_core::tf::{TfEntry, MAX_TF_ENTRIES};
use model_core::ValidModel;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;

/// Ridge penalties `auto` tries (0 first: plain least squares wins ties).
pub const RIDGE_GRID: [f64; 7] = [0.0, 1e-7, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2];

/// Default order ranges of `--model arx`.
const ARX_DEFAULTS: [OrderRange; 3] = [
    OrderRange::new(0, 3),
    OrderRange::new(1, 3),
    OrderRange::new(0, 2),
];

/// What `arx` reports (fields in the JSON's key order).
#[derive(Clone, Debug, Serialize)]
pub struct ArxDetails {
    /// The row of the search kept.
    pub chosen: ArxChosen,
    /// Model sample time, s.
    pub dt_s: f64,
    /// Per target, its equation.
    pub equations: BTreeMap<String, ArxEquation>,
    /// Unit of the step gains.
    pub gain_unit: &'static str,
    /// Better rows whose re-estimate on every calibration sample the model
    /// core refused.
    pub refused_after_refit: Vec<RefusedRefit>,
    /// The ridge penalty.
    pub ridge: RidgeReport,
    /// The order and ridge search.
    pub search: ArxSearch,
    /// Forward input selection (`null` with `--select-inputs off`).
    pub selection: Option<SelectionReport>,
    /// How the least squares were solved.
    pub solver: &'static str,
}

/// The search row kept (fields in the JSON's key order).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ArxChosen {
    /// Its mean simulation fit over the targets in the search, %.
    pub mean_sim_fit_pct: f64,
    /// Its structure.
    #[serde(flatten)]
    pub orders: Orders,
    /// Its ridge penalty.
    pub ridge: f64,
}

/// A search row whose re-estimate was refused.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RefusedRefit {
    /// Why (the model core's message).
    pub error: String,
    /// Its structure.
    pub orders: Orders,
    /// Its ridge penalty.
    pub ridge: f64,
}

/// The ridge penalty: as set and as chosen.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RidgeReport {
    /// What the penalty applies to.
    pub basis: &'static str,
    /// The penalty of the model.
    pub chosen: f64,
    /// `--ridge`: `"auto"` or the fixed penalty.
    pub setting: Ridge,
}

/// The order and ridge search.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ArxSearch {
    /// Every (orders, penalty) tried, in grid order.
    pub table: Vec<ArxTableRow>,
    /// How a candidate was scored.
    pub validation: SchemeReport,
}

/// One row of the search table (fields in the JSON's key order).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ArxTableRow {
    /// Mean simulation fit over the targets, % (`null` if any is missing).
    pub mean_sim_fit_pct: Option<f64>,
    /// The structure.
    #[serde(flatten)]
    pub orders: Orders,
    /// Why the candidate was refused (the first fold that refused it).
    pub note: Option<String>,
    /// The ridge penalty.
    pub ridge: f64,
    /// Per target, the simulation fit, % (`null`: refused or not finite).
    pub sim_fit_pct: BTreeMap<String, Option<f64>>,
    /// Whether every fold's model was accepted by the model core.
    pub stable: bool,
}

/// One target's ARX equation.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ArxEquation {
    /// `A`: `[1, a_1 .. a_na]`.
    pub denominator: Vec<f64>,
    /// Per input, its numerator and TF entry.
    pub inputs: BTreeMap<String, ArxTerm>,
}

/// One input's part of an ARX equation, as the TF entry it is exported to.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ArxTerm {
    /// The TF entry's numerator, `[0; nk] ++ B_i`.
    pub a_entry: Vec<f64>,
    /// `B_i`: `[b_i0 .. b_i,nb-1]`.
    pub b: Vec<f64>,
    /// The entry's step response.
    pub step: StepInfo,
}

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
pub fn fit(ds: &Dataset, args: &DynamicOptions) -> Result<Fitted> {
    let scheme = SearchScheme::new(args.search_folds, args.search_holdout)?;
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
        return fit_inputs(ds, args, scheme, dt, &cands, None);
    }
    let k_max = max_selected(args, ds)?;
    let grid = grid_runs(ds, dt, "arx")?;
    let n_t = ds.targets.len();
    let sel = Forward {
        k_max,
        min_gain: args.min_gain_pct,
        what: "arx input selection",
        orders: TrialOrders::Searched("the full order search at every trial"),
        ridge: Some(0.0),
    };
    let (idx, selection) = forward_select(ds, sel, |idx| {
        let g = sub_grid(&grid, idx);
        let names = names_only(ds, idx);
        let check = |p: &[ArxPoly]| bank(&names, dt, export(p)?).map(|_| ());
        let table: Vec<SearchRow> = cands
            .iter()
            .flat_map(|&o| eval_orders(&g, n_t, o, scheme, &[0.0], &check))
            .collect();
        best_row(&table).map(|(r, m)| (m, r.orders))
    })?;
    fit_inputs(
        &ds.with_inputs(&idx),
        args,
        scheme,
        dt,
        &cands,
        Some(selection),
    )
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
    refused: Vec<RefusedRefit>,
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
            Err(e) => refused.push(RefusedRefit {
                error: e.to_string(),
                orders: row.orders,
                ridge: row.ridge,
            }),
        }
    }
    bail!("arx: no candidate order gave a stable model (try other --na/--nb/--nk or inputs)");
}

/// The search table as reported: orders, penalty, fit per target, stability.
fn search_table(ds: &Dataset, table: &[SearchRow]) -> Vec<ArxTableRow> {
    table
        .iter()
        .map(|r| ArxTableRow {
            mean_sim_fit_pct: r.mean(),
            orders: r.orders,
            note: r.note.clone(),
            ridge: r.ridge,
            sim_fit_pct: ds
                .targets
                .iter()
                .cloned()
                .zip(r.fit.iter().copied())
                .collect(),
            stable: r.stable,
        })
        .collect()
}

/// Each target's equation: its denominator and, per input, the numerator
/// and the entry's step response.
fn equations(ds: &Dataset, polys: &[ArxPoly], dt: f64) -> BTreeMap<String, ArxEquation> {
    let mut per_target = BTreeMap::new();
    for (t, p) in polys.iter().enumerate() {
        let inputs = ds
            .inputs
            .iter()
            .enumerate()
            .map(|(i, name)| {
                let term = ArxTerm {
                    a_entry: p.entry_num(i),
                    b: p.num[i].clone(),
                    step: step_info(&p.entry_num(i), &p.den, dt),
                };
                (name.clone(), term)
            })
            .collect();
        per_target.insert(
            ds.targets[t].clone(),
            ArxEquation {
                denominator: p.den.clone(),
                inputs,
            },
        );
    }
    per_target
}

/// The joint search over orders and ridge penalties, then the final
/// estimate on `ds`'s inputs.
fn fit_inputs(
    ds: &Dataset,
    args: &DynamicOptions,
    scheme: SearchScheme,
    dt: f64,
    cands: &[Orders],
    selection: Option<SelectionReport>,
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
    let details = ArxDetails {
        chosen: ArxChosen {
            mean_sim_fit_pct: score,
            orders: row.orders,
            ridge: row.ridge,
        },
        dt_s: dt,
        equations: equations(ds, &polys, dt),
        gain_unit: "target unit per input unit (um/K for temperatures)",
        refused_after_refit: refused,
        ridge: RidgeReport {
            basis: "penalty on the column-scaled coefficients (unit-norm regressor columns)",
            chosen: row.ridge,
            setting: args.ridge,
        },
        search: ArxSearch {
            table: search_table(ds, &table),
            validation: scheme.report(),
        },
        selection,
        solver: "blocked QR of [X | y], SVD of the column-scaled R (ridge rows appended when > 0)",
    };
    Ok(Fitted {
        model,
        details: Details::Arx(Box::new(details)),
    })
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
            x_lead: vec![Vec::new()],
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
}
