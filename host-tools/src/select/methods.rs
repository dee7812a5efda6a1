//! The three methods over the lined-up rows: each calls the pure functions
//! of its method module ([`grey`], [`wgrey`], [`maxtree`]) step by step and
//! returns its typed outcome. Notes (left-out rows, scale fallbacks) go to
//! stderr as the steps meet them.

use super::outcome::{
    Combination, GreyOutcome, GreyVariable, MaxtreeLevel, MaxtreeOutcome, RowCounts, TreeEdge,
    WgreyOutcome, WgreyTarget,
};
use super::params::SelectParams;
use super::rows::{
    names_of, scaled_inputs, scaled_target, series, target_correlations, with_target, ScaleChoice,
    Table,
};
use super::{grey, maxtree, wgrey, MAX_TYPICAL};
use crate::data::cells::Level;
use crate::data::runfile::RunFile;
use crate::num::stats;
use anyhow::{anyhow, bail, Context, Result};
use std::collections::BTreeMap;

/// The rows of a computation between the inputs (`x`) and of one with the
/// target (`xy`).
fn row_counts(x: &Table, xy: &Table) -> RowCounts {
    RowCounts {
        inputs: x.rows(),
        with_target: xy.rows(),
        left_out: xy.left_out.iter().sum::<usize>(),
    }
}

/// Grey degrees between the inputs and the clusters they form.
struct InputClusters {
    /// Rows where every input has a value.
    x: Table,
    /// Grey absolute degrees.
    abs: Vec<Vec<f64>>,
    /// Grey relative degrees, and the images they used.
    rel: Vec<Vec<f64>>,
    rel_choice: ScaleChoice,
    /// Comprehensive degrees.
    rho: Vec<Vec<f64>>,
    /// The clusters at `--level`.
    groups: Vec<Vec<usize>>,
}

/// What the relative degree's scale note says it is about.
const RELATIVE_WHAT: &str = "the grey relative degree between the inputs";

/// Seed 000's first step: the comprehensive degrees between the inputs and
/// their clusters at `--level` (at most [`MAX_TYPICAL`] of them).
fn grey_clusters(a: &SelectParams, files: &[RunFile], names: &[&str]) -> Result<InputClusters> {
    let x = Table::new(files, names);
    x.report(files, "a value of some input", 2)?;
    let abs = grey::absolute_matrix(&x.cols, &x.runs);
    let rel_choice = ScaleChoice::new(grey::Scale::Initial, &series(names, &x.cols), &x.runs);
    rel_choice.note(RELATIVE_WHAT);
    let rel = grey::relative_matrix(&x.cols, &x.runs, rel_choice.used).map_err(|(j, e)| {
        anyhow!(
            "{}: {e}: the grey relative degree needs its {} image",
            names[j],
            rel_choice.used.name()
        )
    })?;
    let rho = grey::comprehensive_matrix(&abs, &rel, a.theta);
    let groups = grey::clusters(&rho, a.level);
    let k = groups.len();
    if k > MAX_TYPICAL {
        bail!(
            "{k} groups at --level {}: more than {MAX_TYPICAL} typical variables would make {} combinations; lower --level so that fewer, larger groups form",
            a.level,
            (1u64 << k.min(63)) - 1
        );
    }
    Ok(InputClusters {
        x,
        abs,
        rel,
        rel_choice,
        rho,
        groups,
    })
}

/// Each input's grey (Deng) coefficient and Pearson r with the target.
struct TargetFit {
    /// Rows where the target and every input have values (target last).
    xy: Table,
    /// The processing of the correlation with the target.
    choice: ScaleChoice,
    /// What `choice`'s note is about.
    with_what: String,
    deng: Vec<f64>,
    pearson: Vec<f64>,
}

/// Seed 000's second step: the grey coefficient of each input with the
/// target (in `--scale`'s processing) and its Pearson r.
fn grey_with_target(
    a: &SelectParams,
    files: &[RunFile],
    names: &[&str],
    target: &str,
) -> Result<TargetFit> {
    let xy = Table::new(files, &with_target(names, target));
    xy.report(files, &format!("a value of {target} or of an input"), 3)?;
    let choice = ScaleChoice::new(
        a.scale,
        &series(&with_target(names, target), &xy.cols),
        &xy.runs,
    );
    let with_what = format!("the grey correlation with {target}");
    choice.note(&with_what);
    let ys = scaled_target(&xy.cols[names.len()], &xy.runs, choice.used, target)?;
    let xs = scaled_inputs(&xy, names, choice.used)?;
    let deng = grey::deng_coefficients(&ys, &xs, a.xi);
    let pearson = target_correlations(&xy, names, target)?;
    Ok(TargetFit {
        xy,
        choice,
        with_what,
        deng,
        pearson,
    })
}

