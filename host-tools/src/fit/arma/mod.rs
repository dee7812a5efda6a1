//! `thermcomp fit --model arma`: an ARMA forecaster of one thermal-error
//! series (seed 001, Yang et al. 2014, section 3 and 5.1).
//!
//! The pipeline, on the calibration part of the run resampled to `dt`:
//!
//! 1. Gaussian standardisation (seed 001 Eq. 8-9, lost in extraction):
//!    `z = (y - mean) / std`, `std` the sample standard deviation.
//! 2. [`adf`]: the ADF test with AIC lag choice; while it does not reject a
//!    unit root at `--adf-alpha`, difference once more (`w = nabla^d z`,
//!    `d <= --max-diff <= 2`). Seed 001 found its standardised series
//!    stationary (d = 0); a thermal drift over a day usually is not.
//! 3. [`acf`]: ACF and PACF of `w` (Eq. 14-16), reported for model
//!    identification; [`yule_walker`]: the AR estimates of Eq. 17-20.
//! 4. [`order`] + [`estimate`] + [`likelihood`]: every ARMA(p, q) up to
//!    `--max-p`, `--max-q` by exact Gaussian maximum likelihood, and the
//!    smallest AIC (Eq. 29) wins.
//! 5. The blob: `model_core::arma::Arma` with `c = mu (1 - sum phi)`.
//!
//! What the model is for, and what it is not, is in docs/arma.md: it
//! forecasts the error one step ahead from the *measured* error.

pub mod acf;
pub mod adf;
pub mod estimate;
pub mod likelihood;
pub mod mackinnon;
pub mod ols;
pub mod optimise;
pub mod order;
pub mod report;
pub mod transform;
pub mod yule_walker;

use super::{channels, outputs, Details, Fitted};
use crate::data::dataset::{Dataset, GridRun, RunData};
use anyhow::{anyhow, bail, Result};
use estimate::Estimate;
use model_core::arma::{Arma, ArmaState, MAX_ARMA_ORDER, MAX_DIFF};
use model_core::{Model, Params};
use report::{
    AdfStep, ArmaDetails, ArmaOrder, Forecasts, Horizon, Standardisation, YuleWalkerReport,
};

/// ACF/PACF lags reported in the JSON.
const REPORTED_LAGS: usize = 10;

/// ARMA options (`fit --model arma`); [`Default`] is `fit`'s defaults.
#[derive(Clone, Debug, PartialEq)]
pub struct ArmaOptions {
    /// arma: largest AR order tried (at most 10).
    pub max_p: usize,
    /// arma: largest MA order tried (at most 10).
    pub max_q: usize,
    /// arma: most differences taken while the ADF test keeps a unit root (at most 2).
    pub max_diff: usize,
    /// arma: ADF level: difference while the p-value is above it.
    pub adf_alpha: f64,
    /// arma: largest ADF lag tried (default statsmodels' ceil(12 (n/100)^(1/4))).
    pub adf_maxlag: Option<usize>,
    /// arma: Yule-Walker autocovariance divisor for the reported AR estimate.
    pub yw_method: yule_walker::Method,
}

impl ArmaOptions {
    /// `--max-p`, `--max-q`, `--max-diff` and `--adf-alpha` in their ranges.
    pub fn check(&self) -> Result<()> {
        if self.max_p > MAX_ARMA_ORDER || self.max_q > MAX_ARMA_ORDER {
            bail!("arma: --max-p and --max-q are at most {MAX_ARMA_ORDER}");
        }
        if self.max_diff > MAX_DIFF {
            bail!("arma: --max-diff is at most {MAX_DIFF}");
        }
        if !(self.adf_alpha > 0.0 && self.adf_alpha < 1.0) {
            bail!("arma: --adf-alpha must lie in (0, 1)");
        }
        Ok(())
    }
}

impl Default for ArmaOptions {
    fn default() -> Self {
        Self {
            max_p: 4,
            max_q: 4,
            max_diff: 2,
            adf_alpha: 0.05,
            adf_maxlag: None,
            yw_method: yule_walker::Method::Adjusted,
        }
    }
}

/// Everything the trainer decided, in the units the blob uses.
#[derive(Clone, Debug)]
pub struct ArmaFit {
    /// Standardisation mean (series units).
    pub mean: f64,
    /// Standardisation standard deviation (series units).
    pub std: f64,
    /// Differences taken.
    pub d: usize,
    /// The chosen ARMA of `w`.
    pub est: Estimate,
}

