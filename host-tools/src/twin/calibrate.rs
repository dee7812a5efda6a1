//! Grey-box calibration of the twin to a measured run: the network keeps its
//! structure and physics; a few physical factors are fitted so that the
//! twin, driven by the run's logged speed, reproduces the run's
//! displacements and temperatures on its calibration part.
//!
//! **Nonlinear parameters** `theta` (fitted by bounded Levenberg–Marquardt,
//! [`super::lm`], on logs so factors stay positive):
//!
//! | parameter | scales | why |
//! |---|---|---|
//! | `heat_factor` | every speed loss (bearings, motor idle and iron) | heat gains of a new machine are known to a factor of 2-3 |
//! | `bearing_exponent` | `b` in `Q = Q_ref (n/n_ref)^b` (plain, not a log) | Palmgren 5/3; 1-2 in practice |
//! | `capacity_factor` | every heat capacity | time constants (masses are rarely known) |
//! | `g_ambient_factor` | every conductance to ambient | equilibrium level vs time constant |
//!
//! **Linear parameters**, solved exactly for each `theta` (variable
//! projection, Golub & Pereyra 1973): the node rises `dT_i(t; theta)` come
//! from one simulation from rest; then
//!
//! ```text
//! displacement channel d:  y_d(t) ~ sum_i c_di dT_i(t)               (least squares, um/K)
//! temperature channel j:   y_j(t) ~ o_j + (1 - s_j) dT_a(t) + s_j dT_b(t)   (a, b, s_j in 0..1, o_j)
//! ```
//!
//! where `a, b` are two of the seven nodes, or `a = b` is a node or one of
//! the two boundaries (rise 0): a sensor sits on a part, between two parts,
//! or in the air or coolant (gain 1: a thermometer reads temperature, it
//! is not fitted; a share toward a boundary is excluded because it would be
//! a free gain below 1 that makes the heat factor unidentifiable). The pair of each sensor is chosen by the
//! smallest error; since that choice is discrete, it is fixed while the
//! optimiser runs and re-chosen after it (block coordinate descent, at most
//! [`MAX_ROUNDS`] rounds, stopped when no pair changes).
//!
//! The cost is `0.5 sum_channels w_ch sum_rows (y - yhat)^2` with
//! `w_ch = 1 / (n_ch scale_ch^2 n_group group_size)`: every channel counts as
//! its unexplained variance fraction, displacements and temperatures
//! half each, so sixteen thermometers do not outvote five probes.
//!
//! The start is the best of a 3 x 3 grid of heat and capacity factors (a
//! wrong start by a factor of 3 is typical for a machine that is not the
//! default); the boundary temperature `T0` (ambient = coolant at rest) is the
//! median of the sensors' fitted levels at rest, and each sensor keeps its
//! difference from it as `offset_c`. Method and numbers: docs/twin.md.
//!
//! [`calibrate_with`] takes a [`Setup`]: a start for the factors, sensor
//! places pinned per channel, and an effect driving the simulation
//! ([`super::drive`]) whose parameters are appended to `theta` and fitted
//! with the factors (`diagnose --machine`). [`calibrate`] is the nominal
//! setup.

use super::drive::{self, Drive, FittedEffect, Rises, N_PLACES};
use super::lm::{self, LmOptions};
use super::machine::{DisplacementOutput, Machine, Node, SensorSite, Site, N_NODES};
use super::network::Network;
use super::param::{to_theta, to_values, ParamDef};
use super::profile::{self, Profile, Schedule};
use crate::data::runfile::{is_temperature_column, ReadOptions, RunFile};
use crate::num::lsq;
use anyhow::{anyhow, bail, Context, Result};
use serde_json::{json, Value};
use std::path::Path;

/// Re-choices of the sensor places at most (a change after three rounds
/// would mean a sensor sits between two equally good places).
pub const MAX_ROUNDS: usize = 3;
/// Below this spread a channel's scale is floored: weighting a sensor that
/// barely moved by its own spread would let its noise steer the fit
/// (0.1 K is five times the PT100 noise; 1 um ten times the probe noise).
const MIN_SCALE_C: f64 = 0.1;
/// See [`MIN_SCALE_C`].
const MIN_SCALE_UM: f64 = 1.0;

/// The nonlinear parameters, in `theta` order. Bounds keep the network
/// physical (every capacity, conductance and heat positive) and exclude
/// factors no real spindle needs (50x the default's losses is 35 kW of
/// idle losses).
pub const PARAMS: [ParamDef; 4] = [
    ParamDef {
        name: "heat_factor",
        unit: "x",
        lo: 0.02,
        hi: 50.0,
        log: true,
    },
    ParamDef {
        name: "bearing_exponent",
        unit: "1",
        // Friction laws in the literature: 1 (Coulomb-like) to 2; margin.
        lo: 0.8,
        hi: 2.5,
        log: false,
    },
    ParamDef {
        name: "capacity_factor",
        unit: "x",
        lo: 0.02,
        hi: 50.0,
        log: true,
    },
    ParamDef {
        name: "g_ambient_factor",
        unit: "x",
        lo: 0.1,
        hi: 10.0,
        log: true,
    },
];

