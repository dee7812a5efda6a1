//! What the diagnosis said about one benchmark case, whatever made the
//! case (the twin-derived cases of [`super::cases`] or the plant zoo of
//! [`super::zoo`]), and running many cases in parallel.

use super::cases::Case;
use crate::diagnose::candidates::round;
use crate::diagnose::outcome::{self, finite, LookFigures};
use anyhow::{Context, Result};
use rayon::prelude::*;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The figures the benchmark keeps of one diagnosis.
#[derive(Debug, Clone)]
pub struct Diagnosis {
    /// The true cause (a name of [`super::cases::LABELS`]).
    pub truth: String,
    /// The verdict.
    pub verdict: String,
    /// The second effect, if one was claimed.
    pub second: Option<String>,
    /// The channel the candidates were scored on.
    pub main_channel: String,
    /// Held-out shrink of the verdict's candidate (of the `none` baseline
    /// when the verdict is `none`), %.
    pub verdict_shrink_pct: f64,
    /// Held-out shrink of the true cause's candidate, % (`None` for `none`).
    pub true_shrink_pct: Option<f64>,
    /// Best candidate's held-out rms over the baseline's (rule 3 wants <= 0.8).
    pub best_ratio_to_none: f64,
    /// Name of the best candidate on the held-out rms.
    pub best: String,
    /// Deployment view: real held-out rmse of a model trained on the sim
    /// and on the sim plus the verdict's effect, um (if computed).
    pub deploy_sim_um: Option<f64>,
    /// See `deploy_sim_um`.
    pub deploy_sim_effect_um: Option<f64>,
    /// Confidence of the true cause's candidate (`None` for `none`).
    pub true_confidence: Option<f64>,
    /// The diagnosis's looks (channel, candidates' figures).
    pub looks: Vec<LookFigures>,
    /// Wall time of the case (both runs and the diagnosis), s.
    pub elapsed_s: f64,
}

/// A case and what the diagnosis said about it.
#[derive(Debug, Clone)]
pub struct Outcome<C> {
    /// The case.
    pub case: C,
    /// The diagnosis.
    pub diag: Diagnosis,
}

/// A figure of the candidate `name` in a diagnosis, if it is there and
/// finite.
fn effect_field(
    d: &outcome::Diagnosis,
    name: &str,
    field: impl Fn(&outcome::Effect) -> Option<f64>,
) -> Option<f64> {
    d.effects
        .iter()
        .find(|e| e.name == name)
        .and_then(field)
        .and_then(finite)
}

impl Diagnosis {
    /// Reads the figures out of a diagnosis for a case of cause `truth`.
    pub fn of(truth: &str, d: &outcome::Diagnosis, elapsed_s: f64) -> Diagnosis {
        let best = d
            .effects
            .iter()
            .find(|e| e.name != "none")
            .map_or("none", |e| e.name.as_str())
            .to_string();
        let shrink = |e: &outcome::Effect| Some(e.shrink_pct);
        let after = |e: &outcome::Effect| Some(e.rms_after);
        let none_after = effect_field(d, "none", after).unwrap_or(f64::NAN);
        let best_after = effect_field(d, &best, after).unwrap_or(f64::NAN);
        let truth_field = |field: &dyn Fn(&outcome::Effect) -> Option<f64>| {
            (truth != "none")
                .then(|| effect_field(d, truth, field))
                .flatten()
        };
        let dep = d.deployment.comparison();
        Diagnosis {
            truth: truth.to_string(),
            verdict_shrink_pct: effect_field(d, &d.verdict, shrink).unwrap_or(f64::NAN),
            true_shrink_pct: truth_field(&shrink),
            true_confidence: truth_field(&|e| e.confidence),
            looks: d.looks.clone(),
            best_ratio_to_none: best_after / none_after,
            best,
            second: d.second.as_ref().map(|s| s.name.clone()),
            main_channel: d.main_channel.clone(),
            deploy_sim_um: dep.and_then(|c| c.trained_on_sim.rmse_um()),
            deploy_sim_effect_um: dep
                .and_then(|c| c.trained_on_sim_plus_effect.as_ref())
                .and_then(|t| t.rmse_um()),
            verdict: d.verdict.clone(),
            elapsed_s,
        }
    }