impl ArmaFit {
    /// The blob's coefficients (channel 0, output 0).
    pub fn to_blob(&self) -> Result<Arma> {
        Ok(Arma {
            channel: 0,
            output: 0,
            mean: self.mean,
            std: self.std,
            diff: u8::try_from(self.d)?,
            constant: self.est.constant(),
            phi: heapless::Vec::from_slice(&self.est.phi)
                .map_err(|_| anyhow!("arma: more than {MAX_ARMA_ORDER} AR terms"))?,
            theta: heapless::Vec::from_slice(&self.est.theta)
                .map_err(|_| anyhow!("arma: more than {MAX_ARMA_ORDER} MA terms"))?,
        })
    }

    /// The trainer's own one-step forecasts of `y` (series units), by the
    /// exact Kalman filter of [`likelihood`] with the fitted coefficients
    /// and mean, started from the stationary distribution at `y[0]`. The
    /// first `d` entries are NaN (no difference exists yet). After a
    /// burn-in they equal the blob's recursive forecasts (the filter's
    /// gain converges to the recursion's), which the tests check.
    pub fn one_step_forecasts(&self, y: &[f64]) -> Vec<f64> {
        let z: Vec<f64> = y.iter().map(|v| (v - self.mean) / self.std).collect();
        let w = difference(&z, self.d);
        let Some(f) =
            likelihood::filter(&w, &self.est.phi, &self.est.theta, Some(self.est.mu), true)
        else {
            return vec![f64::NAN; y.len()];
        };
        let mut out = vec![f64::NAN; self.d.min(y.len())];
        for (i, wp) in f.predictions.iter().enumerate() {
            let t = i + self.d;
            // z_t = w_t + (z_t - nabla^d z_t): the undifferenced part is known at t - 1.
            let zt = wp + (z[t] - w[i]);
            out.push(self.mean + self.std * zt);
        }
        out
    }
}

/// `nabla^d x` (length `n - d`).
pub fn difference(x: &[f64], d: usize) -> Vec<f64> {
    let mut w = x.to_vec();
    for _ in 0..d {
        w = w.windows(2).map(|p| p[1] - p[0]).collect();
    }
    w
}

fn median_step(t: &[f64]) -> Option<f64> {
    let mut steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    if steps.is_empty() {
        return None;
    }
    steps.sort_by(f64::total_cmp);
    Some(steps[steps.len() / 2])
}

fn rmse(a: impl Iterator<Item = (f64, f64)>) -> Option<f64> {
    let (mut s, mut n) = (0.0, 0usize);
    for (x, y) in a {
        if x.is_finite() && y.is_finite() {
            s += (x - y) * (x - y);
            n += 1;
        }
    }
    (n > 0).then(|| (s / n as f64).sqrt())
}

/// The blob run over `y` as the hub runs it: one-step forecasts, and free
/// runs (forecasts fed back, no more measurements) from `from`.
fn blob_forecasts(arma: &Arma, y: &[f64], from: usize) -> (Vec<f64>, Vec<f64>) {
    let mut st = ArmaState::default();
    let mut one = Vec::with_capacity(y.len());
    let mut free = Vec::new();
    for (k, &v) in y.iter().enumerate() {
        if k == from {
            let mut s = st;
            for _ in from..y.len() {
                let f = arma.forecast(&s);
                free.push(f);
                arma.observe(&mut s, f, f);
            }
        }
        let f = arma.forecast(&st);
        one.push(f);
        arma.observe(&mut st, v, f);
    }
    (one, free)
}

/// The calibration run's native step (median over its calibration part)
/// and the step the fit uses: `--dt-s`, or the native one.
fn sample_time(run: &RunData, dt_s: Option<f64>) -> Result<(Option<f64>, f64)> {
    let native = median_step(&run.t_s[..run.calib_end.max(2).min(run.t_s.len())]);
    let dt = match (dt_s, native) {
        (Some(dt), _) if dt.is_finite() && dt > 0.0 => dt,
        (Some(dt), _) => bail!("arma: --dt-s {dt} must be a positive number"),
        (None, Some(dt)) if dt > 0.0 => dt,
        _ => bail!("arma: {}: too few rows to tell the sample time", run.name),
    };
    Ok((native, dt))
}