/// Number of nonlinear parameters.
pub const N_PARAMS: usize = PARAMS.len();

/// One measured channel.
#[derive(Debug, Clone)]
pub struct Series {
    /// Column name.
    pub name: String,
    /// Values on the schedule's rows (`None`: empty cell).
    pub values: Vec<Option<f64>>,
    /// Rows with a value before the calibration end.
    pub fit_rows: Vec<usize>,
    /// Rows with a value from the calibration end on.
    pub rest_rows: Vec<usize>,
    /// Spread on the fit rows (floored), channel unit.
    pub scale: f64,
}

/// A measured run ready for calibration.
#[derive(Debug, Clone)]
pub struct Measured {
    /// The run's speed on its own grid (as `--profile file:` reads it).
    pub schedule: Schedule,
    /// `*_um` columns (displacements).
    pub disp: Vec<Series>,
    /// `T<n>` columns.
    pub temps: Vec<Series>,
    /// Calibration part: rows with `t_s < until_s`.
    pub until_s: f64,
    /// Rows before `until_s`.
    pub n_fit: usize,
}

impl Measured {
    /// Reads a run file; calibration on `t_s < until_s` (default the middle).
    pub fn read(path: &Path, until_s: Option<f64>) -> Result<Measured> {
        let schedule = profile::schedule(&Profile::File(path.to_path_buf()), 1.0, None, 1.0, 0)?;
        let run = RunFile::read(path, &ReadOptions::default())?;
        let t = &schedule.t_s;
        let (Some(&t0), Some(&t1)) = (t.first(), t.last()) else {
            bail!("{}: no data rows to calibrate to", path.display());
        };
        let until_s = until_s.unwrap_or(0.5 * (t0 + t1));
        if !until_s.is_finite() {
            bail!("--calibrate-until-s must be finite");
        }
        let n_fit = t.partition_point(|&x| x < until_s);
        if n_fit == 0 {
            bail!(
                "{}: no row before --calibrate-until-s {until_s} (the run starts at t_s = {t0}): \
                 nothing to calibrate to",
                path.display()
            );
        }
        // The twin's parameters scale the spindle's heat: a calibration part
        // where it never turns has nothing to fit them to.
        if schedule.speed_rpm[..n_fit].iter().all(|&v| v == 0.0) {
            bail!(
                "{}: speed_rpm is 0 on every row before --calibrate-until-s {until_s}: \
                 nothing heats the twin there, so nothing can be calibrated",
                path.display()
            );
        }
        // 30 rows: enough to see a time constant; 4 parameters + 7 gains.
        if n_fit < 30 {
            bail!(
                "{}: only {n_fit} rows before --calibrate-until-s {until_s} (the run spans {t0} .. {t1} s); at least 30 are needed",
                path.display()
            );
        }
        let series = |name: &str, unit_floor: f64| -> Option<Series> {
            let values = run.column(name)?.to_options();
            Some(series(name, values, n_fit, unit_floor))
        };
        let is_disp = |c: &&String| c.ends_with("_um");
        let disp: Vec<Series> = run
            .columns
            .iter()
            .filter(is_disp)
            .filter_map(|c| series(c, MIN_SCALE_UM))
            .collect();
        let temps: Vec<Series> = run
            .columns
            .iter()
            .filter(|c| is_temperature_column(c))
            .filter_map(|c| series(c, MIN_SCALE_C))
            .collect();
        if disp.is_empty() && temps.is_empty() {
            bail!(
                "{}: no displacement (*_um) or temperature (T<n>) column to calibrate to",
                path.display()
            );
        }
        if let Some(s) = disp.iter().chain(&temps).find(|s| s.fit_rows.len() < 30) {
            bail!(
                "{}: column {} has only {} values in the calibration part (at least 30 are needed)",
                path.display(),
                s.name,
                s.fit_rows.len()
            );
        }
        Ok(Measured {
            schedule,
            disp,
            temps,
            until_s,
            n_fit,
        })
    }
}

