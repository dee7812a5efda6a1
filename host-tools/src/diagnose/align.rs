//! Putting a simulated and a measured run on one time base: the real run's
//! own `t_s`, with the simulation interpolated onto it, and the residual
//! `r = real - sim` of every channel both files have.

use super::spill::Spill;
use crate::data::runfile::{is_temperature_column, resample_linear, ReadOptions, RunFile};
use anyhow::{bail, Context, Result};
use std::collections::HashMap;
use std::path::Path;
use std::sync::{Arc, Mutex};

/// A regressor column, shared (not copied) between the designs that use it.
pub type Col = Arc<Vec<f64>>;

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

/// The compared channels of an [`Aligned`]: their names in memory, their
/// simulated values and residuals spilled ([`Spill`]: column `2 i` is
/// channel `i`'s sim, `2 i + 1` its residual) and loaded one channel, or a
/// block of rows, at a time: on the heap a channel is its name only
/// ([`Aligned::heap_bytes`]).
#[derive(Debug)]
pub struct Channels {
    names: Vec<String>,
    spill: Spill,
}

impl Channels {
    /// No channels yet, for runs of `rows` rows.
    pub fn new(rows: usize) -> std::io::Result<Self> {
        Ok(Channels {
            names: Vec::new(),
            spill: Spill::new(rows)?,
        })
    }

    /// Adds channel `name` with its simulated values and residual.
    pub fn push(&mut self, name: &str, sim: &[f64], resid: &[f64]) -> std::io::Result<()> {
        self.spill.push(sim)?;
        self.spill.push(resid)?;
        self.names.push(name.to_string());
        Ok(())
    }

    /// Number of channels.
    pub fn len(&self) -> usize {
        self.names.len()
    }

    /// Whether every channel read back so far came back whole
    /// ([`Spill::check`]).
    pub fn check(&self) -> std::io::Result<()> {
        self.spill.check()
    }

    /// Whether there is no channel.
    pub fn is_empty(&self) -> bool {
        self.names.is_empty()
    }

    /// The channels' names, in order.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// Name of channel `i`.
    pub fn name(&self, i: usize) -> &str {
        &self.names[i]
    }

    /// Index of the channel named `name`.
    pub fn position(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }

    /// Whether channel `i` is a displacement ([`is_displacement`]).
    pub fn is_displacement(&self, i: usize) -> bool {
        is_displacement(&self.names[i])
    }

    /// Channel `i` with its columns (read back: the bytes live while the
    /// returned value does).
    pub fn load(&self, i: usize) -> Channel {
        Channel {
            name: self.names[i].clone(),
            sim: Col::new(self.spill.column(2 * i)),
            resid: self.spill.column(2 * i + 1),
        }
    }

    /// Every channel, loaded one at a time as the iterator is walked.
    pub fn each(&self) -> impl Iterator<Item = Channel> + '_ {
        (0..self.len()).map(|i| self.load(i))
    }

    /// Channel `i`'s residual alone.
    pub fn resid(&self, i: usize) -> Vec<f64> {
        self.spill.column(2 * i + 1)
    }

    /// Channel `i`'s simulated values on `rows`.
    pub fn sim_rows(&self, i: usize, rows: std::ops::Range<usize>) -> Vec<f64> {
        self.spill.rows_of(2 * i, rows)
    }

    /// Channel `i`'s measured values on `rows` (`sim + resid`, as
    /// [`Channel::real_at`]).
    pub fn real_rows(&self, i: usize, rows: std::ops::Range<usize>) -> Vec<f64> {
        let resid = self.spill.rows_of(2 * i + 1, rows.clone());
        let mut v = self.sim_rows(i, rows);
        v.iter_mut().zip(&resid).for_each(|(s, r)| *s += r);
        v
    }

    /// The same channels on rows `keep` only.
    fn picked(&self, keep: &[usize]) -> std::io::Result<Channels> {
        let mut out = Channels::new(keep.len())?;
        for i in 0..self.len() {
            let c = self.load(i);
            let pick = |v: &[f64]| -> Vec<f64> { keep.iter().map(|&k| v[k]).collect() };
            out.push(&c.name, &pick(&c.sim), &pick(&c.resid))?;
        }
        Ok(out)
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
#[derive(Debug)]
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
    /// file order (kept off the heap, loaded one at a time).
    pub channels: Channels,
    /// Figures computed once and looked up again (see [`Memo`]).
    pub memo: Memo,
}

