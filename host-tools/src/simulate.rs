//! `thermcomp simulate` as a job: run the thermal twin ([`crate::twin`])
//! over a speed profile, or calibrate the twin to a measured run and run
//! the calibrated twin over that run's grid (CONTRACT.md section 2). The
//! command line (`cli/simulate.rs`) turns its flags into [`SimulateParams`]
//! or [`CalibrateParams`] and prints the typed outcomes.

use crate::data::runfile::{ReadOptions, RunFile};
use crate::twin::calibrate;
use crate::twin::effects::EffectSet;
use crate::twin::machine::{Machine, DEFAULT_MACHINE_TOML, N_NODES};
use crate::twin::profile::{self, Profile};
use crate::twin::sim::{self, SimOptions, Summary};
use anyhow::{Context, Result};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// What to simulate: the parameters of `thermcomp simulate` (without
/// `--calibrate`).
#[derive(Clone, Debug)]
pub struct SimulateParams {
    /// Length of the run, h (built-in profiles; with `file:PATH`, cuts the file).
    pub hours: Option<f64>,
    /// Speed profile: steps, spectrum, cooldown, constant:RPM or file:PATH.
    pub profile: String,
    /// Unmodelled effects, comma-separated (empty: the nominal twin).
    pub effects: String,
    /// Seed of the sensor noise, the spectrum and the door openings.
    pub seed: u64,
    /// Machine file (TOML); the built-in machine if `None`.
    pub machine: Option<PathBuf>,
    /// Sample time, s.
    pub dt_s: f64,
    /// Number of temperature sensors (the machine's first N sites; `None`: all).
    pub sensors: Option<usize>,
}

impl Default for SimulateParams {
    fn default() -> Self {
        SimulateParams {
            hours: None,
            profile: "steps".into(),
            effects: String::new(),
            seed: 0,
            machine: None,
            dt_s: 1.0,
            sensors: None,
        }
    }
}

/// Checked [`SimulateParams`]: the machine loaded, the profile and effects
/// parsed, the schedule built.
#[derive(Clone, Debug)]
pub struct ValidSimulateParams {
    /// The machine simulated.
    pub machine: Machine,
    /// `"default"` or the machine file's path.
    pub machine_label: String,
    /// The speed profile.
    pub profile: Profile,
    /// Time grid and drive of the run.
    pub schedule: profile::Schedule,
    /// Effects, seed and sensor count.
    pub opts: SimOptions,
}

impl SimulateParams {
    /// Loads the machine, parses the profile and effects and builds the
    /// schedule; every error is one line.
    pub fn check(&self) -> Result<ValidSimulateParams> {
        let machine = match &self.machine {
            Some(p) => Machine::load(p)?,
            None => Machine::default_machine(),
        };
        let profile = Profile::parse(&self.profile)?;
        let effects = EffectSet::parse(&self.effects)?;
        let schedule =
            profile::schedule(&profile, machine.max_rpm, self.hours, self.dt_s, self.seed)?;
        schedule.check_top_speed(machine.max_rpm, &profile.label())?;
        Ok(ValidSimulateParams {
            machine,
            machine_label: self
                .machine
                .as_ref()
                .map_or_else(|| "default".to_string(), |p| p.display().to_string()),
            profile,
            schedule,
            opts: SimOptions {
                effects,
                seed: self.seed,
                sensors: self.sensors,
            },
        })
    }
}

