//! `fit --model auto`: the input form, the features, the penalty and the
//! filter time constants of each target, chosen by cross-validation that
//! respects time, on the calibration data only.
//!
//! The model family is a ridge regression over a bank of first-order
//! low-pass filters of the temperatures and of the heat sources (spindle
//! speed and power, linear and squared), which is a transfer-function bank
//! with fixed real poles: the hub evaluates it exactly (model-core `fbank`).
//! Without heat-source columns, plain least squares on the temperatures
//! (`mlr`, ridge-stabilised) is one of the candidates (no filters, the
//! smallest penalty). With them, every candidate reads them: a candidate
//! set that could leave them out lost on the development split
//! (docs/fit.md).
//!
//! Cross-validation: leave one run out when the calibration has several
//! runs (a fold then holds conditions no other fold saw, as a new day does);
//! within a single run, contiguous blocks. Each candidate's CV table row and
//! the winner go to `--json`; the winner (the average of the best few) is
//! refitted on every calibration sample and carries its calibration-CV error
//! band and input envelope in the blob.
//!
//! The other model families (PCR, ARX, TF, BP, GA-BP: family.rs) are then
//! scored on the same folds and samples, and one of them replaces the ridge
//! only when its CV error is lower beyond noise (`--auto-families`). Both
//! write rows of one CV table, whose vocabulary (families, input forms, the
//! row) is table.rs.

pub mod family;
pub mod features;
pub mod folds;
pub mod layout;
pub mod ridge;
pub mod search;
pub mod sight;
pub mod table;

use super::quiet;
use super::{outputs, Details, Fitted};
use crate::data::dataset::{Dataset, GridRun};
use anyhow::{anyhow, bail, Result};
use family::{Bench, Comparison, FamilyChoice, Residuals, Trainers};
use features::Role;
use folds::Folds;
use layout::Layout;
use model_core::fbank::MAX_FB_FEATURES;
use model_core::model::{Bounds, Name, Span};
use model_core::{Channel, Model, Params};
use search::{FormData, Member, SearchSettings};
use serde::Serialize;
use sight::Sight;
use table::{CvRow, Family, Form};

/// Filter time constants, s, that the temperature banks draw from: 5 min
/// to 6.75 h in steps of 3 (a machine's structural time constants lie
/// between a spindle's minutes and a column's hours).
const TEMP_SETS: [&[f64]; 7] = [
    &[],
    &[900.0],
    &[2700.0],
    &[900.0, 8100.0],
    &[300.0, 2700.0],
    &[2700.0, 24300.0],
    &[900.0, 2700.0, 8100.0],
];

/// Heat-source filter sets, s (a heat source acts only through the
/// structure's lag, so it has no unfiltered column).
const HEAT_SETS: [&[f64]; 3] = [&[2700.0], &[900.0, 8100.0], &[300.0, 2700.0, 24300.0]];

/// Penalties on the standardised features: 1e-6 to 10 by half decades.
fn lambda_grid() -> Vec<f64> {
    (0..=14)
        .map(|i| 10f64.powf(-6.0 + 0.5 * f64::from(i)))
        .collect()
}

/// Options of `fit --model auto`; [`Default`] is `fit`'s defaults.
#[derive(Clone, Debug, PartialEq)]
pub struct AutoOptions {
    /// auto: contiguous cross-validation folds within a single calibration
    /// run (several runs: one fold per run).
    pub auto_folds: usize,
    /// auto: how many of the best candidates the model averages (as many
    /// as fit the hub's 256 features; 20 won on the development split,
    /// scripts/auto_dev_split.sh).
    pub auto_ensemble: usize,
    /// auto: how many of the best candidates also try dropping temperature
    /// sensors (backward elimination by CV, one-standard-error rule; 0: off,
    /// the default: on the development split it lost more than it won,
    /// docs/validation-auto.md).
    pub auto_eliminate: usize,
    /// auto: model families weighed by the same cross-validation: ridge
    /// (the filter bank; must be listed), pcr, arx, tf, bp, gabp. Another family
    /// replaces the ridge only when its CV error is lower beyond noise;
    /// "ridge" alone: the filter bank only. arx and tf are tried only when
    /// the CV sees extrapolation (not over alike calibration runs).
    pub auto_families: Vec<String>,
}

