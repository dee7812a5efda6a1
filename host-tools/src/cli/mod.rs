//! The command line: the only part of the crate that knows about argv,
//! stdout and exit codes (CONTRACT.md section 1). Each subcommand turns its
//! clap arguments into a job's checked parameters, calls the job over
//! in-memory data, and prints the typed outcome as text or JSON.
//!
//! Every subcommand prints its results on stdout (one JSON object with
//! `--json`), progress and notes on stderr, and fails with a one-line error
//! and a non-zero exit status.

mod bench;
mod demo;
mod diagnose;
mod eval;
pub mod fit;
mod fivepoint;
mod hub;
pub mod pairs;
mod predict;
mod refit;
mod replay;
pub mod select;
pub mod simulate;
mod source;

use crate::data::fsio::{self, named};
use crate::data::{blobfile, spec};
use crate::show;

use clap::error::ErrorKind;
use clap::{Args, CommandFactory, FromArgMatches, Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;

/// Thermal-error compensation for CNC machine tools.
#[derive(Parser)]
#[command(name = "thermcomp", version, about, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// The whole job, end to end, on the built-in default machine: simulate
    /// calibration and validation runs, select sensors, fit and validate
    /// every model kind, export the best, replay it through the firmware,
    /// diagnose a sim-to-real gap (README, "Two commands").
    Demo(demo::DemoArgs),
    /// Benchmarks of the tool's methods on runs with known answers
    /// (`bench gap`: the blind benchmark of `diagnose` on the plant zoo).
    #[command(subcommand)]
    Bench(bench::BenchCommand),
    /// Build or inspect model blobs.
    #[command(subcommand)]
    Model(ModelCommand),
    /// Talk to the sensor hub over its serial link: upload a model, set the
    /// tool length, ping, watch telemetry (docs/wire-format.md).
    #[command(subcommand)]
    Hub(hub::HubCommand),
    /// Write a model's predictions for run files, row for row.
    Predict(predict::PredictArgs),
    /// Score a model against the measured columns of run files.
    ///
    /// Metrics per target (residual r = y - yhat): rmse_um; fit_pct =
    /// (1 - ||r|| / ||y - mean(y)||) * 100; r2 = 1 - SSE/SST; eta_pct (the
    /// seeds' "predictive ability") = (1 - ||r|| / ||y||) * 100; max_abs_um,
    /// mean_abs_um of |r|; dpk_um = |max r| + |min r|; reduction_pct =
    /// (1 - mean|r| / mean|y|) * 100.
    Eval(eval::EvalArgs),
    /// Train a model (mlr, pcr, arx, tf, gain, bp, gabp, arma) on calibration rows, score it on held-out rows, write the blob.
    Fit(Box<fit::FitArgs>),
    /// Test whether the temperature-to-displacement relation has changed on
    /// new runs and, if it has, update the model (seed 002's self-adaptive
    /// compensation; rule in docs/fit.md, "refit").
    Refit(refit::RefitArgs),
    /// Run the hub's own firmware pipeline over run files and write the CAN
    /// frames it would send (candump log).
    ///
    /// Temperatures become the codes a MAX31865 returns for a PT100, read back
    /// through the firmware's driver; the pipeline spike-filters, steps the
    /// model, holds/ramps on faults, slew-limits and clamps; frames per
    /// firmware/thermcomp.dbc. The sample period is the hub's (the model's
    /// dt_s, or 1 s for static models).
    Replay(replay::ReplayArgs),
    /// From five-point probes S1..S5: the spindle's elongation e_um and
    /// tilts theta_x_urad, theta_y_urad, and the tool-tip drift dx_um,
    /// dy_um, dz_um, beside the run's other columns (docs/fivepoint.md).
    ///
    /// Changes are taken from each probe's first reading; theta =
    /// atan((dS_near minus dS_far) / a); the tip drift is the exact geometry
    /// about the deflection centre l_defl above the nose, about
    /// (l_defl + tool) theta for X/Y and -E for Z (seeds 000/001).
    #[command(name = "fivepoint")]
    FivePoint(fivepoint::FivePointArgs),
    /// Rank and pick temperature sensors (grey: seed 000; wgrey: seed 002; maxtree: seed 003).
    ///
    /// grey: grey clustering, grey correlation, best adjusted R^2 of the
    /// typical variables' combinations. wgrey: weighted grey correlativity
    /// (Eq. 1), top-k per target and their intersection. maxtree:
    /// maximal-tree clustering, the level by R^2, F test and collinearity.
    /// Formulas and rules: docs/select.md.
    Select(select::SelectArgs),
    /// Run the thermal twin (a lumped model of a motorized spindle) and
    /// write a run file; effects from CONTRACT.md section 3 can be switched
    /// on (docs/twin.md).
    Simulate(simulate::SimulateArgs),
    /// Diagnose the sim-to-real gap: where the residual real - sim sits
    /// (regimes, frequency bands) and which unmodelled effect explains it,
    /// judged on a held-out part of the run (docs/diagnose.md).
    Diagnose(diagnose::DiagnoseArgs),
}

#[derive(Subcommand)]
enum ModelCommand {
    /// Build a blob from a TOML spec of hand-written coefficients (README: "Model specs").
    Build(BuildArgs),
    /// Print what a blob holds: kind, inputs, outputs, coefficients, version, CRC.
    Show(ShowArgs),
}

