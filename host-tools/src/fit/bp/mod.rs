//! BP network and GA-BP trainers (seed 000; seed 003 also uses a BP net).
//!
//! `--model bp`: a one-hidden-layer net (tansig or logsig hidden, purelin
//! output) on `mapminmax`-scaled calibration rows, Nguyen-Widrow initial
//! weights from `--seed`, trained by Levenberg-Marquardt with early
//! stopping on validation blocks of the calibration rows, as MATLAB's
//! `feedforwardnet` + `trainlm` would be (the papers used MATLAB).
//! `--model gabp`: a genetic algorithm first picks the hidden size and the
//! initial weights (seed 000, Eq. 16-17), then the same LM training runs
//! from its best individual; the details report BP alone beside GA-BP.
//!
//! Validation rows: the calibration rows are a time series, and MATLAB's
//! default random division would put each validation row between two
//! training rows a few seconds away, so the validation error would measure
//! interpolation and never stop anything. The rows are instead cut into
//! `--val-blocks` contiguous blocks and every `--val-every`-th block
//! (counting from the first, so the last block of the calibration part is
//! one of them) validates: 20 blocks, every 5th, gives 20 % of the rows in
//! four blocks of 72 min each on a 24 h calibration day.

pub mod ga;
pub mod gd;
pub mod init;
pub mod lm;
pub mod net;
pub mod report;

use super::{channels, outputs, Details, Fitted};
use crate::data::dataset::Dataset;
use crate::num::linalg;
use crate::num::progress::progress;
use crate::num::rng::SplitMix64;
use anyhow::{anyhow, bail, Result};
use model_core::bp::{Activation, BpNet, MAX_HIDDEN, MAX_W1};
use model_core::{Model, Params};
use net::{Data, Scaling, Shape};
use report::{
    BpDetails, Convergence, ConvergenceRow, Division, GaFigures, GdComparison, GdRow,
    HoldoutFigures, LmComparison, LmFigures, NetHoldouts,
};
use std::collections::BTreeMap;

/// Hidden size without `--hidden`: seed 000's GA settled on a 4-10-3 net,
/// and the FL_THERMAL runs have 16 inputs, where 10 neurons keep the net at
/// 181 weights for 4600 training rows. Capped by the blob's `MAX_W1 / m`.
pub const DEFAULT_HIDDEN: usize = 10;

/// Hidden transfer functions a trainer offers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum HiddenActivation {
    /// `tanh` (MATLAB's default for `feedforwardnet`).
    Tansig,
    /// The logistic sigmoid.
    Logsig,
}

impl From<HiddenActivation> for Activation {
    fn from(a: HiddenActivation) -> Self {
        match a {
            HiddenActivation::Tansig => Self::Tansig,
            HiddenActivation::Logsig => Self::Logsig,
        }
    }
}

/// BP and GA-BP options (`fit --model bp|gabp`); [`Default`] is `fit`'s defaults.
#[derive(Clone, Debug, PartialEq)]
pub struct BpOptions {
    /// bp, gabp: random seed (training is deterministic for a given seed).
    pub seed: u64,
    /// bp: hidden neurons [default: 10 (seed 000's 4-10-3 net), at most 384 / inputs].
    pub hidden: Option<usize>,
    /// bp, gabp: hidden-layer transfer function.
    pub activation: HiddenActivation,
    /// bp, gabp: Levenberg-Marquardt epochs at most.
    pub epochs: usize,
    /// bp, gabp: stop after this many epochs without a better validation error (MATLAB max_fail).
    pub max_fail: usize,
    /// bp, gabp: cut the calibration rows into this many contiguous blocks for validation.
    pub val_blocks: usize,
    /// bp, gabp: every K-th block validates (0: no validation, no early stop).
    pub val_every: usize,
    /// bp, gabp: training MSE goal (on targets scaled to [-1, 1]) for the
    /// convergence report [default: half the MSE of a linear least-squares fit].
    pub goal: Option<f64>,
    /// gabp: individuals per generation.
    pub ga_population: usize,
    /// gabp: generations.
    pub ga_generations: usize,
    /// gabp: crossover probability of a pair.
    pub ga_crossover: f64,
    /// gabp: mutation probability of an individual.
    pub ga_mutation: f64,
    /// gabp: hidden sizes the GA searches [default: 2..16, at most 384 / inputs].
    pub ga_hidden: Option<String>,
    /// gabp: epochs of gradient-descent BP (traingdx) for the convergence comparison (0: skip).
    pub gd_epochs: usize,
    /// gabp: also train the nets it is compared with (BP at the default size and
    /// at the GA's size, LM, and the three gradient-descent runs) and report how
    /// each converged; off, only the GA-BP net is trained (the same blob, about a
    /// third of the time).
    pub report_convergence: bool,
}

