//! The benchmark's files: `cases.csv` (one row per case), `confusion.md`
//! (the matrix and the rates as a Markdown table, ready for docs/),
//! `summary.json` and `confusion.svg` (the matrix as a heat map, drawn
//! by hand like the diagnose report: no font or system library needed).

use super::cases::{Case, LABELS};
use super::outcome::Outcome;
use super::summary::Summary;
use anyhow::{Context, Result};
use serde_json::Value;
use std::fmt::Write as _;
use std::path::Path;

/// Writes every file into `dir` (created if missing).
pub fn write(dir: &Path, outs: &[Outcome<Case>], s: &Summary, summary: &Value) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let put = |name: &str, text: String| -> Result<()> {
        let p = dir.join(name);
        crate::data::fsio::write_bytes_atomic(&p, text.as_bytes())
    };
    put("cases.csv", cases_csv(outs))?;
    put("confusion.md", markdown(outs, s))?;
    put("summary.json", format!("{summary:#}\n"))?;
    put("confusion.svg", svg(s))?;
    Ok(())
}

/// A number with one decimal, or empty.
pub fn f1(v: Option<f64>) -> String {
    v.filter(|x| x.is_finite())
        .map_or_else(String::new, |x| format!("{x:.1}"))
}

/// A percentage with one decimal, or "-" where there is none (no effect
/// case to take a rate or a median of: it printed NaN).
fn pct(x: f64) -> String {
    crate::num::shown::figure(Some(x), 0, 1)
}

/// A number with three decimals, or empty.
fn f3(v: Option<f64>) -> String {
    v.filter(|x| x.is_finite())
        .map_or_else(String::new, |x| format!("{x:.3}"))
}

/// One row per case.
pub fn cases_csv(outs: &[Outcome<Case>]) -> String {
    let mut s = String::from(
        "id,effect,profile,seed,magnitude,logged,verdict,second,main_channel,shrink_pct,true_shrink_pct,best,best_ratio_to_none,deploy_sim_rmse_um,deploy_sim_effect_rmse_um,correct,elapsed_s\n",
    );
    for o in outs {
        let (c, d) = (&o.case, &o.diag);
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{},{:.3},{},{},{},{:.3}",
            c.id,
            c.effect,
            c.profile.label(),
            c.seed,
            c.magnitude,
            c.logged,
            d.verdict,
            d.second.as_deref().unwrap_or(""),
            d.main_channel,
            f1(Some(d.verdict_shrink_pct)),
            f1(d.true_shrink_pct),
            d.best,
            d.best_ratio_to_none,
            f3(d.deploy_sim_um),
            f3(d.deploy_sim_effect_um),
            d.correct(),
            d.elapsed_s
        );
    }
    s
}

/// The confusion matrix as Markdown rows (true cause x verdict).
pub fn matrix_md(s: &Summary) -> String {
    let mut m = String::from("| true \\ verdict |");
    for l in LABELS {
        let _ = write!(m, " {l} |");
    }
    m.push_str(" correct |\n|---|");
    m.push_str(&"---|".repeat(LABELS.len() + 1));
    m.push('\n');
    for (i, l) in LABELS.iter().enumerate() {
        let n: usize = s.confusion[i].iter().sum();
        let _ = write!(m, "| **{l}** |");
        for j in 0..LABELS.len() {
            let v = s.confusion[i][j];
            if v == 0 {
                m.push_str(" |");
            } else if i == j {
                let _ = write!(m, " **{v}** |");
            } else {
                let _ = write!(m, " {v} |");
            }
        }
        let _ = writeln!(m, " {}/{n} |", s.confusion[i][i]);
    }
    m
}

/// The rates line and the shrinks per cause, as Markdown.
pub fn rates_md(s: &Summary) -> String {
    let mut m = String::new();
    let _ = writeln!(
        m,
        "\nAccuracy {} % of {} cases; effect cases identified {} %; false alarms {} of {} `none` cases ({} %); misses (effect -> none) {}; wrong effect {} ({} % of effect cases); second effect claimed {} times; median held-out shrink of the correctly identified effect cases {} %.\n",
        pct(s.accuracy_pct),
        s.cases,
        pct(s.effect_accuracy_pct),
        s.false_alarms.0,
        s.false_alarms.1,
        pct(s.false_alarm_rate_pct()),
        s.misses,
        s.wrong_effect,
        pct(s.wrong_effect_rate_pct()),
        s.spurious_seconds,
        pct(s.median_shrink_correct_pct)
    );
    m.push_str("| cause | correct | held-out shrink of the verdict: min | median | max |\n|---|---|---|---|---|\n");
    for (l, n, lo, med, hi) in &s.shrink_by_effect {
        let _ = writeln!(
            m,
            "| {l} | {n} | {} | {} | {} |",
            f1(Some(*lo)),
            f1(Some(*med)),
            f1(Some(*hi))
        );
    }
    m
}

