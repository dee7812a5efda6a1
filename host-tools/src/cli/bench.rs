//! `thermcomp bench`: the flags, the jobs ([`crate::bench::gap::bench_twin`],
//! [`crate::bench::zoo::bench::bench_zoo`]) and their outcomes printed as
//! text tables or one JSON object, with the report files of `--out`.

use crate::bench::cases::{GapConfig, ProfileSpec};
use crate::bench::gap::{
    bench_twin, Scratch, DEFAULT_MAGNITUDES, DEFAULT_PROFILES, DEFAULT_SEEDS, TWIN_MISMATCH_PCT,
    ZOO_MISMATCH_PCT,
};
use crate::bench::outcome::Outcome;
use crate::bench::zoo::{self, ZooParams};
use crate::bench::{report, zoo::cases::ZooPlan};
use crate::data::fsio;
use anyhow::{bail, Result};
use clap::{Args, Subcommand};
use serde_json::Value;

/// The benchmarks.
#[derive(Subcommand, Debug)]
pub enum BenchCommand {
    /// Blind benchmark of the sim-to-real gap diagnosis: real machines with
    /// one known effect (or none) and a mismatch, diagnosed without being
    /// told the effect; confusion matrix, false alarms and held-out shrink
    /// (docs/gap-benchmark.md). Runs the plant zoo (plants the diagnosis
    /// was not built around; one held out) unless --twin.
    Gap(GapArgs),
}

/// Runs `thermcomp bench ...`.
pub fn run(c: &BenchCommand) -> Result<()> {
    match c {
        BenchCommand::Gap(a) => run_gap(a),
    }
}

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
    /// magnitude and logging [default: 3].
    #[arg(long, requires = "twin")]
    pub seeds: Option<usize>,
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
    /// Twin: profiles as NAME:HOURS, comma-separated (steps, spectrum,
    /// cooldown) [default: steps:48,spectrum:48,spectrum:24].
    #[arg(long, requires = "twin")]
    pub profiles: Option<String>,
    /// Twin: effect magnitudes, multiples of the machine file's effect
    /// parameters [default: 0.5,1,2].
    #[arg(long, requires = "twin")]
    pub magnitudes: Option<String>,
    /// Half-width of the uniform parameter mismatch of the real machine, %
    /// (default 10 for the zoo, 4 for the twin).
    #[arg(long)]
    pub mismatch_pct: Option<f64>,
    /// Write the case table, confusion matrices, summary.json and SVGs here.
    #[arg(long)]
    pub out: Option<std::path::PathBuf>,
    /// Keep each case's real.csv and sim.csv under OUT/runs (which must be
    /// absent or an empty folder).
    #[arg(long, requires = "out")]
    pub keep_runs: bool,
    /// Print one JSON object (every case and the summary).
    #[arg(long)]
    pub json: bool,
}

/// Splits a comma-separated list, refusing an empty one or a word given
/// twice (`--effects ambient,ambient` ran each ambient case twice).
pub fn parse_list<T>(flag: &str, s: &str, f: impl Fn(&str) -> Result<T>) -> Result<Vec<T>> {
    let words: Vec<&str> = s
        .split(',')
        .map(str::trim)
        .filter(|w| !w.is_empty())
        .collect();
    if let Some((i, w)) = words
        .iter()
        .enumerate()
        .find(|(i, w)| words[..*i].contains(w))
    {
        bail!("{flag}: {w} is listed twice (item {})", i + 1);
    }
    let v: Vec<T> = words.into_iter().map(f).collect::<Result<_>>()?;
    if v.is_empty() {
        bail!("{flag} is empty");
    }
    Ok(v)
}

/// The twin benchmark's configuration from the command line.
pub fn config(a: &GapArgs) -> Result<GapConfig> {
    let seeds = if a.quick {
        1
    } else {
        a.seeds.unwrap_or(DEFAULT_SEEDS)
    };
    if !(1..=100).contains(&seeds) {
        bail!("--seeds must be in 1..=100 (got {seeds})");
    }
    Ok(GapConfig {
        effects: parse_list("--effects", &a.effects, |w| Ok(w.to_string()))?,
        profiles: parse_list(
            "--profiles",
            a.profiles.as_deref().unwrap_or(DEFAULT_PROFILES),
            ProfileSpec::parse,
        )?,
        magnitudes: parse_list(
            "--magnitudes",
            a.magnitudes.as_deref().unwrap_or(DEFAULT_MAGNITUDES),
            |w| {
                w.parse::<f64>()
                    .map_err(|_| anyhow::anyhow!("--magnitudes: \"{w}\" is not a number"))
            },
        )?,
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

/// Where the cases are written.
fn scratch(a: &GapArgs) -> Scratch {
    Scratch {
        out: a.out.clone(),
        keep_runs: a.keep_runs,
    }
}

/// Runs `thermcomp bench gap`: the zoo, or the twin cases with `--twin`.
fn run_gap(a: &GapArgs) -> Result<()> {
    if let (true, Some(out)) = (a.keep_runs, &a.out) {
        crate::bench::outcome::free_runs_dir(out)?;
    }
    if a.twin {
        run_twin(a)
    } else {
        refuse_twin_flags(a)?;
        run_zoo(a, &zoo_params(a)?.check()?)
    }
}

/// Refuses the twin's flags on a zoo run. clap's `requires = "twin"` lets
/// them through when a zoo flag (which conflicts with `--twin`) is given:
/// `--cases 2 --plants a` ran every zoo case without a word.
fn refuse_twin_flags(a: &GapArgs) -> Result<()> {
    let given = [
        ("--seeds", a.seeds.is_some()),
        ("--cases", a.cases.is_some()),
        ("--profiles", a.profiles.is_some()),
        ("--magnitudes", a.magnitudes.is_some()),
    ];
    match given.iter().find(|(_, g)| *g) {
        Some((flag, _)) => bail!("{flag} is for the twin cases: add --twin, or leave it out"),
        None => Ok(()),
    }
}

/// `thermcomp bench gap` on the zoo.
fn run_zoo(a: &GapArgs, plan: &ZooPlan) -> Result<()> {
    let which = if plan.scored_heldout {
        " (the held-out plant: final score)".to_string()
    } else {
        format!(" (plant {} held out)", plan.heldout)
    };
    eprintln!(
        "bench gap (zoo): {} cases on plant(s) {}{which}",
        plan.cases.len(),
        plan.plants.join(", "),
    );
    let (summary, outs) = zoo::bench::bench_zoo(plan, &scratch(a))?;
    if let Some(out) = &a.out {
        zoo::report::write(out, &outs, &summary)?;
    }
    if a.json {
        fsio::print_line(&serde_json::to_string(&summary)?)
    } else {
        fsio::print(&zoo::report::text(&summary))
    }
}

/// `thermcomp bench gap --twin`.
fn run_twin(a: &GapArgs) -> Result<()> {
    if a.cases == Some(0) {
        bail!("--cases must be at least 1 (0 ran every case)");
    }
    let mut run = bench_twin(&config(a)?, a.cases, &scratch(a))?;
    if let Some(out) = &a.out {
        let summary = serde_json::to_value(&run.report)?;
        report::write(out, &run.outcomes, &run.summary, &summary)?;
    }
    if a.json {
        run.report.per_case = Some(
            run.outcomes
                .iter()
                .map(Outcome::to_json)
                .collect::<Vec<Value>>(),
        );
        fsio::print_line(&serde_json::to_value(&run.report)?.to_string())
    } else {
        let text = report::text(&run.outcomes, &run.summary, run.report.wall_s);
        fsio::print(&text)
    }
}
