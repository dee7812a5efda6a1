//! Putting a simulated and a measured run on one time base: the real run's
//! own `t_s`, with the simulation interpolated onto it, and the residual
//! `r = real - sim` of every channel both files have.

use super::baseline::Col;
use crate::data::runfile::{is_temperature_column, resample_linear, ReadOptions, RunFile};
use anyhow::{bail, Context, Result};
use std::collections::HashMap;
use std::path::Path;
use std::sync::Mutex;

/// One compared channel.
#[derive(Debug, Clone)]
pub struct Channel {
    /// Column name (`dz_um`, `T3`, `S5`, ...).
    pub name: String,
    /// Simulated values on the common rows (shared with the designs that
    /// use them as a regressor).
    pub sim: Col,
    /// `real - sim`.
    pub resid: Vec<f64>,
}

impl Channel {
    /// Whether this is a displacement (`dx_um`, `dy_um`, `dz_um`, or any
    /// other `*_um` column both files have).
    pub fn is_displacement(&self) -> bool {
        is_displacement(&self.name)
    }

    /// Unit of the channel for parameter names: `um` or `k`.
    pub fn unit(&self) -> &'static str {
        if is_temperature_column(&self.name) {
            "k"
        } else {
            "um"
        }
    }

    /// Measured value on row `k`: `sim + resid` (not stored: it is the
    /// measured value itself wherever `real - sim` was exact, as for two
    /// temperatures within a factor 2 of each other, and within an ulp of
    /// it otherwise).
    pub fn real_at(&self, k: usize) -> f64 {
        self.sim[k] + self.resid[k]
    }

    /// Measured values on every row (see [`Channel::real_at`]).
    pub fn real(&self) -> Vec<f64> {
        self.sim
            .iter()
            .zip(&self.resid)
            .map(|(s, r)| s + r)
            .collect()
    }
}

/// A displacement channel: any `*_um` column (the tool-tip `dx_um, dy_um,
/// dz_um`, or a real machine's own channels such as `ch3_um`); the probe
/// readings `S<n>` carry no unit suffix.
pub fn is_displacement(name: &str) -> bool {
    name.ends_with("_um") && name.len() > 3
}

fn is_probe(name: &str) -> bool {
    name.strip_prefix('S')
        .is_some_and(|d| !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit()))
}

/// Both runs on the real run's time base.
#[derive(Debug, Clone)]
pub struct Aligned {
    /// Time of each common row, s (the real run's).
    pub t_s: Vec<f64>,
    /// Spindle speed, rpm (the real log's, else the simulation's).
    pub speed_rpm: Vec<f64>,
    /// Spindle power, kW, if logged.
    pub power_kw: Option<Vec<f64>>,
    /// Ambient air, deg C, if logged.
    pub ambient_c: Option<Vec<f64>>,
    /// Coolant supply, deg C, if logged.
    pub coolant_c: Option<Vec<f64>>,
    /// Whether the simulation's own `coolant_c` cycles (a chiller the twin
    /// models: then a cycling real coolant is no unmodelled effect;
    /// gates.rs).
    pub sim_coolant_cycles: bool,
    /// Compared channels: displacements first, then T, then S, each in
    /// file order.
    pub channels: Vec<Channel>,
    /// Figures computed once and looked up again (see [`Memo`]).
    pub memo: Memo,
}

/// Small per-channel figures the diagnosis needs many times (a channel's
/// own time constant, its baseline's priors, its chiller-band level per
/// fold), each computed once: keyed by what they are of, a few numbers
/// each, never columns. Cloning gives an empty memo.
#[derive(Debug, Default)]
pub struct Memo(Mutex<HashMap<String, Vec<f64>>>);

impl Clone for Memo {
    fn clone(&self) -> Self {
        Memo::default()
    }
}

impl Memo {
    /// The figures under `key`, computed by `make` the first time.
    pub fn get_or(&self, key: &str, make: impl FnOnce() -> Vec<f64>) -> Vec<f64> {
        let lock = || {
            self.0
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner)
        };
        if let Some(v) = lock().get(key) {
            return v.clone();
        }
        // Computed without the lock held (`make` may look up other keys).
        let v = make();
        lock().insert(key.to_string(), v.clone());
        v
    }
}

