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

use super::cases::{self, Case, GapConfig, ProfileSpec};
use super::outcome::{self as oc, diagnose_case, run_parallel};
use super::report;
use super::summary::summary_json;
use super::zoo::{self, ZooParams};
use crate::diagnose::candidates::round;
use crate::twin::machine::Machine;
use anyhow::{bail, Result};
use clap::Args;
use serde_json::{json, Value};
use std::path::Path;
use std::time::Instant;

pub use super::outcome::Outcome;
pub use super::summary::{median, summarise, Summary};

/// Profiles of the full twin benchmark: the stepwise test with its final
/// stop (a hold-out regime the fit part never saw), the ISO 230-3-like
/// spectrum, and a half-length spectrum (a 24 h day fitted on 12 h).
pub const DEFAULT_PROFILES: &str = "steps:48,spectrum:48,spectrum:24";
/// Effect magnitudes of the full twin benchmark, multiples of the machine file's.
pub const DEFAULT_MAGNITUDES: &str = "0.5,1,2";
/// Mismatch of the twin cases, %.
pub const TWIN_MISMATCH_PCT: f64 = 4.0;
/// Mismatch of the zoo cases, %.
pub const ZOO_MISMATCH_PCT: f64 = 10.0;

/// Arguments of `thermcomp bench gap`.
#[derive(Args, Debug)]
pub struct GapArgs {
    /// Run the plant zoo (the default; docs/gap-benchmark.md, "Plant zoo").
    #[arg(long, conflicts_with = "twin")]
    pub zoo: bool,
    /// Run the twin-derived cases instead of the zoo.
    #[arg(long)]
    pub twin: bool,
    /// Zoo: plants to run, comma-separated (default: every plant but the
    /// held-out one).
    #[arg(long, conflicts_with = "twin")]
    pub plants: Option<String>,
    /// Zoo: the plant kept out of development and tuning.
    #[arg(long, default_value = zoo::catalogue::DEFAULT_HELDOUT, conflicts_with = "twin")]
    pub heldout_plant: String,
    /// Zoo: run only the held-out plant (the final, one-time score).
    #[arg(long, conflicts_with_all = ["twin", "plants"])]
    pub score_heldout: bool,
    /// Zoo: cases per cause and plant.
    #[arg(long, default_value_t = 10, conflicts_with = "twin")]
    pub cases_per_label: usize,
    /// Zoo: length of each run, h.
    #[arg(long, default_value_t = 48.0, conflicts_with = "twin")]
    pub hours: f64,
    /// Twin: seeds (independent cases) per combination of cause, profile,
    /// magnitude and logging.
    #[arg(long, default_value_t = 3, requires = "twin")]
    pub seeds: usize,
    /// One seed per combination (twin) or one case per cause and plant (zoo).
    #[arg(long)]
    pub quick: bool,
    /// Twin: keep only about N cases, the same number per cause, spread evenly.
    #[arg(long, requires = "twin")]
    pub cases: Option<usize>,
    /// Base seed; each case's seed is derived from it and the case.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Causes, comma-separated (ambient, coolant, cutting, motor_loss,
    /// sensor_lag, none).
    #[arg(
        long,
        default_value = "ambient,coolant,cutting,motor_loss,sensor_lag,none"
    )]
    pub effects: String,
    /// Twin: profiles as NAME:HOURS, comma-separated (steps, spectrum, cooldown).
    #[arg(long, default_value = DEFAULT_PROFILES, requires = "twin")]
    pub profiles: String,
    /// Twin: effect magnitudes, multiples of the machine file's effect parameters.
    #[arg(long, default_value = DEFAULT_MAGNITUDES, requires = "twin")]
    pub magnitudes: String,
    /// Half-width of the uniform parameter mismatch of the real machine, %
    /// (default 10 for the zoo, 4 for the twin).
    #[arg(long)]
    pub mismatch_pct: Option<f64>,
    /// Write the case table, confusion matrices, summary.json and SVGs here.
    #[arg(long)]
    pub out: Option<std::path::PathBuf>,
    /// Keep each case's real.csv and sim.csv (under OUT/runs).
    #[arg(long, requires = "out")]
    pub keep_runs: bool,
    /// Print one JSON object (every case and the summary).
    #[arg(long)]
    pub json: bool,
}

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

/// Splits a comma-separated list, refusing an empty one.
pub fn parse_list<T>(flag: &str, s: &str, f: impl Fn(&str) -> Result<T>) -> Result<Vec<T>> {
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

/// The twin benchmark's configuration from the command line.
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
        mismatch_pct: a.mismatch_pct.unwrap_or(TWIN_MISMATCH_PCT),
        seed: a.seed,
    })
}

/// The zoo benchmark's settings from the command line (checked later by
/// [`ZooParams::check`]).
pub fn zoo_params(a: &GapArgs) -> Result<ZooParams> {
    let plants = match &a.plants {
        Some(p) => Some(parse_list("--plants", p, |w| Ok(w.to_string()))?),
        None => None,
    };
    Ok(ZooParams {
        plants,
        heldout: a.heldout_plant.trim().to_string(),
        score_heldout: a.score_heldout,
        labels: parse_list("--effects", &a.effects, |w| Ok(w.to_string()))?,
        cases_per_label: if a.quick { 1 } else { a.cases_per_label },
        seed: a.seed,
        mismatch_pct: a.mismatch_pct.unwrap_or(ZOO_MISMATCH_PCT),
        hours: a.hours,
    })
}

/// Runs `thermcomp bench gap`: the zoo, or the twin cases with `--twin`.
pub fn run(a: &GapArgs) -> Result<()> {
    if !a.twin {
        let opts = zoo::bench::RunOptions {
            out: a.out.clone(),
            keep_runs: a.keep_runs,
            json: a.json,
        };
        return zoo::bench::run(&zoo_params(a)?.check()?, &opts);
    }
    run_twin(a)
}

/// `thermcomp bench gap --twin`.
fn run_twin(a: &GapArgs) -> Result<()> {
    let cfg = config(a)?;
    let mut all = cases::cases(&cfg)?;
    if let Some(n) = a.cases {
        all = cases::strided(all, n);
    }
    let work = oc::scratch_dir(a.out.as_deref())?;
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
        crate::data::fsio::print_line(&v.to_string())?;
    } else {
        crate::data::fsio::print(&report::text(&outs, &s, wall_s))?;
    }
    Ok(())
}
