//! What `arma` reports (`details` in `fit --json`): the standardisation,
//! the ADF tests and differencing, ACF/PACF, the AIC table and the chosen
//! ARMA, and how its forecasts do. Fields are declared in the JSON's key
//! order; `um` figures are in the series' unit.

use super::order::CellReport;
use super::yule_walker::Method;
use serde::Serialize;
use std::collections::BTreeMap;

/// What `arma` reports.
#[derive(Clone, Debug, Serialize)]
pub struct ArmaDetails {
    /// ACF of the differenced series, lags 0..
    pub acf: Vec<f64>,
    /// Each ADF test, `d` = 0 first.
    pub adf: Vec<AdfStep>,
    /// AIC of the chosen model.
    pub aic: f64,
    /// Every (p, q) tried, in (p, q) order.
    pub aic_table: Vec<CellReport>,
    /// Calibration samples on the grid.
    pub calibration_samples: usize,
    /// The blob's constant `c = mu (1 - sum phi)`.
    pub constant: f64,
    /// Differences taken.
    pub d: usize,
    /// Model sample time, s.
    pub dt_s: f64,
    /// How the forecasts do.
    pub forecasts: Forecasts,
    /// Held-out samples on the grid.
    pub held_out_samples: usize,
    /// Innovation standard deviation in the series' unit.
    pub innovation_std_um: f64,
    /// Log-likelihood of the chosen model.
    pub llf: f64,
    /// Mean of the differenced, standardised series.
    pub mu: f64,
    /// The run's native sample time, s (`null` if it cannot be told).
    pub native_dt_s: Option<f64>,
    /// The chosen order.
    pub order: ArmaOrder,
    /// PACF of the differenced series, lags 0..
    pub pacf: Vec<f64>,
    /// AR coefficients.
    pub phi: Vec<f64>,
    /// The series forecast (the target column).
    pub series: String,
    /// Innovation variance (standardised units).
    pub sigma2: f64,
    /// Gaussian standardisation.
    pub standardisation: Standardisation,
    /// Whether the last ADF test rejected a unit root.
    pub stationary: bool,
    /// MA coefficients.
    pub theta: Vec<f64>,
    /// The Yule-Walker AR estimate of the chosen order (`null` for p = 0).
    pub yule_walker: Option<YuleWalkerReport>,
}

/// One ADF test of the (differenced) series.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AdfStep {
    /// Critical values per level (`1%`, `5%`, `10%`).
    pub crit: BTreeMap<String, f64>,
    /// Differences taken before the test.
    pub d: usize,
    /// Largest lag tried.
    pub maxlag: usize,
    /// Observations of the regression.
    pub nobs: usize,
    /// MacKinnon p-value.
    pub pvalue: f64,
    /// Whether it rejects a unit root at `--adf-alpha`.
    pub rejects_unit_root: bool,
    /// The test statistic.
    pub stat: f64,
    /// Lag chosen by AIC.
    pub usedlag: usize,
}

/// An ARMA order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct ArmaOrder {
    /// AR order.
    pub p: usize,
    /// MA order.
    pub q: usize,
}

/// `z = (y - mean) / std`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Standardisation {
    /// Mean, series unit.
    pub mean: f64,
    /// Sample standard deviation, series unit.
    pub std: f64,
}

/// The Yule-Walker AR estimate.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct YuleWalkerReport {
    /// `--yw-method`.
    pub method: Method,
    /// AR order.
    pub order: usize,
    /// AR coefficients.
    pub phi: Vec<f64>,
    /// Innovation standard deviation (standardised units).
    pub sigma: f64,
}

/// How the forecasts do, series unit (`null`: nothing to score).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Forecasts {
    /// RMS error of the blob's one-step forecasts on the calibration part.
    pub blob_one_step_rmse_calibration_um: Option<f64>,
    /// RMS error of the blob's one-step forecasts on the held-out part.
    pub blob_one_step_rmse_held_out_um: Option<f64>,
    /// RMS error of the blob's free run from the end of calibration.
    pub free_run_from_calibration_end_rmse_held_out_um: Option<f64>,
    /// The free run's error at 1, 4, 40, 240 and 960 steps (`null` beyond the run).
    pub free_run_horizons: Vec<Option<Horizon>>,
    /// RMS error of persistence (the last value) on the held-out part.
    pub persistence_rmse_held_out_um: Option<f64>,
    /// RMS error of the trainer's one-step forecasts on the calibration part.
    pub trainer_one_step_rmse_calibration_um: Option<f64>,
}

/// The free run's error at one horizon.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Horizon {
    /// |forecast - measured|, series unit.
    pub abs_error_um: f64,
    /// The horizon, minutes.
    pub minutes: f64,
    /// The horizon, steps.
    pub steps: usize,
}