/// A simulated run's figures (`simulate --json`).
#[derive(Clone, Debug, Serialize)]
pub struct SimulateOutcome {
    /// The run file written.
    pub out: String,
    /// Rows written.
    pub rows: usize,
    /// Temperature sensor columns.
    pub sensors: usize,
    /// The profile's label.
    pub profile: String,
    /// Effects switched on.
    pub effects: Vec<&'static str>,
    /// Seed.
    pub seed: u64,
    /// `"default"` or the machine file.
    pub machine: String,
    /// Largest |dz_um|, um.
    pub max_abs_dz_um: f64,
    /// Largest |dx_um|, um.
    pub max_abs_dx_um: f64,
    /// Largest |dy_um|, um.
    pub max_abs_dy_um: f64,
    /// Largest node temperature rise, K.
    pub max_rise_c: f64,
    /// The node of that rise.
    pub max_rise_node: &'static str,
    /// Slowest time constant of the network, s.
    pub slowest_time_constant_s: f64,
    /// The first constant-speed segment's approach to equilibrium.
    pub equilibrium: Option<sim::Equilibrium>,
    /// Wall time, s.
    pub elapsed_s: f64,
}

/// Simulates `p` into the run file `out`; returns its figures.
pub fn simulate_to(p: &ValidSimulateParams, out: &Path) -> Result<SimulateOutcome> {
    let started = std::time::Instant::now();
    let (s, n_sensors) = write_run(&p.machine, &p.schedule, &p.opts, out)?;
    Ok(SimulateOutcome {
        out: out.display().to_string(),
        rows: s.rows,
        sensors: n_sensors,
        profile: p.profile.label(),
        effects: p.opts.effects.names(),
        seed: p.opts.seed,
        machine: p.machine_label.clone(),
        max_abs_dz_um: s.max_abs_dz_um,
        max_abs_dx_um: s.max_abs_dx_um,
        max_abs_dy_um: s.max_abs_dy_um,
        max_rise_c: s.max_rise_c.0,
        max_rise_node: s.max_rise_c.1.name(),
        slowest_time_constant_s: s.slowest_time_constant_s,
        equilibrium: s.equilibrium,
        elapsed_s: started.elapsed().as_secs_f64(),
    })
}

/// The run [`simulate_to`] would write, in memory: the very text of the
/// file, read back, so every value is the file's.
pub fn simulate(p: &ValidSimulateParams) -> Result<RunFile> {
    run_in_memory(&p.machine, &p.schedule, &p.opts)
}

/// The twin's run as the text of its file, read back.
fn run_in_memory(
    machine: &Machine,
    schedule: &profile::Schedule,
    opts: &SimOptions,
) -> Result<RunFile> {
    let n_sensors = opts.sensors.unwrap_or(machine.sensors.sites.len());
    let mut text = Vec::new();
    write_rows(
        machine,
        schedule,
        opts,
        n_sensors,
        &mut text,
        Path::new("simulated"),
    )?;
    Ok(RunFile::from_reader(
        "simulated",
        text.as_slice(),
        &ReadOptions::default(),
    )?)
}

/// `simulate --calibrate`: calibrate a machine to a measured run.
#[derive(Clone, Debug)]
pub struct CalibrateParams {
    /// The measured run.
    pub real: PathBuf,
    /// The machine to start from (TOML); the built-in one if `None`.
    pub machine: Option<PathBuf>,
    /// Calibrate on rows before this time, s (default: the first half).
    pub until_s: Option<f64>,
    /// Seed of the calibrated twin's run (its sensor noise).
    pub seed: u64,
    /// Draw a progress bar on stderr.
    pub progress: bool,
}

/// A calibrated twin: the fit, the measured run's grid, and the machine
/// file's text (the starting file with the calibrated values).
pub struct Calibrated {
    /// The calibration (parameters, per-channel fit).
    pub calibration: calibrate::Calibration,
    /// The measured run (its grid and speed drive the calibrated twin).
    pub measured: calibrate::Measured,
    /// The calibrated machine file (TOML).
    pub toml: String,
}

impl Calibrated {
    /// The calibrated twin's run over the measured run's grid, in memory.
    pub fn simulate(&self, seed: u64) -> Result<RunFile> {
        run_in_memory(
            &self.calibration.machine,
            &self.measured.schedule,
            &calibrated_options(seed),
        )
    }

    /// The same run written to `out`.
    pub fn write_run(&self, seed: u64, out: &Path) -> Result<(Summary, usize)> {
        write_run(
            &self.calibration.machine,
            &self.measured.schedule,
            &calibrated_options(seed),
            out,
        )
    }
}

