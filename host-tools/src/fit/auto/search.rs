//! The candidate search of `fit --model auto`, for one target.
//!
//! Every candidate is a ridge regression over a filter bank (features.rs):
//! an input form (changes from the run's first sample without intercept,
//! or absolute values with one), a set of temperature filter time
//! constants, a set of heat-source filter time constants and a penalty.
//! Each is scored by cross-validation that respects time (folds.rs); the
//! penalty of each (form, filters) pair is the one with the lowest CV error.
//! The winner is the average of the best few candidates (an average of
//! filter-bank regressions is one again, so it runs on the hub as it is):
//! on real runs the CV errors of the leading candidates lie within each
//! other's noise, and averaging them halves the held-out spread that picking
//! one of them by a noisy CV minimum leaves. Where the folds are whole runs
//! the average is of the candidates within one standard error of the best
//! that have the fewest features ([`simplest_within_noise`]): a few (the
//! filter grid has at most three candidates of one size per form when the
//! inputs are temperatures only).

use super::features::{self, FeatureDef, Role};
use super::folds::{Folds, Scheme};
use super::ridge::{Coefs, CvScore, Design};
use super::table::{cv_columns, CvRow, Family, Form};
use serde::Serialize;

/// The feature columns of one input form over the calibration grid.
#[derive(Clone, Copy)]
pub struct FormData<'a> {
    /// The form.
    pub form: Form,
    /// `x[run][input][k]`: reference-adjusted inputs on the grid.
    pub x: &'a [Vec<Vec<f64>>],
    /// `lead[run][input][k]`: the same before the grid starts
    /// (`GridRun::x_lead`), which the filters run through first.
    pub lead: &'a [Vec<Vec<f64>>],
    /// Input roles.
    pub roles: &'a [Role],
}

/// The search's settings (checked by `AutoParams::check`).
#[derive(Clone, Debug, Serialize)]
pub struct SearchSettings {
    /// Candidate temperature filter sets.
    pub temp_sets: Vec<Vec<f64>>,
    /// Candidate heat-source filter sets.
    pub heat_sets: Vec<Vec<f64>>,
    /// Penalties tried.
    pub lambdas: Vec<f64>,
    /// Candidates averaged into the winner.
    pub ensemble: usize,
    /// Most feature columns the averaged model may have (the hub's capacity).
    pub max_features: usize,
    /// How many of the best candidates also try dropping sensors (0: none).
    pub eliminate: usize,
    /// Sample time, s.
    pub dt_s: f64,
}

/// One fitted member of the winner: its features and coefficients.
#[derive(Clone, Debug)]
pub struct Member {
    /// Input form.
    pub form: Form,
    /// Features, by dataset input index.
    pub features: Vec<FeatureDef>,
    /// Coefficients fitted on every calibration row.
    pub coefs: Coefs,
    /// Penalty.
    pub lambda: f64,
    /// Coefficients fitted without each fold, for the CV residuals.
    pub fold_coefs: Vec<Option<Coefs>>,
}

/// The outcome for one target.
pub struct TargetSearch {
    /// Every candidate, best CV error first.
    pub table: Vec<CvRow>,
    /// The averaged members.
    pub members: Vec<Member>,
    /// Cross-validated residuals of the averaged winner, one per scored
    /// calibration sample (`Folds::scored`), in grid order; `None` where
    /// no member could be fitted for the sample's fold.
    pub cv_residuals: Vec<Option<f64>>,
    /// The same for the average of the best candidates whatever their
    /// size (`cv_residuals` itself within one run): what another family
    /// must beat to replace the ridge, so that preferring the simpler
    /// ridge never hands the choice to a family the best ridge beats.
    pub best_residuals: Vec<Option<f64>>,
}

/// Feature columns of `defs` over every run, concatenated.
fn columns(data: &FormData, defs: &[FeatureDef], dt_s: f64) -> Vec<Vec<f64>> {
    defs.iter()
        .map(|d| {
            data.x
                .iter()
                .zip(data.lead)
                .flat_map(|(run, lead)| features::column_after(lead, run, d, dt_s))
                .collect()
        })
        .collect()
}

struct Scored {
    row: CvRow,
    /// The ranking criterion (`CvScore::geo`).
    rank: f64,
    /// Its standard error (`CvScore::geo_se`).
    rank_se: f64,
    /// Index into the designs.
    design: usize,
    /// Feature columns of that design the candidate uses.
    idx: Vec<usize>,
}

