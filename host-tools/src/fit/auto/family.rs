//! The other model families `fit --model auto` weighs against its ridge
//! (search.rs), scored on the very folds and calibration samples the ridge
//! is scored on, so that their CV errors compare.
//!
//! For each scored fold a family is trained by its own `fit --model`
//! trainer, with that trainer's defaults, on a dataset cut from the
//! calibration grid ([`fold_cuts`]): under the rolling origin, the run
//! truncated at the fold's end, the blocks before the fold calibration and
//! the fold held out; leaving one run out, the other runs' calibration
//! samples, and the fold's run held out. The trained blob is then stepped
//! by model-core over the held-out run from its start on the logged inputs
//! (a dynamic model is simulated, never fed a measured output), and its
//! errors on the fold's scored samples are pooled as the ridge's are
//! (ridge.rs [`CvScore::pooled`]). Each (family, input form) is one row of
//! every target's CV table.
//!
//! Decision ([`compare`]): one blob holds one kind, so the family is chosen
//! for every target together, on the sum over targets of CV mse over the
//! target's calibration variance. The ridge winner (its averaged ensemble;
//! with several runs the average of its best candidates, before the
//! one-standard-error rule picks the simplest) stays unless the best other
//! (family, form) has a lower sum by more than one standard error of the
//! paired per-fold difference: within noise the simpler, hub-exact model
//! with the tame extrapolation is kept.

use super::features::Role;
use super::folds::Folds;
use super::ridge::{standard_error, CvScore};
use super::table::{cv_columns, CvRow, Family, Form};
use super::{cv_extrapolation, Band};
use crate::data::dataset::{Dataset, GridRun, InputForm, RunData};
use crate::fit::bp::BpOptions;
use crate::fit::dynamic::options::DynamicOptions;
use crate::fit::dynamic::orders::OrderRange;
use crate::fit::pcr::PcrOptions;
use crate::fit::{arx, bp, pcr, tfbank, Details, Fitted};
use anyhow::{anyhow, bail, Result};
use model_core::tf::MAX_TF_ENTRIES;
use model_core::ValidModel;
use serde::Serialize;
use std::time::Instant;

/// tf's structure inside auto: one first-order TF per input (`na 1, nb 1,
/// nk 0`, the first structure of tf's search). tf's per-input order search
/// fits the whole bank 113 times for 16 inputs (40 s per fit on one
/// FL_THERMAL channel), too slow to repeat on every fold.
const TF_ORDERS: [OrderRange; 3] = [
    OrderRange { min: 1, max: 1 },
    OrderRange { min: 1, max: 1 },
    OrderRange { min: 0, max: 0 },
];

/// The settings each family is trained with inside auto: its `fit --model`
/// defaults (the options' [`Default`]s, which a CLI test holds to the
/// documented flags' defaults), at the grid's sample time, with tf capped at [`TF_ORDERS`] and
/// gabp without its gradient-descent comparison (a report, not the model).
#[derive(Clone, Debug)]
pub struct Trainers {
    pcr: PcrOptions,
    arx: DynamicOptions,
    tf: DynamicOptions,
    bp: BpOptions,
}

impl Trainers {
    /// The defaults at sample time `dt_s`.
    pub fn defaults(dt_s: f64) -> Result<Self> {
        let arx = DynamicOptions {
            dt_s: Some(dt_s),
            ..DynamicOptions::default()
        };
        let mut tf = arx.clone();
        [tf.na, tf.nb, tf.nk] = TF_ORDERS.map(Some);
        let bp = BpOptions {
            gd_epochs: 0,
            ..BpOptions::default()
        };
        Ok(Self {
            pcr: PcrOptions::default(),
            arx,
            tf,
            bp,
        })
    }

    /// Trains `family` on `ds`'s calibration rows.
    fn train(&self, family: Family, ds: &Dataset) -> Result<Fitted> {
        match family {
            Family::Ridge => bail!("auto: the ridge is fitted by its own search"),
            Family::Pcr => pcr::fit(ds, &self.pcr),
            Family::Arx => arx::fit(ds, &self.arx),
            Family::Tf => tfbank::fit(ds, &self.tf),
            Family::Bp => bp::fit(ds, &self.bp, false),
            Family::Gabp => bp::fit(ds, &self.bp, true),
        }
    }
}

