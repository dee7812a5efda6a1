//! `thermcomp simulate`: run the thermal twin ([`crate::twin`]) and write a
//! run file (CONTRACT.md section 2).

use crate::data::fsio::{named, Named};
use crate::data::runfile::RunFile;
use crate::twin::calibrate;
use crate::twin::effects::EffectSet;
use crate::twin::machine::{Machine, DEFAULT_MACHINE_TOML, N_NODES};
use crate::twin::profile::{self, Profile};
use crate::twin::sim::{self, SimOptions, Summary};
use anyhow::{bail, Context, Result};
use clap::Args;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

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

/// Runs `thermcomp simulate`.
pub fn run(a: &SimulateArgs) -> Result<()> {
    if a.print_machine {
        crate::data::fsio::print(DEFAULT_MACHINE_TOML)?;
        return Ok(());
    }
    if let Some(real) = &a.calibrate {
        return run_calibration(a, real);
    }
    let Some(out) = &a.out else {
        bail!("--out FILE.csv is needed");
    };
    check_paths(a, &[])?;
    let (machine, profile, schedule, opts) = setup(a)?;
    let effects = opts.effects;
    let started = Instant::now();
    let (summary, n_sensors) = write_run(&machine, &schedule, &opts, out)?;
    let elapsed_s = started.elapsed().as_secs_f64();
    if a.json {
        crate::data::fsio::print_line(
            &summary_json(&summary, a, &profile, &effects, n_sensors, out, elapsed_s).to_string(),
        )?;
    } else {
        eprintln!(
            "wrote {} ({} rows, {} sensors, max |dz| {:.1} um, effects: {}) in {:.2} s",
            out.display(),
            summary.rows,
            n_sensors,
            summary.max_abs_dz_um,
            if effects.names().is_empty() {
                "none".to_string()
            } else {
                effects.names().join(",")
            },
            elapsed_s
        );
    }
    Ok(())
}

/// The machine (`--machine` or the built-in one), profile, schedule and
/// options `a` asks for.
fn setup(a: &SimulateArgs) -> Result<(Machine, Profile, profile::Schedule, SimOptions)> {
    let machine = match &a.machine {
        Some(p) => Machine::load(p)?,
        None => Machine::default_machine(),
    };
    let profile = Profile::parse(&a.profile)?;
    let effects = EffectSet::parse(&a.effects)?;
    let schedule = profile::schedule(&profile, machine.max_rpm, a.hours, a.dt_s, a.seed)?;
    let opts = SimOptions {
        effects,
        seed: a.seed,
        sensors: a.sensors,
    };
    Ok((machine, profile, schedule, opts))
}

/// The run `simulate` would write for `a` (its `--out` is not used), in
/// memory: the very text of the file, read back, so every value is the
/// file's.
///
/// With `--calibrate REAL.csv` (and `--save-machine`, written), the
/// calibrated twin's run over the real run's grid, as `--out` would hold.
pub fn simulate(a: &SimulateArgs) -> Result<RunFile> {
    let (machine, schedule, opts) = match &a.calibrate {
        Some(real) => {
            let (cal, data, _) = calibrate_machine(a, real)?;
            (cal.machine, data.schedule, calibrated_options(a)?)
        }
        None => {
            let (machine, _, schedule, opts) = setup(a)?;
            (machine, schedule, opts)
        }
    };
    let n_sensors = opts.sensors.unwrap_or(machine.sensors.sites.len());
    let name = std::path::Path::new("simulated");
    let mut text = Vec::new();
    write_rows(&machine, &schedule, &opts, n_sensors, &mut text, name)?;
    Ok(RunFile::from_reader(
        "simulated",
        text.as_slice(),
        &crate::data::runfile::ReadOptions::default(),
    )?)
}

/// `simulate --calibrate REAL.csv --save-machine CAL.toml [--out SIM.csv]`.
fn run_calibration(a: &SimulateArgs, real: &std::path::Path) -> Result<()> {
    let (cal, data, save) = calibrate_machine(a, real)?;
    let mut v = calibrate::to_json(&cal);
    v["machine"] = save.display().to_string().into();
    if let Some(out) = &a.out {
        write_run(&cal.machine, &data.schedule, &calibrated_options(a)?, out)?;
        v["out"] = out.display().to_string().into();
    }
    if a.json {
        crate::data::fsio::print_line(&v.to_string())?;
    } else {
        eprint!("{}", calibration_table(&cal));
        eprintln!("wrote {}", save.display());
    }
    Ok(())
}

