//! `thermcomp diagnose`: the flags, the files checked, the job
//! ([`crate::diagnose::diagnose_with_machine`]) and its object printed as a
//! short table or as JSON.

use crate::data::fsio;
use crate::diagnose::outcome::{finite, json_number, Diagnosis};
use crate::diagnose::{diagnose_with_machine, physical};
use anyhow::Result;
use clap::Args;
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
    let page = super::report_page(a.report.as_deref())?;
    let writes: Vec<_> = page.iter().map(|p| fsio::named("--report", p)).collect();
    let mut reads = vec![fsio::named("--sim", &a.sim), fsio::named("--real", &a.real)];
    reads.extend(a.machine.as_deref().map(|m| fsio::named("--machine", m)));
    fsio::check_distinct(&reads, &writes)?;
    let d = diagnose_with_machine(
        &a.sim,
        &a.real,
        a.holdout_from_s,
        a.report.as_deref(),
        a.machine.as_deref(),
    )?;
    if a.json {
        fsio::print_line(&serde_json::to_string(&d)?)?;
    } else {
        let physical = d.physical.as_ref().map_or_else(String::new, physical::text);
        fsio::print(&(text_table(&d) + &physical))?;
    }
    eprintln!("diagnose: {:.2} s", started.elapsed().as_secs_f64());
    Ok(())
}

/// The short text table printed without `--json`.
fn text_table(d: &Diagnosis) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let main = d.main_channel.as_str();
    let gap = d.gap.get(main);
    let _ = writeln!(
        s,
        "main channel {main}: gap rms {} max {} ; hold-out from t = {} s",
        json_number(gap.map_or(f64::NAN, |g| g.rms)),
        json_number(gap.map_or(f64::NAN, |g| g.max_abs)),
        json_number(d.holdout_from_t_s)
    );
    let _ = writeln!(s, "\nwhere (share of residual energy):");
    for w in d.where_.iter().take(6) {
        let _ = writeln!(
            s,
            "  {:>6} {} .. {} s  {:<28} {:>6.1} %",
            w.channel,
            json_number(w.from_t_s),
            json_number(w.to_t_s),
            w.regime,
            finite(w.share_pct).unwrap_or(0.0)
        );
    }
    for b in &d.bands {
        let _ = writeln!(
            s,
            "  {} bands: slow (>2 h) {:.1} %, mid (10 min-2 h) {:.1} %, fast (<10 min) {:.1} %",
            b.channel,
            finite(b.slow_pct).unwrap_or(0.0),
            finite(b.mid_pct).unwrap_or(0.0),
            finite(b.fast_pct).unwrap_or(0.0)
        );
    }
    effects_table(&mut s, d);
    let _ = writeln!(s, "\nverdict: {}", d.verdict);
    if let Some(sec) = &d.second {
        let _ = writeln!(
            s,
            "second effect: {} (held-out rms {} after both)",
            sec.name,
            json_number(sec.rms_after)
        );
    }
    deployment_line(&mut s, d);
    s
}

/// The candidates' held-out figures, one line each.
fn effects_table(s: &mut String, d: &Diagnosis) {
    use std::fmt::Write as _;
    let _ = writeln!(
        s,
        "\n{:<12} {:>11} {:>10} {:>9} {:>11}",
        "candidate", "rms_before", "rms_after", "shrink %", "confidence"
    );
    for e in &d.effects {
        let _ = writeln!(
            s,
            "{:<12} {:>11.3} {:>10.3} {:>9.1} {:>11}",
            e.name,
            finite(e.rms_before).unwrap_or(0.0),
            finite(e.rms_after).unwrap_or(0.0),
            finite(e.shrink_pct).unwrap_or(0.0),
            e.confidence
                .and_then(finite)
                .map_or("-".to_string(), |c| format!("{c:.3}"))
        );
    }
}

/// The deployment comparison in a line, if the model trained on the sim
/// was scored.
fn deployment_line(s: &mut String, d: &Diagnosis) {
    use std::fmt::Write as _;
    let Some(c) = d.deployment.comparison() else {
        return;
    };
    let Some(sim) = c.trained_on_sim.rmse_um() else {
        return;
    };
    let with_effect = c
        .trained_on_sim_plus_effect
        .as_ref()
        .and_then(|t| t.rmse_um());
    let _ = writeln!(
        s,
        "\ndeployment ({} on {} temperatures, real held-out rmse): trained on sim {:.3} um{}; trained on the real fit part {:.3} um",
        c.target,
        c.inputs.len(),
        sim,
        with_effect.map_or_else(String::new, |e| format!(", on sim + {} {e:.3} um", c.effect.as_deref().unwrap_or("?"))),
        c.trained_on_real_fit_part.rmse_um().unwrap_or(f64::NAN)
    );
}