impl Default for BpOptions {
    fn default() -> Self {
        Self {
            seed: 1,
            hidden: None,
            activation: HiddenActivation::Tansig,
            epochs: 200,
            max_fail: 6,
            val_blocks: 20,
            val_every: 5,
            goal: None,
            ga_population: 40,
            ga_generations: 30,
            ga_crossover: 0.7,
            ga_mutation: 0.2,
            ga_hidden: None,
            gd_epochs: 1000,
            report_convergence: false,
        }
    }
}

/// Splits row indices `0..rows` into training and validation blocks.
pub fn division(rows: usize, blocks: usize, every: usize) -> (Vec<usize>, Vec<usize>) {
    if every == 0 || blocks < 2 || rows < 2 * blocks {
        return ((0..rows).collect(), Vec::new());
    }
    (0..rows).partition(|&r| !(r * blocks / rows + 1).is_multiple_of(every))
}

/// Parses `MIN..MAX` (inclusive).
fn parse_range(s: &str) -> Result<(usize, usize)> {
    let bad = || anyhow!("--ga-hidden {s}: expected MIN..MAX, e.g. 2..16");
    let (a, b) = s.split_once("..").ok_or_else(bad)?;
    let lo: usize = a.trim().parse().map_err(|_| bad())?;
    let hi: usize = b.trim().parse().map_err(|_| bad())?;
    Ok((lo, hi))
}

/// MSE of per-target linear least squares on scaled rows: the default goal's base.
fn linear_mse(d: &Data) -> Result<f64> {
    let x: Vec<Vec<f64>> = (0..d.x.nrows())
        .map(|r| d.x.row(r).iter().copied().collect())
        .collect();
    let mut sse = 0.0;
    for k in 0..d.t.ncols() {
        let y: Vec<f64> = d.t.column(k).iter().copied().collect();
        let (b0, b) = linalg::least_squares(&x, &y)?;
        for (row, yv) in x.iter().zip(&y) {
            let fit = b0 + row.iter().zip(&b).map(|(a, c)| a * c).sum::<f64>();
            sse += (yv - fit) * (yv - fit);
        }
    }
    Ok(sse / d.errors().max(1) as f64)
}

/// Held-out figures of `net` on `ds`'s held-out rows, with eval's metric code.
fn holdout_figures(ds: &Dataset, net: &BpNet) -> Result<HoldoutFigures> {
    let q = ds.targets.len();
    let (mut xs, mut ys) = (Vec::new(), Vec::new());
    for run in &ds.runs {
        for r in run.calib_end..run.t_s.len() {
            if let Some(x) = run.x_row(r) {
                xs.push(x);
                ys.push((0..q).map(|k| run.y(k, r)).collect::<Vec<_>>());
            }
        }
    }
    if xs.is_empty() {
        return Ok(None);
    }
    let pred = net::predict_rows(net, &xs).ok_or_else(|| anyhow!("bp: net not in trainer form"))?;
    let mut out = BTreeMap::new();
    for k in 0..q {
        let (y, yhat): (Vec<f64>, Vec<f64>) = ys
            .iter()
            .zip(&pred)
            .filter_map(|(y, p)| y[k].map(|v| (v, p[k])))
            .unzip();
        let m = model_core::metrics::metrics(&y, &yhat)
            .map_err(|e| anyhow!("{}: {e}", ds.targets[k]))?;
        out.insert(ds.targets[k].clone(), crate::eval::MetricsReport::from(&m));
    }
    Ok(Some(out))
}

/// LM with a progress bar.
fn run_lm(
    shape: Shape,
    act: Activation,
    w0: &[f64],
    tr: &Data,
    val: Option<&Data>,
    o: &lm::LmOptions,
    what: &str,
) -> lm::LmReport {
    let pb = progress(o.epochs, what);
    let r = lm::train(shape, act, w0, tr, val, o, Some(&pb));
    pb.finish_and_clear();
    r
}

