//! `thermcomp fit`: the flags (every kind's options as its flag group, with
//! their help texts and defaults), reading the runs, the typed job
//! ([`crate::fit::fit`]), writing the blob, and the outcome printed as one
//! JSON object with `--json` or as a table of scores. Each flag group turns
//! into the library's plain options struct ([`FitOptions`] and its parts).

use crate::data::dataset::InputForm;
use crate::data::fsio;
use crate::data::runfile::ReadOptions;
use crate::data::runfile::RunFile;
use crate::fit::arma::{yule_walker, ArmaOptions};
use crate::fit::auto::AutoOptions;
use crate::fit::bp::{BpOptions, HiddenActivation};
use crate::fit::dynamic::options::{DynamicOptions, Ridge, Selection};
use crate::fit::dynamic::orders::OrderRange;
use crate::fit::pcr::PcrOptions;
use crate::fit::{auto, fit, FitKind, FitOptions, FitOutcome, FitParams};
use crate::plot::model::{PageRun, PageText};
use crate::runner::ColumnMap;
use crate::score::TargetScore;
use anyhow::{bail, Result};
use clap::Args;
use serde_json::Value;
use std::path::PathBuf;

/// Arguments of `thermcomp fit`.
#[derive(Args)]
pub struct FitArgs {
    /// A calibration run (CSV); repeatable. Each run restarts a dynamic model's state.
    #[arg(long, required = true)]
    pub data: Vec<PathBuf>,
    /// A validation run, held out whole (repeatable).
    #[arg(long)]
    pub validate: Vec<PathBuf>,
    /// Target column(s), comma-separated (e.g. ch1_um or dx_um,dz_um).
    #[arg(long, value_delimiter = ',', required = true)]
    pub target: Vec<String>,
    /// Input columns, comma-separated (default: every column named T<number>;
    /// with `auto` also speed_rpm, power_kw, ambient_c and coolant_c where present).
    #[arg(long, value_delimiter = ',')]
    pub inputs: Vec<String>,
    /// The model kind.
    #[arg(long, value_enum)]
    pub model: FitKind,
    /// Where to write the model blob.
    #[arg(long)]
    pub out: PathBuf,
    /// Hold out every row at or after this time (s) of each --data run.
    #[arg(long, value_name = "SECONDS")]
    pub holdout_from_s: Option<f64>,
    /// How inputs enter the model: "change" from each run's first sample
    /// (default: cancels day-to-day offsets of absolute temperature), or "absolute".
    #[arg(long, value_enum, default_value = "change")]
    pub reference: InputForm,
    /// Skip rows with unparsable cells instead of failing (they are counted and reported).
    #[arg(long)]
    pub skip_bad_rows: bool,
    /// Print one JSON object with the fit and held-out figures.
    #[arg(long)]
    pub json: bool,
    /// Write DIR/index.html: measured, predicted and the 95 % band of every
    /// output on every run, the residuals, and (auto) the CV table as bars.
    #[arg(long, value_name = "DIR")]
    pub report: Option<PathBuf>,
    /// Five-point targets (e_um,theta_x_urad,theta_y_urad): the spindle's
    /// deflection centre above the nose, mm, recorded in the blob so that the
    /// hub turns the outputs into tool-tip offsets (default 300, the twin's
    /// machine; docs/fivepoint.md).
    #[arg(long, value_name = "MM")]
    pub l_defl_mm: Option<f64>,
    /// Every kind's training options, as flag groups.
    #[command(flatten)]
    pub options: FitOptionsArgs,
}

/// Every kind's training options as `fit`'s flag groups, in the order
/// `--help` lists them.
#[derive(Args, Clone, Debug)]
pub struct FitOptionsArgs {
    /// PCR options.
    #[command(flatten)]
    pub pcr: PcrArgs,
    /// ARX, TF, gain (and auto/arma `--dt-s`) options.
    #[command(flatten)]
    pub arx: DynamicArgs,
    /// BP and GA-BP options.
    #[command(flatten)]
    pub bp: BpArgs,
    /// ARMA options.
    #[command(flatten)]
    pub arma: ArmaArgs,
    /// Auto options.
    #[command(flatten)]
    pub auto: AutoArgs,
}

