//! `thermcomp diagnose`: the flags, the files checked, the job
//! ([`crate::diagnose::diagnose_with_machine`]) and its object printed as a
//! short table or as JSON.

use crate::data::fsio;
use crate::diagnose::{diagnose_with_machine, physical};
use anyhow::Result;
use clap::Args;
use serde_json::Value;
use std::path::PathBuf;

/// Arguments of `thermcomp diagnose`.
#[derive(Args, Debug)]
pub struct DiagnoseArgs {
    /// The simulated run (the twin driven by the real run's inputs).
    #[arg(long)]
    pub sim: PathBuf,
    /// The measured run.
    #[arg(long)]
    pub real: PathBuf,
    /// Candidates are fitted before this time and scored from it on, s
    /// (default: the middle of the real run).
    #[arg(long)]
    pub holdout_from_s: Option<f64>,
    /// Write an HTML report with plots (DIR/index.html).
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Print one JSON object (CONTRACT.md section 1) instead of a table.
    #[arg(long)]
    pub json: bool,
    /// The twin's machine file (the one that made --sim): recalibrate it on
    /// the fit part, add each effect to it and re-simulate (JSON `physical`;
    /// docs/diagnose.md, "With the machine file").
    #[arg(long)]
    pub machine: Option<PathBuf>,
}

/// Runs `thermcomp diagnose`.
pub fn run(a: &DiagnoseArgs) -> Result<()> {
    let started = std::time::Instant::now();
    let page = a.report.as_ref().map(|d| d.join("index.html"));
    let writes: Vec<_> = page.iter().map(|p| fsio::named("--report", p)).collect();
    let mut reads = vec![fsio::named("--sim", &a.sim), fsio::named("--real", &a.real)];
    reads.extend(a.machine.as_deref().map(|m| fsio::named("--machine", m)));
    fsio::check_distinct(&reads, &writes)?;
    let v = diagnose_with_machine(
        &a.sim,
        &a.real,
        a.holdout_from_s,
        a.report.as_deref(),
        a.machine.as_deref(),
    )?;
    if a.json {
        fsio::print_line(&v.to_string())?;
    } else {
        fsio::print(&(text_table(&v) + &physical::text(&v["physical"])))?;
    }
    eprintln!("diagnose: {:.2} s", started.elapsed().as_secs_f64());
    Ok(())
}

/// The short text table printed without `--json`.
fn text_table(v: &Value) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let main = v["main_channel"].as_str().unwrap_or("?");
    let _ = writeln!(
        s,
        "main channel {main}: gap rms {} max {} ; hold-out from t = {} s",
        v["gap"][main]["rms"], v["gap"][main]["max_abs"], v["holdout_from_t_s"]
    );
    let _ = writeln!(s, "\nwhere (share of residual energy):");
    for w in v["where"].as_array().into_iter().flatten().take(6) {
        let _ = writeln!(
            s,
            "  {:>6} {:>8} .. {:>8} s  {:<28} {:>6.1} %",
            w["channel"].as_str().unwrap_or(""),
            w["from_t_s"],
            w["to_t_s"],
            w["regime"].as_str().unwrap_or(""),
            w["share_pct"].as_f64().unwrap_or(0.0)
        );
    }
    for b in v["bands"].as_array().into_iter().flatten() {
        let _ = writeln!(
            s,
            "  {} bands: slow (>2 h) {:.1} %, mid (10 min-2 h) {:.1} %, fast (<10 min) {:.1} %",
            b["channel"].as_str().unwrap_or(""),
            b["slow_pct"].as_f64().unwrap_or(0.0),
            b["mid_pct"].as_f64().unwrap_or(0.0),
            b["fast_pct"].as_f64().unwrap_or(0.0)
        );
    }
    let _ = writeln!(
        s,
        "\n{:<12} {:>11} {:>10} {:>9} {:>11}",
        "candidate", "rms_before", "rms_after", "shrink %", "confidence"
    );
    for e in v["effects"].as_array().into_iter().flatten() {
        let _ = writeln!(
            s,
            "{:<12} {:>11.3} {:>10.3} {:>9.1} {:>11}",
            e["name"].as_str().unwrap_or(""),
            e["rms_before"].as_f64().unwrap_or(0.0),
            e["rms_after"].as_f64().unwrap_or(0.0),
            e["shrink_pct"].as_f64().unwrap_or(0.0),
            e["confidence"]
                .as_f64()
                .map_or("-".to_string(), |c| format!("{c:.3}"))
        );
    }
    let _ = writeln!(s, "\nverdict: {}", v["verdict"].as_str().unwrap_or("none"));
    if let Some(sec) = v["second"].as_object() {
        let _ = writeln!(
            s,
            "second effect: {} (held-out rms {} after both)",
            sec["name"].as_str().unwrap_or(""),
            sec["rms_after"]
        );
    }
    let d = &v["deployment"];
    if let Some(sim) = d["trained_on_sim"]["rmse_um"].as_f64() {
        let _ = writeln!(
            s,
            "\ndeployment ({} on {} temperatures, real held-out rmse): trained on sim {:.3} um{}; trained on the real fit part {:.3} um",
            d["target"].as_str().unwrap_or("?"),
            d["inputs"].as_array().map_or(0, Vec::len),
            sim,
            d["trained_on_sim_plus_effect"]["rmse_um"]
                .as_f64()
                .map_or_else(String::new, |e| format!(", on sim + {} {e:.3} um", d["effect"].as_str().unwrap_or("?"))),
            d["trained_on_real_fit_part"]["rmse_um"].as_f64().unwrap_or(f64::NAN)
        );
    }
    s
}