/// The samples of grid run `run` a training dataset holds: its first
/// `rows`, of which the first `calib` are calibration and the rest held out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cut {
    /// Grid run.
    pub run: usize,
    /// Leading samples kept.
    pub rows: usize,
    /// Of which calibration.
    pub calib: usize,
}

/// The cuts of the dataset that scores fold `f`: in each grid run, the
/// leading samples the fold's model trains on (the blocks before the fold,
/// or another run's whole calibration part) as calibration, through the
/// last sample of the fold itself as held out. Runs with neither (held-out
/// tails, validation runs) are left out.
pub fn fold_cuts(grid: &[GridRun], folds: &Folds, f: usize) -> Vec<Cut> {
    let mut out = Vec::new();
    let mut start = 0;
    for (run, g) in grid.iter().enumerate() {
        let of = &folds.of[start..start + g.t_s.len()];
        start += g.t_s.len();
        let calib = of
            .iter()
            .take_while(|s| s.is_some_and(|s| folds.scheme.trains_on(f, s)))
            .count();
        let held = of.iter().rposition(|s| *s == Some(f)).map_or(0, |i| i + 1);
        if calib.max(held) > 0 {
            out.push(Cut {
                run,
                rows: calib.max(held),
                calib,
            });
        }
    }
    out
}

/// Every calibration sample of every grid run: the refit's cuts.
pub fn calibration_cuts(grid: &[GridRun]) -> Vec<Cut> {
    (0..grid.len())
        .filter(|&run| grid[run].calib_end > 0)
        .map(|run| Cut {
            run,
            rows: grid[run].calib_end,
            calib: grid[run].calib_end,
        })
        .collect()
}

/// The dataset of `cuts` on the grid's times: inputs `idx` of `x` (the
/// grid's inputs in `form`, every input referenced alike as the trainers'
/// channels are), every target of `names`.
pub fn cut_dataset(
    grid: &[GridRun],
    x: &[Vec<Vec<f64>>],
    cuts: &[Cut],
    names: &Dataset,
    idx: &[usize],
    form: Form,
) -> Dataset<'static> {
    let runs = cuts
        .iter()
        .map(|c| {
            let g = &grid[c.run];
            let head = |v: &[f64]| v[..c.rows].to_vec();
            RunData::owned(
                g.name.clone(),
                head(&g.t_s),
                idx.iter().map(|&i| head(&x[c.run][i])).collect(),
                g.y.iter().map(|y| head(y)).collect(),
                c.calib,
            )
        })
        .collect();
    Dataset {
        inputs: idx.iter().map(|&i| names.inputs[i].clone()).collect(),
        targets: names.targets.clone(),
        form: match form {
            Form::Change => InputForm::Change,
            Form::Absolute => InputForm::Absolute,
        },
        runs,
    }
}

/// Outputs `[target][k]` of `model` over the first `to` samples of grid run
/// `g`, stepped by model-core from the run's start on the logged inputs
/// (`inputs`: the names of `g.x`), as the hub runs it: through the run's
/// lead first (`GridRun::x_lead`: references and state start there).
fn run_model(
    model: &ValidModel,
    g: &GridRun,
    inputs: &[String],
    to: usize,
) -> Result<Vec<Vec<Option<f64>>>> {
    let lead = g.x_lead.first().map_or(0, Vec::len);
    let cols = model
        .inputs()
        .iter()
        .map(|ch| {
            let i = inputs
                .iter()
                .position(|n| n == ch.name.as_str())
                .ok_or_else(|| anyhow!("auto: model input {} is not in the data", ch.name))?;
            let lead_i = g.x_lead.get(i).map_or(&[][..], Vec::as_slice);
            Ok(lead_i
                .iter()
                .chain(&g.x[i][..to])
                .map(|&v| Some(v))
                .collect())
        })
        .collect::<Result<Vec<Vec<Option<f64>>>>>()?;
    let mut out = crate::runner::step_all(model, &cols, lead + to, &mut Vec::new()).0;
    for y in &mut out {
        y.drain(..lead);
    }
    Ok(out)
}

