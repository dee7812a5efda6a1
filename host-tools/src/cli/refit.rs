//! `thermcomp refit`: the flags, reading the model in service and the runs,
//! the typed job ([`crate::refit::refit`]), writing the blob, and the
//! outcome printed as one JSON object with `--json` or as a text report.

use crate::data::fsio::{self, named};
use crate::data::runfile::{ReadOptions, RunFile};
use crate::data::{blobfile, source};
use crate::refit::{holdout_from_s, refit, InService, Method, RefitOutcome, RefitParams, Verdict};
use crate::runner::ColumnMap;
use crate::score::TargetScore;
use anyhow::Result;
use clap::Args;
use model_core::ValidModel;
use serde_json::Value;
use std::path::{Path, PathBuf};

/// Arguments of `thermcomp refit`.
#[derive(Args)]
pub struct RefitArgs {
    /// The model in service (blob).
    #[arg(long)]
    pub model: PathBuf,
    /// A new run (CSV) with the model's inputs and measured outputs; repeatable.
    #[arg(long, required = true)]
    pub data: Vec<PathBuf>,
    /// Where to write the model (the old blob, byte for byte, if nothing changed
    /// or the update does not improve the held-out rmse).
    #[arg(long)]
    pub out: PathBuf,
    /// A run the old model was validated on (repeatable): its rmse/dpk is the
    /// expected level for the --tolerance rule.
    #[arg(long)]
    pub baseline: Vec<PathBuf>,
    /// With --baseline: a new-run rmse or dpk above this multiple of the
    /// baseline's (and at least --min-effect-um above it) flags a change.
    #[arg(long, default_value_t = 1.5, value_name = "FACTOR")]
    pub tolerance: f64,
    /// Smallest systematic error (um, largest |bias + drift + gain error|
    /// fitted to the residual) that counts as a change.
    #[arg(long, default_value_t = 1.0, value_name = "UM")]
    pub min_effect_um: f64,
    /// Significance level of the HAC Wald test.
    #[arg(long, default_value_t = 0.01)]
    pub alpha: f64,
    /// How to update a changed model.
    #[arg(long, value_enum, default_value = "rls")]
    pub method: Method,
    /// RLS forgetting factor per sample (default: 1 - dt / memory, from the
    /// runs' median sample time and --memory-h).
    #[arg(long, value_name = "LAMBDA")]
    pub forgetting: Option<f64>,
    /// RLS memory, hours: the default forgetting factor's time constant.
    #[arg(long, default_value_t = 4.0, value_name = "HOURS")]
    pub memory_h: f64,
    /// RLS prior: the old coefficients weigh as much as this many hours of
    /// new samples (prior covariance I / n_prior on standardised regressors).
    #[arg(long, default_value_t = 1.0, value_name = "HOURS")]
    pub prior_h: f64,
    /// --method window: refit on the last H hours of each run's update part.
    #[arg(long, value_name = "H", default_value_t = 8.0)]
    pub window_h: f64,
    /// Fraction of each new run (by time, at its end) held out for scoring.
    #[arg(long, default_value_t = 0.3, value_name = "FRACTION")]
    pub holdout_fraction: f64,
    /// Skip rows with unparsable cells instead of failing (they are counted and reported).
    #[arg(long)]
    pub skip_bad_rows: bool,
    /// Print one JSON object instead of the text report.
    #[arg(long)]
    pub json: bool,
    /// Write DIR/index.html: the written model on every new run (measured,
    /// predicted, the 95 % band, the residual; the held-out tail marked).
    #[arg(long, value_name = "DIR")]
    pub report: Option<PathBuf>,
}

impl RefitArgs {
    /// The job's parameters, from the flags.
    pub fn params(&self) -> RefitParams {
        RefitParams {
            tolerance: self.tolerance,
            min_effect_um: self.min_effect_um,
            alpha: self.alpha,
            method: self.method,
            forgetting: self.forgetting,
            memory_h: self.memory_h,
            prior_h: self.prior_h,
            window_h: self.window_h,
            holdout_fraction: self.holdout_fraction,
        }
    }
}

/// Refuses an `--out` that is the same file as any file read.
fn check_paths(a: &RefitArgs) -> Result<()> {
    let reads: Vec<_> = [named("--model", &a.model)]
        .into_iter()
        .chain(a.data.iter().map(|p| named("--data", p)))
        .chain(a.baseline.iter().map(|p| named("--baseline", p)))
        .collect();
    let page = super::report_page(a.report.as_deref())?;
    let mut writes = vec![named("--out", &a.out)];
    writes.extend(page.as_deref().map(|p| named("--report", p)));
    fsio::check_distinct(&reads, &writes)
}