/// Values of column `name` of `run` on `grid`, gaps (missing cells) filled
/// by linear interpolation in time over the column's own samples; NaN
/// where it cannot (the edges; a run file holds no NaN). `None` if the
/// column is not there (or not read).
fn filled(run: &RunFile, name: &str, grid: &[f64]) -> Option<Vec<f64>> {
    let col = run.column(name)?;
    Some(
        resample_linear(&run.t_s, col, grid)
            .into_iter()
            .map(|v| v.unwrap_or(f64::NAN))
            .collect(),
    )
}

/// Compared channels read per pass over the files in [`read`]: a run
/// file holds 16 bytes a cell (`Option<f64>`), so 8 channels of two
/// files at 10^6 rows are 256 MB at a time instead of 740 MB for all 23
/// columns of two FL_THERMAL-shaped files.
const CHANNELS_PER_PASS: usize = 8;

/// Reads both files and aligns them. Rows of the real run outside the
/// simulation's time span, or where a compared channel or the speed cannot
/// be had even by interpolation, are dropped (and counted on stderr).
/// Only the columns the diagnosis uses are read, a few channels per pass
/// ([`CHANNELS_PER_PASS`]).
pub fn read(sim_path: &Path, real_path: &Path) -> Result<Aligned> {
    let only = |names: Vec<String>| ReadOptions {
        only: Some(names),
        ..ReadOptions::default()
    };
    let sim = RunFile::read(sim_path, &only(Vec::new()))?;
    let real = RunFile::read(real_path, &only(Vec::new()))?;
    check_lengths(&sim, &real)?;
    let names = compared_names(&sim, &real)?;
    let mut b = Builder::new(real.t_s);
    for (i, group) in names.chunks(CHANNELS_PER_PASS).enumerate() {
        let mut cols = group.to_vec();
        if i == 0 {
            cols.extend(INPUTS.iter().map(|s| s.to_string()));
        }
        let sim = RunFile::read(sim_path, &only(cols.clone()))?;
        let real = RunFile::read(real_path, &only(cols))?;
        b.add(&sim, &real, group, i == 0)?;
    }
    b.finish(sim_path, real_path)
}

/// Inputs the diagnosis reads besides the compared channels.
pub const INPUTS: [&str; 4] = ["speed_rpm", "power_kw", "ambient_c", "coolant_c"];

/// Whether the diagnosis compares a column of this name (if both files
/// have it): a displacement, a temperature or a probe.
pub fn is_compared(name: &str) -> bool {
    is_displacement(name) || is_temperature_column(name) || is_probe(name)
}

/// [`read`] for runs already in memory (named by their `path` in messages).
pub fn align(sim: &RunFile, real: &RunFile) -> Result<Aligned> {
    check_lengths(sim, real)?;
    let names = compared_names(sim, real)?;
    let mut b = Builder::new(real.t_s.clone());
    b.add(sim, real, &names, true)?;
    b.finish(&sim.path, &real.path)
}

fn check_lengths(sim: &RunFile, real: &RunFile) -> Result<()> {
    if sim.len() < 2 || real.len() < 2 {
        bail!("diagnose needs at least two rows in each of --sim and --real");
    }
    Ok(())
}

/// The channels both runs have that the diagnosis compares:
/// displacements, then temperatures, then probes, each in the real file's
/// order.
fn compared_names(sim: &RunFile, real: &RunFile) -> Result<Vec<String>> {
    let names: Vec<&String> = real
        .columns
        .iter()
        .filter(|c| is_compared(c) && sim.has_column(c))
        .collect();
    let kinds: [fn(&str) -> bool; 3] = [is_displacement, is_temperature_column, is_probe];
    let sorted: Vec<String> = kinds
        .iter()
        .flat_map(|kind| names.iter().filter(|c| kind(c)).map(|c| c.to_string()))
        .collect();
    if sorted.is_empty() {
        bail!(
            "{} and {} share no channel to compare (*_um, T<n>, S<n>)",
            sim.path.display(),
            real.path.display()
        );
    }
    Ok(sorted)
}

/// Refuses values that cannot be centred and scaled in f64 in any of the
/// columns `names` of either run, naming the file and column.
fn check_values<'n>(
    sim: &RunFile,
    real: &RunFile,
    names: impl Iterator<Item = &'n str>,
) -> Result<()> {
    for name in names {
        for run in [sim, real] {
            let Some(values) = run.column(name) else {
                continue;
            };
            let label = format!("{}: column {name}", run.path.display());
            crate::num::linalg::check_scalable(&label, values.iter().flatten().copied())?;
        }
    }
    Ok(())
}

