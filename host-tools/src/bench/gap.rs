//! `thermcomp bench gap`: the blind benchmark of the sim-to-real gap
//! diagnosis (docs/gap-benchmark.md).
//!
//! Each case ([`super::cases`]) writes a real and a sim run, runs
//! [`crate::diagnose::diagnose_files`] on them without telling it the cause,
//! and keeps the verdict, the second effect and the held-out shrinks. The
//! summary is the confusion matrix (true cause x verdict), the accuracy,
//! the false-alarm rate (a `none` case given an effect) and the held-out
//! shrink of the correctly identified cases.

use super::cases::{self, Case, GapConfig, ProfileSpec, LABELS};
use super::report;
use crate::diagnose::candidates::round;
use crate::twin::machine::Machine;
use anyhow::{bail, Context, Result};
use clap::Args;
use rayon::prelude::*;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Profiles of the full benchmark: the stepwise test with its final stop
/// (a hold-out regime the fit part never saw), the ISO 230-3-like
/// spectrum, and a half-length spectrum (a 24 h day fitted on 12 h).
pub const DEFAULT_PROFILES: &str = "steps:48,spectrum:48,spectrum:24";
/// Effect magnitudes of the full benchmark, multiples of the machine file's.
pub const DEFAULT_MAGNITUDES: &str = "0.5,1,2";

/// Arguments of `thermcomp bench gap`.
#[derive(Args, Debug)]
pub struct GapArgs {
    /// Seeds (independent cases) per combination of cause, profile,
    /// magnitude and logging.
    #[arg(long, default_value_t = 3)]
    pub seeds: usize,
    /// One seed per combination (a quick look; same as --seeds 1).
    #[arg(long)]
    pub quick: bool,
    /// Keep only about N cases, the same number per cause, spread evenly.
    #[arg(long)]
    pub cases: Option<usize>,
    /// Base seed; each case's seed is derived from it and the case index.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Causes, comma-separated (ambient, coolant, cutting, motor_loss,
    /// sensor_lag, none).
    #[arg(
        long,
        default_value = "ambient,coolant,cutting,motor_loss,sensor_lag,none"
    )]
    pub effects: String,
    /// Profiles as NAME:HOURS, comma-separated (steps, spectrum, cooldown).
    #[arg(long, default_value = DEFAULT_PROFILES)]
    pub profiles: String,
    /// Effect magnitudes, multiples of the machine file's effect parameters.
    #[arg(long, default_value = DEFAULT_MAGNITUDES)]
    pub magnitudes: String,
    /// Half-width of the uniform mismatch of eight twin parameters in the
    /// real machine, %.
    #[arg(long, default_value_t = 4.0)]
    pub mismatch_pct: f64,
    /// Write cases.csv, confusion.md, summary.json and confusion.svg here.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Keep each case's real.csv and sim.csv (under OUT/runs).
    #[arg(long, requires = "out")]
    pub keep_runs: bool,
    /// Print one JSON object (every case and the summary).
    #[arg(long)]
    pub json: bool,
}

/// What the diagnosis said about one case.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// The case.
    pub case: Case,
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
    /// The diagnosis's looks (channel, candidates' figures; JSON `looks`).
    pub looks: Value,
    /// Wall time of the case (both runs and the diagnosis), s.
    pub elapsed_s: f64,
}

impl Outcome {
    /// Whether the verdict names the true cause.
    pub fn correct(&self) -> bool {
        self.verdict == self.case.effect
    }