/// `refit --report DIR`: the written model on the new runs, each run's
/// held-out tail (the last `--holdout-fraction` of its span) marked, under
/// the `text` and `json` the command prints.
fn write_report(
    a: &RefitArgs,
    o: &RefitOutcome,
    (old, runs): (&ValidModel, &[RunFile]),
    text: &str,
    json: &Value,
) -> Result<()> {
    use crate::plot::model::{PageRun, PageText};
    let Some(dir) = &a.report else {
        return Ok(());
    };
    let page_runs: Vec<PageRun> = runs
        .iter()
        .map(|run| PageRun {
            run,
            holdout_from_s: holdout_from_s(run, a.holdout_fraction),
            role: "new run; its last --holdout-fraction held out",
        })
        .collect();
    let page = PageText {
        title: if o.model.is_some() {
            "thermcomp refit: the updated model"
        } else {
            "thermcomp refit: the model unchanged"
        },
        auto: None,
        summary: text,
    };
    let model = o.model.as_ref().unwrap_or(old);
    super::publish_page(dir, model, &page_runs, &ColumnMap::default(), &page, json)
}

/// What `refit` reads.
struct RefitInputs {
    /// The model in service.
    old: ValidModel,
    /// Its blob, byte for byte.
    old_bytes: Vec<u8>,
    /// The new runs.
    runs: Vec<RunFile>,
    /// The baseline runs.
    baseline: Vec<RunFile>,
}

/// The model in service (decoded, and its bytes), the new runs and the
/// baseline runs, read with only the model's columns.
fn read_inputs(a: &RefitArgs) -> Result<RefitInputs> {
    let (old, old_bytes) = blobfile::read(&a.model)?;
    let opts = ReadOptions {
        skip_bad_rows: a.skip_bad_rows,
        only: Some(ColumnMap::default().model_columns(&old, true)),
    };
    let runs = source::read_runs(&a.data, &opts)?;
    let baseline = source::read_runs(&a.baseline, &opts)?;
    Ok(RefitInputs {
        old,
        old_bytes,
        runs,
        baseline,
    })
}

/// `refit --json`'s object: the report and the path written.
pub fn report_json(o: &RefitOutcome, out: &Path) -> Result<Value> {
    super::with_out(&o.report, out)
}

/// Runs `thermcomp refit`.
pub fn run(a: &RefitArgs) -> Result<()> {
    let params = a.params().check()?;
    check_paths(a)?;
    let RefitInputs {
        old,
        old_bytes,
        runs,
        baseline,
    } = read_inputs(a)?;
    let in_service = InService {
        model: &old,
        bytes: &old_bytes,
    };
    let o = refit(&params, in_service, &runs, &baseline)?;
    fsio::write_bytes_atomic(&a.out, &o.bytes)?;
    for n in &o.report.notes {
        eprintln!("note: {n}");
    }
    let (text, json) = (outcome_text(&o), report_json(&o, &a.out)?);
    write_report(a, &o, (&old, &runs), &text, &json)?;
    if a.json {
        return fsio::print_line(&json.to_string());
    }
    fsio::print(&text)?;
    let what = if o.model.is_some() {
        "updated"
    } else {
        "unchanged"
    };
    eprintln!(
        "wrote {} ({} bytes, {what} model)",
        a.out.display(),
        o.bytes.len()
    );
    Ok(())
}

/// The text report of an outcome (what `refit` prints without `--json`).
fn outcome_text(o: &RefitOutcome) -> String {
    let r = &o.report;
    text_report(
        &o.outputs,
        &o.verdicts,
        r.test.decision,
        &o.before,
        &o.after,
        r.kept,
        &r.targets_updated,
    )
}

/// The text report: the test per output, old and new rmse per part, what
/// was kept.
fn text_report(
    outputs: &[String],
    verdicts: &[Verdict],
    decision: &str,
    before: &[TargetScore],
    after: &[TargetScore],
    kept: &str,
    kept_targets: &[String],
) -> String {
    let mut s = format!("refit: {decision}\n");
    s.push_str(&format!(
        "{:<10} {:>9} {:>10} {:>8} {:>9} {:>10} {:>6} {:>10} {:>9}\n",
        "target", "bias_um", "drift_um/h", "gain", "wald", "p", "n_eff", "effect_um", "decision"
    ));
    for (o, v) in outputs.iter().zip(verdicts) {
        let d = if v.changed { "changed" } else { "unchanged" };
        match &v.test {
            Some(t) => s.push_str(&format!(
                "{:<10} {:>9.3} {:>10.4} {:>8.4} {:>9.2} {:>10.2e} {:>6.0} {:>10.3} {:>9}\n",
                o, t.c0_um, t.c1_um_per_h, t.c2, t.wald, t.p_value, t.n_eff, t.effect_um, d
            )),
            None => s.push_str(&format!("{o:<10} (too few samples to test) {d}\n")),
        }
    }
    s.push_str(&format!(
        "{:<10} {:<12} {:>12} {:>12}\n",
        "target", "part", "rmse_old_um", "rmse_written_um"
    ));
    for (b, n) in before.iter().zip(after) {
        for (part, mb, mn) in [
            ("update", &b.calibration, &n.calibration),
            ("held-out", &b.holdout, &n.holdout),
        ] {
            if let (Some(mb), Some(mn)) = (mb, mn) {
                s.push_str(&format!(
                    "{:<10} {:<12} {:>12.3} {:>12.3}\n",
                    b.output, part, mb.rmse, mn.rmse
                ));
            }
        }
    }
    if kept == "new" {
        s.push_str(&format!(
            "kept: new ({} updated)\n",
            kept_targets.join(", ")
        ));
    } else {
        s.push_str("kept: old (written unchanged)\n");
    }
    s
}