/// Calibrates the twin (`p.machine`, or the built-in one; no effects) to
/// the measured run `p.real`.
pub fn calibrate_machine(p: &CalibrateParams) -> Result<Calibrated> {
    let (text, label) = match &p.machine {
        Some(m) => (
            crate::data::fsio::read_text_capped(m)?,
            m.display().to_string(),
        ),
        None => (DEFAULT_MACHINE_TOML.to_string(), "<default machine>".into()),
    };
    let base = crate::twin::machine::parse(&label, &text)?;
    let measured = calibrate::Measured::read(&p.real, p.until_s)?;
    let opts = calibrate::CalibrateOptions {
        progress: p.progress,
        ..Default::default()
    };
    let calibration = calibrate::calibrate(&base, &measured, &opts)?;
    let toml = calibrate::to_toml(&text, &calibration, &p.real.display().to_string())?;
    Ok(Calibrated {
        calibration,
        measured,
        toml,
    })
}

/// The options of the calibrated twin's run: no effects, every sensor.
fn calibrated_options(seed: u64) -> SimOptions {
    SimOptions {
        effects: EffectSet::none(),
        seed,
        sensors: None,
    }
}

/// Runs the twin and writes the run file; returns the summary and the
/// number of sensor columns.
pub fn write_run(
    machine: &Machine,
    schedule: &profile::Schedule,
    opts: &SimOptions,
    out: &std::path::Path,
) -> Result<(Summary, usize)> {
    let n_sensors = opts.sensors.unwrap_or(machine.sensors.sites.len());
    let summary = crate::data::fsio::write_atomic(out, |w| {
        write_rows(machine, schedule, opts, n_sensors, w, out)
    })?;
    Ok((summary, n_sensors))
}

/// The body of [`write_run`]: the header and one row per sample into `w`.
fn write_rows(
    machine: &Machine,
    schedule: &profile::Schedule,
    opts: &SimOptions,
    n_sensors: usize,
    w: &mut dyn std::io::Write,
    out: &std::path::Path,
) -> Result<Summary> {
    let write_err = || format!("cannot write {}", out.display());
    let mut header = String::from("t_s,speed_rpm,power_kw,ambient_c,coolant_c,tool_mm");
    for name in machine.sensors.names.iter().take(n_sensors) {
        let _ = write!(header, ",{name}");
    }
    header.push_str(",S1,S2,S3,S4,S5");
    // A calibrated output named dx_um/dy_um/dz_um replaces the twin's own.
    let own_xyz: Vec<bool> = ["dx_um", "dy_um", "dz_um"]
        .iter()
        .map(|c| !machine.outputs.iter().any(|o| o.name == *c))
        .collect();
    for (c, keep) in ["dx_um", "dy_um", "dz_um"].iter().zip(&own_xyz) {
        if *keep {
            let _ = write!(header, ",{c}");
        }
    }
    for o in &machine.outputs {
        let _ = write!(header, ",{}", o.name);
    }
    header.push('\n');
    w.write_all(header.as_bytes()).with_context(write_err)?;
    let n = schedule.t_s.len();
    // Hidden when stderr is not a terminal; only worth drawing for long runs.
    let pb = (n >= 200_000).then(|| crate::num::progress::progress(n, "simulate"));
    let mut line = String::with_capacity(512);
    let mut reference: Option<crate::twin::network::State> = None;
    let summary = sim::run(machine, schedule, opts, |r| {
        within_physics(r)?;
        line.clear();
        let _ = write!(line, "{},{}", r.t_s, r.speed_rpm);
        for v in [r.power_kw, r.ambient_c, r.coolant_c] {
            line.push(',');
            push_fixed4(&mut line, v);
        }
        let _ = write!(line, ",{}", r.tool_mm);
        let xyz = [r.dx_um, r.dy_um, r.dz_um];
        let own = xyz
            .iter()
            .zip(&own_xyz)
            .filter(|(_, k)| **k)
            .map(|(v, _)| v);
        for &v in r.temps_c.iter().chain(&r.probes_um).chain(own) {
            line.push(',');
            push_fixed4(&mut line, v);
        }
        // Rises above the run's initial state (row 0), as the expansion.
        let x0 = *reference.get_or_insert(*r.nodes_c);
        for o in &machine.outputs {
            let v: f64 = (0..N_NODES)
                .map(|i| o.um_per_k[i] * (r.nodes_c[i] - x0[i]))
                .sum();
            line.push(',');
            push_fixed4(&mut line, v);
        }
        line.push('\n');
        w.write_all(line.as_bytes()).with_context(write_err)?;
        if let Some(pb) = &pb {
            if r.index % 8192 == 0 {
                pb.set_position(r.index as u64);
            }
        }
        Ok(())
    })?;
    if let Some(pb) = pb {
        pb.finish_and_clear();
    }
    Ok(summary)
}