fn series(name: &str, values: Vec<Option<f64>>, n_fit: usize, floor: f64) -> Series {
    let fit_rows: Vec<usize> = (0..n_fit).filter(|&k| values[k].is_some()).collect();
    let rest_rows: Vec<usize> = (n_fit..values.len())
        .filter(|&k| values[k].is_some())
        .collect();
    let v: Vec<f64> = fit_rows.iter().filter_map(|&k| values[k]).collect();
    let scale = std_dev(&v).max(floor);
    Series {
        name: name.to_string(),
        values,
        fit_rows,
        rest_rows,
        scale,
    }
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

fn std_dev(v: &[f64]) -> f64 {
    let m = mean(v);
    (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len().max(1) as f64).sqrt()
}

/// `theta` of a machine as it is (factors 1, its own exponent).
pub fn theta_of(base: &Machine) -> [f64; N_PARAMS] {
    [0.0, base.heat.bearing_exponent, 0.0, 0.0]
}

/// Parameter values (factors, exponent) from `theta`.
pub fn values(theta: &[f64]) -> [f64; N_PARAMS] {
    let mut v = [0.0; N_PARAMS];
    for (slot, x) in v.iter_mut().zip(to_values(&PARAMS, theta)) {
        *slot = x;
    }
    v
}

/// `base` with the factors of `theta` applied (a valid machine: every
/// factor is positive).
pub fn scaled(base: &Machine, theta: &[f64]) -> Machine {
    let [heat, exponent, capacity, g_amb] = values(theta);
    let mut m = base.clone();
    let h = &mut m.heat;
    h.front_bearing_w_at_ref *= heat;
    h.rear_bearing_w_at_ref *= heat;
    h.motor_idle_w *= heat;
    h.motor_iron_w_at_ref *= heat;
    h.bearing_exponent = exponent;
    for p in m.nodes.each_mut() {
        p.c_j_per_k *= capacity;
        p.g_ambient_w_per_k *= g_amb;
    }
    m
}

/// Node temperature rises above the state at rest, for the first `rows`
/// rows of `s`, with constant boundaries and the air-cutting speed losses
/// (the nominal twin: the network is linear, so the rises do not depend on
/// the boundary temperature).
pub fn node_rises(m: &Machine, s: &Schedule, rows: usize) -> Vec<Rises> {
    drive::rises(m, s, rows, &Drive::default())
}

/// Rise of place `p` (a node index, or a boundary: 0 unless a drive moves it).
fn place_rise(r: &Rises, p: usize) -> f64 {
    r[p]
}

/// A temperature channel's fitted place: `o + (1 - s) dT_a + s dT_b`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TempFit {
    /// First place (index into nodes, then ambient, coolant).
    pub a: usize,
    /// Second place.
    pub b: usize,
    /// Share of `b`, 0..=1.
    pub share: f64,
    /// Level at rest, deg C.
    pub offset_c: f64,
}

impl TempFit {
    /// The prediction for rises `r`.
    pub fn predict(&self, r: &Rises) -> f64 {
        self.offset_c
            + (1.0 - self.share) * place_rise(r, self.a)
            + self.share * place_rise(r, self.b)
    }
}