/// `--calibrate REAL.csv`: the twin fitted to the real run, its machine
/// file written to `--save-machine`; returns the calibration, the real
/// run's schedule and the path written.
fn calibrate_machine<'a>(
    a: &'a SimulateArgs,
    real: &std::path::Path,
) -> Result<(
    calibrate::Calibration,
    calibrate::Measured,
    &'a std::path::Path,
)> {
    let Some(save) = &a.save_machine else {
        bail!("--calibrate needs --save-machine CAL.toml");
    };
    check_paths(a, &[named("--calibrate", real)])?;
    // The run file fixes the time grid and the speed; the nominal twin
    // (no effects) is what gets calibrated.
    if a.hours.is_some() || !a.effects.trim().is_empty() || a.sensors.is_some() {
        bail!("--hours, --effects and --sensors do not apply to --calibrate (the run file sets the grid, the speed and the sensors)");
    }
    let (text, label) = match &a.machine {
        Some(p) => (
            crate::data::fsio::read_text_capped(p)?,
            p.display().to_string(),
        ),
        None => (DEFAULT_MACHINE_TOML.to_string(), "<default machine>".into()),
    };
    let base = crate::twin::machine::parse(&label, &text)?;
    let data = calibrate::Measured::read(real, a.calibrate_until_s)?;
    let opts = calibrate::CalibrateOptions {
        progress: true,
        ..Default::default()
    };
    let cal = calibrate::calibrate(&base, &data, &opts)?;
    let toml = calibrate::to_toml(&text, &cal, &real.display().to_string())?;
    crate::data::fsio::write_bytes_atomic(save, toml.as_bytes())?;
    Ok((cal, data, save))
}

/// The options of the calibrated twin's run: no effects, `--seed`.
fn calibrated_options(a: &SimulateArgs) -> Result<SimOptions> {
    Ok(SimOptions {
        effects: EffectSet::parse("")?,
        seed: a.seed,
        sensors: None,
    })
}

/// Refuses outputs (`--out`, `--save-machine`) that are the same file as an
/// input (`--machine`, a `file:` profile, `extra`) or as each other.
fn check_paths(a: &SimulateArgs, extra: &[Named<'_>]) -> Result<()> {
    let profile_file = a
        .profile
        .trim()
        .strip_prefix("file:")
        .map(std::path::Path::new);
    let mut reads: Vec<Named<'_>> = extra.to_vec();
    reads.extend(a.machine.as_deref().map(|p| named("--machine", p)));
    reads.extend(profile_file.map(|p| named("--profile file:", p)));
    let mut writes = Vec::new();
    writes.extend(a.out.as_deref().map(|p| named("--out", p)));
    writes.extend(
        a.save_machine
            .as_deref()
            .map(|p| named("--save-machine", p)),
    );
    crate::data::fsio::check_distinct(&reads, &writes)
}

/// A human-readable summary of a calibration (stderr).
fn calibration_table(cal: &calibrate::Calibration) -> String {
    let mut s = String::new();
    for (p, v) in calibrate::PARAMS.iter().zip(calibrate::values(&cal.theta)) {
        let _ = writeln!(s, "{:>18} = {v:.4} {}", p.name, p.unit);
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
            "{:>10} {:>9.3} {:<2} {:>8.1} {:>9.3} {:<2} {:>8.1}",
            c.name, c.calibration.rmse, c.unit, c.calibration.fit_pct, r, c.unit, f
        );
    }
    s
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

fn summary_json(
    s: &Summary,
    a: &SimulateArgs,
    profile: &Profile,
    effects: &EffectSet,
    n_sensors: usize,
    out: &std::path::Path,
    elapsed_s: f64,
) -> serde_json::Value {
    let eq = s.equilibrium.as_ref().map(|e| {
        serde_json::json!({
            "speed_rpm": e.speed_rpm,
            "from_t_s": e.from_t_s,
            "dz_um": e.dz_um,
            "t63_s": e.t63_s,
            "t95_s": e.t95_s,
        })
    });
    serde_json::json!({
        "out": out.display().to_string(),
        "rows": s.rows,
        "sensors": n_sensors,
        "profile": profile.label(),
        "effects": effects.names(),
        "seed": a.seed,
        "machine": a.machine.as_ref().map_or_else(|| "default".to_string(), |p| p.display().to_string()),
        "max_abs_dz_um": s.max_abs_dz_um,
        "max_abs_dx_um": s.max_abs_dx_um,
        "max_abs_dy_um": s.max_abs_dy_um,
        "max_rise_c": s.max_rise_c.0,
        "max_rise_node": s.max_rise_c.1.name(),
        "slowest_time_constant_s": s.slowest_time_constant_s,
        "equilibrium": eq,
        "elapsed_s": elapsed_s,
    })
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