/// The typical variables' combinations, each regressed on the target.
struct Combinations {
    /// The typical variables (input indices, sorted).
    typical: Vec<usize>,
    /// Each combination (input indices) with its regression.
    combos: Vec<(Vec<usize>, stats::Regression)>,
    /// Index of the best adjusted R^2 in `combos`.
    best: usize,
}

/// Seed 000's last step: every combination of the typical variables
/// regressed on the target, the best by adjusted R^2.
fn grey_combinations(
    c: &InputClusters,
    t: &TargetFit,
    names: &[&str],
    target: &str,
) -> Result<Combinations> {
    let k = c.groups.len();
    let mut typical = grey::typical(&c.groups, &t.deng);
    typical.sort_unstable();
    let y = &t.xy.cols[names.len()];
    let reg_cols: Vec<Vec<f64>> = typical.iter().map(|&j| t.xy.cols[j].clone()).collect();
    let basis = stats::Basis::new(&reg_cols, y).with_context(|| format!("regressing {target}"))?;
    let combos: Vec<(Vec<usize>, stats::Regression)> = grey::combinations(k)
        .into_iter()
        .map(|c| {
            let r = basis.fit(&c);
            (c.iter().map(|&i| typical[i]).collect(), r)
        })
        .collect();
    let best = combos
        .iter()
        .enumerate()
        .filter(|(_, (_, r))| !r.rank_deficient && r.adj_r2.is_finite())
        .fold(None::<(usize, f64)>, |acc, (i, (_, r))| match acc {
            Some((_, b)) if b >= r.adj_r2 => acc,
            _ => Some((i, r.adj_r2)),
        })
        .map(|(i, _)| i)
        .ok_or_else(|| {
            anyhow!(
                "{} rows are too few to compare the combinations of {k} typical variables",
                t.xy.rows()
            )
        })?;
    Ok(Combinations {
        typical,
        combos,
        best,
    })
}

/// `--method grey` (seed 000): grey clustering of the inputs, the typical
/// variable of each cluster by grey correlation with the target, the
/// combination of typical variables with the best adjusted R^2.
pub(super) fn grey(
    a: &SelectParams,
    files: &[RunFile],
    names: &[&str],
    skipped_rows: usize,
) -> Result<GreyOutcome> {
    let target = a.target[0].as_str();
    let c = grey_clusters(a, files, names)?;
    let t = grey_with_target(a, files, names, target)?;
    let Combinations {
        typical,
        combos,
        best,
    } = grey_combinations(&c, &t, names, target)?;
    let group_of = |j: usize| c.groups.iter().position(|g| g.contains(&j)).unwrap_or(0);
    let variables = (0..names.len())
        .map(|j| GreyVariable {
            name: names[j].to_string(),
            grey_coefficient: t.deng[j],
            pearson: t.pearson[j],
            group: group_of(j),
            typical: typical.contains(&j),
        })
        .collect();
    let combinations = combos
        .iter()
        .map(|(v, r)| Combination {
            regression: r.into(),
            variables: names_of(v, names),
        })
        .collect();
    let notes = [
        c.rel_choice.text(RELATIVE_WHAT),
        t.choice.text(&t.with_what),
    ];
    Ok(GreyOutcome {
        target: vec![target.to_string()],
        inputs: names.iter().map(|n| n.to_string()).collect(),
        selected: names_of(&combos[best].0, names),
        criterion: "adj_r2",
        rows: row_counts(&c.x, &t.xy),
        scale: t.choice.requested.name(),
        scale_used: t.choice.used.name(),
        scale_fallback: t.choice.fallback(),
        relative_images: c.rel_choice.used.name(),
        relative_fallback: c.rel_choice.fallback(),
        xi: a.xi,
        theta: a.theta,
        level: a.level,
        groups: c.groups.iter().map(|g| names_of(g, names)).collect(),
        typical: names_of(&typical, names),
        variables,
        combinations,
        skipped_rows,
        best,
        notes: notes.into_iter().flatten().collect(),
        absolute: c.abs,
        relative: c.rel,
        comprehensive: c.rho,
    })
}

