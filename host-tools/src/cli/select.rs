//! `thermcomp select`: runs the typed job ([`select::select_files`]) and
//! prints its outcome, as one JSON object with `--json` or as the method's
//! text tables.

use crate::data::fsio;
use crate::select::outcome::{GreyOutcome, MaxtreeOutcome, WgreyOutcome};
use crate::select::{self, SelectArgs, SelectOutcome};
use anyhow::Result;

/// Runs `thermcomp select`.
pub fn run(a: &SelectArgs) -> Result<()> {
    let out = select::select_files(a)?;
    if a.json {
        fsio::print_line(&serde_json::to_value(&out)?.to_string())
    } else {
        fsio::print(&text(&out))
    }
}

/// The tables `select` prints without `--json`.
pub fn text(out: &SelectOutcome) -> String {
    match out {
        SelectOutcome::Grey(g) => grey_text(g),
        SelectOutcome::Wgrey(w) => wgrey_text(w),
        SelectOutcome::Maxtree(m) => maxtree_text(m),
    }
}

/// A figure with `prec` decimals; `-` for NaN, `inf` for infinity.
fn fmt_f(v: f64, prec: usize) -> String {
    if v.is_nan() {
        "-".into()
    } else if v.is_infinite() {
        "inf".into()
    } else {
        format!("{v:.prec$}")
    }
}

/// p-values print in scientific notation when small.
fn fmt_p(p: f64) -> String {
    if p.is_finite() && p > 0.0 && p < 1e-3 {
        format!("{p:.1e}")
    } else {
        fmt_f(p, 4)
    }
}

/// A square matrix under `title`, rows and columns named `names`.
fn matrix_text(title: &str, m: &[Vec<f64>], names: &[String]) -> String {
    let mut s = format!("{title}\n{:>6}", "");
    for n in names {
        s.push_str(&format!(" {n:>6}"));
    }
    s.push('\n');
    for (n, row) in names.iter().zip(m) {
        s.push_str(&format!("{n:>6}"));
        for v in row {
            s.push_str(&format!(" {v:>6.3}"));
        }
        s.push('\n');
    }
    s
}

/// Groups as `{a, b} {c}` (`sep` between the names).
fn groups_text(groups: &[Vec<String>], sep: &str, between: &str) -> String {
    groups
        .iter()
        .map(|g| format!("{{{}}}", g.join(sep)))
        .collect::<Vec<_>>()
        .join(between)
}

/// `select --method grey`'s text: the degrees, the groups, every
/// combination's regression and the pick.
fn grey_text(g: &GreyOutcome) -> String {
    let mut text = format!(
        "grey selection for {} ({} rows; seed 000: grey clustering at level {}, theta {}, Deng xi {}, --scale {})\n\n",
        g.target[0], g.rows.with_target, g.level, g.theta, g.xi, g.scale_used
    );
    for line in &g.notes {
        text.push_str(&format!("{line}\n\n"));
    }
    text.push_str(&matrix_text(
        "grey comprehensive correlation degree between inputs",
        &g.comprehensive,
        &g.inputs,
    ));
    text.push_str(&format!(
        "\n{:<8} {:>10} {:>9} {:>6}\n",
        "input", "grey_coef", "pearson", "group"
    ));
    for v in &g.variables {
        text.push_str(&format!(
            "{:<8} {:>10.5} {:>9.5} {:>6}{}\n",
            v.name,
            v.grey_coefficient,
            v.pearson,
            v.group + 1,
            if v.typical { "  typical" } else { "" }
        ));
    }
    text.push_str(&format!(
        "\ngroups: {}\n\n{:<40} {:>8} {:>8} {:>8} {:>11} {:>9}\n",
        groups_text(&g.groups, ", ", " "),
        "combination",
        "R",
        "R2",
        "adj_R2",
        "F",
        "p"
    ));
    for (i, c) in g.combinations.iter().enumerate() {
        let r = &c.regression;
        text.push_str(&format!(
            "{:<40} {:>8.5} {:>8.5} {:>8.5} {:>11} {:>9}{}\n",
            c.variables.join(","),
            r.r,
            r.r2,
            r.adj_r2,
            fmt_f(r.f, 1),
            fmt_p(r.p_value),
            if i == g.best {
                "  <- best adjusted R2"
            } else {
                ""
            }
        ));
    }
    text.push_str(&format!("\nselected: {}\n", g.selected.join(", ")));
    text
}