/// Best `(share, offset)` for a fixed place pair on the fit rows, and the
/// error sum of squares.
fn fit_pair(rises: &[Rises], s: &Series, a: usize, b: usize) -> (TempFit, f64) {
    let rows = &s.fit_rows;
    let ys: Vec<(f64, f64)> = rows
        .iter()
        .map(|&k| {
            let ra = place_rise(&rises[k], a);
            (
                s.values[k].unwrap_or(0.0) - ra,
                place_rise(&rises[k], b) - ra,
            )
        })
        .collect();
    let n = ys.len().max(1) as f64;
    let (my, md) = (
        ys.iter().map(|p| p.0).sum::<f64>() / n,
        ys.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let (mut sdd, mut syd) = (0.0, 0.0);
    for (y, d) in &ys {
        sdd += (d - md).powi(2);
        syd += (y - my) * (d - md);
    }
    let share = if a == b || sdd <= 1e-18 {
        0.0
    } else {
        (syd / sdd).clamp(0.0, 1.0)
    };
    let offset_c = my - share * md;
    let sse = ys
        .iter()
        .map(|(y, d)| (y - offset_c - share * d).powi(2))
        .sum();
    (
        TempFit {
            a,
            b,
            share,
            offset_c,
        },
        sse,
    )
}

/// The best place pair of every temperature channel (a pinned channel
/// keeps its pair and only gets its share and offset).
fn choose_places(sim: &Sim, temps: &[Series], pinned: &[Option<(usize, usize)>]) -> Vec<TempFit> {
    temps
        .iter()
        .enumerate()
        .map(|(j, s)| {
            let rises = sim.temp(j);
            if let Some(&Some((a, b))) = pinned.get(j) {
                return fit_pair(rises, s, a, b).0;
            }
            let mut best: Option<(TempFit, f64)> = None;
            for a in 0..N_PLACES {
                // Between two nodes, or on one place alone: a share toward
                // a boundary (rise 0) would be a free gain below 1, and
                // "heat x k, every sensor (k - 1)/k toward the air" would
                // fit as well as the truth: the heat would not be
                // identifiable.
                let last = if a < N_NODES { N_NODES - 1 } else { a };
                for b in a..=last {
                    let (f, sse) = fit_pair(rises, s, a, b);
                    if best.as_ref().is_none_or(|(_, e)| sse < *e) {
                        best = Some((f, sse));
                    }
                }
            }
            best.map_or(
                TempFit {
                    a: 0,
                    b: 0,
                    share: 0.0,
                    offset_c: 0.0,
                },
                |(f, _)| f,
            )
        })
        .collect()
}

/// Least-squares um/K per node rise for a displacement channel (SVD with a
/// rank tolerance, [`lsq::fit`]: node rises are strongly correlated, and
/// the tolerance keeps the solution bounded where they are collinear).
fn fit_displacement(rises: &[Rises], s: &Series) -> [f64; N_NODES] {
    let cols: Vec<Vec<f64>> = (0..N_NODES)
        .map(|i| s.fit_rows.iter().map(|&k| rises[k][i]).collect())
        .collect();
    let y: Vec<f64> = s.fit_rows.iter().filter_map(|&k| s.values[k]).collect();
    let coef = lsq::fit(&cols, &y, y.len()).map_or(vec![0.0; N_NODES], |f| f.coef);
    std::array::from_fn(|i| coef.get(i).copied().unwrap_or(0.0))
}

fn disp_predict(c: &[f64; N_NODES], r: &Rises) -> f64 {
    c.iter().zip(r).map(|(a, b)| a * b).sum()
}

/// The linear part for one `theta`: gains per displacement channel, place
/// fits per temperature channel (places fixed if given).
#[derive(Debug, Clone)]
struct Linear {
    disp: Vec<[f64; N_NODES]>,
    temps: Vec<TempFit>,
}

/// One simulation's rises: as the displacements see them, and as each
/// temperature channel reads them (lagged if a drive lags its sensor).
struct Sim {
    rises: Vec<Rises>,
    lagged: Vec<Option<Vec<Rises>>>,
}

impl Sim {
    /// The first `rows` rows of `data`'s run on machine `m` with `d`.
    fn run(m: &Machine, data: &Measured, rows: usize, d: &Drive) -> Sim {
        let rises = drive::rises(m, &data.schedule, rows, d);
        let lagged = (0..data.temps.len())
            .map(|j| {
                d.lag_s(j)
                    .map(|tau| drive::lagged(&rises, &data.schedule.t_s, tau))
            })
            .collect();
        Sim { rises, lagged }
    }

    /// What temperature channel `j` reads.
    fn temp(&self, j: usize) -> &[Rises] {
        self.lagged
            .get(j)
            .and_then(Option::as_deref)
            .unwrap_or(&self.rises)
    }
}

fn solve_linear(
    sim: &Sim,
    data: &Measured,
    places: Option<&[TempFit]>,
    pinned: &[Option<(usize, usize)>],
) -> Linear {
    let disp = data
        .disp
        .iter()
        .map(|s| fit_displacement(&sim.rises, s))
        .collect();
    let temps = match places {
        None => choose_places(sim, &data.temps, pinned),
        Some(p) => data
            .temps
            .iter()
            .zip(p)
            .enumerate()
            .map(|(j, (s, f))| fit_pair(sim.temp(j), s, f.a, f.b).0)
            .collect(),
    };
    Linear { disp, temps }
}

/// The weighted residual vector on the fit rows (module docs: the cost).
fn weighted_residual(sim: &Sim, data: &Measured, lin: &Linear) -> Vec<f64> {
    let groups = usize::from(!data.disp.is_empty()) + usize::from(!data.temps.is_empty());
    let mut r = Vec::new();
    let mut push = |s: &Series, group: usize, rises: &[Rises], pred: &dyn Fn(&Rises) -> f64| {
        let w = 1.0 / (s.scale * ((s.fit_rows.len() * group * groups) as f64).sqrt());
        for &k in &s.fit_rows {
            r.push(w * (s.values[k].unwrap_or(0.0) - pred(&rises[k])));
        }
    };
    for (s, c) in data.disp.iter().zip(&lin.disp) {
        push(s, data.disp.len(), &sim.rises, &|x| disp_predict(c, x));
    }
    for (j, (s, f)) in data.temps.iter().zip(&lin.temps).enumerate() {
        push(s, data.temps.len(), sim.temp(j), &|x| f.predict(x));
    }
    r
}

/// The problem a calibration solves: a base machine, a measured run and
/// the setup; `theta` is the machine's factors, then the effect's
/// parameters (logs where [`ParamDef::log`]).
struct Ctx<'a> {
    base: &'a Machine,
    data: &'a Measured,
    setup: &'a Setup<'a>,
    defs: Vec<ParamDef>,
}

impl<'a> Ctx<'a> {
    fn new(base: &'a Machine, data: &'a Measured, setup: &'a Setup<'a>) -> Self {
        let mut defs = PARAMS.to_vec();
        defs.extend(setup.effect.map(|e| e.params()).unwrap_or_default());
        Ctx {
            base,
            data,
            setup,
            defs,
        }
    }

    /// The drive for `theta` (nominal without an effect).
    fn drive(&self, theta: &[f64]) -> Drive {
        match self.setup.effect {
            Some(e) => e.drive(&to_values(&self.defs[N_PARAMS..], &theta[N_PARAMS..])),
            None => Drive::default(),
        }
    }

    /// One evaluation: simulate the fit part, project, weigh.
    fn evaluate(&self, theta: &[f64], places: Option<&[TempFit]>) -> (Vec<f64>, Linear) {
        let m = scaled(self.base, theta);
        let sim = Sim::run(&m, self.data, self.data.n_fit, &self.drive(theta));
        let lin = solve_linear(&sim, self.data, places, self.setup.pinned);
        (weighted_residual(&sim, self.data, &lin), lin)
    }

    fn cost(&self, theta: &[f64]) -> f64 {
        half_sq(&self.evaluate(theta, None).0)
    }
}

fn half_sq(r: &[f64]) -> f64 {
    0.5 * r.iter().map(|v| v * v).sum::<f64>()
}

/// Fit figures of one channel on one part.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PartFit {
    /// Rows compared.
    pub n: usize,
    /// Root mean square error, channel unit.
    pub rmse: f64,
    /// `(1 - |y - yhat| / |y - mean y|) 100` (CONTRACT.md: the "fit").
    pub fit_pct: f64,
}