/// One target's weighted grey correlativities (seed 002 Eq. 1), with the
/// scale note it gave, if any.
fn wgrey_target(
    a: &SelectParams,
    files: &[RunFile],
    names: &[&str],
    t: &str,
) -> Result<(WgreyTarget, Option<String>)> {
    let w = wgrey::Weights {
        xi: a.xi,
        lambda1: a.lambda1,
        lambda2: a.lambda2,
    };
    let xy = Table::new(files, &with_target(names, t));
    xy.report(files, &format!("a value of {t} or of an input"), 2)?;
    // A constant input gets a grade that says nothing (every constant
    // input the same one): refused as grey and maxtree refuse it.
    if let Some(n) = names
        .iter()
        .zip(&xy.cols)
        .find_map(|(n, c)| matches!(Level::of(c.iter().copied()), Level::Flat(_)).then_some(n))
    {
        bail!(
            "{n} is constant over the {} rows used: it cannot be ranked; leave it out with --inputs",
            xy.rows()
        );
    }
    let choice = ScaleChoice::new(a.scale, &series(&with_target(names, t), &xy.cols), &xy.runs);
    let with_what = format!("the grey correlativity with {t}");
    choice.note(&with_what);
    let scale = choice.used;
    let ys = scaled_target(&xy.cols[names.len()], &xy.runs, scale, t)?;
    let xs = scaled_inputs(&xy, names, scale)?;
    let g = wgrey::gammas(&ys, &xs, &xy.runs, &w).map_err(|e| anyhow!("{t}: {e}"))?;
    let figures = WgreyTarget {
        rows: xy.rows(),
        left_out: xy.left_out.iter().sum::<usize>(),
        scale_used: scale.name(),
        scale_fallback: choice.fallback(),
        ranking: names_of(&wgrey::top_k(&g, names.len()), names),
        top: names_of(&wgrey::top_k(&g, a.top), names),
        gamma: g,
    };
    Ok((figures, choice.text(&with_what)))
}

/// `--method wgrey` (seed 002 Eq. 1): the `--top` inputs of each target by
/// weighted grey correlativity, and those in every target's top set.
pub(super) fn wgrey(
    a: &SelectParams,
    files: &[RunFile],
    names: &[&str],
    skipped_rows: usize,
) -> Result<WgreyOutcome> {
    if a.top > names.len() {
        eprintln!(
            "note: --top {} is more than the {} inputs: every input is kept",
            a.top,
            names.len()
        );
    }
    let mut per_target = BTreeMap::new();
    let mut tops = Vec::new();
    let mut notes: Vec<String> = Vec::new();
    for t in &a.target {
        let (figures, note) = wgrey_target(a, files, names, t)?;
        tops.push(wgrey::top_k(&figures.gamma, a.top));
        notes.extend(note);
        per_target.insert(t.clone(), figures);
    }
    let selected = names_of(&wgrey::intersection(&tops), names);
    if selected.is_empty() {
        eprintln!(
            "note: no input is in the top {} of every target; raise --top or select per target",
            a.top
        );
    }
    Ok(WgreyOutcome {
        target: a.target.clone(),
        inputs: names.iter().map(|n| n.to_string()).collect(),
        selected,
        scale: a.scale.name(),
        xi: a.xi,
        lambda1: a.lambda1,
        lambda2: a.lambda2,
        top: a.top,
        per_target,
        skipped_rows,
        notes,
    })
}

/// One level's representatives, regression and collinearity.
struct LevelFit {
    reps: Vec<usize>,
    reg: stats::Regression,
    col: stats::Collinearity,
}

/// The maximal tree of the inputs by |Pearson r| and what it is built on.
struct MaximalTree {
    /// Rows where every input has a value.
    x: Table,
    /// Pearson r between the inputs.
    r: Vec<Vec<f64>>,
    /// |r|: the similarity.
    sim: Vec<Vec<f64>>,
    /// The tree's edges, in the order Prim added them.
    edges: Vec<maxtree::Edge>,
}

