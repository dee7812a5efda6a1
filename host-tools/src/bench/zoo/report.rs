//! The zoo benchmark's text and files: `cases.csv`, `zoo.md` (the plant
//! table and per-plant confusion matrices, ready for docs/), `summary.json`
//! and one `confusion-<plant>.svg` per plant plus `confusion-all.svg`. The
//! matrix tables and the SVG are the twin benchmark's ([`crate::bench::report`]).

use super::bench::{PlantScore, ZooSummary};
use super::cases::ZooCase;
use super::plant::PlantFacts;
use crate::bench::outcome::Outcome;
use crate::bench::report::{f1, matrix_md, matrix_text, rates_md, svg_titled};
use anyhow::{Context, Result};
use std::fmt::Write as _;
use std::path::Path;

/// A fraction as a percentage with one decimal, or `-`.
fn pct(v: Option<f64>) -> String {
    v.map_or_else(|| "-".into(), |x| format!("{:.1} %", 100.0 * x))
}

/// One line of a plant's score.
fn score_line(s: &PlantScore) -> String {
    format!(
        "plant {} ({}): {} cases, accuracy {}, false alarms {}/{} ({}), wrong effect {}/{} ({}), misses {}, median shrink of correct effect cases {}",
        s.plant,
        s.name,
        s.cases,
        pct(s.accuracy),
        s.false_alarms,
        s.none_cases,
        pct(s.false_alarm_rate),
        s.wrong_effect,
        s.effect_cases,
        pct(s.wrong_effect_rate),
        s.misses,
        s.median_shrink_correct_pct.map_or_else(|| "-".into(), |v| format!("{v:.1} %"))
    )
}

/// The text printed without `--json`: each plant's matrix and score.
pub fn text(z: &ZooSummary) -> String {
    let mut t = String::new();
    for s in z.plants.iter().chain(std::iter::once(&z.pooled)) {
        let _ = writeln!(t, "{}\n{}", score_line(s), matrix_text(&s.summary));
    }
    let _ = writeln!(
        t,
        "{} cases in {:.1} s; held-out plant {} {}",
        z.cases,
        z.wall_s,
        z.heldout_plant,
        if z.scored_heldout {
            "scored"
        } else {
            "not run"
        }
    );
    t
}

/// The plant table.
pub fn plants_md(facts: &[PlantFacts]) -> String {
    let mut m = String::from(
        "| plant | machine | nodes | links | friction exponents | motors | T sensors (time constants, s) | displacements | network time constants |\n|---|---|---|---|---|---|---|---|---|\n",
    );
    for f in facts {
        let taus: Vec<String> = f.sensor_taus_s.iter().map(|t| format!("{t:.0}")).collect();
        let _ = writeln!(
            m,
            "| {} | {} | {}: {} | {} | {:?} | {} | {} ({}; last = air) | {} | {:.0} s .. {:.1} h |",
            f.id,
            f.name,
            f.nodes.len(),
            f.nodes.join(", "),
            f.links,
            f.friction_exponents,
            f.motors,
            f.sensors,
            taus.join(", "),
            f.axes.join(", "),
            f.tau_range_s.1,
            f.tau_range_s.0 / 3600.0
        );
    }
    m
}

/// The wrong cases.
fn wrong_md(outs: &[Outcome<ZooCase>]) -> String {
    let mut m = String::from("| id | plant | true | profile | magnitude | logged | verdict | main channel | best (ratio to none) | shrink of true candidate % |\n|---|---|---|---|---|---|---|---|---|---|\n");
    for o in outs.iter().filter(|o| !o.correct()) {
        let (c, d) = (&o.case, &o.diag);
        let _ = writeln!(
            m,
            "| {} | {} | {} | {} | {:.2} | {} | {} | {} | {} ({:.2}) | {} |",
            c.id,
            c.plant,
            c.effect,
            c.profile.label(),
            c.magnitude,
            if c.logged { "yes" } else { "no" },
            d.verdict,
            d.main_channel,
            d.best,
            d.best_ratio_to_none,
            f1(d.true_shrink_pct)
        );
    }
    m
}

/// `zoo.md`: plant table, each plant's matrix and rates, the pool, the
/// wrong cases.
pub fn markdown(outs: &[Outcome<ZooCase>], z: &ZooSummary) -> String {
    let mut m = plants_md(&z.plant_facts);
    for s in z.plants.iter().chain(std::iter::once(&z.pooled)) {
        let _ = writeln!(m, "\n#### Plant {} ({})\n", s.plant, s.name);
        m.push_str(&matrix_md(&s.summary));
        m.push_str(&rates_md(&s.summary));
    }
    m.push_str("\nWrong cases:\n\n");
    m.push_str(&wrong_md(outs));
    m
}

/// One row per case.
pub fn cases_csv(z: &ZooSummary) -> String {
    let mut s = String::from("id,plant,effect,profile,seed,magnitude,logged,verdict,second,main_channel,shrink_pct,true_shrink_pct,best,best_ratio_to_none,correct,elapsed_s\n");
    for c in &z.per_case {
        let d = &c.diagnosis;
        let cell = |k: &str| match &d[k] {
            serde_json::Value::Null => String::new(),
            serde_json::Value::String(v) => v.clone(),
            v => v.to_string(),
        };
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            c.id,
            c.plant,
            c.effect,
            c.profile,
            c.seed,
            c.magnitude,
            c.logged,
            cell("verdict"),
            cell("second"),
            cell("main_channel"),
            cell("shrink_pct"),
            cell("true_shrink_pct"),
            cell("best"),
            cell("best_ratio_to_none"),
            cell("correct"),
            cell("elapsed_s")
        );
    }
    s
}

/// Writes every file into `dir` (created if missing).
pub fn write(dir: &Path, outs: &[Outcome<ZooCase>], z: &ZooSummary) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let put = |name: &str, text: String| {
        crate::data::fsio::write_bytes_atomic(&dir.join(name), text.as_bytes())
    };
    put("cases.csv", cases_csv(z))?;
    put("zoo.md", markdown(outs, z))?;
    put("summary.json", format!("{:#}\n", serde_json::to_value(z)?))?;
    for s in z.plants.iter().chain(std::iter::once(&z.pooled)) {
        let title = format!(
            "plant {}: verdict (columns) for each true cause (rows)",
            s.plant
        );
        put(
            &format!("confusion-{}.svg", s.plant),
            svg_titled(&s.summary, &title),
        )?;
    }
    Ok(())
}