/// The aligned runs being built on the real run's time base, a group of
/// channels at a time; NaN marks a value that cannot be had there.
struct Builder {
    grid: Vec<f64>,
    speed: Vec<f64>,
    power: Option<Vec<f64>>,
    ambient: Option<Vec<f64>>,
    coolant: Option<Vec<f64>>,
    sim_coolant_cycles: bool,
    channels: Vec<Channel>,
}

impl Builder {
    fn new(grid: Vec<f64>) -> Self {
        Builder {
            grid,
            speed: Vec::new(),
            power: None,
            ambient: None,
            coolant: None,
            sim_coolant_cycles: false,
            channels: Vec::new(),
        }
    }

    /// Adds channels `names` of both runs (checked), and with `inputs` the
    /// speed (the real log's, else the simulation's) and the optional
    /// inputs of the real run.
    fn add(&mut self, sim: &RunFile, real: &RunFile, names: &[String], inputs: bool) -> Result<()> {
        let used = names.iter().map(String::as_str);
        if inputs {
            check_values(sim, real, used.chain(INPUTS))?;
        } else {
            check_values(sim, real, used)?;
        }
        let grid = &self.grid;
        if inputs {
            self.speed = filled(real, "speed_rpm", grid)
                .or_else(|| filled(sim, "speed_rpm", grid))
                .with_context(|| {
                    format!(
                        "neither {} nor {} has a speed_rpm column (needed to find the regimes)",
                        real.path.display(),
                        sim.path.display()
                    )
                })?;
            self.power = filled(real, "power_kw", grid);
            self.ambient = filled(real, "ambient_c", grid);
            self.coolant = filled(real, "coolant_c", grid);
            self.sim_coolant_cycles = super::gates::sim_coolant_cycles(sim, grid);
        }
        for name in names {
            let s = filled(sim, name, grid).unwrap_or_else(|| vec![f64::NAN; grid.len()]);
            let r = filled(real, name, grid).unwrap_or_else(|| vec![f64::NAN; grid.len()]);
            let resid = r.iter().zip(&s).map(|(a, b)| a - b).collect();
            self.channels.push(Channel {
                name: name.clone(),
                sim: Col::new(s),
                resid,
            });
        }
        Ok(())
    }

    /// Keeps the rows where the speed and every channel are known (at
    /// least 20; a note on stderr when some are dropped).
    fn finish(self, sim_path: &Path, real_path: &Path) -> Result<Aligned> {
        let n = self.grid.len();
        let keep: Vec<usize> = (0..n)
            .filter(|&k| {
                !self.speed[k].is_nan() && self.channels.iter().all(|c| !c.resid[k].is_nan())
            })
            .collect();
        if keep.len() < 20 {
            bail!(
                "only {} rows of {} fall inside {}'s time span with every channel known; diagnose needs at least 20",
                keep.len(),
                real_path.display(),
                sim_path.display()
            );
        }
        if keep.len() < n {
            eprintln!(
                "note: diagnose: {} of {} rows of {} dropped (outside the simulation's span or a channel missing)",
                n - keep.len(),
                n,
                real_path.display()
            );
        }
        let pick = |v: Vec<f64>| -> Vec<f64> {
            if keep.len() == n {
                v
            } else {
                keep.iter().map(|&k| v[k]).collect()
            }
        };
        // An optional input with a gap at a kept row is treated as not logged.
        let optional = |v: Option<Vec<f64>>| -> Option<Vec<f64>> {
            let v = pick(v?);
            v.iter().all(|x| !x.is_nan()).then_some(v)
        };
        let channels = self
            .channels
            .into_iter()
            .map(|c| {
                let sim = match Col::try_unwrap(c.sim) {
                    Ok(v) => Col::new(pick(v)),
                    Err(shared) => Col::new(pick(shared.to_vec())),
                };
                Channel {
                    name: c.name,
                    sim,
                    resid: pick(c.resid),
                }
            })
            .collect();
        Ok(Aligned {
            t_s: pick(self.grid),
            speed_rpm: pick(self.speed),
            power_kw: optional(self.power),
            ambient_c: optional(self.ambient),
            coolant_c: optional(self.coolant),
            sim_coolant_cycles: self.sim_coolant_cycles,
            channels,
            memo: Memo::default(),
        })
    }
}