/// A channel's fit on the calibration part and on the rest.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelFit {
    /// Column name.
    pub name: String,
    /// `um` or `c`.
    pub unit: &'static str,
    /// Calibration part.
    pub calibration: PartFit,
    /// The rest of the run (`None` if it has no rows).
    pub rest: Option<PartFit>,
    /// The calibrated twin's value on every row of the run.
    pub pred: Vec<f64>,
}

fn part_fit(s: &Series, rows: &[usize], pred: &[f64]) -> Option<PartFit> {
    if rows.is_empty() {
        return None;
    }
    let y: Vec<f64> = rows.iter().filter_map(|&k| s.values[k]).collect();
    let e: f64 = rows
        .iter()
        .zip(&y)
        .map(|(&k, v)| (v - pred[k]).powi(2))
        .sum();
    let m = mean(&y);
    let d: f64 = y.iter().map(|v| (v - m).powi(2)).sum();
    Some(PartFit {
        n: y.len(),
        rmse: (e / y.len() as f64).sqrt(),
        fit_pct: if d > 0.0 {
            (1.0 - (e / d).sqrt()) * 100.0
        } else {
            f64::NAN
        },
    })
}

/// Optimiser options of a calibration.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CalibrateOptions {
    /// Levenberg–Marquardt stopping rules.
    pub lm: LmOptions,
    /// Draw a progress bar on stderr.
    pub progress: bool,
}

/// What a calibration solves besides the nominal problem (`diagnose
/// --machine`): where to start, sensor places known from the machine, and
/// an effect switched on whose parameters are fitted with the factors.
/// `Setup::default()` is the nominal calibration.
#[derive(Clone, Copy, Default)]
pub struct Setup<'a> {
    /// Start of the machine's factors (`theta`, [`theta_of`] for the base
    /// as it is); `None`: the best of the 3 x 3 grid.
    pub start: Option<[f64; N_PARAMS]>,
    /// Per temperature channel (the measured run's order) a place pair
    /// (indices into nodes, then ambient, coolant) kept throughout, only
    /// its share and offset fitted; `None` or past the end: chosen.
    pub pinned: &'a [Option<(usize, usize)>],
    /// An effect switched on.
    pub effect: Option<&'a dyn FittedEffect>,
}

/// A calibrated machine and how it was reached.
#[derive(Debug, Clone)]
pub struct Calibration {
    /// The calibrated machine (base with factors, sensor places, outputs).
    pub machine: Machine,
    /// Fitted `theta`.
    pub theta: [f64; N_PARAMS],
    /// Start chosen from the grid.
    pub start: [f64; N_PARAMS],
    /// The effect's fitted parameter values (empty without an effect).
    pub effect: Vec<f64>,
    /// Final cost (half the weighted sum of squares; each channel weighs
    /// its unexplained variance fraction).
    pub cost: f64,
    /// LM iterations over all rounds.
    pub iterations: usize,
    /// Simulations over all rounds and the start grid.
    pub evaluations: usize,
    /// Rounds of place choice.
    pub rounds: usize,
    /// Whether the last LM run met a tolerance and the places settled.
    pub converged: bool,
    /// The last LM run's stopping rule.
    pub reason: &'static str,
    /// Fit per channel, displacements first.
    pub channels: Vec<ChannelFit>,
    /// Calibration part end, s.
    pub until_s: f64,
    /// Wall time, s.
    pub elapsed_s: f64,
}

/// The machine's start: best of heat x capacity factors {1/3, 1, 3}^2
/// around `base` (the effect at its first start), or the setup's.
fn start_machine(ctx: &Ctx) -> (Vec<f64>, usize) {
    let effect0 = ctx
        .setup
        .effect
        .and_then(|e| e.starts().into_iter().next())
        .map(|v| to_theta(&ctx.defs[N_PARAMS..], &v))
        .unwrap_or_default();
    let with = |m: [f64; N_PARAMS]| -> Vec<f64> { m.iter().chain(&effect0).copied().collect() };
    if let Some(s) = ctx.setup.start {
        return (with(s), 0);
    }
    let t0 = theta_of(ctx.base);
    let mut best = (with(t0), f64::INFINITY);
    let mut evals = 0;
    for h in [1.0f64 / 3.0, 1.0, 3.0] {
        for c in [1.0f64 / 3.0, 1.0, 3.0] {
            let mut th = t0;
            th[0] = h.ln();
            th[2] = c.ln();
            let cost = ctx.cost(&with(th));
            evals += 1;
            if cost < best.1 {
                best = (with(th), cost);
            }
        }
    }
    (best.0, evals)
}

/// The start: the machine's, then the effect's best start with it.
fn start_point(ctx: &Ctx) -> (Vec<f64>, usize) {
    let (machine, mut evals) = start_machine(ctx);
    let Some(e) = ctx.setup.effect else {
        return (machine, evals);
    };
    let mut best = (machine.clone(), f64::INFINITY);
    for v in e.starts() {
        let mut th = machine[..N_PARAMS].to_vec();
        th.extend(to_theta(&ctx.defs[N_PARAMS..], &v));
        let cost = ctx.cost(&th);
        evals += 1;
        if cost < best.1 {
            best = (th, cost);
        }
    }
    (best.0, evals)
}