    /// Whether the verdict names the true cause.
    pub fn correct(&self) -> bool {
        self.verdict == self.truth
    }

    /// The diagnosis' figures as JSON fields.
    pub fn to_json(&self) -> Value {
        json!({
            "verdict": self.verdict, "second": self.second, "main_channel": self.main_channel,
            "shrink_pct": round(self.verdict_shrink_pct),
            "true_shrink_pct": self.true_shrink_pct.map(round),
            "best": self.best, "best_ratio_to_none": round(self.best_ratio_to_none),
            "deployment_rmse_um": {"trained_on_sim": self.deploy_sim_um.map(round),
                                    "trained_on_sim_plus_effect": self.deploy_sim_effect_um.map(round)},
            "true_confidence": self.true_confidence.map(round), "looks": self.looks,
            "correct": self.correct(), "elapsed_s": round(self.elapsed_s),
        })
    }
}

impl<C> Outcome<C> {
    /// Whether the verdict names the true cause.
    pub fn correct(&self) -> bool {
        self.diag.correct()
    }
}

impl Outcome<Case> {
    /// The case and its outcome as one JSON object.
    pub fn to_json(&self) -> Value {
        let c = &self.case;
        let mut v = json!({
            "id": c.id, "effect": c.effect, "profile": c.profile.label(), "seed": c.seed,
            "magnitude": c.magnitude, "logged": c.logged,
        });
        merge(&mut v, self.diag.to_json());
        v
    }
}

/// Adds the fields of object `b` to object `a`.
pub fn merge(a: &mut Value, b: Value) {
    if let (Some(a), Value::Object(b)) = (a.as_object_mut(), b) {
        a.extend(b);
    }
}

/// Writes a case's runs into `dir` with `write`, diagnoses them blind for
/// a case of cause `truth`, and removes `dir` afterwards unless `keep`.
pub fn diagnose_case<C>(
    case: C,
    truth: &str,
    dir: &Path,
    keep: bool,
    write: impl FnOnce(&C, &Path) -> Result<(PathBuf, PathBuf)>,
) -> Result<Outcome<C>> {
    let started = Instant::now();
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let (sim, real) = write(&case, dir)?;
    let v = crate::diagnose::diagnose_files(&sim, &real, None, None)
        .with_context(|| format!("{}: diagnose", dir.display()))?;
    if !keep {
        // Best effort: a leftover temporary file is not worth failing for.
        let _ = std::fs::remove_dir_all(dir);
    }
    let diag = Diagnosis::of(truth, &v, started.elapsed().as_secs_f64());
    Ok(Outcome { case, diag })
}

/// Runs `f` on every case in parallel (rayon) with a progress bar on
/// stderr; results in case order.
pub fn run_parallel<C: Send, R: Send>(
    cases: Vec<C>,
    what: &str,
    f: impl Fn(C) -> Result<R> + Sync + Send,
) -> Result<Vec<R>> {
    let pb = crate::num::progress::progress(cases.len(), what);
    let out: Result<Vec<R>> = cases
        .into_par_iter()
        .map(|c| {
            let r = f(c);
            pb.inc(1);
            r
        })
        .collect();
    pb.finish_and_clear();
    out
}

/// The folder `--keep-runs` writes the run files to, `OUT/runs`: created,
/// or empty if it exists (a user's files there were deleted with it once).
pub fn kept_runs_dir(out: &Path) -> Result<PathBuf> {
    let dir = free_runs_dir(out)?;
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    Ok(dir)
}

/// `OUT/runs` if nothing is there or it is an empty folder; else why not
/// (checked before a run starts, and again when it does).
pub fn free_runs_dir(out: &Path) -> Result<PathBuf> {
    let dir = out.join("runs");
    if dir.symlink_metadata().is_ok() {
        let empty = std::fs::read_dir(&dir).is_ok_and(|mut d| d.next().is_none());
        if !empty {
            anyhow::bail!(
                "{} exists and is not an empty folder: --keep-runs writes the run files \
                 there; give another --out or move it",
                dir.display()
            );
        }
    }
    Ok(dir)
}