impl Default for AutoOptions {
    fn default() -> Self {
        Self {
            auto_folds: 6,
            auto_ensemble: 20,
            auto_eliminate: 0,
            auto_families: table::DEFAULT_FAMILIES
                .split(',')
                .map(String::from)
                .collect(),
        }
    }
}

/// Settings of an auto fit.
#[derive(Clone, Debug)]
pub struct AutoParams {
    /// Contiguous folds within a run when there is one calibration run.
    pub folds: usize,
    /// Candidates averaged into the winner.
    pub ensemble: usize,
    /// Sample time, s (None: the first run's median step).
    pub dt_s: Option<f64>,
    /// How many of the best candidates also try dropping temperature
    /// sensors by backward elimination (0: every sensor stays).
    pub eliminate: usize,
    /// Model families weighed by the CV (names of [`Family`]; must
    /// include `ridge`).
    pub families: Vec<String>,
}

impl Default for AutoParams {
    fn default() -> Self {
        Self {
            folds: 6,
            ensemble: 20,
            dt_s: None,
            eliminate: 0,
            families: table::DEFAULT_FAMILIES
                .split(',')
                .map(String::from)
                .collect(),
        }
    }
}

/// Checked [`AutoParams`].
#[derive(Clone, Debug)]
pub struct ValidAutoParams {
    folds: usize,
    settings: SearchSettings,
    families: Vec<Family>,
    trainers: Trainers,
}

impl AutoParams {
    /// Checks the settings against the data's sample time.
    pub fn check(&self, ds: &Dataset) -> Result<ValidAutoParams> {
        if !(2..=32).contains(&self.folds) {
            bail!("auto: --auto-folds {} must be 2..32", self.folds);
        }
        if !(1..=100).contains(&self.ensemble) {
            bail!("auto: --auto-ensemble {} must be 1..100", self.ensemble);
        }
        super::job::within_hub("auto", ds)?;
        let families = Family::parse_list(&self.families)?;
        let dt_s = super::dynamic::grid::sample_time(ds, self.dt_s)?;
        Ok(ValidAutoParams {
            folds: self.folds,
            families,
            trainers: Trainers::defaults(dt_s)?,
            settings: SearchSettings {
                temp_sets: TEMP_SETS.iter().map(|s| s.to_vec()).collect(),
                heat_sets: HEAT_SETS.iter().map(|s| s.to_vec()).collect(),
                lambdas: lambda_grid(),
                ensemble: self.ensemble,
                max_features: MAX_FB_FEATURES,
                eliminate: self.eliminate,
                dt_s,
            },
        })
    }
}

/// What `--json` reports of an auto fit, per target.
#[derive(Clone, Debug, Serialize)]
pub struct TargetChoice {
    /// Target column.
    pub target: String,
    /// Every candidate, lowest `cv_geo_rmse` (the ranking criterion)
    /// first; families that could not be scored last.
    pub cv_table: Vec<CvRow>,
    /// Forms of the averaged candidates (of the other family's model when
    /// one won).
    pub forms: Vec<Form>,
    /// The family of the blob.
    pub family: Family,
    /// CV rmse of the winner (pooled over the folds).
    pub cv_rmse: f64,
    /// CV rmse of the ridge's averaged winner (= `cv_rmse` when it won).
    pub ridge_cv_rmse: f64,
    /// 95 % half-width of the CV error: the band the blob carries.
    pub half_width_95: f64,
    /// How the band was calibrated on the CV residuals.
    pub band: Band,
}

/// The 95 % band of a target, calibrated on its cross-validation
/// residuals: `half_width * (1 + growth * d)`, `d` the extrapolation of the
/// inputs beyond the calibration envelope in envelope widths. In the CV each
/// held-out fold is measured against the envelope of the other folds, so
/// the folds that hold new conditions teach the band how fast it must widen.
#[derive(Clone, Debug, Serialize)]
pub struct Band {
    /// 95 % quantile of |CV residual|.
    pub half_width: f64,
    /// Widening per envelope width of extrapolation.
    pub growth: f64,
    /// Calibration samples outside the other folds' envelope by more than
    /// the hub's flag threshold.
    pub extrapolating_samples: usize,
    /// Coverage of the band on the CV residuals, %.
    pub cv_coverage_pct: f64,
}