/// CV residuals `[target][scored sample]`, scored samples in grid order
/// (`Folds::scored`); `None` where there is no prediction.
pub type Residuals = Vec<Vec<Option<f64>>>;

/// What every family's cross-validation shares.
pub struct Bench<'a> {
    grid: &'a [GridRun],
    folds: &'a Folds,
    /// Input and target names (inputs absolute on the grid).
    ds: &'a Dataset<'a>,
    trainers: &'a Trainers,
    /// The grid's inputs in each form, every input referenced alike.
    xs: Vec<super::FormX>,
    /// Their leads (`GridRun::x_lead`), alike.
    leads: Vec<super::FormX>,
    /// Per grid sample, its place among the scored samples.
    scored_pos: Vec<Option<usize>>,
    /// Fold of each scored sample.
    scored_fold: Vec<usize>,
    /// First grid sample of each run in the concatenated order.
    offsets: Vec<usize>,
    /// Calibration variance of each target over the grid.
    variance: Vec<f64>,
    /// Whether each input moves over the calibration samples.
    moves: Vec<bool>,
    /// Input roles.
    roles: Vec<Role>,
}

impl<'a> Bench<'a> {
    /// The bench of `ds` on `grid` (absolute inputs) and its `folds`.
    pub fn new(
        grid: &'a [GridRun],
        folds: &'a Folds,
        ds: &'a Dataset,
        trainers: &'a Trainers,
    ) -> Self {
        let alike = vec![Role::Temperature; ds.inputs.len()];
        let xs = Form::ALL
            .iter()
            .map(|&f| (f, super::adjusted(grid, &alike, f)))
            .collect();
        let leads = Form::ALL
            .iter()
            .map(|&f| (f, super::adjusted_lead(grid, &alike, f)))
            .collect();
        let mut scored_pos = vec![None; folds.of.len()];
        let mut scored_fold = Vec::new();
        for (k, pos) in scored_pos.iter_mut().enumerate() {
            if let (true, Some(f)) = (folds.scored(k), folds.of[k]) {
                *pos = Some(scored_fold.len());
                scored_fold.push(f);
            }
        }
        let offsets = grid
            .iter()
            .scan(0, |s, g| {
                *s += g.t_s.len();
                Some(*s - g.t_s.len())
            })
            .collect();
        Self {
            variance: calibration_variance(grid, folds),
            moves: moving_inputs(grid, folds),
            roles: ds.inputs.iter().map(|c| Role::of(c)).collect(),
            grid,
            folds,
            ds,
            trainers,
            xs,
            leads,
            scored_pos,
            scored_fold,
            offsets,
        }
    }

    fn x(&self, form: Form) -> &[Vec<Vec<f64>>] {
        super::form_x(&self.xs, form)
    }

    /// Scored samples.
    pub fn n_scored(&self) -> usize {
        self.scored_fold.len()
    }

    /// Folds the CV scores.
    pub fn scored_folds(&self) -> usize {
        (0..self.folds.n)
            .filter(|&f| self.folds.scheme.scores(f))
            .count()
    }
}

/// One grid column's values over the calibration samples (`col` picks the
/// column of a run).
fn calibration_values<'g>(
    grid: &'g [GridRun],
    folds: &Folds,
    col: impl Fn(&'g GridRun) -> &'g [f64],
) -> Vec<f64> {
    grid.iter()
        .flat_map(|g| col(g).iter().copied())
        .zip(&folds.of)
        .filter_map(|(v, f)| f.map(|_| v))
        .collect()
}

/// Variance of each target over the calibration samples of the grid.
fn calibration_variance(grid: &[GridRun], folds: &Folds) -> Vec<f64> {
    let n_t = grid.first().map_or(0, |g| g.y.len());
    (0..n_t)
        .map(|t| {
            let y = calibration_values(grid, folds, |g| &g.y[t]);
            let n = y.len().max(1) as f64;
            let mean = y.iter().sum::<f64>() / n;
            y.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n
        })
        .collect()
}