/// The matrix, the rates, the shrinks per cause and every wrong case.
pub fn markdown(outs: &[Outcome<Case>], s: &Summary) -> String {
    let mut m = matrix_md(s);
    m.push_str(&rates_md(s));
    m.push_str("\nWrong cases:\n\n| id | true | profile | magnitude | logged | verdict | second | main channel | best (ratio to none) | shrink of true candidate % |\n|---|---|---|---|---|---|---|---|---|---|\n");
    for o in outs.iter().filter(|o| !o.correct()) {
        let (c, d) = (&o.case, &o.diag);
        let _ = writeln!(
            m,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} ({:.2}) | {} |",
            c.id,
            c.effect,
            c.profile.label(),
            c.magnitude,
            if c.logged { "yes" } else { "no" },
            d.verdict,
            d.second.as_deref().unwrap_or("—"),
            d.main_channel,
            d.best,
            d.best_ratio_to_none,
            f1(d.true_shrink_pct)
        );
    }
    m
}

/// The confusion matrix as a plain-text table.
pub fn matrix_text(s: &Summary) -> String {
    let mut t = String::new();
    let _ = write!(t, "{:>12}", "true\\verdict");
    for l in LABELS {
        let _ = write!(t, " {:>10}", l);
    }
    t.push('\n');
    for (i, l) in LABELS.iter().enumerate() {
        let _ = write!(t, "{l:>12}");
        for j in 0..LABELS.len() {
            let _ = write!(t, " {:>10}", s.confusion[i][j]);
        }
        t.push('\n');
    }
    t
}

/// The short summary printed without `--json`.
pub fn text(outs: &[Outcome<Case>], s: &Summary, wall_s: f64) -> String {
    let mut t = matrix_text(s);
    let _ = writeln!(
        t,
        "\n{} cases in {:.1} s: accuracy {} %, false alarms {}/{}, misses {}, wrong effect {}, median shrink (correct effect cases) {} %",
        outs.len(),
        wall_s,
        pct(s.accuracy_pct),
        s.false_alarms.0,
        s.false_alarms.1,
        s.misses,
        s.wrong_effect,
        pct(s.median_shrink_correct_pct)
    );
    t
}

/// The confusion matrix as an SVG heat map: cell shade = share of the row.
pub fn svg(s: &Summary) -> String {
    svg_titled(s, "verdict (columns) for each true cause (rows)")
}

/// [`svg`] with its own title.
pub fn svg_titled(s: &Summary, title: &str) -> String {
    let n = LABELS.len() as f64;
    let (cell, left, top) = (80.0, 110.0, 90.0);
    let (w, h) = (left + n * cell + 20.0, top + n * cell + 40.0);
    let mut g = format!(
        r##"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="12">"##
    );
    let _ = write!(
        g,
        r##"<text x="{}" y="18" text-anchor="middle" font-size="14">{title}</text>"##,
        left + n * cell / 2.0
    );
    for (j, l) in LABELS.iter().enumerate() {
        let x = left + (j as f64 + 0.5) * cell;
        let _ = write!(
            g,
            r##"<text x="{x}" y="{}" text-anchor="middle">{l}</text>"##,
            top - 8.0
        );
    }
    for (i, l) in LABELS.iter().enumerate() {
        let y = top + i as f64 * cell;
        let row: usize = s.confusion[i].iter().sum();
        let _ = write!(
            g,
            r##"<text x="{}" y="{}" text-anchor="end">{l}</text>"##,
            left - 8.0,
            y + cell / 2.0 + 4.0
        );
        for j in 0..LABELS.len() {
            let v = s.confusion[i][j];
            let share = if row > 0 { v as f64 / row as f64 } else { 0.0 };
            // Diagonal in blue, off-diagonal in red; white for 0.
            let (r, gg, b) = if i == j {
                (255.0 - 200.0 * share, 255.0 - 130.0 * share, 255.0)
            } else {
                (255.0, 255.0 - 200.0 * share, 255.0 - 200.0 * share)
            };
            let x = left + j as f64 * cell;
            let _ = write!(
                g,
                r##"<rect x="{x}" y="{y}" width="{cell}" height="{cell}" fill="rgb({},{},{})" stroke="#888"/>"##,
                r as u8, gg as u8, b as u8
            );
            if v > 0 {
                let _ = write!(
                    g,
                    r##"<text x="{}" y="{}" text-anchor="middle" font-size="16">{v}</text>"##,
                    x + cell / 2.0,
                    y + cell / 2.0 + 6.0
                );
            }
        }
    }
    let _ = write!(
        g,
        r##"<text x="{}" y="{}" text-anchor="middle">accuracy {} %, false alarms {}/{}, median shrink of correct effect cases {} %</text></svg>"##,
        left + n * cell / 2.0,
        h - 12.0,
        pct(s.accuracy_pct),
        s.false_alarms.0,
        s.false_alarms.1,
        pct(s.median_shrink_correct_pct)
    );
    g.push('\n');
    g
}