/// `select --method wgrey`'s text: each input's correlativity with each
/// target, the top sets and the pick.
fn wgrey_text(w: &WgreyOutcome) -> String {
    let mut text = format!(
        "weighted grey correlativity (seed 002 Eq. 1; --scale {}, xi {}, lambda1 {}, lambda2 {})\n\n{}{:<8}",
        w.scale,
        w.xi,
        w.lambda1,
        w.lambda2,
        w.notes
            .iter()
            .map(|l| format!("{l}\n\n"))
            .collect::<String>(),
        "input"
    );
    for t in &w.target {
        text.push_str(&format!(" {t:>10}"));
    }
    text.push('\n');
    for (j, n) in w.inputs.iter().enumerate() {
        text.push_str(&format!("{n:<8}"));
        for t in &w.target {
            text.push_str(&format!(" {:>10.5}", w.per_target[t].gamma[j]));
        }
        text.push('\n');
    }
    text.push('\n');
    for t in &w.target {
        text.push_str(&format!(
            "top {} of {t}: {}\n",
            w.top,
            w.per_target[t].top.join(", ")
        ));
    }
    let shown = if w.selected.is_empty() {
        "none".to_string()
    } else {
        w.selected.join(", ")
    };
    text.push_str(&format!("selected: {shown}\n"));
    text
}

/// `select --method maxtree`'s text: the tree, each level's fit, the
/// groups and the pick.
fn maxtree_text(m: &MaxtreeOutcome) -> String {
    let mut text = format!(
        "maximal-tree selection for {} ({} rows; seed 003: similarity |Pearson r|, Prim from {})\n\ntree edges (added in this order):\n",
        m.target[0], m.rows.with_target, m.inputs[0]
    );
    for e in &m.tree {
        text.push_str(&format!("  {}-{} {:.5}\n", e.a, e.b, e.weight));
    }
    text.push_str(&format!("\n{:<8} {:>8}\n", "input", "r_target"));
    for (n, v) in m.inputs.iter().zip(&m.target_correlation) {
        text.push_str(&format!("{n:<8} {v:>8.5}\n"));
    }
    text.push_str(&format!(
        "\n{:>3} {:>8} {:<34} {:>8} {:>8} {:>11} {:>9} {:>9} {:>10}\n",
        "#", "lambda", "representatives", "R2", "adj_R2", "F", "p", "cond", "max_VIF"
    ));
    for (i, l) in m.levels.iter().enumerate() {
        let max_vif = l.vif.iter().copied().fold(1.0, f64::max);
        text.push_str(&format!(
            "{:>3} {:>8.5} {:<34} {:>8.5} {:>8.5} {:>11} {:>9} {:>9} {:>10}{}\n",
            i + 1,
            l.lambda,
            l.representatives.join(","),
            l.regression.r2,
            l.regression.adj_r2,
            fmt_f(l.regression.f, 1),
            fmt_p(l.regression.p_value),
            fmt_f(l.condition_number, 1),
            fmt_f(max_vif, 1),
            if i == m.chosen_level {
                "  <- chosen"
            } else {
                ""
            }
        ));
    }
    text.push_str("\ngroups per level:\n");
    for (i, l) in m.levels.iter().enumerate() {
        text.push_str(&format!(
            "{:>3} {:.5} {}\n",
            i + 1,
            l.lambda,
            groups_text(&l.groups, ",", " ")
        ));
    }
    text.push_str(&format!(
        "\nrule: {}\nselected: {}\n",
        m.rule,
        m.selected.join(", ")
    ));
    text
}