/// Whether each input takes two different values over the calibration
/// samples of the grid.
fn moving_inputs(grid: &[GridRun], folds: &Folds) -> Vec<bool> {
    let n_in = grid.first().map_or(0, |g| g.x.len());
    (0..n_in)
        .map(|i| {
            let v = calibration_values(grid, folds, |g| &g.x[i]);
            v.iter().any(|a| Some(a) != v.first())
        })
        .collect()
}

/// The inputs (indices into the fit's inputs) `family` reads, and those it
/// leaves out. An input that never moves over the calibration samples is
/// left out: nothing can be learnt from it, and a hub flags a sensor stuck
/// at one value as faulty (the ridge gives it weight 0, which an `fbank`
/// output does not read). A TF bank holds 16 entries, so when the rest x
/// targets exceed it arx and tf read the temperatures only (seed 004's TFs
/// are of temperatures; heat sources reach the model through them).
fn family_inputs(b: &Bench, family: Family) -> Result<(Vec<usize>, Vec<usize>)> {
    let n_t = b.ds.targets.len();
    let (mut kept, mut dropped): (Vec<usize>, Vec<usize>) =
        (0..b.ds.inputs.len()).partition(|&i| b.moves[i]);
    if family.tf_bank() && kept.len() * n_t > MAX_TF_ENTRIES {
        let heat: Vec<usize>;
        (kept, heat) = kept.iter().partition(|&&i| b.roles[i] == Role::Temperature);
        dropped.extend(heat);
        dropped.sort_unstable();
        if kept.len() * n_t > MAX_TF_ENTRIES {
            bail!(
                "{} temperatures x {n_t} targets exceed the {MAX_TF_ENTRIES}-entry TF bank",
                kept.len()
            );
        }
    }
    if kept.is_empty() {
        bail!("no input moves over the calibration samples");
    }
    Ok((kept, dropped))
}

/// The residuals of `family` in `form` on inputs `idx`, fold by fold; an
/// error when a fold cannot be trained or a scored sample has no prediction.
fn cross_validate(
    b: &Bench,
    family: Family,
    form: Form,
    idx: &[usize],
    progress: &dyn Fn(),
) -> Result<Residuals> {
    let n_t = b.ds.targets.len();
    let mut r = vec![vec![None; b.n_scored()]; n_t];
    for f in (0..b.folds.n).filter(|&f| b.folds.scheme.scores(f)) {
        progress();
        let cuts = fold_cuts(b.grid, b.folds, f);
        if cuts.iter().all(|c| c.calib == 0) {
            continue;
        }
        let ds = cut_dataset(b.grid, b.x(form), &cuts, b.ds, idx, form);
        let fitted = b
            .trainers
            .train(family, &ds)
            .map_err(|e| anyhow!("fold {f}: {e}"))?;
        for c in cuts.iter().filter(|c| c.rows > c.calib) {
            let g = &b.grid[c.run];
            let pred = run_model(&fitted.model, g, &b.ds.inputs, c.rows)?;
            let held = c.calib..c.rows;
            let at = &b.scored_pos[b.offsets[c.run]..][held.clone()];
            for ((rt, pt), yt) in r.iter_mut().zip(&pred).zip(&g.y) {
                for ((pos, p), y) in at.iter().zip(&pt[held.clone()]).zip(&yt[held.clone()]) {
                    if let Some(pos) = pos {
                        rt[*pos] = p.map(|p| y - p);
                    }
                }
            }
        }
    }
    let missing = r.iter().flatten().filter(|v| v.is_none()).count();
    if missing > 0 {
        bail!("no prediction for {missing} scored samples (a non-finite output)");
    }
    Ok(r)
}

/// One model's squared CV errors, `(sum, samples)` per target and fold.
#[derive(Clone, Debug)]
pub struct FoldErrors(Vec<Vec<(f64, f64)>>);