impl Aligned {
    /// Bytes its columns hold on the heap (allocated capacity): the time,
    /// the speed and the optional inputs, 8 bytes a row each; the compared
    /// channels are spilled ([`Channels`]), so they add nothing a row.
    pub fn heap_bytes(&self) -> usize {
        let optional = [&self.power_kw, &self.ambient_c, &self.coolant_c];
        let cols = [&self.t_s, &self.speed_rpm]
            .into_iter()
            .chain(optional.into_iter().flatten());
        let names: usize = self.channels.names().iter().map(String::capacity).sum();
        cols.map(|c| c.capacity() * std::mem::size_of::<f64>())
            .sum::<usize>()
            + names
    }
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
    // Collected from a borrow, not in place: an in-place collect would keep
    // the 16-byte `Option` cells' allocation (twice the bytes a row).
    let values = resample_linear(&run.t_s, col, grid);
    Some(values.iter().map(|v| v.unwrap_or(f64::NAN)).collect())
}

/// Compared channels read per pass over the files in [`read`]: a run
/// file holds 16 bytes a cell (`Option<f64>`), so 4 channels of two
/// files at 10^6 rows are 128 MB at a time instead of 740 MB for all 23
/// columns of two FL_THERMAL-shaped files (each pass scans both files
/// again: 6 passes for 21 channels).
const CHANNELS_PER_PASS: usize = 4;

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
    let mut b = Builder::new(real.t_s)?;
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
    let mut b = Builder::new(real.t_s.clone())?;
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

/// The aligned runs being built on the real run's time base, a group of
/// channels at a time; NaN marks a value that cannot be had there.
struct Builder {
    grid: Vec<f64>,
    speed: Vec<f64>,
    power: Option<Vec<f64>>,
    ambient: Option<Vec<f64>>,
    coolant: Option<Vec<f64>>,
    sim_coolant_cycles: bool,
    channels: Channels,
    /// Rows where every channel added so far is known.
    known: Vec<bool>,
}

impl Builder {
    fn new(mut grid: Vec<f64>) -> Result<Self> {
        // A reader's column may be allocated for more rows than it has.
        grid.shrink_to_fit();
        let n = grid.len();
        Ok(Builder {
            grid,
            speed: Vec::new(),
            power: None,
            ambient: None,
            coolant: None,
            sim_coolant_cycles: false,
            channels: Channels::new(n).context("cannot create a temporary file for diagnose")?,
            known: vec![true; n],
        })
    }

    /// Adds channels `names` of both runs (checked), and with `inputs` the
    /// speed (the real log's, else the simulation's) and the optional
    /// inputs of the real run.
    fn add(&mut self, sim: &RunFile, real: &RunFile, names: &[String], inputs: bool) -> Result<()> {
        for note in crate::data::spikes::notes(std::slice::from_ref(real), names, "The diagnosis") {
            eprintln!("note: {note}");
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
            self.sim_coolant_cycles = super::chiller::sim_coolant_cycles(sim, grid);
        }
        for name in names {
            let s = filled(sim, name, grid).unwrap_or_else(|| vec![f64::NAN; grid.len()]);
            let r = filled(real, name, grid).unwrap_or_else(|| vec![f64::NAN; grid.len()]);
            let resid: Vec<f64> = r.iter().zip(&s).map(|(a, b)| a - b).collect();
            for (k, v) in self.known.iter_mut().zip(&resid) {
                *k &= !v.is_nan();
            }
            self.channels
                .push(name, &s, &resid)
                .context("cannot write diagnose's temporary file")?;
        }
        Ok(())
    }

