//! `thermcomp simulate`: the flags, their checks against each other, and
//! the printing of the [`crate::simulate`] job's outcomes.

use crate::data::fsio::{self, named, Named};
use crate::simulate::{self, CalibrateParams, Calibrated, SimulateParams};
use crate::twin::calibrate;
use crate::twin::machine::DEFAULT_MACHINE_TOML;
use anyhow::{bail, Result};
use clap::Args;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Arguments of `thermcomp simulate`.
#[derive(Args, Debug)]
pub struct SimulateArgs {
    /// Where to write the run file (CSV).
    /// With --calibrate: optional, the whole calibration run simulated from
    /// its logged speed with the calibrated machine.
    #[arg(long, required_unless_present_any = ["print_machine", "calibrate"])]
    pub out: Option<PathBuf>,
    /// Length of the run, hours (built-in profiles; with file:PATH, cuts the file).
    #[arg(long)]
    pub hours: Option<f64>,
    /// Speed profile: steps, spectrum, cooldown, constant:RPM or file:PATH
    /// (a run file's speed_rpm, power_kw and tool_mm columns on its own time grid).
    /// Not with --calibrate, whose run file sets the speed.
    #[arg(long, default_value = "steps", conflicts_with = "calibrate")]
    pub profile: String,
    /// Unmodelled effects to switch on, comma-separated: ambient, coolant,
    /// cutting, motor_loss, sensor_lag (none: the nominal twin).
    #[arg(long, default_value = "")]
    pub effects: String,
    /// Seed of the sensor noise, the spectrum and the door openings.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Machine file (TOML); the built-in machine if not given
    /// (see --print-machine).
    #[arg(long)]
    pub machine: Option<PathBuf>,
    /// Sample time, s (built-in profiles; not with --calibrate, whose run
    /// file sets the grid).
    #[arg(long, default_value_t = 1.0, conflicts_with = "calibrate")]
    pub dt_s: f64,
    /// Number of temperature sensors T1..Tn (the machine's first N sites;
    /// default all).
    #[arg(long)]
    pub sensors: Option<usize>,
    /// Print a JSON summary on stdout.
    #[arg(long)]
    pub json: bool,
    /// Print the built-in machine file (TOML, commented) and exit.
    #[arg(long)]
    pub print_machine: bool,
    /// Calibrate the machine (--machine, or the built-in one) to this
    /// measured run: heat, bearing speed exponent, heat capacities and
    /// ambient conductances by Levenberg-Marquardt; every *_um column as a
    /// combination of node rises and every T<n> column at its best place
    /// (docs/twin.md, "Calibration"). Needs --save-machine.
    #[arg(long, requires = "save_machine")]
    pub calibrate: Option<PathBuf>,
    /// Where to write the calibrated machine file (TOML).
    #[arg(long, requires = "calibrate")]
    pub save_machine: Option<PathBuf>,
    /// Calibrate on rows with t_s below this, s (default: the first half of
    /// the run); the rest is reported as held out.
    #[arg(long, requires = "calibrate")]
    pub calibrate_until_s: Option<f64>,
}

impl SimulateArgs {
    /// The job's parameters (without `--calibrate`).
    pub fn params(&self) -> SimulateParams {
        SimulateParams {
            hours: self.hours,
            profile: self.profile.clone(),
            effects: self.effects.clone(),
            seed: self.seed,
            machine: self.machine.clone(),
            dt_s: self.dt_s,
            sensors: self.sensors,
        }
    }

    /// The calibration's parameters, with the file the calibrated machine
    /// goes to; refuses the flags that do not apply to `--calibrate`.
    pub fn calibrate_params(&self, progress: bool) -> Result<Option<(CalibrateParams, &Path)>> {
        let Some(real) = &self.calibrate else {
            return Ok(None);
        };
        let Some(save) = &self.save_machine else {
            bail!("--calibrate needs --save-machine CAL.toml");
        };
        // The run file fixes the time grid and the speed; the nominal twin
        // (no effects) is what gets calibrated.
        if self.hours.is_some() || !self.effects.trim().is_empty() || self.sensors.is_some() {
            bail!("--hours, --effects and --sensors do not apply to --calibrate (the run file sets the grid, the speed and the sensors)");
        }
        let p = CalibrateParams {
            real: real.clone(),
            machine: self.machine.clone(),
            until_s: self.calibrate_until_s,
            seed: self.seed,
            progress,
        };
        Ok(Some((p, save)))
    }

    /// Refuses outputs (`--out`, `--save-machine`) that are the same file
    /// as an input (`--machine`, a `file:` profile, `--calibrate`) or as
    /// each other.
    pub fn check_paths(&self) -> Result<()> {
        let profile_file = self.profile.trim().strip_prefix("file:").map(Path::new);
        let mut reads: Vec<Named<'_>> = Vec::new();
        reads.extend(self.calibrate.as_deref().map(|p| named("--calibrate", p)));
        reads.extend(self.machine.as_deref().map(|p| named("--machine", p)));
        reads.extend(profile_file.map(|p| named("--profile file:", p)));
        let mut writes = Vec::new();
        writes.extend(self.out.as_deref().map(|p| named("--out", p)));
        writes.extend(
            self.save_machine
                .as_deref()
                .map(|p| named("--save-machine", p)),
        );
        fsio::check_distinct(&reads, &writes)
    }
}