/// Calibrates `base` to `data` (module docs: the method).
pub fn calibrate(base: &Machine, data: &Measured, opts: &CalibrateOptions) -> Result<Calibration> {
    calibrate_with(base, data, &Setup::default(), opts)
}

/// Figures of the optimiser over the rounds of place choice.
struct Rounds {
    theta: Vec<f64>,
    places: Vec<TempFit>,
    iterations: usize,
    evaluations: usize,
    rounds: usize,
    converged: bool,
    reason: &'static str,
}

/// Levenberg-Marquardt with the places fixed, then the places re-chosen,
/// until they settle (at most [`MAX_ROUNDS`]; pinned places never move).
fn optimise(ctx: &Ctx, theta: Vec<f64>, opts: &CalibrateOptions) -> Result<Rounds> {
    let bound = |b: fn(&ParamDef) -> f64| -> Vec<f64> {
        let v: Vec<f64> = ctx.defs.iter().map(b).collect();
        to_theta(&ctx.defs, &v)
    };
    let (lo, hi) = (bound(|p| p.lo), bound(|p| p.hi));
    let mut out = Rounds {
        places: ctx.evaluate(&theta, None).1.temps,
        theta,
        iterations: 0,
        evaluations: 0,
        rounds: 0,
        converged: false,
        reason: "",
    };
    let pb = opts
        .progress
        .then(|| crate::num::progress::progress(MAX_ROUNDS * opts.lm.max_iter, "calibrate"));
    let mut settled = false;
    while out.rounds < MAX_ROUNDS && !settled {
        out.rounds += 1;
        let fixed = out.places.clone();
        let mut f = |th: &[f64]| -> Result<Vec<f64>> {
            let r = ctx.evaluate(th, Some(&fixed)).0;
            if r.iter().all(|v| v.is_finite()) {
                Ok(r)
            } else {
                bail!("the twin diverged at theta = {th:?}")
            }
        };
        let (done, round) = (out.iterations, out.rounds);
        let res = lm::minimize(&mut f, &out.theta, &lo, &hi, &opts.lm, &mut |it, cost| {
            if let Some(pb) = &pb {
                pb.set_position((done + it) as u64);
                pb.set_message(format!("calibrate (round {round}, cost {cost:.5})"));
            }
        })?;
        out.iterations += res.iterations;
        out.evaluations += res.evaluations + 1;
        out.theta = res.x;
        let again = ctx.evaluate(&out.theta, None).1.temps;
        settled = again
            .iter()
            .zip(&out.places)
            .all(|(a, b)| (a.a, a.b) == (b.a, b.b));
        out.places = again;
        (out.converged, out.reason) = (res.converged && settled, res.reason);
    }
    if let Some(pb) = pb {
        pb.finish_and_clear();
    }
    Ok(out)
}

/// Calibrates `base` to `data` with `setup` (an effect's parameters are
/// fitted alongside the factors: [`Calibration::effect`]).
pub fn calibrate_with(
    base: &Machine,
    data: &Measured,
    setup: &Setup,
    opts: &CalibrateOptions,
) -> Result<Calibration> {
    let started = std::time::Instant::now();
    let ctx = Ctx::new(base, data, setup);
    let (start, start_evals) = start_point(&ctx);
    let r = optimise(&ctx, start.clone(), opts)?;
    finish(&ctx, &r.theta, &start, &r.places, started)
        .map(|c| Calibration {
            iterations: r.iterations,
            evaluations: start_evals + r.evaluations,
            rounds: r.rounds,
            converged: r.converged,
            reason: r.reason,
            ..c
        })
        .context("building the calibrated machine")
}

/// The calibrated machine and the per-channel fit over the whole run.
fn finish(
    ctx: &Ctx,
    theta: &[f64],
    start: &[f64],
    places: &[TempFit],
    started: std::time::Instant,
) -> Result<Calibration> {
    let data = ctx.data;
    let mut machine = scaled(ctx.base, theta);
    let drive = ctx.drive(theta);
    let fit_sim = Sim::run(&machine, data, data.n_fit, &drive);
    let lin = solve_linear(&fit_sim, data, Some(places), ctx.setup.pinned);
    let cost = half_sq(&weighted_residual(&fit_sim, data, &lin));
    let sim = Sim::run(&machine, data, data.schedule.t_s.len(), &drive);
    let mut channels = Vec::new();
    for (s, c) in data.disp.iter().zip(&lin.disp) {
        let pred: Vec<f64> = sim.rises.iter().map(|r| disp_predict(c, r)).collect();
        channels.push(channel_fit(s, "um", pred));
    }
    for (j, (s, f)) in data.temps.iter().zip(&lin.temps).enumerate() {
        let pred: Vec<f64> = sim.temp(j).iter().map(|r| f.predict(r)).collect();
        channels.push(channel_fit(s, "c", pred));
    }
    apply_outputs(&mut machine, data, &lin);
    let machine_theta = |v: &[f64]| std::array::from_fn(|i| v[i]);
    Ok(Calibration {
        machine,
        theta: machine_theta(theta),
        start: machine_theta(start),
        effect: to_values(&ctx.defs[N_PARAMS..], &theta[N_PARAMS..]),
        cost,
        iterations: 0,
        evaluations: 0,
        rounds: 0,
        converged: false,
        reason: "",
        channels,
        until_s: data.until_s,
        elapsed_s: started.elapsed().as_secs_f64(),
    })
}