/// Hidden sizes a fit may use: `(bp's, the GA's range)`, after checking
/// every option against the data's input count.
fn checked_sizes(
    args: &BpOptions,
    m: usize,
    genetic: bool,
    kind: &str,
) -> Result<(usize, (usize, usize))> {
    let max_hidden = MAX_HIDDEN.min(MAX_W1 / m.max(1));
    if max_hidden == 0 {
        bail!("{kind}: {m} inputs exceed the blob's {MAX_W1} input weights (MAX_W1) even with one hidden neuron");
    }
    let hidden = match args.hidden {
        Some(0) => bail!("--hidden must be at least 1"),
        Some(n) if n > max_hidden => bail!(
            "--hidden {n} with {m} inputs needs {} input weights; a BP blob holds at most {MAX_W1} (MAX_W1) and {MAX_HIDDEN} hidden neurons: use --hidden {max_hidden} or fewer",
            n * m
        ),
        Some(n) => n,
        None => DEFAULT_HIDDEN.min(max_hidden),
    };
    if args.val_every == 1 {
        bail!("--val-every 1 would validate on every block and train on none: use 0 (no validation) or 2 and up");
    }
    if args.epochs == 0 {
        bail!("--epochs must be at least 1");
    }
    for (name, p) in [
        ("--ga-crossover", args.ga_crossover),
        ("--ga-mutation", args.ga_mutation),
    ] {
        if !(0.0..=1.0).contains(&p) {
            bail!("{name} {p} must be a probability in [0, 1]");
        }
    }
    if args.goal.is_some_and(|g| !(g.is_finite() && g >= 0.0)) {
        bail!("--goal must be a finite MSE >= 0");
    }
    let ga_hidden = match &args.ga_hidden {
        Some(s) => parse_range(s)?,
        None => (2.min(max_hidden), 16.min(max_hidden)),
    };
    if genetic {
        if ga_hidden.0 == 0 || ga_hidden.0 > ga_hidden.1 || ga_hidden.1 > max_hidden {
            bail!(
                "--ga-hidden {}..{}: need 1 <= MIN <= MAX <= {max_hidden} ({MAX_W1} input weights (MAX_W1) / {m} inputs, at most {MAX_HIDDEN})",
                ga_hidden.0, ga_hidden.1
            );
        }
        if args.ga_population < 2 {
            bail!("--ga-population must be at least 2");
        }
    }
    Ok((hidden, ga_hidden))
}

/// The scaled training and validation rows, the goal and the LM settings.
struct Prepared {
    scaling: Scaling,
    tr: Data,
    val: Option<Data>,
    goal: f64,
    act: Activation,
    lm_opts: lm::LmOptions,
    /// The rows' division, for the report.
    division: Division,
    /// Where the goal comes from.
    goal_rule: String,
    /// `--seed`.
    seed: u64,
}

fn prepare(ds: &Dataset, args: &BpOptions, kind: &str) -> Result<Prepared> {
    let (m, q) = (ds.inputs.len(), ds.targets.len());
    let (x, y) = ds.calibration_rows();
    let rows = x.len();
    if rows < 10 {
        bail!(
            "{kind}: {rows} calibration rows with every input and target: too few to train a net"
        );
    }
    let scaling = Scaling::from_rows(&x, &y, m, q);
    let all = Data {
        x: scaling.x(&x),
        t: scaling.y(&y),
    };
    let (tr_idx, val_idx) = division(rows, args.val_blocks, args.val_every);
    let tr = all.rows(&tr_idx);
    let val = (!val_idx.is_empty()).then(|| all.rows(&val_idx));
    let (goal, goal_rule) = match args.goal {
        Some(g) => (g, "--goal".to_string()),
        None => (
            0.5 * linear_mse(&tr)?,
            "half the training MSE of linear least squares on the same scaled rows".to_string(),
        ),
    };
    let act: Activation = args.activation.into();
    let division = Division {
        blocks: args.val_blocks,
        every: args.val_every,
        rule: "contiguous blocks; every K-th validates",
        train_rows: tr_idx.len(),
        validation_rows: val_idx.len(),
    };
    Ok(Prepared {
        scaling,
        tr,
        val,
        goal,
        act,
        lm_opts: lm::LmOptions {
            epochs: args.epochs,
            max_fail: args.max_fail,
            goal_mse: goal,
        },
        division,
        goal_rule,
        seed: args.seed,
    })
}

impl Prepared {
    /// The report of a net with `hidden` neurons (chosen by `hidden_rule`),
    /// `parameters` weights, trained by LM run `lm` (gabp's parts unset).
    fn details(
        &self,
        (hidden, hidden_rule): (usize, String),
        parameters: usize,
        lm: &lm::LmReport,
    ) -> BpDetails {
        BpDetails {
            activation: self.act.name(),
            convergence: None,
            division: self.division.clone(),
            ga: None,
            goal_mse: self.goal,
            goal_rule: self.goal_rule.clone(),
            hidden,
            hidden_rule,
            holdout: None,
            init: "Nguyen-Widrow (initnw)",
            lm: LmFigures::from(lm),
            output_activation: "purelin",
            parameters,
            scaling: "mapminmax to [-1, 1] over the calibration rows",
            seed: self.seed,
            training: "Levenberg-Marquardt (trainlm: mu 1e-3, x0.1/x10, mu_max 1e10)",
        }
    }