impl From<FitOptionsArgs> for FitOptions {
    fn from(a: FitOptionsArgs) -> Self {
        Self {
            pcr: a.pcr.into(),
            arx: a.arx.into(),
            bp: a.bp.into(),
            arma: a.arma.into(),
            auto: a.auto.into(),
        }
    }
}

/// Options by name and value as `fit`'s flags spell them, without the
/// leading `--` (`("variance", "0.9")`, `("auto_folds", "3")`: underscores
/// stand for dashes); the others keep their defaults. A bad name or value
/// fails with the CLI's one-line message. The Python package's keyword
/// arguments come through here.
pub fn options_from_pairs(pairs: &[(String, String)]) -> Result<FitOptions> {
    super::pairs::args_from_pairs::<FitOptionsArgs>("fit", pairs).map(FitOptions::from)
}

/// PCR options of `thermcomp fit`.
#[derive(Args, Clone, Debug)]
pub struct PcrArgs {
    /// pcr: keep the fewest components whose cumulative share of the
    /// variance reaches this fraction (seed 003: 0.85).
    #[arg(long, default_value_t = 0.85, value_name = "FRACTION")]
    pub variance: f64,
    /// pcr: keep exactly this many components instead.
    #[arg(long, value_name = "K")]
    pub components: Option<usize>,
}

impl From<PcrArgs> for PcrOptions {
    fn from(a: PcrArgs) -> Self {
        Self {
            variance: a.variance,
            components: a.components,
        }
    }
}