#[derive(Args)]
struct BuildArgs {
    /// The spec (TOML).
    #[arg(long)]
    spec: PathBuf,
    /// Where to write the blob.
    #[arg(long)]
    out: PathBuf,
    /// Print a JSON summary of the blob written.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct ShowArgs {
    /// The model blob.
    #[arg(long)]
    model: PathBuf,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Model(ModelCommand::Build(a)) => {
            fsio::check_distinct(&[named("--spec", &a.spec)], &[named("--out", &a.out)])?;
            let model = spec::load(&a.spec)?;
            let bytes = blobfile::write(&model, &a.out)?;
            if a.json {
                fsio::print_line(&show::describe_json(&model, &bytes).to_string())?;
            } else {
                eprintln!(
                    "wrote {} ({} bytes, {} model, {} inputs, {} outputs)",
                    a.out.display(),
                    bytes.len(),
                    model.kind().name(),
                    model.inputs().len(),
                    model.outputs().len()
                );
            }
            Ok(())
        }
        Command::Model(ModelCommand::Show(a)) => {
            let (model, bytes) = blobfile::read(&a.model)?;
            if a.json {
                fsio::print_line(&show::describe_json(&model, &bytes).to_string())?;
            } else {
                fsio::print(&show::describe_text(&a.model, &model, &bytes))?;
            }
            Ok(())
        }
        Command::Demo(a) => demo::run(&a),
        Command::FivePoint(a) => fivepoint::run(&a),
        Command::Bench(c) => bench::run(&c),
        Command::Hub(c) => hub::run(&c),
        Command::Predict(a) => predict::run(&a),
        Command::Eval(a) => eval::run(&a),
        Command::Fit(a) => fit::run(&a),
        Command::Refit(a) => refit::run(&a),
        Command::Select(a) => select::run(&a),
        Command::Replay(a) => replay::run(&a),
        Command::Simulate(a) => simulate::run(&a),
        Command::Diagnose(a) => diagnose::run(&a),
    }
}

/// Every option that takes a value also takes a negative number
/// (`--holdout-from-s -1`, `--ambient-c -5`), rather than clap reading it as
/// an unknown option; the subcommand then judges the value.
fn allow_negative_numbers(cmd: clap::Command) -> clap::Command {
    cmd.mut_args(|a| {
        if a.get_action().takes_values() {
            a.allow_negative_numbers(true)
        } else {
            a
        }
    })
    .mut_subcommands(allow_negative_numbers)
}

/// A usage error as one line, as every other error (CONTRACT.md section 1):
/// clap's message and tip, without the usage block; the last part names
/// the `--help` to read.
fn one_line(e: &clap::Error) -> String {
    let text = e.render().to_string();
    let mut line = String::new();
    for part in text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with("Usage:"))
        .map(|l| l.strip_prefix("error: ").unwrap_or(l))
    {
        if !line.is_empty() {
            // "...were not provided:" then the list: a space, not "; ".
            line.push_str(if line.ends_with(':') { " " } else { "; " });
        }
        line.push_str(part);
    }
    line
}

/// The command line, or exit: help and version print as clap prints them;
/// a usage error prints one line on stderr and exits with status 2.
fn parse_cli() -> Cli {
    let matches = allow_negative_numbers(Cli::command()).try_get_matches();
    match matches.and_then(|m| Cli::from_arg_matches(&m)) {
        Ok(cli) => cli,
        Err(e) => match e.kind() {
            ErrorKind::DisplayHelp
            | ErrorKind::DisplayVersion
            | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => e.exit(),
            _ => {
                eprintln!("error: {}", one_line(&e));
                std::process::exit(2)
            }
        },
    }
}

/// `thermcomp`'s entry point: parse argv, run, report.
pub fn main() -> ExitCode {
    match run(parse_cli()) {
        Ok(()) => ExitCode::SUCCESS,
        // The reader of stdout has what it wanted: a quiet success (fsio).
        Err(e) if e.downcast_ref::<fsio::StdoutClosed>().is_some() => ExitCode::SUCCESS,
        Err(e) => {
            // `{:#}` joins the context chain on one line.
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// A job's report as the JSON object its subcommand prints: the report's
/// keys and `out`, the path the command wrote (a job over data in memory
/// does not know it).
fn with_out(
    report: &impl serde::Serialize,
    out: &std::path::Path,
) -> anyhow::Result<serde_json::Value> {
    let mut v = serde_json::to_value(report)?;
    if let serde_json::Value::Object(m) = &mut v {
        m.insert("out".into(), out.display().to_string().into());
    }
    Ok(v)
}

/// The page `--report DIR` writes, `DIR/index.html`, for the paths check;
/// a `DIR` that exists and is not a folder is refused before any work.
fn report_page(dir: Option<&std::path::Path>) -> anyhow::Result<Option<std::path::PathBuf>> {
    let Some(dir) = dir else {
        return Ok(None);
    };
    if dir.exists() && !dir.is_dir() {
        anyhow::bail!("--report {}: exists and is not a folder", dir.display());
    }
    Ok(Some(dir.join("index.html")))
}

/// Writes the page `--report DIR` asked for, `model` on `runs` under the
/// command's `text` and its `--json` object, and says where on stderr.
fn publish_page(
    dir: &std::path::Path,
    model: &model_core::ValidModel,
    runs: &[crate::plot::model::PageRun],
    map: &crate::runner::ColumnMap,
    text: &crate::plot::model::PageText,
    json: &serde_json::Value,
) -> anyhow::Result<()> {
    let html = crate::plot::model::page_html(model, runs, map, text, json)?;
    let path = crate::plot::write_page(dir, &html)?;
    eprintln!("wrote {}", path.display());
    Ok(())
}