/// The run `name` on the grid of step `dt`, with at least 20 finite
/// calibration samples of its target.
fn target_on_grid(ds: &Dataset, name: &str, target: &str, dt: f64) -> Result<GridRun> {
    let grid = ds
        .on_grid(dt)?
        .into_iter()
        .find(|g| g.name == name)
        .ok_or_else(|| anyhow!("arma: {name}: no span where the series has values"))?;
    let y_all = grid
        .y
        .first()
        .ok_or_else(|| anyhow!("arma: no target column"))?;
    let y = &y_all[..grid.calib_end];
    let n = y.len();
    if y.iter().any(|v| !v.is_finite()) {
        bail!("arma: {target} has a non-finite value");
    }
    if n < 20 {
        bail!("arma: {n} calibration samples at dt {dt} s are too few (need at least 20)");
    }
    Ok(grid)
}

/// Step 1, Gaussian standardisation: `(mean, std, z)` of `y`; fails on a
/// constant series.
fn standardise(y: &[f64], target: &str) -> Result<(f64, f64, Vec<f64>)> {
    let n = y.len();
    let mean = y.iter().sum::<f64>() / n as f64;
    let std = (y.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1) as f64).sqrt();
    if std.is_nan() || std <= 1e-12 * mean.abs().max(1.0) {
        bail!("arma: {target} is constant over the calibration part: nothing to model");
    }
    let z: Vec<f64> = y.iter().map(|v| (v - mean) / std).collect();
    Ok((mean, std, z))
}

/// The series differenced until the ADF test rejects a unit root.
struct Stationary {
    /// The differenced series.
    w: Vec<f64>,
    /// Differences taken.
    d: usize,
    /// Each ADF test's figures, `d` = 0 first.
    steps: Vec<AdfStep>,
    /// The last test rejected the unit root (else `--max-diff` stopped it).
    stationary: bool,
}

/// Step 2, ADF and differencing: differences `z` until the ADF test at
/// `--adf-alpha` rejects a unit root, at most `--max-diff` times (a
/// warning on stderr if it never does).
fn difference_to_stationary(z: &[f64], args: &ArmaOptions) -> Result<Stationary> {
    let mut w = z.to_vec();
    let mut d = 0;
    let mut steps = Vec::new();
    let stationary = loop {
        let t = adf::adfuller(&w, args.adf_maxlag).map_err(|e| anyhow!("arma: d = {d}: {e}"))?;
        let rejects = t.pvalue <= args.adf_alpha;
        steps.push(AdfStep {
            crit: mackinnon::CRIT_LEVELS
                .iter()
                .map(|k| k.to_string())
                .zip(t.crit)
                .collect(),
            d,
            maxlag: t.maxlag,
            nobs: t.nobs,
            pvalue: t.pvalue,
            rejects_unit_root: rejects,
            stat: t.stat,
            usedlag: t.usedlag,
        });
        if rejects {
            break true;
        }
        if d == args.max_diff {
            break false;
        }
        w = difference(&w, 1);
        d += 1;
    };
    if !stationary {
        eprintln!(
            "arma: warning: the ADF test keeps a unit root after {d} difference(s) (p > {}); fitting on d = {d} anyway",
            args.adf_alpha
        );
    }
    Ok(Stationary {
        w,
        d,
        steps,
        stationary,
    })
}

/// Step 4, the order by AIC over `(p, q)`: the table of every cell and the
/// best cell's estimate; the Yule-Walker AR estimate beside it.
fn choose_order(
    w: &[f64],
    args: &ArmaOptions,
) -> Result<(Vec<order::Cell>, Estimate, Option<YuleWalkerReport>)> {
    let (table, best) = order::search(w, args.max_p, args.max_q, true);
    let Some(best) = best else {
        let why = table
            .first()
            .and_then(|c| c.fit.as_ref().err().cloned())
            .unwrap_or_default();
        bail!("arma: no ARMA(p, q) could be fitted ({why})");
    };
    let est = table[best].fit.clone().map_err(|e| anyhow!("arma: {e}"))?;
    let yw = if est.p > 0 {
        let y = yule_walker::yule_walker(w, est.p, args.yw_method)?;
        Some(YuleWalkerReport {
            method: args.yw_method,
            order: est.p,
            phi: y.phi,
            sigma: y.sigma,
        })
    } else {
        None
    };
    Ok((table, est, yw))
}