/// Growths tried, smallest first. The floor is 1 (the band at least
/// doubles one envelope width out): the CV folds extrapolate only a little,
/// so they can show that the band must widen faster, never that it may
/// widen slower.
const GROWTHS: [f64; 7] = [1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0];

/// Fewest extrapolating CV samples from which the growth is fitted; with
/// fewer the band widens at the model-core default of 1 per envelope width.
pub const MIN_EXTRAPOLATING: usize = 20;

impl Band {
    /// The half-width is the 95 % quantile of `|r|`; the growth is the
    /// smallest of [`GROWTHS`] that covers 95 % of the residuals whose
    /// inputs lay beyond the flag threshold outside the other folds'
    /// envelope (the floor, 1, with fewer than [`MIN_EXTRAPOLATING`] such).
    pub fn calibrate(r: &[f64], d: &[f64]) -> Self {
        let half_width = crate::num::stats::quantile_abs(r, 0.95);
        let flag = model_core::model::EXTRAPOLATION_FLAG_AT;
        let out: Vec<(f64, f64)> = r
            .iter()
            .zip(d)
            .filter(|(_, d)| **d > flag)
            .map(|(r, d)| (*r, *d))
            .collect();
        let covered = |g: f64, set: &[(f64, f64)]| {
            let pairs = set.iter().map(|(r, d)| (*r, half_width * (1.0 + g * d)));
            crate::num::stats::coverage_pct(pairs).map_or(0.0, |(pct, _)| pct)
        };
        let growth = if out.len() < MIN_EXTRAPOLATING {
            1.0
        } else {
            GROWTHS
                .iter()
                .copied()
                .find(|&g| covered(g, &out) >= 95.0)
                .unwrap_or(GROWTHS[GROWTHS.len() - 1])
        };
        let all: Vec<(f64, f64)> = r.iter().copied().zip(d.iter().copied()).collect();
        Self {
            half_width,
            growth,
            extrapolating_samples: out.len(),
            cv_coverage_pct: covered(growth, &all),
        }
    }

    /// Whether the growth was measured: enough CV samples lay outside the
    /// other folds' envelope. Otherwise it is the floor, 1, a guess: the
    /// band is then calibrated inside the envelope only (calibration runs
    /// alike, e.g. all at one room temperature, never show how fast the
    /// error grows outside it).
    pub fn growth_measured(&self) -> bool {
        self.extrapolating_samples >= MIN_EXTRAPOLATING
    }
}

impl AutoReport {
    /// Targets whose band growth was not measured ([`Band::growth_measured`]).
    pub fn unmeasured_growth(&self) -> Vec<&str> {
        self.targets
            .iter()
            .filter(|t| !t.band.growth_measured())
            .map(|t| t.target.as_str())
            .collect()
    }
}

/// For each scored calibration sample (`Folds::scored`, grid order), how
/// far it lies outside the envelope of the calibration samples its fold's
/// model was fitted on, in envelope widths: the largest over `columns`
/// (each a form's inputs `x[run][input][k]` and an input), as the hub
/// takes the largest over the blob's channels (model-core
/// `ValidModel::extrapolation`, `Span::outside`).
fn cv_extrapolation(columns: &[(&[Vec<Vec<f64>>], usize)], folds: &Folds) -> Vec<f64> {
    let Some((x0, _)) = columns.first() else {
        return vec![0.0; (0..folds.of.len()).filter(|&k| folds.scored(k)).count()];
    };
    let samples = || {
        x0.iter()
            .enumerate()
            .flat_map(|(r, run)| (0..run[0].len()).map(move |k| (r, k)))
    };
    let value = |(x, i): &(&[Vec<Vec<f64>>], usize), (r, k): (usize, usize)| x[r][*i][k];
    let empty = Span {
        min: f64::INFINITY,
        max: f64::NEG_INFINITY,
    };
    // env[f][j]: span of column j over the samples fold f trains on.
    let mut env = vec![vec![empty; columns.len()]; folds.n];
    for (at, g) in samples().zip(&folds.of) {
        let Some(g) = *g else { continue };
        for (f, e) in env.iter_mut().enumerate() {
            if !folds.scheme.trains_on(f, g) {
                continue;
            }
            for (span, c) in e.iter_mut().zip(columns) {
                let v = value(c, at);
                span.min = span.min.min(v);
                span.max = span.max.max(v);
            }
        }
    }
    samples()
        .zip(&folds.of)
        .enumerate()
        .filter(|(k, _)| folds.scored(*k))
        .map(|(_, (at, f))| {
            let e = f.and_then(|f| env.get(f));
            e.map_or(0.0, |e| {
                columns
                    .iter()
                    .zip(e)
                    .filter(|(_, s)| s.min <= s.max)
                    .map(|(c, s)| s.outside(value(c, at)))
                    .fold(0.0, f64::max)
            })
        })
        .collect()
}