impl FoldErrors {
    /// From residuals on the scored samples of `b`.
    pub fn of(b: &Bench, r: &Residuals) -> Self {
        Self(
            r.iter()
                .map(|rt| {
                    let mut per = vec![(0.0, 0.0); b.folds.n];
                    for (e, &f) in rt.iter().zip(&b.scored_fold) {
                        if let Some(e) = e {
                            per[f].0 += e * e;
                            per[f].1 += 1.0;
                        }
                    }
                    per
                })
                .collect(),
        )
    }

    /// Target `t`'s CV score, pooled over its folds.
    pub fn target(&self, t: usize) -> Option<CvScore> {
        let folds: Vec<(f64, f64)> = self.0[t].iter().copied().filter(|p| p.1 > 0.0).collect();
        CvScore::pooled(&folds)
    }

    /// Sum over targets of the pooled CV mse over the target's variance.
    pub fn score(&self, variance: &[f64]) -> Option<f64> {
        (0..self.0.len())
            .map(|t| Some(self.target(t)?.mse / variance[t].max(f64::MIN_POSITIVE)))
            .sum()
    }

    /// Fold `f`'s share: the sum over targets of its mse over the
    /// variance, when every target has a sample there.
    fn fold_score(&self, f: usize, variance: &[f64]) -> Option<f64> {
        self.0
            .iter()
            .zip(variance)
            .map(|(per, v)| {
                let (sse, n) = per[f];
                (n > 0.0).then(|| sse / n / v.max(f64::MIN_POSITIVE))
            })
            .sum()
    }
}

/// One (family, form) weighed against the ridge.
#[derive(Clone, Debug, Serialize)]
pub struct Candidate {
    /// Family.
    pub family: Family,
    /// Input form of every input.
    pub form: Form,
    /// Sum over targets of CV mse / calibration variance (null: not scored).
    pub score: Option<f64>,
    /// `score` minus the ridge's (negative: lower CV error than the ridge).
    pub diff: Option<f64>,
    /// Standard error of the paired per-fold difference.
    pub se_diff: Option<f64>,
    /// Folds both were scored on.
    pub paired_folds: usize,
    /// Seconds its cross-validation took.
    pub seconds: f64,
    /// Why it has no score.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
    /// Inputs read (indices into the fit's inputs).
    #[serde(skip)]
    inputs: Vec<usize>,
    /// Inputs left out.
    #[serde(skip)]
    dropped: Vec<usize>,
    #[serde(skip)]
    residuals: Option<Residuals>,
}

/// The decision rule, for the JSON.
const RULE: &str = "the ridge (averaged ensemble) stays unless the best other (family, form) has a sum over targets of CV mse / calibration variance lower by more than one standard error of the paired per-fold difference (at least 2 folds)";

/// The family decision, for the JSON.
#[derive(Clone, Debug, Serialize)]
pub struct FamilyChoice {
    /// Families compared.
    pub compared: Vec<Family>,
    /// The rule.
    pub rule: &'static str,
    /// The ridge winner's score (from its averaged ensemble's residuals;
    /// with several runs the best candidates' average, before the
    /// one-standard-error rule picks the simplest).
    pub ridge_score: Option<f64>,
    /// Every other (family, form), best score first.
    pub candidates: Vec<Candidate>,
    /// The family the blob holds.
    pub winner: Family,
    /// Its input form, when it is not the ridge (the ridge's are per
    /// target: `targets[].forms`).
    pub winner_form: Option<Form>,
    /// The winner's trainer report of its refit on every calibration
    /// sample (null for the ridge).
    pub winner_details: Option<Box<Details>>,
}