/// Step 5, what the forecasts do on the grid `y_all` (calibration part
/// `..ce`, step `dt`): the trainer's and the blob's one-step forecasts, the
/// blob's free run from the end of calibration and at fixed horizons, and
/// persistence.
fn forecasts(fitted: &ArmaFit, arma: &Arma, y_all: &[f64], ce: usize, dt: f64) -> Forecasts {
    let y = &y_all[..ce];
    let trainer = fitted.one_step_forecasts(y_all);
    let (blob_one, free) = blob_forecasts(arma, y_all, ce);
    let held = y_all.len() - ce;
    let horizon = |steps: usize| {
        (steps > 0 && steps <= held).then(|| Horizon {
            abs_error_um: (free[steps - 1] - y_all[ce + steps - 1]).abs(),
            minutes: steps as f64 * dt / 60.0,
            steps,
        })
    };
    let held_out = || y_all[ce..].iter().copied();
    Forecasts {
        blob_one_step_rmse_calibration_um: rmse(
            blob_one[..ce].iter().copied().zip(y.iter().copied()),
        ),
        blob_one_step_rmse_held_out_um: rmse(blob_one[ce..].iter().copied().zip(held_out())),
        free_run_from_calibration_end_rmse_held_out_um: rmse(free.iter().copied().zip(held_out())),
        free_run_horizons: [1usize, 4, 40, 240, 960]
            .iter()
            .map(|h| horizon(*h))
            .collect(),
        persistence_rmse_held_out_um: rmse(
            y_all[ce.max(1) - 1..y_all.len() - 1]
                .iter()
                .copied()
                .zip(y_all[ce.max(1)..].iter().copied()),
        ),
        trainer_one_step_rmse_calibration_um: rmse(
            trainer[..ce].iter().copied().zip(y.iter().copied()),
        ),
    }
}

/// Fits `--model arma`.
/// `dt_s` is `--dt-s` (shared with arx and tf); default the run's median step.
pub fn fit(ds: &Dataset, args: &ArmaOptions, dt_s: Option<f64>) -> Result<Fitted> {
    let target = ds
        .targets
        .first()
        .ok_or_else(|| anyhow!("arma: no target"))?
        .clone();
    let calib_runs: Vec<_> = ds.runs.iter().filter(|r| r.calib_end > 0).collect();
    let [run] = calib_runs.as_slice() else {
        bail!(
            "arma: fits one calibration run, got {}; give one --data (more runs can be --validate)",
            calib_runs.len()
        );
    };
    let (native, dt) = sample_time(run, dt_s)?;
    let grid = target_on_grid(ds, &run.name, &target, dt)?;
    let (y_all, ce) = (&grid.y[0], grid.calib_end);
    let (mean, std, z) = standardise(&y_all[..ce], &target)?;
    let s = difference_to_stationary(&z, args)?;
    // 3. Identification figures.
    let lags = REPORTED_LAGS.min(s.w.len().saturating_sub(1));
    let acf = acf::acf(&s.w, lags);
    let pacf = acf::pacf(&s.w, lags);
    let (table, est, yw) = choose_order(&s.w, args)?;
    let fitted = ArmaFit {
        mean,
        std,
        d: s.d,
        est,
    };
    let arma = fitted.to_blob()?;
    let model = Model {
        inputs: channels(ds)?,
        outputs: outputs(ds)?,
        dt_s: dt,
        params: Params::Arma(arma.clone()),
        bounds: None,
        five_point: None,
    }
    .validate()
    .map_err(|e| {
        anyhow!("arma: fitted ARMA({}, {}) refused: {e} (a root on the unit circle? try smaller --max-p/--max-q)", fitted.est.p, fitted.est.q)
    })?;
    let e = &fitted.est;
    let details = ArmaDetails {
        acf,
        adf: s.steps,
        aic: e.aic,
        aic_table: table.iter().map(order::Cell::report).collect(),
        calibration_samples: ce,
        constant: e.constant(),
        d: s.d,
        dt_s: dt,
        forecasts: forecasts(&fitted, &arma, y_all, ce, dt),
        held_out_samples: y_all.len() - ce,
        innovation_std_um: e.sigma2.sqrt() * std,
        llf: e.llf,
        mu: e.mu,
        native_dt_s: native,
        order: ArmaOrder { p: e.p, q: e.q },
        pacf,
        phi: e.phi.clone(),
        series: target,
        sigma2: e.sigma2,
        standardisation: Standardisation { mean, std },
        stationary: s.stationary,
        theta: e.theta.clone(),
        yule_walker: yw,
    };
    Ok(Fitted {
        model,
        details: Details::Arma(Box::new(details)),
    })
}