/// What `--json` reports of an auto fit.
#[derive(Clone, Debug, Serialize)]
pub struct AutoReport {
    /// How the folds were made.
    pub scheme: String,
    /// Which folds train the model that scores a fold.
    pub training: folds::Scheme,
    /// Folds.
    pub folds: usize,
    /// Sample time, s.
    pub dt_s: f64,
    /// Settings searched.
    pub settings: SearchSettings,
    /// Per target.
    pub targets: Vec<TargetChoice>,
    /// The model family chosen for every target together.
    pub families: FamilyChoice,
    /// Inputs left out because they did not move beyond their noise in the
    /// calibration rows (fit/quiet.rs): the model does not read them.
    pub quiet_inputs: Vec<quiet::QuietInput>,
    /// Whether the CV saw extrapolation, and what was left out when not.
    pub sight: Sight,
}

/// Reference-adjusted inputs of every grid run in `form`, `[run][input][k]`.
fn adjusted(grid: &[GridRun], roles: &[Role], form: Form) -> Vec<Vec<Vec<f64>>> {
    adjust(grid, roles, form, |g| &g.x)
}

/// The same for each run's lead (`GridRun::x_lead`), with the same
/// references: what the filters run through before the grid starts.
fn adjusted_lead(grid: &[GridRun], roles: &[Role], form: Form) -> Vec<Vec<Vec<f64>>> {
    adjust(grid, roles, form, |g| &g.x_lead)
}

/// `part` of every grid run less its input's reference in `form`: a
/// temperature's change is taken from the run's first sample, the lead's
/// if it has one (where the hub takes its reference), else the grid's.
fn adjust(
    grid: &[GridRun],
    roles: &[Role],
    form: Form,
    part: impl Fn(&GridRun) -> &Vec<Vec<f64>>,
) -> Vec<Vec<Vec<f64>>> {
    grid.iter()
        .map(|g| {
            part(g)
                .iter()
                .enumerate()
                .zip(roles)
                .map(|((i, c), role)| {
                    let r0 = match (form, role) {
                        (Form::Change, Role::Temperature) => {
                            let first = g.x_lead.get(i).and_then(|l| l.first());
                            first.or(g.x[i].first()).copied().unwrap_or(0.0)
                        }
                        _ => 0.0,
                    };
                    c.iter().map(|v| v - r0).collect()
                })
                .collect()
        })
        .collect()
}

/// The ridge search's outcome for every target.
struct RidgeFit {
    /// Per target, for the JSON (with its band).
    choices: Vec<TargetChoice>,
    /// The CV residuals on the scored samples that other families must
    /// beat: the averaged winners', with several runs the average of the
    /// best candidates (`TargetSearch::best_residuals`).
    residuals: Residuals,
    /// The winners on the hub (layout.rs).
    layout: Layout,
}