    /// The case and its outcome as one JSON object.
    pub fn to_json(&self) -> Value {
        let c = &self.case;
        json!({
            "id": c.id, "effect": c.effect, "profile": c.profile.label(), "seed": c.seed,
            "magnitude": c.magnitude, "logged": c.logged, "verdict": self.verdict,
            "second": self.second, "main_channel": self.main_channel,
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

/// Figure `key` of the candidate `name` in a diagnosis.
fn figure_of(v: &Value, name: &str, key: &str) -> Option<f64> {
    v["effects"]
        .as_array()?
        .iter()
        .find(|e| e["name"] == name)?[key]
        .as_f64()
}

/// Held-out shrink of the candidate `name` in a diagnosis, %.
fn shrink_of(v: &Value, name: &str) -> Option<f64> {
    figure_of(v, name, "shrink_pct")
}

/// Held-out rms left by the candidate `name`.
fn after_of(v: &Value, name: &str) -> Option<f64> {
    figure_of(v, name, "rms_after")
}

/// Reads the figures the benchmark keeps out of a diagnosis JSON.
fn outcome_of(case: Case, v: &Value, elapsed_s: f64) -> Outcome {
    let verdict = v["verdict"].as_str().unwrap_or("none").to_string();
    let best = v["effects"]
        .as_array()
        .and_then(|a| a.iter().find(|e| e["name"] != "none"))
        .and_then(|e| e["name"].as_str())
        .unwrap_or("none")
        .to_string();
    let none_after = after_of(v, "none").unwrap_or(f64::NAN);
    let best_after = after_of(v, &best).unwrap_or(f64::NAN);
    let dep = &v["deployment"];
    Outcome {
        verdict_shrink_pct: shrink_of(v, &verdict).unwrap_or(f64::NAN),
        true_shrink_pct: (case.effect != "none")
            .then(|| shrink_of(v, &case.effect))
            .flatten(),
        true_confidence: (case.effect != "none")
            .then(|| figure_of(v, &case.effect, "confidence"))
            .flatten(),
        looks: v["looks"].clone(),
        best_ratio_to_none: best_after / none_after,
        best,
        second: v["second"]["name"].as_str().map(str::to_string),
        main_channel: v["main_channel"].as_str().unwrap_or("?").to_string(),
        deploy_sim_um: dep["trained_on_sim"]["rmse_um"].as_f64(),
        deploy_sim_effect_um: dep["trained_on_sim_plus_effect"]["rmse_um"].as_f64(),
        verdict,
        case,
        elapsed_s,
    }
}

/// Generates and diagnoses one case in `work/case-ID`; the run files are
/// removed afterwards unless `keep`.
pub fn run_case(case: Case, nominal: &Machine, work: &Path, keep: bool) -> Result<Outcome> {
    let started = Instant::now();
    let dir = work.join(format!("case-{:04}", case.id));
    let (sim, real) = cases::write_case(&case, nominal, &dir)
        .with_context(|| format!("case {} ({})", case.id, case.effect))?;
    let v = crate::diagnose::diagnose_files(&sim, &real, None, None)
        .with_context(|| format!("case {}: diagnose", case.id))?;
    if !keep {
        // Best effort: a leftover temporary file is not worth failing for.
        let _ = std::fs::remove_dir_all(&dir);
    }
    Ok(outcome_of(case, &v, started.elapsed().as_secs_f64()))
}

/// Runs every case in parallel (rayon) with a progress bar on stderr;
/// outcomes in case order.
pub fn run_all(all: Vec<Case>, work: &Path, keep: bool) -> Result<Vec<Outcome>> {
    let nominal = Machine::default_machine();
    let pb = crate::fit::arx::progress(all.len(), "bench gap");
    let out: Result<Vec<Outcome>> = all
        .into_par_iter()
        .map(|c| {
            let o = run_case(c, &nominal, work, keep);
            pb.inc(1);
            o
        })
        .collect();
    pb.finish_and_clear();
    out
}

/// The summary of a benchmark.
#[derive(Debug, Clone)]
pub struct Summary {
    /// `confusion[i][j]`: cases of true cause `LABELS[i]` with verdict `LABELS[j]`.
    pub confusion: [[usize; 6]; 6],
    /// Share of all cases whose verdict is the true cause, %.
    pub accuracy_pct: f64,
    /// Share of the effect cases (not `none`) identified, %.
    pub effect_accuracy_pct: f64,
    /// `none` cases given an effect, and all `none` cases.
    pub false_alarms: (usize, usize),
    /// Effect cases given `none`.
    pub misses: usize,
    /// Effect cases given another effect.
    pub wrong_effect: usize,
    /// Cases where a second effect was claimed (every case has one cause).
    pub spurious_seconds: usize,
    /// Median held-out shrink of the correctly identified effect cases, %.
    pub median_shrink_correct_pct: f64,
    /// Per cause: (n correct, min, median, max shrink of the correct ones).
    pub shrink_by_effect: Vec<(String, usize, f64, f64, f64)>,
}

impl Summary {
    /// False alarms over `none` cases, %.
    pub fn false_alarm_rate_pct(&self) -> f64 {
        pct(self.false_alarms.0, self.false_alarms.1)
    }
}

fn pct(a: usize, b: usize) -> f64 {
    if b == 0 {
        f64::NAN
    } else {
        100.0 * a as f64 / b as f64
    }
}

/// Median of `x` (NaN when empty).
pub fn median(x: &[f64]) -> f64 {
    let mut v: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn label_index(l: &str) -> usize {
    LABELS
        .iter()
        .position(|x| *x == l)
        .unwrap_or(LABELS.len() - 1)
}

/// Confusion matrix, rates and shrink distributions of `outs`.
pub fn summarise(outs: &[Outcome]) -> Summary {
    let mut confusion = [[0usize; 6]; 6];
    for o in outs {
        confusion[label_index(&o.case.effect)][label_index(&o.verdict)] += 1;
    }
    let effect_cases: Vec<&Outcome> = outs.iter().filter(|o| o.case.effect != "none").collect();
    let none_cases = outs.len() - effect_cases.len();
    let correct = outs.iter().filter(|o| o.correct()).count();
    let effect_correct: Vec<&Outcome> = effect_cases
        .iter()
        .copied()
        .filter(|o| o.correct())
        .collect();
    let shrinks: Vec<f64> = effect_correct
        .iter()
        .map(|o| o.verdict_shrink_pct)
        .collect();
    let shrink_by_effect = LABELS[..5]
        .iter()
        .map(|l| {
            let s: Vec<f64> = effect_correct
                .iter()
                .filter(|o| o.case.effect == *l)
                .map(|o| o.verdict_shrink_pct)
                .collect();
            let lo = s.iter().copied().fold(f64::NAN, f64::min);
            let hi = s.iter().copied().fold(f64::NAN, f64::max);
            (l.to_string(), s.len(), lo, median(&s), hi)
        })
        .collect();
    Summary {
        confusion,
        accuracy_pct: pct(correct, outs.len()),
        effect_accuracy_pct: pct(effect_correct.len(), effect_cases.len()),
        false_alarms: (
            outs.iter()
                .filter(|o| o.case.effect == "none" && o.verdict != "none")
                .count(),
            none_cases,
        ),
        misses: effect_cases.iter().filter(|o| o.verdict == "none").count(),
        wrong_effect: effect_cases
            .iter()
            .filter(|o| o.verdict != "none" && !o.correct())
            .count(),
        spurious_seconds: outs.iter().filter(|o| o.second.is_some()).count(),
        median_shrink_correct_pct: median(&shrinks),
        shrink_by_effect,
    }
}

/// The summary as JSON (confusion rows keyed by true cause).
pub fn summary_json(s: &Summary) -> Value {
    let confusion: serde_json::Map<String, Value> = LABELS
        .iter()
        .enumerate()
        .map(|(i, l)| {
            let row: serde_json::Map<String, Value> = LABELS
                .iter()
                .enumerate()
                .map(|(j, v)| (v.to_string(), json!(s.confusion[i][j])))
                .collect();
            (l.to_string(), Value::Object(row))
        })
        .collect();
    let by_effect: serde_json::Map<String, Value> = s
        .shrink_by_effect
        .iter()
        .map(|(l, n, lo, med, hi)| {
            (
                l.clone(),
                json!({"n_correct": n, "min_pct": fin(*lo), "median_pct": fin(*med), "max_pct": fin(*hi)}),
            )
        })
        .collect();
    json!({
        "labels": LABELS,
        "confusion": confusion,
        "accuracy_pct": fin(s.accuracy_pct),
        "effect_accuracy_pct": fin(s.effect_accuracy_pct),
        "false_alarms": s.false_alarms.0,
        "none_cases": s.false_alarms.1,
        "false_alarm_rate_pct": fin(s.false_alarm_rate_pct()),
        "misses": s.misses,
        "wrong_effect": s.wrong_effect,
        "spurious_seconds": s.spurious_seconds,
        "median_shrink_correct_pct": fin(s.median_shrink_correct_pct),
        "shrink_correct_by_effect": by_effect,
    })
}

/// A finite number rounded, or null (JSON has no NaN).
fn fin(v: f64) -> Value {
    if v.is_finite() {
        json!(round(v))
    } else {
        Value::Null
    }
}

fn parse_list<T>(flag: &str, s: &str, f: impl Fn(&str) -> Result<T>) -> Result<Vec<T>> {
    let v: Vec<T> = s
        .split(',')
        .map(str::trim)
        .filter(|w| !w.is_empty())
        .map(f)
        .collect::<Result<_>>()?;
    if v.is_empty() {
        bail!("{flag} is empty");
    }
    Ok(v)
}

/// The benchmark's configuration from the command line.
pub fn config(a: &GapArgs) -> Result<GapConfig> {
    let seeds = if a.quick { 1 } else { a.seeds };
    if !(1..=100).contains(&seeds) {
        bail!("--seeds must be in 1..=100 (got {seeds})");
    }
    Ok(GapConfig {
        effects: parse_list("--effects", &a.effects, |w| Ok(w.to_string()))?,
        profiles: parse_list("--profiles", &a.profiles, ProfileSpec::parse)?,
        magnitudes: parse_list("--magnitudes", &a.magnitudes, |w| {
            w.parse::<f64>()
                .map_err(|_| anyhow::anyhow!("--magnitudes: \"{w}\" is not a number"))
        })?,
        seeds,
        mismatch_pct: a.mismatch_pct,
        seed: a.seed,
    })
}

/// A fresh scratch folder for the run files: OUT/runs, or one under the
/// system's temporary directory named by the process id and time.
fn work_dir(a: &GapArgs) -> Result<PathBuf> {
    let dir = match &a.out {
        Some(out) => out.join("runs"),
        None => {
            let nanos = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.subsec_nanos());
            std::env::temp_dir().join(format!("thermcomp-bench-{}-{nanos}", std::process::id()))
        }
    };
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    Ok(dir)
}

/// Runs `thermcomp bench gap`.
pub fn run(a: &GapArgs) -> Result<()> {
    let cfg = config(a)?;
    let mut all = cases::cases(&cfg)?;
    if let Some(n) = a.cases {
        all = cases::strided(all, n);
    }
    let work = work_dir(a)?;
    let started = Instant::now();
    let n_cases = all.len();
    let outs = run_all(all, &work, a.keep_runs);
    if !a.keep_runs {
        let _ = std::fs::remove_dir_all(&work);
    }
    let outs = outs?;
    let wall_s = started.elapsed().as_secs_f64();
    let s = summarise(&outs);
    let mut summary = summary_json(&s);
    summary["cases"] = json!(n_cases);
    summary["wall_s"] = json!(round(wall_s));
    summary["threads"] = json!(rayon::current_num_threads());
    summary["config"] = json!({
        "effects": cfg.effects, "profiles": cfg.profiles.iter().map(ProfileSpec::label).collect::<Vec<_>>(),
        "magnitudes": cfg.magnitudes, "seeds": cfg.seeds, "mismatch_pct": cfg.mismatch_pct,
        "seed": cfg.seed, "dt_s": cases::DT_S, "cases_cap": a.cases,
    });
    if let Some(out) = &a.out {
        report::write(out, &outs, &s, &summary)?;
    }
    if a.json {
        let mut v = summary;
        v["per_case"] = Value::Array(outs.iter().map(Outcome::to_json).collect());
        crate::fsio::print_line(&v.to_string())?;
    } else {
        crate::fsio::print(&report::text(&outs, &s, wall_s))?;
    }
    Ok(())
}