/// The best penalty for the columns `idx` of a design.
fn best_lambda_of(
    design: &Design,
    idx: &[usize],
    lambdas: &[f64],
    intercept: bool,
) -> Option<(f64, CvScore)> {
    lambdas
        .iter()
        .filter_map(|&l| design.cv(idx, l, intercept).map(|s| (l, s)))
        .min_by(|a, b| a.1.geo.total_cmp(&b.1.geo))
}

/// Backward elimination of whole temperature sensors (every feature of
/// one input) from a candidate, by CV with the penalty re-chosen at each
/// step; of the path, the smallest set whose CV error is within one
/// standard error of the path's best ("prefer the simpler model when CV
/// errors are within noise"). `None` when nothing can be dropped.
fn eliminate(
    design: &Design,
    defs: &[FeatureDef],
    roles: &[Role],
    lambdas: &[f64],
    intercept: bool,
) -> Option<(Vec<usize>, Vec<usize>, f64, CvScore)> {
    let mut kept: Vec<usize> = (0..roles.len())
        .filter(|&i| roles[i] == Role::Temperature && defs.iter().any(|d| d.input == i))
        .collect();
    let cols = |kept: &[usize]| -> Vec<usize> {
        (0..defs.len())
            .filter(|&j| roles[defs[j].input] != Role::Temperature || kept.contains(&defs[j].input))
            .collect()
    };
    let mut path: Vec<(Vec<usize>, f64, CvScore)> = Vec::new();
    while kept.len() > 1 {
        let step = kept
            .iter()
            .filter_map(|&drop| {
                let rest: Vec<usize> = kept.iter().copied().filter(|&i| i != drop).collect();
                let (l, cv) = best_lambda_of(design, &cols(&rest), lambdas, intercept)?;
                Some((rest, l, cv))
            })
            .min_by(|a, b| a.2.geo.total_cmp(&b.2.geo))?;
        kept.clone_from(&step.0);
        path.push(step);
    }
    let best = path.iter().map(|p| p.2.geo).fold(f64::INFINITY, f64::min);
    let best_se = path
        .iter()
        .find(|p| p.2.geo == best)
        .map_or(0.0, |p| p.2.geo_se);
    let (kept, lambda, cv) = path
        .into_iter()
        .filter(|p| p.2.geo <= best + best_se)
        .min_by_key(|p| p.0.len())?;
    let all: Vec<usize> = (0..roles.len())
        .filter(|&i| roles[i] == Role::Temperature && defs.iter().any(|d| d.input == i))
        .collect();
    let dropped = all.into_iter().filter(|i| !kept.contains(i)).collect();
    Some((cols(&kept), dropped, lambda, cv))
}

/// The designs (a form's feature bank and its fold sums) and the
/// candidates scored on them.
struct Scoring {
    designs: Vec<(Form, Vec<FeatureDef>, Design)>,
    scored: Vec<Scored>,
}

/// Step 1: every (form, temperature filters, heat filters) candidate of the
/// grid, each at its best penalty.
fn score_grid(
    forms: &[FormData],
    y: &[f64],
    folds: &Folds,
    s: &SearchSettings,
    progress: &dyn Fn(),
) -> Scoring {
    let mut out = Scoring {
        designs: Vec::new(),
        scored: Vec::new(),
    };
    for data in forms {
        let heat_sets: &[Vec<f64>] = if data.roles.contains(&Role::HeatSource) {
            &s.heat_sets
        } else {
            &[Vec::new()][..]
        };
        for temp in &s.temp_sets {
            for heat in heat_sets {
                progress();
                let defs = features::bank(data.roles, temp, heat);
                let design = Design::new(&columns(data, &defs, s.dt_s), y, folds);
                let Some((lambda, cv)) = best_lambda_of(
                    &design,
                    &(0..defs.len()).collect::<Vec<_>>(),
                    &s.lambdas,
                    data.form.intercept(),
                ) else {
                    continue;
                };
                let mut row = CvRow {
                    temp_taus_s: temp.clone(),
                    heat_taus_s: heat.clone(),
                    ..CvRow::new(Family::Ridge, data.form)
                };
                cv_columns(&mut row, lambda, defs.len(), &cv);
                out.scored.push(Scored {
                    design: out.designs.len(),
                    idx: (0..defs.len()).collect(),
                    row,
                    rank: cv.geo,
                    rank_se: cv.geo_se,
                });
                out.designs.push((data.form, defs, design));
            }
        }
    }
    out
}