/// Step 1: the ridge search of every target over the `searched` forms
/// (`forms` holds both, for the envelope) and the winners' layout on the
/// hub (layout.rs; the grids cannot exceed its features, a test checks),
/// each winner with its band.
fn ridge_targets(
    ds: &Dataset,
    grid: &[GridRun],
    folds: &Folds,
    (forms, searched): (&[FormData], &[FormData]),
    roles: &[Role],
    s: &SearchSettings,
    progress: &dyn Fn(),
) -> Result<RidgeFit> {
    let ys: Vec<Vec<f64>> = (0..ds.targets.len())
        .map(|j| grid.iter().flat_map(|g| g.y[j].iter().copied()).collect())
        .collect();
    let mut found = Vec::new();
    for (target, y) in ds.targets.iter().zip(&ys) {
        found.push(
            search::search(searched, y, folds, s, progress)
                .ok_or_else(|| anyhow!("auto: no candidate could be fitted for {target}"))?,
        );
    }
    let winners: Vec<&[Member]> = found.iter().map(|f| f.members.as_slice()).collect();
    let layout = Layout::of(roles, &winners)?;
    // The blob's channels, each in the form of its envelope: the hub's
    // extrapolation measure, which every target's band grows with.
    let columns: Vec<(&[Vec<Vec<f64>>], usize)> = layout
        .channels
        .iter()
        .map(|c| {
            let x = forms
                .iter()
                .find(|f| f.form == c.form)
                .expect("both forms")
                .x;
            (x, c.input)
        })
        .collect();
    let d = cv_extrapolation(&columns, folds);
    let mut out = RidgeFit {
        choices: Vec::new(),
        residuals: Vec::new(),
        layout,
    };
    for (target, found) in ds.targets.iter().zip(found) {
        let choice = target_choice(target, found.table, &found.cv_residuals, &found.members, &d);
        out.choices.push(choice);
        out.residuals.push(found.best_residuals);
    }
    Ok(out)
}

/// A target's report and band from its averaged winner's CV residuals.
fn target_choice(
    target: &str,
    cv_table: Vec<CvRow>,
    cv_residuals: &[Option<f64>],
    members: &[Member],
    d: &[f64],
) -> TargetChoice {
    let (r, d): (Vec<f64>, Vec<f64>) = cv_residuals
        .iter()
        .zip(d.iter().copied())
        .filter_map(|(r, d)| Some(((*r)?, d)))
        .unzip();
    let band = Band::calibrate(&r, &d);
    let cv_rmse = crate::num::lsq::rms(&r);
    TargetChoice {
        target: target.to_string(),
        forms: members.iter().map(|m| m.form).collect(),
        family: Family::Ridge,
        cv_table,
        cv_rmse,
        ridge_cv_rmse: cv_rmse,
        half_width_95: band.half_width,
        band,
    }
}

/// Step 3: the family rows go into each target's table (lowest
/// `cv_geo_rmse` first, the unscored last); when another family won, the targets report it.
fn merge_families(choices: &mut [TargetChoice], cmp: &Comparison, won: Option<&family::Refit>) {
    for (t, c) in choices.iter_mut().enumerate() {
        if let (Some(w), Some(r)) = (&cmp.winner, won) {
            for row in &mut c.cv_table {
                row.chosen = false;
            }
            c.family = w.family;
            c.forms = vec![w.form];
            c.cv_rmse = r.cv_rmse[t];
            c.half_width_95 = r.bands[t].half_width;
            c.band = r.bands[t].clone();
        }
        c.cv_table.extend(cmp.rows[t].iter().cloned());
        // By the ranking criterion (the ridge's members were picked by it,
        // or with several runs the simplest within its noise); unscored
        // rows (NaN) last.
        c.cv_table
            .sort_by(|a, b| a.cv_geo_rmse.total_cmp(&b.cv_geo_rmse));
    }
}

/// Trains an auto model on `ds` (inputs in absolute form); its details
/// are the [`AutoReport`]. Inputs that did not move in calibration are
/// left out first (fit/quiet.rs).
pub fn fit(ds: &Dataset, params: &ValidAutoParams) -> Result<Fitted> {
    let quiet = quiet::quiet_inputs(ds);
    let kept: Vec<usize> = (0..ds.inputs.len())
        .filter(|i| !quiet.iter().any(|(q, _)| q == i))
        .collect();
    if kept.is_empty() {
        let shown: Vec<String> = quiet.iter().take(3).map(|(_, q)| q.to_string()).collect();
        let more = match quiet.len().saturating_sub(3) {
            0 => String::new(),
            n => format!("; {n} more"),
        };
        bail!(
            "auto: no input moved beyond {} times its noise in the calibration rows ({}{more}): nothing to calibrate a model on",
            quiet::MIN_SWING_OVER_NOISE,
            shown.join("; ")
        );
    }
    let ds = ds.with_inputs(&kept);
    let grid = super::dynamic::grid::grid_runs(&ds, params.settings.dt_s, "auto")?;
    let quiet = quiet.into_iter().map(|(_, q)| q).collect();
    fit_moved(&ds, grid, params, quiet)
}