/// The calibrated machine (and its run, if `--out`) for `a`, written; for
/// scripts that want the run in memory, `None` when `a` does not calibrate.
pub fn calibrated(a: &SimulateArgs, progress: bool) -> Result<Option<Calibrated>> {
    let Some((p, save)) = a.calibrate_params(progress)? else {
        return Ok(None);
    };
    a.check_paths()?;
    let cal = simulate::calibrate_machine(&p)?;
    fsio::write_bytes_atomic(save, cal.toml.as_bytes())?;
    Ok(Some(cal))
}

/// Runs `thermcomp simulate`.
pub fn run(a: &SimulateArgs) -> Result<()> {
    if a.print_machine {
        return fsio::print(DEFAULT_MACHINE_TOML);
    }
    if let Some(cal) = calibrated(a, true)? {
        return print_calibration(a, &cal);
    }
    let Some(out) = &a.out else {
        bail!("--out FILE.csv is needed");
    };
    a.check_paths()?;
    let o = simulate::simulate_to(&a.params().check()?, out)?;
    if a.json {
        fsio::print_line(&serde_json::to_value(&o)?.to_string())
    } else {
        eprintln!(
            "wrote {} ({} rows, {} sensors, max |dz| {:.1} um, effects: {}) in {:.2} s",
            o.out,
            o.rows,
            o.sensors,
            o.max_abs_dz_um,
            if o.effects.is_empty() {
                "none".to_string()
            } else {
                o.effects.join(",")
            },
            o.elapsed_s
        );
        Ok(())
    }
}

/// `simulate --calibrate REAL.csv --save-machine CAL.toml [--out SIM.csv]`:
/// writes the calibrated run if asked, prints the calibration.
fn print_calibration(a: &SimulateArgs, cal: &Calibrated) -> Result<()> {
    let mut v = calibrate::to_json(&cal.calibration);
    if let Some(save) = &a.save_machine {
        v["machine"] = save.display().to_string().into();
    }
    if let Some(out) = &a.out {
        cal.write_run(a.seed, out)?;
        v["out"] = out.display().to_string().into();
    }
    if a.json {
        fsio::print_line(&v.to_string())
    } else {
        eprint!("{}", calibration_table(&cal.calibration));
        if let Some(save) = &a.save_machine {
            eprintln!("wrote {}", save.display());
        }
        Ok(())
    }
}

/// A human-readable summary of a calibration (stderr).
fn calibration_table(cal: &calibrate::Calibration) -> String {
    let mut s = String::new();
    for (p, v) in calibrate::PARAMS.iter().zip(calibrate::values(&cal.theta)) {
        let _ = write!(s, "{:>18} = {v:.4} {}", p.name, p.unit);
        if let Some(side) = p.bound_hit(v) {
            let _ = write!(
                s,
                "  (at its {side} bound: the run did not pin it; the bounds are {} .. {})",
                p.lo, p.hi
            );
        }
        s.push('\n');
    }
    let _ = writeln!(
        s,
        "{} iterations, {} simulations, converged: {} ({}), {:.2} s",
        cal.iterations, cal.evaluations, cal.converged, cal.reason, cal.elapsed_s
    );
    let _ = writeln!(
        s,
        "{:>10} {:>12} {:>8} {:>12} {:>8}",
        "channel", "rmse cal", "fit %", "rmse rest", "fit %"
    );
    for c in &cal.channels {
        let (r, f) = c.rest.map_or((f64::NAN, f64::NAN), |p| (p.rmse, p.fit_pct));
        let _ = writeln!(
            s,
            "{:>10} {} {} {} {}",
            c.name,
            figure(c.calibration.rmse, 9, 3, c.unit),
            figure(c.calibration.fit_pct, 8, 1, ""),
            figure(r, 9, 3, c.unit),
            figure(f, 8, 1, "")
        );
    }
    if cal.channels.iter().all(|c| c.rest.is_none()) {
        s.push_str("nothing held out (--calibrate-until-s covers the run): no rest figures\n");
    }
    s
}

/// `x` as a table figure, then `unit` in two columns (blank beside "-":
/// nothing held out, a flat channel's fit).
fn figure(x: f64, width: usize, decimals: usize, unit: &str) -> String {
    let n = crate::num::shown::figure(Some(x), width, decimals);
    match (unit, x.is_finite()) {
        ("", _) => n,
        (_, true) => format!("{n} {unit:<2}"),
        (_, false) => format!("{n}   "),
    }
}