/// Candidate indices, best CV error first.
fn ranked(scored: &[Scored]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..scored.len()).collect();
    order.sort_by(|&a, &b| scored[a].rank.total_cmp(&scored[b].rank));
    order
}

/// Step 2 (optional): sensor elimination from the best `s.eliminate`
/// candidates, each result a candidate of its own.
fn add_eliminations(forms: &[FormData], sc: &mut Scoring, s: &SearchSettings, progress: &dyn Fn()) {
    for i in ranked(&sc.scored).into_iter().take(s.eliminate) {
        progress();
        let (form, defs, design) = &sc.designs[sc.scored[i].design];
        let Some(roles) = forms.iter().find(|d| d.form == *form).map(|d| d.roles) else {
            continue;
        };
        let Some((idx, dropped, lambda, cv)) =
            eliminate(design, defs, roles, &s.lambdas, form.intercept())
        else {
            continue;
        };
        if dropped.is_empty() {
            continue;
        }
        let mut row = sc.scored[i].row.clone();
        cv_columns(&mut row, lambda, idx.len(), &cv);
        row.dropped_inputs = dropped;
        let design = sc.scored[i].design;
        sc.scored.push(Scored {
            row,
            rank: cv.geo,
            rank_se: cv.geo_se,
            design,
            idx,
        });
    }
}

/// Step 3: the members of the winner, in `order`: candidates of the
/// first one's form (one set of model input channels) that together fit
/// the hub's feature capacity, up to `s.ensemble`; with the indices of
/// the candidates they are.
fn pick_members(
    sc: &Scoring,
    order: &[usize],
    n_folds: usize,
    s: &SearchSettings,
) -> (Vec<Member>, Vec<usize>) {
    let Some(best_form) = order.first().map(|&i| sc.scored[i].row.form) else {
        return (Vec::new(), Vec::new());
    };
    let mut picked = Vec::new();
    let mut members: Vec<Member> = Vec::new();
    let mut union: Vec<FeatureDef> = Vec::new();
    for &i in order {
        if members.len() >= s.ensemble.max(1) {
            break;
        }
        let (form, all_defs, design) = &sc.designs[sc.scored[i].design];
        if *form != best_form {
            continue;
        }
        let idx = &sc.scored[i].idx;
        let defs: Vec<FeatureDef> = idx.iter().map(|&j| all_defs[j]).collect();
        let mut grown = union.clone();
        for d in &defs {
            if !grown.contains(d) {
                grown.push(*d);
            }
        }
        if grown.len() > s.max_features {
            continue;
        }
        let lambda = sc.scored[i].row.lambda;
        let Some(coefs) = design.fit(idx, lambda, form.intercept(), None) else {
            continue;
        };
        let fold_coefs = (0..n_folds)
            .map(|f| design.fit(idx, lambda, form.intercept(), Some(f)))
            .collect();
        union = grown;
        picked.push(i);
        members.push(Member {
            form: *form,
            features: defs,
            coefs,
            lambda,
            fold_coefs,
        });
    }
    (members, picked)
}

/// The one-standard-error rule where the folds are whole runs: of the
/// candidates whose CV error lies within one standard error of the best
/// one's (`rank <= best + se`, both on the mse scale), those with the
/// fewest features, in `order`. A run left out is an operating condition
/// the others did not see, so candidates within that spread are alike for
/// the next one, and the one with fewer filters has less to extrapolate
/// with. A best that is not finite leaves `order` as it is.
fn simplest_within_noise(scored: &[Scored], order: &[usize]) -> Vec<usize> {
    let Some(&best) = order.first() else {
        return Vec::new();
    };
    let within = scored[best].rank + scored[best].rank_se;
    if !within.is_finite() {
        return order.to_vec();
    }
    let near: Vec<usize> = order
        .iter()
        .copied()
        .filter(|&i| scored[i].rank <= within)
        .collect();
    let fewest = near.iter().map(|&i| scored[i].idx.len()).min().unwrap_or(0);
    near.into_iter()
        .filter(|&i| scored[i].idx.len() == fewest)
        .collect()
}