fn channel_fit(s: &Series, unit: &'static str, pred: Vec<f64>) -> ChannelFit {
    let empty = PartFit {
        n: 0,
        rmse: f64::NAN,
        fit_pct: f64::NAN,
    };
    ChannelFit {
        name: s.name.clone(),
        unit,
        calibration: part_fit(s, &s.fit_rows, &pred).unwrap_or(empty),
        rest: part_fit(s, &s.rest_rows, &pred),
        pred,
    }
}

fn place_site(p: usize) -> Site {
    match p {
        p if p < N_NODES => Site::Node(Node::ALL[p]),
        p if p == N_NODES => Site::Ambient,
        _ => Site::Coolant,
    }
}

/// Writes the linear part into the machine: boundary `T0` = median level at
/// rest, one named sensor site per temperature column (offset from `T0`),
/// one `[[output]]` per displacement column.
fn apply_outputs(m: &mut Machine, data: &Measured, lin: &Linear) {
    // The run's top speed is within the calibrated machine's range, so
    // `simulate --machine` runs it again (its file profile).
    let top = data.schedule.speed_rpm.iter().copied().fold(0.0, f64::max);
    m.max_rpm = m.max_rpm.max(top);
    if !lin.temps.is_empty() {
        let mut levels: Vec<f64> = lin.temps.iter().map(|f| f.offset_c).collect();
        levels.sort_by(f64::total_cmp);
        let t0 = levels[levels.len() / 2];
        m.boundary.ambient_c = t0;
        m.boundary.coolant_c = t0;
        m.sensors.sites = lin
            .temps
            .iter()
            .map(|f| {
                // Written from the nearer place: "motor, 10 % toward the
                // housing" rather than "housing, 90 % toward the motor".
                let (a, b, share) = if f.share > 0.5 {
                    (f.b, f.a, 1.0 - f.share)
                } else {
                    (f.a, f.b, f.share)
                };
                SensorSite {
                    node: place_site(a),
                    toward: place_site(if share > 0.0 { b } else { a }),
                    share,
                    offset_c: f.offset_c - t0,
                }
            })
            .collect();
        m.sensors.names = data.temps.iter().map(|s| s.name.clone()).collect();
    }
    m.outputs = data
        .disp
        .iter()
        .zip(&lin.disp)
        .map(|(s, c)| DisplacementOutput {
            name: s.name.clone(),
            um_per_k: *c,
        })
        .collect();
}

fn place_name(s: Site) -> &'static str {
    match s {
        Site::Node(n) => n.name(),
        Site::Ambient => "ambient",
        Site::Coolant => "coolant",
    }
}

/// The calibrated machine as machine-file text: `base_text` (the machine
/// that was calibrated) with the fitted values replaced and the sensors and
/// outputs rewritten, headed by a comment on the calibration. The text is
/// parsed back before it is returned, so it is always a valid machine file.
pub fn to_toml(base_text: &str, cal: &Calibration, source: &str) -> Result<String> {
    let mut doc: toml::Table = toml::from_str(base_text).context("re-reading the base machine")?;
    let m = &cal.machine;
    let set = |doc: &mut toml::Table, path: &[&str], v: f64| -> Result<()> {
        let mut t = doc;
        for key in &path[..path.len() - 1] {
            t = t
                .get_mut(*key)
                .and_then(toml::Value::as_table_mut)
                .ok_or_else(|| anyhow!("base machine has no table {key}"))?;
        }
        t.insert(path[path.len() - 1].to_string(), toml::Value::Float(v));
        Ok(())
    };
    let h = &m.heat;
    set(
        &mut doc,
        &["heat", "front_bearing_w_at_ref"],
        h.front_bearing_w_at_ref,
    )?;
    set(
        &mut doc,
        &["heat", "rear_bearing_w_at_ref"],
        h.rear_bearing_w_at_ref,
    )?;
    set(&mut doc, &["heat", "motor_idle_w"], h.motor_idle_w)?;
    set(
        &mut doc,
        &["heat", "motor_iron_w_at_ref"],
        h.motor_iron_w_at_ref,
    )?;
    set(&mut doc, &["heat", "bearing_exponent"], h.bearing_exponent)?;
    set(&mut doc, &["max_rpm"], m.max_rpm)?;
    set(&mut doc, &["boundary", "ambient_c"], m.boundary.ambient_c)?;
    set(&mut doc, &["boundary", "coolant_c"], m.boundary.coolant_c)?;
    for n in Node::ALL {
        let p = m.nodes.get(n);
        set(&mut doc, &["nodes", n.name(), "c_j_per_k"], p.c_j_per_k)?;
        set(
            &mut doc,
            &["nodes", n.name(), "g_ambient_w_per_k"],
            p.g_ambient_w_per_k,
        )?;
    }
    let sites: Vec<toml::Value> = m
        .sensors
        .sites
        .iter()
        .zip(&m.sensors.names)
        .map(|(s, name)| {
            let mut t = toml::Table::new();
            t.insert("name".into(), toml::Value::String(name.clone()));
            t.insert("node".into(), place_name(s.node).into());
            if s.toward != s.node && s.share > 0.0 {
                t.insert("toward".into(), place_name(s.toward).into());
                t.insert("share".into(), toml::Value::Float(s.share));
            }
            t.insert("offset_c".into(), toml::Value::Float(s.offset_c));
            toml::Value::Table(t)
        })
        .collect();
    set(&mut doc, &["sensors", "noise_c"], m.sensors.noise_c)?;
    if let Some(t) = doc.get_mut("sensors").and_then(toml::Value::as_table_mut) {
        t.insert("site".into(), toml::Value::Array(sites));
    }
    let outputs: Vec<toml::Value> = m
        .outputs
        .iter()
        .map(|o| {
            let mut gains = toml::Table::new();
            for n in Node::ALL {
                gains.insert(n.name().into(), toml::Value::Float(o.um_per_k[n.index()]));
            }
            let mut t = toml::Table::new();
            t.insert("name".into(), toml::Value::String(o.name.clone()));
            t.insert("um_per_k".into(), toml::Value::Table(gains));
            toml::Value::Table(t)
        })
        .collect();
    doc.remove("output");
    if !outputs.is_empty() {
        doc.insert("output".into(), toml::Value::Array(outputs));
    }
    let body = toml::to_string(&doc).context("writing the calibrated machine")?;
    let text = format!("{}{body}", header(cal, source));
    super::machine::parse("<calibrated machine>", &text)?;
    Ok(text)
}