/// [`fit`] on the inputs that moved (`ds` and `grid` hold only those;
/// `quiet`, the ones left out, go to the report).
fn fit_moved(
    ds: &Dataset,
    grid: Vec<GridRun>,
    params: &ValidAutoParams,
    quiet: Vec<quiet::QuietInput>,
) -> Result<Fitted> {
    let s = &params.settings;
    let roles: Vec<Role> = ds.inputs.iter().map(|c| Role::of(c)).collect();
    let folds = Folds::of_grid(&grid, params.folds);
    let xs: Vec<FormX> = Form::ALL
        .iter()
        .map(|&f| (f, adjusted(&grid, &roles, f)))
        .collect();
    let leads: Vec<FormX> = Form::ALL
        .iter()
        .map(|&f| (f, adjusted_lead(&grid, &roles, f)))
        .collect();
    let forms: Vec<FormData> = xs
        .iter()
        .zip(&leads)
        .map(|((form, x), (_, lead))| FormData {
            form: *form,
            x,
            lead,
            roles: &roles,
        })
        .collect();
    let bench = Bench::new(&grid, &folds, ds, &params.trainers);
    let sight = Sight::of(&grid, form_x(&xs, Form::Change), &roles, &folds, &quiet);
    let (settings, families, allowed) = sight.restrict(s, &params.families);
    let s = &settings;
    let searched: Vec<FormData> = forms
        .iter()
        .copied()
        .filter(|f| allowed.contains(&f.form))
        .collect();
    let per_target = s.temp_sets.len() * s.heat_sets.len() * searched.len() + s.eliminate;
    let family_jobs = (families.len() - 1) * allowed.len() * bench.scored_folds();
    let pb = crate::num::progress::progress(
        per_target * ds.targets.len() + family_jobs,
        "auto: candidates",
    );
    let forms = (forms.as_slice(), searched.as_slice());
    let mut ridge = ridge_targets(ds, &grid, &folds, forms, &roles, s, &|| pb.inc(1))?;
    pb.set_message("auto: families");
    let mut cmp = family::compare(&bench, (&families, &allowed), &ridge.residuals, &|| {
        pb.inc(1)
    });
    pb.finish_and_clear();
    let won = cmp
        .winner
        .as_ref()
        .map(|w| family::refit(&bench, w))
        .transpose()?;
    merge_families(&mut ridge.choices, &cmp, won.as_ref());
    let model = match won {
        Some(r) => {
            cmp.choice.winner_details = Some(Box::new(r.details));
            r.model
        }
        None => {
            let bands: Vec<Band> = ridge.choices.iter().map(|c| c.band.clone()).collect();
            assemble(ds, &grid, (&xs, &leads), &ridge.layout, &bands, s.dt_s)?
        }
    };
    let report = AutoReport {
        scheme: folds.description.clone(),
        training: folds.scheme,
        folds: folds.n,
        dt_s: s.dt_s,
        settings: s.clone(),
        targets: ridge.choices,
        families: cmp.choice,
        quiet_inputs: quiet,
        sight,
    };
    Ok(Fitted {
        model,
        details: Details::Auto(Box::new(report)),
    })
}

/// One fbank model of every target's averaged winner, with bounds.
fn assemble(
    ds: &Dataset,
    grid: &[GridRun],
    (xs, leads): (&[FormX], &[FormX]),
    layout: &Layout,
    bands: &[Band],
    dt_s: f64,
) -> Result<model_core::ValidModel> {
    layout.check()?;
    let mut channels = heapless::Vec::new();
    let mut envelope = Vec::new();
    for c in &layout.channels {
        let name = &ds.inputs[c.input];
        channels
            .push(Channel {
                name: Name::try_from(name.as_str())
                    .map_err(|_| anyhow!("input name \"{name}\" is too long"))?,
                reference: c.reference,
            })
            .map_err(|_| anyhow!("auto: too many inputs"))?;
        let (x, lead) = (form_x(xs, c.form), form_x(leads, c.form));
        envelope.push(span(grid, x, lead, c.input));
    }
    let model = Model {
        inputs: channels,
        outputs: outputs(ds)?,
        dt_s,
        params: Params::Fbank(layout.bank()?),
        bounds: Some(bounds(&envelope, bands)?),
        five_point: None,
    };
    model
        .validate()
        .map_err(|e| anyhow!("auto: the fitted model is invalid: {e}"))
}

