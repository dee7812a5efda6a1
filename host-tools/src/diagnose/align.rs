//! Putting a simulated and a measured run on one time base: the real run's
//! own `t_s`, with the simulation interpolated onto it, and the residual
//! `r = real - sim` of every channel both files have.

use crate::data::runfile::{is_temperature_column, resample_linear, ReadOptions, RunFile};
use anyhow::{bail, Context, Result};
use std::path::Path;

/// One compared channel.
#[derive(Debug, Clone)]
pub struct Channel {
    /// Column name (`dz_um`, `T3`, `S5`, ...).
    pub name: String,
    /// Simulated values on the common rows.
    pub sim: Vec<f64>,
    /// Measured values on the common rows.
    pub real: Vec<f64>,
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
    /// Compared channels: displacements first, then T, then S, each in
    /// file order.
    pub channels: Vec<Channel>,
}

/// Fills the gaps (missing cells) of one column by linear interpolation in
/// time over the column's own samples; `None` where it cannot (the edges).
fn filled(run: &RunFile, name: &str, grid: &[f64]) -> Option<Vec<Option<f64>>> {
    let col = run.column(name)?;
    Some(resample_linear(&run.t_s, col, grid))
}

/// Reads both files and aligns them. Rows of the real run outside the
/// simulation's time span, or where a compared channel or the speed cannot
/// be had even by interpolation, are dropped (and counted on stderr).
pub fn read(sim_path: &Path, real_path: &Path) -> Result<Aligned> {
    let opts = ReadOptions::default();
    let sim = RunFile::read(sim_path, &opts)?;
    let real = RunFile::read(real_path, &opts)?;
    align(&sim, &real)
}

/// [`read`] for runs already in memory (named by their `path` in messages).
pub fn align(sim: &RunFile, real: &RunFile) -> Result<Aligned> {
    let (sim_path, real_path) = (sim.path.as_path(), real.path.as_path());
    if sim.len() < 2 || real.len() < 2 {
        bail!("diagnose needs at least two rows in each of --sim and --real");
    }
    let names: Vec<String> = real
        .columns
        .iter()
        .filter(|c| is_displacement(c) || is_temperature_column(c) || is_probe(c))
        .filter(|c| sim.has_column(c))
        .cloned()
        .collect();
    let mut names_sorted: Vec<String> = names
        .iter()
        .filter(|c| is_displacement(c))
        .cloned()
        .collect();
    names_sorted.extend(names.iter().filter(|c| is_temperature_column(c)).cloned());
    names_sorted.extend(names.iter().filter(|c| is_probe(c)).cloned());
    if names_sorted.is_empty() {
        bail!(
            "{} and {} share no channel to compare (*_um, T<n>, S<n>)",
            sim_path.display(),
            real_path.display()
        );
    }
    let inputs = ["speed_rpm", "power_kw", "ambient_c", "coolant_c"];
    let used = names_sorted.iter().map(String::as_str).chain(inputs);
    for name in used {
        for (run, path) in [(sim, sim_path), (real, real_path)] {
            let Some(values) = run.column(name) else {
                continue;
            };
            let label = format!("{}: column {name}", path.display());
            crate::num::linalg::check_scalable(&label, values.iter().flatten().copied())?;
        }
    }
    let grid = &real.t_s;
    let speed = filled(real, "speed_rpm", grid)
        .or_else(|| filled(sim, "speed_rpm", grid))
        .with_context(|| {
            format!(
                "neither {} nor {} has a speed_rpm column (needed to find the regimes)",
                real_path.display(),
                sim_path.display()
            )
        })?;
    let optional = |name: &str| filled(real, name, grid);
    let power = optional("power_kw");
    let ambient = optional("ambient_c");
    let coolant = optional("coolant_c");
    let sims: Vec<Vec<Option<f64>>> = names_sorted
        .iter()
        .map(|c| filled(sim, c, grid).unwrap_or_default())
        .collect();
    let reals: Vec<Vec<Option<f64>>> = names_sorted
        .iter()
        .map(|c| filled(real, c, grid).unwrap_or_default())
        .collect();
    let keep: Vec<usize> = (0..grid.len())
        .filter(|&k| {
            speed[k].is_some()
                && sims.iter().all(|s| s[k].is_some())
                && reals.iter().all(|r| r[k].is_some())
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
    if keep.len() < grid.len() {
        eprintln!(
            "note: diagnose: {} of {} rows of {} dropped (outside the simulation's span or a channel missing)",
            grid.len() - keep.len(),
            grid.len(),
            real_path.display()
        );
    }
    let pick =
        |v: &[Option<f64>]| -> Vec<f64> { keep.iter().map(|&k| v[k].unwrap_or(0.0)).collect() };
    // An optional input with a gap at a kept row is treated as not logged.
    let pick_opt = |v: Option<Vec<Option<f64>>>| -> Option<Vec<f64>> {
        let v = v?;
        keep.iter().map(|&k| v[k]).collect()
    };
    let channels = names_sorted
        .iter()
        .zip(sims.iter().zip(&reals))
        .map(|(name, (s, r))| {
            let sim = pick(s);
            let real = pick(r);
            let resid = real.iter().zip(&sim).map(|(a, b)| a - b).collect();
            Channel {
                name: name.clone(),
                sim,
                real,
                resid,
            }
        })
        .collect();
    Ok(Aligned {
        t_s: keep.iter().map(|&k| grid[k]).collect(),
        speed_rpm: pick(&speed),
        power_kw: pick_opt(power),
        ambient_c: pick_opt(ambient),
        coolant_c: pick_opt(coolant),
        channels,
    })
}