/// Scores `family` in `form` and weighs it against the ridge's errors.
fn candidate(
    b: &Bench,
    family: Family,
    form: Form,
    ridge: &FoldErrors,
    progress: &dyn Fn(),
) -> Candidate {
    let started = Instant::now();
    let run = family_inputs(b, family).and_then(|(idx, dropped)| {
        let r = cross_validate(b, family, form, &idx, progress)?;
        Ok((idx, dropped, r))
    });
    let mut c = Candidate {
        family,
        form,
        score: None,
        diff: None,
        se_diff: None,
        paired_folds: 0,
        seconds: 0.0,
        note: None,
        inputs: Vec::new(),
        dropped: Vec::new(),
        residuals: None,
    };
    match run {
        Ok((idx, dropped, r)) => {
            let e = FoldErrors::of(b, &r);
            c.score = e.score(&b.variance);
            let d: Vec<f64> = (0..b.folds.n)
                .filter_map(|f| {
                    Some(e.fold_score(f, &b.variance)? - ridge.fold_score(f, &b.variance)?)
                })
                .collect();
            c.diff = c.score.zip(ridge.score(&b.variance)).map(|(a, r)| a - r);
            c.se_diff = (!d.is_empty()).then(|| standard_error(&d));
            c.paired_folds = d.len();
            (c.inputs, c.dropped, c.residuals) = (idx, dropped, Some(r));
        }
        Err(e) => c.note = Some(e.to_string()),
    }
    c.seconds = started.elapsed().as_secs_f64();
    c
}

/// Whether `c` beats the ridge beyond noise.
fn beats_ridge(c: &Candidate) -> bool {
    match (c.diff, c.se_diff) {
        (Some(d), Some(se)) => c.paired_folds >= 2 && d < -se,
        _ => false,
    }
}

/// The comparison: its report, each target's table rows, and the winning
/// candidate (`None`: the ridge stays).
pub struct Comparison {
    /// For the JSON (`winner_details` still null).
    pub choice: FamilyChoice,
    /// Per target, one row per (family, form).
    pub rows: Vec<Vec<CvRow>>,
    /// The winner when it is not the ridge.
    pub winner: Option<Candidate>,
}

/// Scores every family of `families` but the ridge in each of `forms` on
/// the bench, and decides against the ridge winner's residuals `ridge`.
pub fn compare(
    b: &Bench,
    (families, forms): (&[Family], &[Form]),
    ridge: &Residuals,
    progress: &dyn Fn(),
) -> Comparison {
    let ridge_errors = FoldErrors::of(b, ridge);
    let mut cands: Vec<Candidate> = families
        .iter()
        .filter(|&&f| f != Family::Ridge)
        .flat_map(|&f| forms.iter().map(move |&form| (f, form)))
        .map(|(f, form)| candidate(b, f, form, &ridge_errors, progress))
        .collect();
    cands.sort_by(|a, c| {
        let key = |x: &Candidate| x.score.unwrap_or(f64::INFINITY);
        key(a).total_cmp(&key(c))
    });
    let winner = cands.first().filter(|c| beats_ridge(c)).cloned();
    let rows = (0..b.ds.targets.len())
        .map(|t| cands.iter().map(|c| table_row(b, c, t, &winner)).collect())
        .collect();
    Comparison {
        choice: FamilyChoice {
            compared: families.to_vec(),
            rule: RULE,
            ridge_score: ridge_errors.score(&b.variance),
            winner: winner.as_ref().map_or(Family::Ridge, |w| w.family),
            winner_form: winner.as_ref().map(|w| w.form),
            winner_details: None,
            candidates: cands,
        },
        rows,
        winner,
    }
}

/// Target `t`'s CV table row of candidate `c`.
fn table_row(b: &Bench, c: &Candidate, t: usize, winner: &Option<Candidate>) -> CvRow {
    let mut row = CvRow::new(c.family, c.form);
    row.dropped_inputs.clone_from(&c.dropped);
    row.features = c.inputs.len();
    row.note.clone_from(&c.note);
    if let Some(r) = &c.residuals {
        if let Some(cv) = FoldErrors::of(b, r).target(t) {
            cv_columns(&mut row, 0.0, c.inputs.len(), &cv);
        }
    }
    row.chosen = winner
        .as_ref()
        .is_some_and(|w| w.family == c.family && w.form == c.form);
    row
}