/// A form and the grid's inputs (or their leads) in it, `[run][input][k]`.
type FormX = (Form, Vec<Vec<Vec<f64>>>);

/// The grid inputs (or their leads) of `form` among `xs`.
fn form_x(xs: &[FormX], form: Form) -> &[Vec<Vec<f64>>] {
    &xs.iter().find(|(f, _)| *f == form).expect("both forms").1
}

/// Calibration range of input `i` of `x` (`[run][input][k]`, a form's
/// grid inputs) over every grid run, with `lead` (the same form's
/// `GridRun::x_lead`) of the runs that calibrate: the hub meets those
/// values too, from its first sample on.
fn span(grid: &[GridRun], x: &[Vec<Vec<f64>>], lead: &[Vec<Vec<f64>>], i: usize) -> Span {
    let (mut min, mut max) = (f64::INFINITY, f64::NEG_INFINITY);
    let runs = grid.iter().zip(x).zip(lead);
    for ((g, run), lead) in runs.filter(|((g, _), _)| g.calib_end > 0) {
        let lead = lead.get(i).map_or(&[][..], Vec::as_slice);
        for &v in lead.iter().chain(&run[i][..g.calib_end]) {
            min = min.min(v);
            max = max.max(v);
        }
    }
    if min > max {
        (min, max) = (0.0, 0.0);
    }
    Span { min, max }
}