/// Refuses a row no machine can produce: a temperature outside -273.15
/// ..= 1000 C or a displacement beyond 10 m, the ranges the run-file
/// reader takes (`runfile::Quantity`). A machine file's parameters can
/// each be valid and still drive the twin there together (a bearing
/// exponent of 1000 gave T1 = 8.9e79 C and a written run nothing could
/// read back).
fn within_physics(r: &sim::Row<'_>) -> Result<()> {
    use crate::data::runfile::Quantity;
    let temps = [r.ambient_c, r.coolant_c]
        .into_iter()
        .chain(r.temps_c.iter().copied());
    let lengths = [r.dx_um, r.dy_um, r.dz_um].into_iter().chain(r.probes_um);
    let judged = temps
        .map(|v| (v, Quantity::Temperature))
        .chain(lengths.map(|v| (v, Quantity::Length)));
    match judged.into_iter().find(|&(v, q)| !q.admits(v)) {
        Some((v, q)) => {
            let (lo, hi) = q.range();
            anyhow::bail!(
                "t_s = {}: {} of the twin reaches {v:e}, outside {lo} ..= {hi}: the machine's \
                 parameters (or the profile's power) drive it beyond any machine; check the \
                 machine file",
                r.t_s,
                q.what()
            )
        }
        None => Ok(()),
    }
}

/// Appends `v` with four decimals (0.1 mK, 0.1 nm: below every noise
/// level), rounding half away from zero. `{:.4}` does the same through an
/// exact big-number conversion that costs three quarters of a 24 h run's
/// time; this integer path is ~10x faster.
pub fn push_fixed4(out: &mut String, v: f64) {
    let scaled = (v * 1e4).round();
    if !scaled.is_finite() || scaled.abs() >= 9.0e15 {
        let _ = write!(out, "{v:.4}");
        return;
    }
    let n = scaled as i64;
    if n < 0 {
        out.push('-');
    }
    let m = n.unsigned_abs();
    let _ = write!(out, "{}.", m / 10_000);
    let frac = m % 10_000;
    for d in [frac / 1000, frac / 100 % 10, frac / 10 % 10, frac % 10] {
        out.push(char::from(b'0' + d as u8));
    }
}

#[cfg(test)]
mod tests {
    use super::push_fixed4;

    #[test]
    fn fixed4_matches_std_formatting() {
        for v in [
            0.0, -0.0, 1.23456, -1.23456, 19.99995, -0.00004, 123456.7, 1e-9, -44.63335, 3.0,
        ] {
            let mut s = String::new();
            push_fixed4(&mut s, v);
            let want = format!("{:.4}", v);
            // std rounds half to even on the exact binary value; only exact
            // ties may differ, and none of these is one.
            let want = if want == "-0.0000" {
                "0.0000".to_string()
            } else {
                want
            };
            assert_eq!(s, want, "{v}");
        }
        let mut s = String::new();
        push_fixed4(&mut s, f64::NAN);
        assert_eq!(s, "NaN");
    }
}
