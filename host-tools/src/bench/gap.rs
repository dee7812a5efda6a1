//! `thermcomp bench gap`: the blind benchmark of the sim-to-real gap
//! diagnosis (docs/gap-benchmark.md).
//!
//! By default it runs the **plant zoo** ([`super::zoo`]): real machines of
//! structures the diagnosis was not built around, each diagnosed against its
//! own nominal model, one plant held out of development. With `--twin` it
//! runs the twin-derived cases ([`super::cases`]): the twin with one effect
//! against the nominal twin. Each case writes a real and a sim run, runs
//! [`crate::diagnose::diagnose_files`] on them without telling it the cause,
//! and keeps the verdict, the second effect and the held-out shrinks
//! ([`super::outcome`]); the summary ([`super::summary`]) is the confusion
//! matrix, the accuracy, the false-alarm rate and the held-out shrink of the
//! correctly identified cases.
//!
//! The jobs: [`bench_twin`] here, [`super::zoo::bench::bench_zoo`] for the
//! zoo; `cli::bench` reads the flags and prints.

use super::cases::{self, Case, GapConfig, ProfileSpec};
use super::outcome::{diagnose_case, kept_runs_dir, run_parallel};
use super::summary::SummaryReport;
use crate::diagnose::candidates::round;
use crate::twin::machine::Machine;
use anyhow::{Context, Result};
use serde::Serialize;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::time::Instant;

pub use super::outcome::Outcome;
pub use super::summary::{median, summarise, Summary};

/// Profiles of the full twin benchmark: the stepwise test with its final
/// stop (a hold-out regime the fit part never saw), the ISO 230-3-like
/// spectrum, and a half-length spectrum (a 24 h day fitted on 12 h).
pub const DEFAULT_PROFILES: &str = "steps:48,spectrum:48,spectrum:24";
/// Effect magnitudes of the full twin benchmark, multiples of the machine file's.
pub const DEFAULT_MAGNITUDES: &str = "0.5,1,2";
/// Default seeds per combination of the twin cases (`--seeds`).
pub const DEFAULT_SEEDS: usize = 3;
/// Mismatch of the twin cases, %.
pub const TWIN_MISMATCH_PCT: f64 = 4.0;
/// Mismatch of the zoo cases, %.
pub const ZOO_MISMATCH_PCT: f64 = 10.0;

/// Generates and diagnoses one twin case in `work/case-ID`; the run files
/// are removed afterwards unless `keep`.
pub fn run_case(case: Case, nominal: &Machine, work: &Path, keep: bool) -> Result<Outcome<Case>> {
    let dir = work.join(format!("case-{:04}", case.id));
    let truth = case.effect.clone();
    diagnose_case(case, &truth, &dir, keep, |c, d| {
        cases::write_case(c, nominal, d)
            .map_err(|e| e.context(format!("case {} ({})", c.id, c.effect)))
    })
}

/// Runs every twin case in parallel (rayon) with a progress bar on
/// stderr; outcomes in case order.
pub fn run_all(all: Vec<Case>, work: &Path, keep: bool) -> Result<Vec<Outcome<Case>>> {
    let nominal = Machine::default_machine();
    run_parallel(all, "bench gap", |c| run_case(c, &nominal, work, keep))
}

/// Where a benchmark's cases are written while they are diagnosed.
#[derive(Debug, Clone, Default)]
pub struct Scratch {
    /// The report directory: with `keep_runs` the runs go under
    /// `OUT/runs` ([`kept_runs_dir`]).
    pub out: Option<PathBuf>,
    /// Keep each case's run files in `OUT/runs` (else they are written to
    /// a temporary folder of this run's own, removed when it ends).
    pub keep_runs: bool,
}

impl Scratch {
    /// Runs `job` in the scratch folder: `OUT/runs` when the runs are kept,
    /// else a fresh temporary folder removed afterwards. Nothing the run
    /// did not create is removed (`OUT/runs` used to be, user files and
    /// all).
    pub fn run<T>(&self, job: impl FnOnce(&Path) -> Result<T>) -> Result<T> {
        match (&self.out, self.keep_runs) {
            (Some(out), true) => job(&kept_runs_dir(out)?),
            _ => {
                let tmp = tempfile::Builder::new()
                    .prefix("thermcomp-bench-")
                    .tempdir()
                    .context("cannot create a temporary folder for the run files")?;
                job(tmp.path())
            }
        }
    }
}

/// The settings of a twin run, as reported.
#[derive(Debug, Clone, Serialize)]
pub struct TwinConfigReport {
    /// Causes.
    pub effects: Vec<String>,
    /// Profiles as `NAME:HOURS`.
    pub profiles: Vec<String>,
    /// Effect magnitudes.
    pub magnitudes: Vec<f64>,
    /// Seeds per combination.
    pub seeds: usize,
    /// Mismatch half-width, %.
    pub mismatch_pct: f64,
    /// Base seed.
    pub seed: u64,
    /// Sample time, s.
    pub dt_s: f64,
    /// `--cases`: about this many cases kept.
    pub cases_cap: Option<usize>,
}

/// What `bench gap --twin` reports (`summary.json`; with the cases,
/// `--json`).
#[derive(Debug, Clone, Serialize)]
pub struct TwinReport {
    /// The confusion matrix, rates and shrinks.
    #[serde(flatten)]
    pub summary: SummaryReport,
    /// Cases.
    pub cases: usize,
    /// Wall time, s.
    pub wall_s: f64,
    /// Worker threads.
    pub threads: usize,
    /// Settings.
    pub config: TwinConfigReport,
    /// Every case and its diagnosis (left out of `summary.json`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub per_case: Option<Vec<Value>>,
}

/// A twin run: the outcomes and their summary.
pub struct TwinRun {
    /// Every case's outcome, in case order.
    pub outcomes: Vec<Outcome<Case>>,
    /// The summary (tables, SVG).
    pub summary: Summary,
    /// The report.
    pub report: TwinReport,
}

/// The twin benchmark: the cases of `cfg` (about `cap` of them when
/// given) written and diagnosed blind in `scratch`.
pub fn bench_twin(cfg: &GapConfig, cap: Option<usize>, scratch: &Scratch) -> Result<TwinRun> {
    let mut all = cases::cases(cfg)?;
    if let Some(n) = cap {
        all = cases::strided(all, n);
    }
    let started = Instant::now();
    let n_cases = all.len();
    let outcomes = scratch.run(|work| run_all(all, work, scratch.keep_runs))?;
    let summary = summarise(&outcomes);
    let report = TwinReport {
        summary: SummaryReport::of(&summary),
        cases: n_cases,
        wall_s: round(started.elapsed().as_secs_f64()),
        threads: rayon::current_num_threads(),
        config: TwinConfigReport {
            effects: cfg.effects.clone(),
            profiles: cfg.profiles.iter().map(ProfileSpec::label).collect(),
            magnitudes: cfg.magnitudes.clone(),
            seeds: cfg.seeds,
            mismatch_pct: cfg.mismatch_pct,
            seed: cfg.seed,
            dt_s: cases::DT_S,
            cases_cap: cap,
        },
        per_case: None,
    };
    Ok(TwinRun {
        outcomes,
        summary,
        report,
    })
}