    fn lm(&self, shape: Shape, w0: &[f64], what: &str) -> lm::LmReport {
        run_lm(
            shape,
            self.act,
            w0,
            &self.tr,
            self.val.as_ref(),
            &self.lm_opts,
            what,
        )
    }
}

/// Fits `--model bp` (`genetic = false`) or `--model gabp`.
pub fn fit(ds: &Dataset, args: &BpOptions, genetic: bool) -> Result<Fitted> {
    let kind = if genetic { "gabp" } else { "bp" };
    let inputs = channels(ds)?;
    let outs = outputs(ds)?;
    let (m, q) = (ds.inputs.len(), ds.targets.len());
    let (hidden, ga_hidden) = checked_sizes(args, m, genetic, kind)?;
    let p = prepare(ds, args, kind)?;
    let mut rng = SplitMix64::new(args.seed);
    // BP alone: Nguyen-Widrow start, LM. This is `--model bp`, and gabp's
    // baseline. Its start is drawn in both cases, so the GA's draws follow
    // the same stream whether the baseline is trained or not.
    let bp_shape = Shape { m, n: hidden, q };
    let bp_w0 = init::nguyen_widrow(bp_shape, p.act, &mut rng);
    let (shape, w, details) = if genetic {
        let base = Baseline {
            shape: bp_shape,
            w0: &bp_w0,
        };
        fit_genetic(ds, args, &p, base, ga_hidden, &mut rng)?
    } else {
        let bp = p.lm(bp_shape, &bp_w0, "bp epochs (LM)");
        let rule = if args.hidden.is_some() {
            "--hidden".to_string()
        } else {
            format!("default {DEFAULT_HIDDEN} (seed 000's 4-10-3 net), capped by {MAX_W1} / inputs")
        };
        let d = p.details((hidden, rule), bp_shape.params(), &bp);
        (bp_shape, bp.w, d)
    };
    let net = net::to_bpnet(shape, p.act, &w, &p.scaling).map_err(|e| anyhow!("{kind}: {e}"))?;
    let model = Model {
        inputs,
        outputs: outs,
        dt_s: 0.0,
        params: Params::Bp(net),
        bounds: None,
        five_point: None,
    }
    .validate()
    .map_err(|e| anyhow!("fitted model refused: {e}"))?;
    Ok(Fitted {
        model,
        details: Details::Bp(Box::new(details)),
    })
}

/// BP at the default size from Nguyen-Widrow weights: what GA-BP is
/// compared with.
#[derive(Clone, Copy)]
struct Baseline<'a> {
    shape: Shape,
    w0: &'a [f64],
}

/// GA-BP (seed 000, Eq. 16-17): the GA picks the hidden size and the
/// initial weights, LM trains from its best individual. With
/// `--report-convergence`, also the comparison nets.
fn fit_genetic(
    ds: &Dataset,
    args: &BpOptions,
    p: &Prepared,
    base: Baseline,
    ga_hidden: (usize, usize),
    rng: &mut SplitMix64,
) -> Result<(Shape, Vec<f64>, BpDetails)> {
    let (m, q) = (ds.inputs.len(), ds.targets.len());
    let ga_opts = ga::GaOptions {
        population: args.ga_population,
        generations: args.ga_generations,
        crossover: args.ga_crossover,
        mutation: args.ga_mutation,
        hidden: ga_hidden,
    };
    let pb = progress(args.ga_generations, "gabp generations");
    let g = ga::evolve(m, q, p.act, &p.tr, &ga_opts, rng, Some(&pb));
    pb.finish_and_clear();
    let ga_shape = Shape { m, n: g.hidden, q };
    let gabp = p.lm(ga_shape, &g.w, "gabp epochs (LM)");
    let ga_net =
        net::to_bpnet(ga_shape, p.act, &gabp.w, &p.scaling).map_err(|e| anyhow!("gabp: {e}"))?;
    let rule = format!("chosen by the GA in {}..{}", ga_hidden.0, ga_hidden.1);
    let mut d = p.details((g.hidden, rule), ga_shape.params(), &gabp);
    d.ga = Some(GaFigures {
        best_train_mse: g
            .best_sse
            .iter()
            .map(|s| s / p.tr.errors() as f64)
            .collect(),
        crossover: args.ga_crossover,
        fitness: "1 / SSE of the scaled training rows (seed 000, Eq. 17)",
        generations: args.ga_generations,
        hidden_range: [ga_hidden.0, ga_hidden.1],
        mutation: args.ga_mutation,
        population: args.ga_population,
        seconds: g.seconds,
    });
    let gabp_conv = ConvergenceRow {
        ga_seconds: Some(g.seconds),
        ..ConvergenceRow::new(g.hidden, "GA best individual", &gabp, g.seconds)
    };
    let (conv, bp_holdout) = if args.report_convergence {
        let (conv, bp_holdout) = compare(ds, args, p, base, ga_shape, &g.w, gabp_conv)?;
        (conv, Some(bp_holdout))
    } else {
        let conv = Convergence {
            compared: Some("no: --report-convergence also trains BP at the default and the GA's size and the gradient-descent runs"),
            gd: None,
            goal_mse: p.goal,
            lm: LmComparison {
                bp: None,
                bp_same_hidden: None,
                gabp: gabp_conv,
            },
        };
        (conv, None)
    };
    d.convergence = Some(conv);
    d.holdout = Some(NetHoldouts {
        bp: bp_holdout,
        gabp: holdout_figures(ds, &ga_net)?,
    });
    Ok((ga_shape, gabp.w, d))
}