/// A winning family refitted on every calibration sample.
pub struct Refit {
    /// With its CV band per target and its input envelope as the blob's
    /// bounds (model-core's bounds belong to the model, whatever its kind).
    pub model: ValidModel,
    /// Per target, calibrated on the family's CV residuals.
    pub bands: Vec<Band>,
    /// Per target, the family's CV rmse.
    pub cv_rmse: Vec<f64>,
    /// The trainer's report of the refit.
    pub details: Details,
}

/// Refits the winner `w` on every calibration sample of the bench.
pub fn refit(b: &Bench, w: &Candidate) -> Result<Refit> {
    let x = b.x(w.form);
    let cuts = calibration_cuts(b.grid);
    let fitted = b.trainers.train(
        w.family,
        &cut_dataset(b.grid, x, &cuts, b.ds, &w.inputs, w.form),
    )?;
    // The family's blob reads exactly these inputs in this form.
    let columns: Vec<(&[Vec<Vec<f64>>], usize)> = w.inputs.iter().map(|&i| (x, i)).collect();
    let d = cv_extrapolation(&columns, b.folds);
    let residuals: Vec<Vec<f64>> = w
        .residuals
        .iter()
        .flatten()
        .map(|rt| rt.iter().flatten().copied().collect())
        .collect();
    let bands: Vec<Band> = residuals.iter().map(|r| Band::calibrate(r, &d)).collect();
    let mut model = fitted.model.into_model();
    let envelope = model
        .inputs
        .iter()
        .map(|ch| {
            let i = b.ds.inputs.iter().position(|n| n == ch.name.as_str());
            i.map(|i| super::span(b.grid, x, super::form_x(&b.leads, w.form), i))
                .ok_or_else(|| anyhow!("auto: model input {} is not in the data", ch.name))
        })
        .collect::<Result<Vec<_>>>()?;
    model.bounds = Some(super::bounds(&envelope, &bands)?);
    let model = model.validate().map_err(|e| {
        anyhow!(
            "auto: the refitted {} model is invalid: {e}",
            w.family.name()
        )
    })?;
    Ok(Refit {
        model,
        bands,
        cv_rmse: residuals.iter().map(|r| crate::num::lsq::rms(r)).collect(),
        details: fitted.details,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::auto::folds::Scheme;

    fn grid(n: usize, calib_end: usize) -> GridRun {
        GridRun {
            name: "r".into(),
            t_s: (0..n).map(|k| k as f64).collect(),
            x: vec![(0..n).map(|k| 20.0 + k as f64).collect()],
            x_lead: vec![Vec::new()],
            y: vec![vec![0.0; n]],
            calib_end,
        }
    }

    #[test]
    fn rolling_origin_trains_on_the_blocks_before_and_holds_out_the_fold() {
        // One run of 60 calibration samples and a held-out tail of 12, six
        // blocks of 10: the dataset scoring block 3 is the run's first 40
        // samples, 30 of them calibration; the tail is never in it.
        let g = [grid(72, 60)];
        let folds = Folds::of_grid(&g, 6);
        assert_eq!(folds.scheme, Scheme::Forward { first: 1 });
        let cuts = fold_cuts(&g, &folds, 3);
        assert_eq!(
            cuts,
            [Cut {
                run: 0,
                rows: 40,
                calib: 30
            }]
        );
        assert!((30..40).all(|k| folds.scored(k) && folds.of[k] == Some(3)));
        // The refit: every calibration sample, no held-out one.
        assert_eq!(
            calibration_cuts(&g),
            [Cut {
                run: 0,
                rows: 60,
                calib: 60
            }]
        );
    }

    #[test]
    fn leave_one_run_out_holds_the_fold_run_out_whole() {
        // Two calibration runs (the second with a held-out tail) and a
        // validation run: scoring run 1, run 0 calibrates whole and run 1's
        // calibration part is held out; the tail and the validation run are
        // in no dataset.
        let g = [grid(30, 30), grid(40, 25), grid(20, 0)];
        let folds = Folds::of_grid(&g, 6);
        assert_eq!(folds.scheme, Scheme::LeaveOut);
        let cuts = fold_cuts(&g, &folds, 1);
        assert_eq!(
            cuts,
            [
                Cut {
                    run: 0,
                    rows: 30,
                    calib: 30
                },
                Cut {
                    run: 1,
                    rows: 25,
                    calib: 0
                }
            ]
        );
        let names = Dataset {
            inputs: vec!["T1".into()],
            targets: vec!["dz".into()],
            form: InputForm::Absolute,
            runs: Vec::new(),
        };
        let x: Vec<Vec<Vec<f64>>> = g.iter().map(|r| r.x.clone()).collect();
        let ds = cut_dataset(&g, &x, &cuts, &names, &[0], Form::Change);
        assert_eq!(ds.calibration_len(), 30);
        assert_eq!(ds.holdout_len(), 25);
        assert_eq!(ds.form, InputForm::Change);
    }

    #[test]
    fn a_family_is_scored_on_the_ridges_samples_by_models_that_never_saw_them() {
        // One run of 60 samples in six blocks; dz = 2 T1 + 1, except that
        // the last block is shifted by 100, and dx = 10 dz. PCR (one input,
        // one component) scoring block f is fitted on the blocks before it,
        // so it is exact on blocks 1..4 and misses block 5 by the whole
        // shift: the fold's own outputs never reached its model. Block 0 is
        // not scored.
        let n = 60;
        let t1: Vec<f64> = (0..n)
            .map(|k| 20.0 + (k as f64 * 0.3).sin() + 0.01 * k as f64)
            .collect();
        let dz: Vec<f64> = t1
            .iter()
            .enumerate()
            .map(|(k, v)| 2.0 * v + 1.0 + if k >= 50 { 100.0 } else { 0.0 })
            .collect();
        let dx: Vec<f64> = dz.iter().map(|v| 10.0 * v).collect();
        let mut g = grid(n, n);
        (g.x, g.y) = (vec![t1], vec![dz, dx]);
        let g = [g];
        let folds = Folds::of_grid(&g, 6);
        let names = Dataset {
            inputs: vec!["T1".into()],
            targets: vec!["dz_um".into(), "dx_um".into()],
            form: InputForm::Absolute,
            runs: Vec::new(),
        };
        let trainers = Trainers::defaults(1.0).unwrap();
        let bench = Bench::new(&g, &folds, &names, &trainers);
        assert_eq!((bench.n_scored(), bench.scored_folds()), (50, 5));
        let r = cross_validate(&bench, Family::Pcr, Form::Absolute, &[0], &|| {}).unwrap();
        let dz_r: Vec<f64> = r[0].iter().map(|e| e.unwrap()).collect();
        // Least squares by SVD on exact data: 1e-9 is rounding with room.
        assert!(dz_r[..40].iter().all(|e| e.abs() < 1e-9), "{dz_r:?}");
        assert!(dz_r[40..].iter().all(|e| (e - 100.0).abs() < 1e-9));
        // Pooled as ridge.rs pools: block 5's mse 1e4 over 50 samples.
        let e = FoldErrors::of(&bench, &r);
        let cv = e.target(0).unwrap();
        assert!((cv.mse - 2000.0).abs() < 1e-6, "{}", cv.mse);
        // Over the targets' variances, dx (10 dz) weighs as much as dz:
        // the score is twice dz's share.
        let dz_share = cv.mse / bench.variance[0];
        let score = e.score(&bench.variance).unwrap();
        assert!((score - 2.0 * dz_share).abs() < 1e-9 * score, "{score}");
    }

    #[test]
    fn trainer_defaults_are_the_cli_defaults_with_tf_capped() {
        let t = Trainers::defaults(15.0).unwrap();
        assert_eq!(t.arx.dt_s, Some(15.0));
        assert_eq!(t.arx.na, None);
        assert_eq!(t.tf.na, Some(OrderRange { min: 1, max: 1 }));
        assert_eq!(t.bp.epochs, 200);
        assert_eq!(t.bp.gd_epochs, 0);
        assert!((t.pcr.variance - 0.85).abs() < 1e-12);
    }
}