fn header(cal: &Calibration, source: &str) -> String {
    let v = values(&cal.theta);
    let mut s = format!(
        "# Calibrated by `thermcomp simulate --calibrate {source}` on t_s < {} s\n",
        cal.until_s
    );
    for (p, x) in PARAMS.iter().zip(v) {
        s.push_str(&format!("#   {} = {x:.4} {}\n", p.name, p.unit));
    }
    s.push_str(&format!(
        "#   {} LM iterations, converged: {} ({}); [[output]] and named sensor sites map the twin to {source}'s columns.\n\n",
        cal.iterations, cal.converged, cal.reason
    ));
    s
}

fn part_json(p: &PartFit) -> Value {
    let num = |x: f64| if x.is_finite() { json!(x) } else { Value::Null };
    json!({"n": p.n, "rmse": num(p.rmse), "fit_pct": num(p.fit_pct)})
}

/// The calibration as one JSON object (fit per channel on both parts, the
/// parameters with units, the optimiser's figures).
pub fn to_json(cal: &Calibration) -> Value {
    let m = &cal.machine;
    let mut params = serde_json::Map::new();
    for (p, x) in PARAMS.iter().zip(values(&cal.theta)) {
        let at_bound = p.bound_hit(x).is_some();
        params.insert(
            p.name.into(),
            json!({"value": x, "unit": p.unit, "lo": p.lo, "hi": p.hi, "at_bound": at_bound}),
        );
    }
    let w = |x: f64| json!({"value": x, "unit": "W"});
    params.insert(
        "front_bearing_w_at_ref".into(),
        w(m.heat.front_bearing_w_at_ref),
    );
    params.insert(
        "rear_bearing_w_at_ref".into(),
        w(m.heat.rear_bearing_w_at_ref),
    );
    params.insert("motor_idle_w".into(), w(m.heat.motor_idle_w));
    params.insert("motor_iron_w_at_ref".into(), w(m.heat.motor_iron_w_at_ref));
    params.insert(
        "ambient_c".into(),
        json!({"value": m.boundary.ambient_c, "unit": "degC"}),
    );
    let tau = Network::new(m).time_constants_s();
    params.insert(
        "slowest_time_constant_s".into(),
        json!({"value": tau.first().copied().unwrap_or(0.0), "unit": "s"}),
    );
    let channels: serde_json::Map<String, Value> = cal
        .channels
        .iter()
        .map(|c| {
            let mut v = json!({"unit": c.unit, "calibration": part_json(&c.calibration),
                "rest": c.rest.as_ref().map_or(Value::Null, part_json)});
            if let Some(i) = m.sensors.names.iter().position(|n| *n == c.name) {
                let s = &m.sensors.sites[i];
                v["site"] = json!({"node": place_name(s.node), "toward": place_name(s.toward),
                    "share": s.share, "offset_c": s.offset_c});
            }
            if let Some(o) = m.outputs.iter().find(|o| o.name == c.name) {
                let g: serde_json::Map<String, Value> = Node::ALL
                    .iter()
                    .map(|n| (n.name().to_string(), json!(o.um_per_k[n.index()])))
                    .collect();
                v["um_per_k"] = Value::Object(g);
            }
            (c.name.clone(), v)
        })
        .collect();
    json!({
        "calibrate_until_s": cal.until_s,
        "channels": channels,
        "params": params,
        "start": values(&cal.start),
        "cost": cal.cost,
        "iterations": cal.iterations,
        "evaluations": cal.evaluations,
        "rounds": cal.rounds,
        "converged": cal.converged,
        "stop_reason": cal.reason,
        "seconds": cal.elapsed_s,
    })
}