/// A blob's bounds: the envelope per model input and each target's band.
fn bounds(envelope: &[Span], bands: &[Band]) -> Result<Bounds> {
    let cap = || anyhow!("auto: too many inputs or outputs for the bounds");
    let per =
        |f: fn(&Band) -> f64| heapless::Vec::from_slice(&bands.iter().map(f).collect::<Vec<_>>());
    Ok(Bounds {
        envelope: heapless::Vec::from_slice(envelope).map_err(|_| cap())?,
        half_width: per(|b| b.half_width).map_err(|_| cap())?,
        growth: per(|b| b.growth).map_err(|_| cap())?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use model_core::model::MAX_CHANNELS;

    #[test]
    fn the_largest_union_of_the_grids_fits_the_hub() {
        // Every target's members together use at most every time constant
        // of the grids. A temperature on a logged channel with the hold:
        // raw, each temperature time constant, the hold; in both forms
        // without the rewrite (two channels each): twice raw and the time
        // constants. A heat source (speed_rpm, power_kw: at most 2), both
        // powers of each heat time constant, on one channel.
        let distinct = |sets: &[&[f64]]| {
            let mut v: Vec<f64> = sets.iter().flat_map(|s| s.iter().copied()).collect();
            v.sort_by(f64::total_cmp);
            v.dedup();
            v.len()
        };
        let per_temp = 1 + distinct(&TEMP_SETS);
        let per_heat = 2 * distinct(&HEAT_SETS);
        let worst = (0..=2)
            .map(|heat| {
                let logged = (MAX_CHANNELS - heat) * (per_temp + 1);
                let both_forms = (MAX_CHANNELS - heat) / 2 * 2 * per_temp;
                logged.max(both_forms) + heat * per_heat
            })
            .max()
            .unwrap();
        assert_eq!(worst, 230, "30 x 7 + 2 x 10");
        assert!(worst <= MAX_FB_FEATURES);
    }

    /// 1000 residuals inside the envelope, |r| = 0.001 .. 1.000: the
    /// nearest-rank 95 % quantile is exactly 0.950.
    fn inside() -> (Vec<f64>, Vec<f64>) {
        let r = (1..=1000).map(|k| f64::from(k) / 1000.0).collect();
        (r, vec![0.0; 1000])
    }

    #[test]
    fn without_extrapolating_folds_the_growth_is_the_unmeasured_floor() {
        let (r, d) = inside();
        let b = Band::calibrate(&r, &d);
        assert!((b.half_width - 0.95).abs() < 1e-12, "{}", b.half_width);
        assert_eq!(b.growth, 1.0);
        assert_eq!(b.extrapolating_samples, 0);
        assert!(!b.growth_measured());
    }

    /// The extrapolation the band grows with is the hub's: the largest
    /// over the blob's channels, each in its envelope's form. Two runs
    /// (leave one run out), one input logged at 20 then 25 C, its change
    /// from each run's first sample 0..1 in both: as a change the second
    /// run lies inside the first's envelope, as logged 4 widths above it.
    #[test]
    fn the_cv_extrapolation_is_the_largest_over_the_blob_s_channels() {
        let logged: Vec<Vec<Vec<f64>>> = vec![
            vec![(0..4).map(|k| 20.0 + f64::from(k) / 3.0).collect()],
            vec![(0..4).map(|k| 25.0 + f64::from(k) / 3.0).collect()],
        ];
        let change: Vec<Vec<Vec<f64>>> = logged
            .iter()
            .map(|run| {
                run.iter()
                    .map(|c| c.iter().map(|v| v - c[0]).collect())
                    .collect()
            })
            .collect();
        let folds = Folds {
            of: (0..8).map(|k| Some(k / 4)).collect(),
            n: 2,
            scheme: folds::Scheme::LeaveOut,
            description: String::new(),
        };
        let d = |cols: &[(&[Vec<Vec<f64>>], usize)]| cv_extrapolation(cols, &folds);
        assert_eq!(d(&[(&change, 0)]), [0.0; 8]);
        let both = d(&[(&change, 0), (&logged, 0)]);
        // Run 2's first sample, 25 C, is 4 widths (of 1 K) above 20..21 C.
        assert!((both[4] - 4.0).abs() < 1e-12, "{both:?}");
        assert_eq!(both, d(&[(&logged, 0)]));
        assert_eq!(d(&[]), [0.0; 8]);
    }

    /// A run whose target starts two samples late: its lead (20.0, 20.2 C)
    /// is in the envelope as the hub meets it, in each form less the same
    /// reference (a change from 20.0: 0 .. 1 K); a run held out whole adds
    /// nothing.
    #[test]
    fn the_envelope_holds_the_lead_of_the_runs_that_calibrate() {
        let run = |calib_end| GridRun {
            name: "r".into(),
            t_s: vec![2.0, 3.0],
            x: vec![vec![20.5, 21.0]],
            x_lead: vec![vec![20.0, 20.2]],
            y: vec![vec![0.0, 0.0]],
            calib_end,
        };
        let roles = [Role::Temperature];
        let grid = [run(2)];
        let change = adjusted(&grid, &roles, Form::Change);
        assert_eq!(change[0][0], [0.5, 1.0]);
        let lead = |g: &[GridRun], f| adjusted_lead(g, &roles, f);
        let s = span(&grid, &change, &lead(&grid, Form::Change), 0);
        assert_eq!((s.min, s.max), (0.0, 1.0));
        let absolute = adjusted(&grid, &roles, Form::Absolute);
        let s = span(&grid, &absolute, &lead(&grid, Form::Absolute), 0);
        assert_eq!((s.min, s.max), (20.0, 21.0));
        let held = [run(2), run(0)];
        let mut x = adjusted(&held, &roles, Form::Absolute);
        x[1][0] = vec![90.0, 91.0];
        let s = span(&held, &x, &lead(&held, Form::Absolute), 0);
        assert_eq!((s.min, s.max), (20.0, 21.0));
    }

    #[test]
    fn extrapolating_folds_measure_the_growth() {
        // 1000 inside plus 30 one envelope width out with |r| = 2.375: with
        // them the 95 % quantile h is 0.979, so |r| is 2.43 h; a growth of
        // 1 covers 2 h there, 2 covers 3 h, so 2 is the smallest.
        let (mut r, mut d) = inside();
        r.extend(std::iter::repeat_n(2.5 * 0.95, 30));
        d.extend(std::iter::repeat_n(1.0, 30));
        let b = Band::calibrate(&r, &d);
        assert_eq!(b.extrapolating_samples, 30);
        assert_eq!(b.growth, 2.0);
        assert!(b.growth_measured());
        // One fewer than the minimum: the floor again, said to be unmeasured.
        let n = 1000 + MIN_EXTRAPOLATING - 1;
        let b = Band::calibrate(&r[..n], &d[..n]);
        assert_eq!(b.growth, 1.0);
        assert!(!b.growth_measured());
    }
}