/// The convergence comparison of `--report-convergence`: BP (default size)
/// and BP at the GA's size from Nguyen-Widrow weights, trained by LM and,
/// with `--gd-epochs`, all three starts by gradient descent. Returns the
/// convergence report and BP's held-out figures.
fn compare(
    ds: &Dataset,
    args: &BpOptions,
    p: &Prepared,
    base: Baseline,
    ga_shape: Shape,
    ga_w: &[f64],
    gabp_conv: ConvergenceRow,
) -> Result<(Convergence, HoldoutFigures)> {
    let bp = p.lm(base.shape, base.w0, "bp epochs (LM)");
    // BP alone at the GA's hidden size: isolates what the GA's initial
    // weights buy from what its choice of size does.
    let same_w0 = init::nguyen_widrow(ga_shape, p.act, &mut SplitMix64::new(args.seed));
    let same = p.lm(ga_shape, &same_w0, "bp epochs at the GA's size (LM)");
    let gd = (args.gd_epochs > 0).then(|| {
        let run = |shape: Shape, w0: &[f64], what: &str| {
            let pb = progress(args.gd_epochs, what);
            let r = gd::train(shape, p.act, w0, &p.tr, args.gd_epochs, p.goal, Some(&pb));
            pb.finish_and_clear();
            GdRow::from(&r)
        };
        GdComparison {
            algorithm: "traingdx (lr 0.01, x1.05/x0.7, momentum 0.9), no early stop",
            bp: run(base.shape, base.w0, "bp epochs (gradient descent)"),
            bp_same_hidden: run(
                ga_shape,
                &same_w0,
                "bp epochs at the GA's size (gradient descent)",
            ),
            epoch_cap: args.gd_epochs,
            gabp: run(ga_shape, ga_w, "gabp epochs (gradient descent)"),
        }
    });
    let bp_net =
        net::to_bpnet(base.shape, p.act, &bp.w, &p.scaling).map_err(|e| anyhow!("bp: {e}"))?;
    let conv = Convergence {
        compared: None,
        gd,
        goal_mse: p.goal,
        lm: LmComparison {
            bp: Some(ConvergenceRow::new(base.shape.n, "Nguyen-Widrow", &bp, 0.0)),
            bp_same_hidden: Some(ConvergenceRow::new(ga_shape.n, "Nguyen-Widrow", &same, 0.0)),
            gabp: gabp_conv,
        },
    };
    Ok((conv, holdout_figures(ds, &bp_net)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn division_takes_every_kth_contiguous_block() {
        let (tr, val) = division(100, 20, 5);
        // Blocks of 5 rows; blocks 4, 9, 14, 19 validate: 20 rows in 4 runs.
        assert_eq!(val.len(), 20);
        assert_eq!(&val[..5], &[20, 21, 22, 23, 24]);
        assert_eq!(*val.last().unwrap(), 99);
        assert_eq!(tr.len() + val.len(), 100);
        assert!(division(100, 20, 0).1.is_empty());
        assert!(division(30, 20, 5).1.is_empty());
    }

    #[test]
    fn ranges_parse() {
        assert_eq!(parse_range("2..16").unwrap(), (2, 16));
        assert!(parse_range("2-16").is_err());
    }
}