    /// Keeps the rows where the speed and every channel are known (at
    /// least 20; a note on stderr when some are dropped).
    fn finish(self, sim_path: &Path, real_path: &Path) -> Result<Aligned> {
        let n = self.grid.len();
        let keep: Vec<usize> = (0..n)
            .filter(|&k| !self.speed[k].is_nan() && self.known[k])
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
        let channels = if keep.len() == n {
            self.channels
        } else {
            self.channels
                .picked(&keep)
                .context("cannot write diagnose's temporary file")?
        };
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A run file of `n` rows at 1 s: speed, `temps` temperatures and two
    /// displacements, values shifted by `shift` (6 significant digits).
    fn run(dir: &Path, name: &str, n: usize, temps: usize, shift: f64) -> std::path::PathBuf {
        let cols: Vec<String> = (1..=temps)
            .map(|i| format!("T{i}"))
            .chain(["dx_um".into(), "dz_um".into()])
            .collect();
        let mut text = format!("t_s,speed_rpm,{}\n", cols.join(","));
        for k in 0..n {
            let vals: Vec<String> = (0..cols.len())
                .map(|j| {
                    format!(
                        "{:.6}",
                        20.0 + shift + (k as f64 * 1e-3 * (j + 1) as f64).sin()
                    )
                })
                .collect();
            text.push_str(&format!(
                "{k},{},{}\n",
                1000 * (k / 500 % 3),
                vals.join(",")
            ));
        }
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        path
    }

    #[test]
    fn the_aligned_runs_hold_no_channel_bytes_a_row() {
        // 16 bytes a row (t_s and speed, 8 each, allocated to length) and
        // no more however many channels: before the spill, 16 + 16 per
        // channel (sim and residual; 24 for an in-place-collected sim).
        // Tolerance 0.1 byte a row for the channels' names (a few dozen
        // bytes over 3000 rows).
        let dir = tempfile::tempdir().unwrap();
        let n = 3000;
        for temps in [2, 16] {
            let sim = run(dir.path(), "sim.csv", n, temps, 0.0);
            let real = run(dir.path(), "real.csv", n, temps, 0.5);
            let al = read(&sim, &real).unwrap();
            assert_eq!(al.channels.len(), temps + 2);
            let per_row = al.heap_bytes() as f64 / n as f64;
            assert!(
                (16.0..16.1).contains(&per_row),
                "{temps} temperatures: {per_row} B a row"
            );
            // The spilled columns come back exact: real - sim of the file's
            // values, and sim + resid the real value.
            let t2 = al.channels.position("T2").unwrap();
            let c = al.channels.load(t2);
            let (s, r) = (20.0 + (7.0f64 * 2e-3).sin(), 20.5 + (7.0f64 * 2e-3).sin());
            let parse = |v: f64| format!("{v:.6}").parse::<f64>().unwrap();
            assert_eq!(c.sim[7], parse(s));
            assert_eq!(c.resid[7], parse(r) - parse(s));
            assert_eq!(al.channels.real_rows(t2, 7..8)[0], c.real_at(7));
        }
    }

    #[test]
    fn rows_outside_the_simulation_are_dropped_from_the_spilled_channels() {
        let dir = tempfile::tempdir().unwrap();
        let sim = run(dir.path(), "sim.csv", 800, 2, 0.0);
        let real = run(dir.path(), "real.csv", 1000, 2, 0.5);
        let al = read(&sim, &real).unwrap();
        assert_eq!(al.t_s.len(), 800);
        let c = al.channels.load(0);
        assert_eq!((c.sim.len(), c.resid.len()), (800, 800));
        assert!(
            c.resid.iter().all(|v| (v - 0.5).abs() < 2e-6),
            "{:?}",
            &c.resid[..3]
        );
    }
}