/// Seed 003's first step: the maximal tree of the inputs by |Pearson r|
/// (Prim's order).
fn maximal_tree(files: &[RunFile], names: &[&str]) -> Result<MaximalTree> {
    let x = Table::new(files, names);
    x.report(files, "a value of some input", 3)?;
    let r = stats::pearson_matrix(&x.cols).map_err(|j| {
        anyhow!(
            "{} is constant over the {} rows used: its correlation is undefined; leave it out with --inputs",
            names[j],
            x.rows()
        )
    })?;
    let sim: Vec<Vec<f64>> = r
        .iter()
        .map(|row| row.iter().map(|v| v.abs()).collect())
        .collect();
    let edges = maxtree::prim(&sim);
    Ok(MaximalTree { x, r, sim, edges })
}

/// Each level's representatives (by |r| with the target) regressed on the
/// target, with their collinearity.
fn fit_levels(basis: &stats::Basis, levels: &[maxtree::Level], target_r: &[f64]) -> Vec<LevelFit> {
    levels
        .iter()
        .map(|l| {
            let reps = maxtree::representatives(&l.groups, target_r);
            let reg = basis.fit(&reps);
            let col = basis.collinearity(&reps);
            LevelFit { reps, reg, col }
        })
        .collect()
}

/// Seed 003's rule over the levels' fits: the chosen level, and the rule
/// as reported (a note on stderr when no level passed).
fn choose_level(a: &SelectParams, fits: &[LevelFit]) -> Result<(usize, String)> {
    let scores: Vec<maxtree::LevelScore> = fits
        .iter()
        .map(|f| maxtree::LevelScore {
            r2: f.reg.r2,
            p_value: f.reg.p_value,
            min_tolerance: if f.reg.rank_deficient {
                0.0
            } else {
                f.col.min_tolerance()
            },
        })
        .collect();
    let choice = maxtree::choose(&scores, a.alpha, a.min_gain, a.min_tolerance)
        .ok_or_else(|| anyhow!("the maximal tree has no edges"))?;
    if choice.fallback {
        eprintln!(
            "note: no level's regression is significant at --alpha {} with every tolerance >= {}: took the smallest p-value",
            a.alpha, a.min_tolerance
        );
    }
    let rule = if choice.fallback {
        "fallback: smallest p-value (no level passed)".to_string()
    } else {
        format!(
            "smallest level with p < {} , every tolerance >= {} and R2 >= best such R2 - {}",
            a.alpha, a.min_tolerance, a.min_gain
        )
    };
    Ok((choice.index, rule))
}

/// `--method maxtree` (seed 003): the levels of the maximal tree, each
/// level's representatives regressed on the target, the level chosen by
/// R^2, the F test and collinearity.
pub(super) fn maxtree(
    a: &SelectParams,
    files: &[RunFile],
    names: &[&str],
    skipped_rows: usize,
) -> Result<MaxtreeOutcome> {
    let target = a.target[0].as_str();
    let MaximalTree { x, r, sim, edges } = maximal_tree(files, names)?;
    let levels = maxtree::levels(names.len(), &edges);
    let xy = Table::new(files, &with_target(names, target));
    xy.report(files, &format!("a value of {target} or of an input"), 3)?;
    let target_r = target_correlations(&xy, names, target)?;
    let y = &xy.cols[names.len()];
    let basis = stats::Basis::new(&xy.cols[..names.len()], y)
        .with_context(|| format!("regressing {target}"))?;
    let fits = fit_levels(&basis, &levels, &target_r);
    let (chosen, rule) = choose_level(a, &fits)?;
    let levels_out = levels
        .iter()
        .zip(&fits)
        .map(|(l, f)| MaxtreeLevel {
            lambda: l.lambda,
            groups: l.groups.iter().map(|g| names_of(g, names)).collect(),
            representatives: names_of(&f.reps, names),
            regression: (&f.reg).into(),
            condition_number: f.col.condition_number,
            vif: f.col.vif.clone(),
            significant: f.reg.p_value < a.alpha,
        })
        .collect();
    let tree = edges
        .iter()
        .map(|e| TreeEdge {
            a: names[e.a].to_string(),
            b: names[e.b].to_string(),
            weight: e.weight,
        })
        .collect();
    Ok(MaxtreeOutcome {
        target: vec![target.to_string()],
        inputs: names.iter().map(|n| n.to_string()).collect(),
        selected: names_of(&fits[chosen].reps, names),
        rows: row_counts(&x, &xy),
        pearson: r,
        similarity: sim,
        tree,
        target_correlation: target_r,
        levels: levels_out,
        chosen_level: chosen,
        alpha: a.alpha,
        min_gain: a.min_gain,
        min_tolerance: a.min_tolerance,
        rule,
        skipped_rows,
    })
}