/// Options of the dynamic trainers (`arx`, `tf`, `gain`) of `thermcomp fit`.
#[derive(Args, Clone, Debug)]
pub struct DynamicArgs {
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

impl From<DynamicArgs> for DynamicOptions {
    fn from(a: DynamicArgs) -> Self {
        Self {
            na: a.na,
            nb: a.nb,
            nk: a.nk,
            search_folds: a.search_folds,
            search_holdout: a.search_holdout,
            dt_s: a.dt_s,
            backfit_rounds: a.backfit_rounds,
            lm_iterations: a.lm_iterations,
            gain_from: a.gain_from,
            gain_inputs: a.gain_inputs,
            select_inputs: a.select_inputs,
            max_inputs: a.max_inputs,
            min_gain_pct: a.min_gain_pct,
            ridge: a.ridge,
        }
    }
}

/// BP and GA-BP options of `thermcomp fit`.
#[derive(Args, Clone, Debug)]
pub struct BpArgs {
    /// bp, gabp: random seed (training is deterministic for a given seed).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// bp: hidden neurons [default: 10 (seed 000's 4-10-3 net), at most 384 / inputs].
    #[arg(long, value_name = "N")]
    pub hidden: Option<usize>,
    /// bp, gabp: hidden-layer transfer function.
    #[arg(long, value_enum, default_value = "tansig")]
    pub activation: HiddenActivation,
    /// bp, gabp: Levenberg-Marquardt epochs at most.
    #[arg(long, default_value_t = 200, value_name = "N")]
    pub epochs: usize,
    /// bp, gabp: stop after this many epochs without a better validation error (MATLAB max_fail).
    #[arg(long, default_value_t = 6, value_name = "N")]
    pub max_fail: usize,
    /// bp, gabp: cut the calibration rows into this many contiguous blocks for validation.
    #[arg(long, default_value_t = 20, value_name = "N")]
    pub val_blocks: usize,
    /// bp, gabp: every K-th block validates (0: no validation, no early stop).
    #[arg(long, default_value_t = 5, value_name = "K")]
    pub val_every: usize,
    /// bp, gabp: training MSE goal (on targets scaled to [-1, 1]) for the
    /// convergence report [default: half the MSE of a linear least-squares fit].
    #[arg(long, value_name = "MSE")]
    pub goal: Option<f64>,
    /// gabp: individuals per generation.
    #[arg(long, default_value_t = 40, value_name = "N")]
    pub ga_population: usize,
    /// gabp: generations.
    #[arg(long, default_value_t = 30, value_name = "N")]
    pub ga_generations: usize,
    /// gabp: crossover probability of a pair.
    #[arg(long, default_value_t = 0.7, value_name = "P")]
    pub ga_crossover: f64,
    /// gabp: mutation probability of an individual.
    #[arg(long, default_value_t = 0.2, value_name = "P")]
    pub ga_mutation: f64,
    /// gabp: hidden sizes the GA searches [default: 2..16, at most 384 / inputs].
    #[arg(long, value_name = "MIN..MAX")]
    pub ga_hidden: Option<String>,
    /// gabp: epochs of gradient-descent BP (traingdx) for the convergence comparison (0: skip).
    #[arg(long, default_value_t = 1000, value_name = "N")]
    pub gd_epochs: usize,
    /// gabp: also train the nets it is compared with (BP at the default size and
    /// at the GA's size, LM, and the three gradient-descent runs) and report how
    /// each converged; off, only the GA-BP net is trained (the same blob, about a
    /// third of the time).
    #[arg(long)]
    pub report_convergence: bool,
}

impl From<BpArgs> for BpOptions {
    fn from(a: BpArgs) -> Self {
        Self {
            seed: a.seed,
            hidden: a.hidden,
            activation: a.activation,
            epochs: a.epochs,
            max_fail: a.max_fail,
            val_blocks: a.val_blocks,
            val_every: a.val_every,
            goal: a.goal,
            ga_population: a.ga_population,
            ga_generations: a.ga_generations,
            ga_crossover: a.ga_crossover,
            ga_mutation: a.ga_mutation,
            ga_hidden: a.ga_hidden,
            gd_epochs: a.gd_epochs,
            report_convergence: a.report_convergence,
        }
    }
}

/// ARMA options of `thermcomp fit`.
#[derive(Args, Clone, Debug)]
pub struct ArmaArgs {
    /// arma: largest AR order tried (at most 10).
    #[arg(long, default_value_t = 4, value_name = "P")]
    pub max_p: usize,
    /// arma: largest MA order tried (at most 10).
    #[arg(long, default_value_t = 4, value_name = "Q")]
    pub max_q: usize,
    /// arma: most differences taken while the ADF test keeps a unit root (at most 2).
    #[arg(long, default_value_t = 2, value_name = "D")]
    pub max_diff: usize,
    /// arma: ADF level: difference while the p-value is above it.
    #[arg(long, default_value_t = 0.05, value_name = "ALPHA")]
    pub adf_alpha: f64,
    /// arma: largest ADF lag tried (default statsmodels' ceil(12 (n/100)^(1/4))).
    #[arg(long, value_name = "L")]
    pub adf_maxlag: Option<usize>,
    /// arma: Yule-Walker autocovariance divisor for the reported AR estimate.
    #[arg(long, value_enum, default_value = "adjusted")]
    pub yw_method: yule_walker::Method,
}

impl From<ArmaArgs> for ArmaOptions {
    fn from(a: ArmaArgs) -> Self {
        Self {
            max_p: a.max_p,
            max_q: a.max_q,
            max_diff: a.max_diff,
            adf_alpha: a.adf_alpha,
            adf_maxlag: a.adf_maxlag,
            yw_method: a.yw_method,
        }
    }
}

/// Options of `--model auto`.
#[derive(Args, Clone, Debug)]
pub struct AutoArgs {
    /// auto: contiguous cross-validation folds within a single calibration
    /// run (several runs: one fold per run).
    #[arg(long, default_value_t = 6)]
    pub auto_folds: usize,
    /// auto: how many of the best candidates the model averages (as many
    /// as fit the hub's 256 features; 20 won on the development split,
    /// scripts/auto_dev_split.sh). With several calibration runs, at most
    /// this many of the simplest candidates within one standard error of
    /// the best.
    #[arg(long, default_value_t = 20)]
    pub auto_ensemble: usize,
    /// auto: how many of the best candidates also try dropping temperature
    /// sensors (backward elimination by CV, one-standard-error rule; 0: off,
    /// the default: on the development split it lost more than it won,
    /// docs/validation-auto.md).
    #[arg(long, default_value_t = 0)]
    pub auto_eliminate: usize,
    /// auto: model families weighed by the same cross-validation: ridge
    /// (the filter bank; must be listed), pcr, arx, tf, bp, gabp. Another family
    /// replaces the ridge only when its CV error is lower beyond noise;
    /// "ridge" alone: the filter bank only. arx and tf are tried only when
    /// the CV sees extrapolation (not over alike calibration runs).
    #[arg(long, value_delimiter = ',', default_value = auto::table::DEFAULT_FAMILIES, value_name = "LIST")]
    pub auto_families: Vec<String>,
}

impl From<AutoArgs> for AutoOptions {
    fn from(a: AutoArgs) -> Self {
        Self {
            auto_folds: a.auto_folds,
            auto_ensemble: a.auto_ensemble,
            auto_eliminate: a.auto_eliminate,
            auto_families: a.auto_families,
        }
    }
}

/// The scores as a text table: one row per target and part.
fn scores_text(scores: &[TargetScore]) -> String {
    let mut s = format!(
        "{:<10} {:<12} {:>7} {:>9} {:>8} {:>8} {:>9} {:>9}\n",
        "target", "part", "n", "rmse_um", "fit_%", "r2", "dpk_um", "reduce_%"
    );
    for t in scores {
        for (part, m) in [("calibration", &t.calibration), ("held-out", &t.holdout)] {
            if let Some(m) = m {
                s.push_str(&format!(
                    "{:<10} {:<12} {:>7} {:>9.3} {:>8.2} {:>8.4} {:>9.3} {:>9.2}\n",
                    t.output, part, m.n, m.rmse, m.fit_pct, m.r2, m.dpk, m.reduction_pct
                ));
            }
        }
    }
    s
}

impl FitArgs {
    /// The job's parameters, from the flags.
    pub fn params(&self) -> FitParams {
        FitParams {
            targets: self.target.clone(),
            inputs: self.inputs.clone(),
            kind: self.model,
            holdout_from_s: self.holdout_from_s,
            reference: self.reference,
            l_defl_mm: self.l_defl_mm,
            options: self.options.clone().into(),
        }
    }
}

/// Reads the runs, [`fit`]s, writes the blob: everything `thermcomp fit`
/// does but print.
pub fn fit_files(a: &FitArgs) -> Result<FitOutcome> {
    Ok(read_and_fit(a)?.0)
}

/// [`fit_files`], also returning the runs read (calibration, validation).
fn read_and_fit(a: &FitArgs) -> Result<(FitOutcome, Vec<RunFile>, Vec<RunFile>)> {
    check_paths(a)?;
    let params = a.params().check()?;
    // Read only the columns the fit uses.
    let opts = ReadOptions {
        skip_bad_rows: a.skip_bad_rows,
        only: Some(params.columns_read(&a.data)?),
    };
    let runs = crate::data::source::read_runs(&a.data, &opts)?;
    let validate = crate::data::source::read_runs(&a.validate, &opts)?;
    let outcome = fit(&params, &runs, &validate)?;
    // Isolated readings in the calibration runs' temperature inputs: the
    // fit took them as figures (crate::data::spikes).
    for note in crate::data::spikes::notes(&runs, &outcome.inputs, "The fit") {
        eprintln!("note: {note}");
    }
    fsio::write_bytes_atomic(&a.out, &outcome.bytes)?;
    Ok((outcome, runs, validate))
}

/// `fit --json`'s object: the report and the path written.
pub fn report_json(o: &FitOutcome, out: &std::path::Path) -> Result<Value> {
    super::with_out(&o.report, out)
}

/// Refuses an `--out` (or the report page) that is the same file as a
/// `--data` or `--validate` run or the `--gain-from` blob.
fn check_paths(a: &FitArgs) -> Result<()> {
    let data = a.data.iter().map(|p| fsio::named("--data", p));
    let validate = a.validate.iter().map(|p| fsio::named("--validate", p));
    let gain = a
        .options
        .arx
        .gain_from
        .iter()
        .map(|p| fsio::named("--gain-from", p));
    let reads: Vec<_> = data.chain(validate).chain(gain).collect();
    for v in &a.validate {
        if let Some(d) = a.data.iter().find(|d| fsio::same_file(d, v)) {
            bail!(
                "--validate {} is the same file as --data {}: its figures would not be held out",
                v.display(),
                d.display()
            );
        }
    }
    let page = super::report_page(a.report.as_deref())?;
    fsio::dir_of(&a.out)?;
    let mut writes = vec![fsio::named("--out", &a.out)];
    writes.extend(page.as_deref().map(|p| fsio::named("--report", p)));
    fsio::check_distinct(&reads, &writes)
}

/// `fit --report DIR`: the model on its calibration and validation runs,
/// under the `table` and `json` the command prints.
fn write_report(
    a: &FitArgs,
    o: &FitOutcome,
    [runs, validate]: [&[RunFile]; 2],
    table: &str,
    json: &Value,
) -> Result<()> {
    let Some(dir) = &a.report else {
        return Ok(());
    };
    let role = if a.holdout_from_s.is_some() {
        "calibration; rows at or after --holdout-from-s held out"
    } else {
        "calibration"
    };
    let page_runs: Vec<PageRun> = runs
        .iter()
        .map(|run| PageRun {
            run,
            holdout_from_s: a.holdout_from_s,
            role,
        })
        .chain(validate.iter().map(|run| PageRun {
            run,
            holdout_from_s: None,
            role: "validation, held out whole",
        }))
        .collect();
    let text = PageText {
        title: "thermcomp fit",
        auto: o.auto_report(),
        summary: table,
    };
    super::publish_page(
        dir,
        &o.model,
        &page_runs,
        &ColumnMap::default(),
        &text,
        json,
    )
}

/// Says on stderr when an auto model's band is calibrated inside the
/// calibration envelope only.
fn warn_unmeasured_band(o: &FitOutcome) {
    let Some(report) = o.auto_report() else {
        return;
    };
    let targets = report.unmeasured_growth();
    if !targets.is_empty() {
        eprintln!(
            "note: {}: no cross-validation fold left the other folds' input envelope, so how fast \
             the 95 % band must widen outside it is not measured (growth 1 assumed); outside \
             the envelope (the hub's \"extrapolating\" flag) the band is a guess",
            targets.join(", ")
        );
    }
}

/// Says on stderr which inputs did not move beyond their noise in the
/// calibration rows: those an auto fit left out, or those another kind
/// fitted a weight to anyway.
fn warn_quiet_inputs(o: &FitOutcome) {
    use crate::fit::quiet;
    let note = match o.auto_report() {
        Some(r) => (!r.quiet_inputs.is_empty()).then(|| quiet::left_out(&r.quiet_inputs)),
        None => (!o.unmoved.is_empty()).then(|| quiet::fitted_anyway(&o.unmoved)),
    };
    if let Some(note) = note {
        eprintln!("note: {note}");
    }
}

/// Says on stderr where an auto fit's CV could not see extrapolation, and
/// what it left out for that reason (`Sight`).
fn warn_static_only(o: &FitOutcome) {
    for sentence in o
        .auto_report()
        .map(|r| r.sight.sentences())
        .unwrap_or_default()
    {
        eprintln!("note: auto: {sentence}; calibrate on runs that differ (room, programme) for the CV to weigh them");
    }
}

/// Says on stderr when `--holdout-from-s` held nothing out (it lies at or
/// after every run's last row): the figures are then calibration figures.
fn warn_nothing_held_out(a: &FitArgs, o: &FitOutcome) {
    if let (Some(h), 0) = (a.holdout_from_s, o.report.holdout_rows) {
        if a.validate.is_empty() {
            eprintln!(
                "note: --holdout-from-s {h} lies after every run's last row: nothing is held \
                 out, every figure is on calibration rows"
            );
        }
    }
}

/// Runs `thermcomp fit`.
pub fn run(a: &FitArgs) -> Result<()> {
    let (o, runs, validate) = read_and_fit(a)?;
    warn_unmeasured_band(&o);
    warn_quiet_inputs(&o);
    warn_static_only(&o);
    warn_nothing_held_out(a, &o);
    let (table, json) = (scores_text(&o.scores), report_json(&o, &a.out)?);
    write_report(a, &o, [&runs, &validate], &table, &json)?;
    if a.json {
        fsio::print_line(&json.to_string())?;
    } else {
        fsio::print(&table)?;
        eprintln!(
            "wrote {} ({} bytes, {} model on {} inputs, {} calibration rows)",
            a.out.display(),
            o.bytes.len(),
            o.model.kind().name(),
            o.inputs.len(),
            o.calibration_rows
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_library_defaults_are_the_flags_defaults() {
        assert_eq!(options_from_pairs(&[]).unwrap(), FitOptions::default());
    }
}