/// Scores every candidate of `forms` for target `y` (concatenated runs),
/// calibration sample `k` in fold `folds.of[k]`, and averages the best.
pub fn search(
    forms: &[FormData],
    y: &[f64],
    folds: &Folds,
    s: &SearchSettings,
    progress: &dyn Fn(),
) -> Option<TargetSearch> {
    let mut sc = score_grid(forms, y, folds, s, progress);
    add_eliminations(forms, &mut sc, s, progress);
    let order = ranked(&sc.scored);
    let (best_members, best_picked) = pick_members(&sc, &order, folds.n, s);
    let simplest = match folds.scheme {
        Scheme::LeaveOut => {
            let near = simplest_within_noise(&sc.scored, &order);
            Some(pick_members(&sc, &near, folds.n, s)).filter(|(m, _)| !m.is_empty())
        }
        Scheme::Forward { .. } => None,
    };
    // The simplest set is another than the best one's: the best's CV
    // residuals are needed apart (what other families must beat).
    let other = matches!(&simplest, Some((_, p)) if *p != best_picked);
    // Without a simplest set that fits (none could be fitted), the best.
    let (members, picked) = simplest.unwrap_or_else(|| (best_members.clone(), best_picked));
    if members.is_empty() {
        return None;
    }
    for &i in &picked {
        sc.scored[i].row.chosen = true;
    }
    let cv_residuals = cv_residuals(forms, &members, y, folds, s.dt_s);
    let best_residuals = if other {
        self::cv_residuals(forms, &best_members, y, folds, s.dt_s)
    } else {
        cv_residuals.clone()
    };
    let table = order
        .into_iter()
        .map(|i| sc.scored[i].row.clone())
        .collect();
    Some(TargetSearch {
        table,
        members,
        cv_residuals,
        best_residuals,
    })
}

/// `y - ŷ` of the averaged winner on each scored calibration sample, `ŷ`
/// from the members fitted for that sample's fold (never on it).
fn cv_residuals(
    forms: &[FormData],
    members: &[Member],
    y: &[f64],
    folds: &Folds,
    dt_s: f64,
) -> Vec<Option<f64>> {
    let mut sum = vec![(0.0, 0usize); y.len()];
    for m in members {
        let Some(data) = forms.iter().find(|d| d.form == m.form) else {
            continue;
        };
        let cols = columns(data, &m.features, dt_s);
        for (k, f) in folds.of.iter().enumerate() {
            let Some(Some(c)) = f.and_then(|f| m.fold_coefs.get(f)) else {
                continue;
            };
            sum[k].0 += c.intercept
                + c.beta
                    .iter()
                    .zip(&cols)
                    .map(|(b, col)| b * col[k])
                    .sum::<f64>();
            sum[k].1 += 1;
        }
    }
    (0..y.len())
        .filter(|&k| folds.scored(k))
        .map(|k| {
            let (s, n) = sum[k];
            (n > 0).then(|| y[k] - s / n as f64)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scored(rank: f64, rank_se: f64, features: usize) -> Scored {
        Scored {
            row: CvRow::new(Family::Ridge, Form::Change),
            rank,
            rank_se,
            design: 0,
            idx: (0..features).collect(),
        }
    }

    /// The best (10 features) is 1.0 +- 0.25; candidates of 4 features at
    /// 1.1 and exactly 1.25 lie within that (the bound is inclusive), one
    /// of 4 at 1.26 and one of 2 at 1.5 do not: the members are the two
    /// 4-feature candidates within the noise, in rank order, never the
    /// 10- or 6-feature ones nor the worse small ones. With a spread of 0
    /// only the best remains, though smaller ones rank below it. A best
    /// that is not finite leaves the order.
    #[test]
    fn within_one_standard_error_the_fewest_features_are_the_members() {
        let sc = [
            scored(1.5, 0.3, 2),
            scored(1.0, 0.25, 10),
            scored(1.25, 0.1, 4),
            scored(1.15, 0.1, 6),
            scored(1.1, 0.1, 4),
            scored(1.26, 0.1, 4),
        ];
        let order = ranked(&sc);
        assert_eq!(order, [1, 4, 3, 2, 5, 0]);
        assert_eq!(simplest_within_noise(&sc, &order), [4, 2]);
        let tight = [
            scored(1.0, 0.0, 10),
            scored(1.1, 0.0, 4),
            scored(0.9, 0.0, 12),
        ];
        let order = ranked(&tight);
        assert_eq!(simplest_within_noise(&tight, &order), [2]);
        assert_eq!(simplest_within_noise(&tight, &[]), Vec::<usize>::new());
        let lost = [
            scored(f64::INFINITY, 0.0, 10),
            scored(f64::INFINITY, 0.0, 4),
        ];
        assert_eq!(simplest_within_noise(&lost, &[0, 1]), [0, 1]);
    }
}
