//! Speed profiles: what the spindle does over a run.
//!
//! | name | profile |
//! |---|---|
//! | `steps` | seed 000's stepwise test: 20, 40, 60, 80, 100 % of `max_rpm`, each for a tenth of the run, then hold at top speed until 75 % of the run, then stop (cool down) |
//! | `spectrum` | ISO 230-3-like speed spectrum: the speed changes every 30, 60 or 120 min (drawn per segment) among 0, 25, 50, 75, 100 % of `max_rpm` (seeded, never the same level twice in a row) |
//! | `cooldown` | top speed for the first half of the run, then stop |
//! | `constant:RPM` | one speed throughout (equilibrium tests) |
//! | `file:PATH` | the `speed_rpm` (and, if present, `power_kw`, `tool_mm`) columns of a run file, on its own time grid |

use super::rng::{Rng, Stream};
use crate::data::cells::Cells;
use crate::data::runfile::{ReadOptions, RunFile};
use anyhow::{anyhow, bail, Result};
use std::path::{Path, PathBuf};

/// A speed profile.
#[derive(Debug, Clone, PartialEq)]
pub enum Profile {
    /// Stepwise increase, hold, stop.
    Steps,
    /// ISO 230-3-like spectrum.
    Spectrum,
    /// Run, then stop.
    Cooldown,
    /// Constant speed, rpm.
    Constant(f64),
    /// Replay a run file's speed (and power, tool) columns.
    File(PathBuf),
}

/// Profile names for messages.
pub const PROFILE_NAMES: &str = "steps, spectrum, cooldown, constant:RPM, file:PATH";

impl Profile {
    /// Parses a `--profile` value.
    pub fn parse(s: &str) -> Result<Profile> {
        let s = s.trim();
        if let Some(path) = s.strip_prefix("file:") {
            if path.is_empty() {
                bail!("--profile file:PATH needs a path");
            }
            return Ok(Profile::File(PathBuf::from(path)));
        }
        if let Some(rpm) = s.strip_prefix("constant:") {
            let v: f64 = rpm
                .trim()
                .parse()
                .map_err(|_| anyhow!("--profile constant:RPM: \"{rpm}\" is not a number"))?;
            if !(v.is_finite() && v >= 0.0) {
                bail!("--profile constant:RPM: speed must be finite and >= 0");
            }
            return Ok(Profile::Constant(v));
        }
        match s {
            "steps" => Ok(Profile::Steps),
            "spectrum" => Ok(Profile::Spectrum),
            "cooldown" => Ok(Profile::Cooldown),
            other => bail!("unknown profile \"{other}\" (one of {PROFILE_NAMES})"),
        }
    }

    /// The profile as it would be written on the command line.
    pub fn label(&self) -> String {
        match self {
            Profile::Steps => "steps".into(),
            Profile::Spectrum => "spectrum".into(),
            Profile::Cooldown => "cooldown".into(),
            Profile::Constant(v) => format!("constant:{v}"),
            Profile::File(p) => format!("file:{}", p.display()),
        }
    }
}

/// The driving signals of a run on its time grid.
#[derive(Debug, Clone, PartialEq)]
pub struct Schedule {
    /// Sample times, s (strictly increasing).
    pub t_s: Vec<f64>,
    /// Spindle speed, rpm.
    pub speed_rpm: Vec<f64>,
    /// Measured spindle power from a run file, kW (written as is).
    pub power_kw: Option<Vec<f64>>,
    /// Tool length from a run file, mm.
    pub tool_mm: Option<Vec<f64>>,
}

/// The schedule of `profile` for a machine with top speed `max_rpm`:
/// `hours` long at `dt_s` (built-in profiles), or the file's grid (cut to
/// `hours` if given).
pub fn schedule(
    profile: &Profile,
    max_rpm: f64,
    hours: Option<f64>,
    dt_s: f64,
    seed: u64,
) -> Result<Schedule> {
    if let Profile::File(path) = profile {
        return from_file(path, hours);
    }
    let Some(hours) = hours else {
        bail!("--hours is needed with --profile {}", profile.label());
    };
    if !(hours.is_finite() && hours > 0.0) {
        bail!("--hours must be finite and > 0 (got {hours})");
    }
    crate::data::spec::check_dt_s(dt_s).map_err(|e| anyhow!("--dt-s: {e}"))?;
    let total_s = hours * 3600.0;
    let steps = (total_s / dt_s + 1e-9).floor();
    if steps > 50e6 {
        bail!("{hours} h at {dt_s} s is {steps} rows; more than 50 million is refused");
    }
    let n = steps as usize + 1;
    let t_s: Vec<f64> = (0..n).map(|k| k as f64 * dt_s).collect();
    let speed_rpm: Vec<f64> = match profile {
        Profile::Steps => t_s
            .iter()
            .map(|&t| steps_rpm(t / total_s, max_rpm))
            .collect(),
        Profile::Cooldown => t_s
            .iter()
            .map(|&t| if t < 0.5 * total_s { max_rpm } else { 0.0 })
            .collect(),
        Profile::Constant(v) => vec![*v; n],
        Profile::Spectrum => {
            let segments = spectrum_segments(total_s, max_rpm, seed);
            let mut j = 0;
            t_s.iter()
                .map(|&t| {
                    while j + 1 < segments.len() && t >= segments[j + 1].0 {
                        j += 1;
                    }
                    segments[j].1
                })
                .collect()
        }
        Profile::File(_) => unreachable!("handled above"),
    };
    Ok(Schedule {
        t_s,
        speed_rpm,
        power_kw: None,
        tool_mm: None,
    })
}

/// `steps` at run fraction `f`.
fn steps_rpm(f: f64, max_rpm: f64) -> f64 {
    if f < 0.5 {
        let level = (f / 0.1).floor() + 1.0;
        (level.min(5.0) * 0.2 * max_rpm).round()
    } else if f < 0.75 {
        max_rpm
    } else {
        0.0
    }
}

/// Segments (start time s, speed rpm) of a seeded spectrum.
pub fn spectrum_segments(total_s: f64, max_rpm: f64, seed: u64) -> Vec<(f64, f64)> {
    const DURATIONS_S: [f64; 3] = [1800.0, 3600.0, 7200.0];
    const LEVELS: [f64; 5] = [0.0, 0.25, 0.5, 0.75, 1.0];
    let mut rng = Rng::new(seed, Stream::Spectrum);
    let mut out = Vec::new();
    let mut t = 0.0;
    let mut last = usize::MAX;
    while t <= total_s {
        let mut level = rng.below(LEVELS.len());
        if level == last {
            level = (level + 1 + rng.below(LEVELS.len() - 1)) % LEVELS.len();
        }
        last = level;
        out.push((t, (LEVELS[level] * max_rpm).round()));
        t += DURATIONS_S[rng.below(DURATIONS_S.len())];
    }
    out
}

impl Schedule {
    /// Refuses a speed above the machine's top speed `max_rpm`: the heat
    /// laws are the machine's up to it, and beyond they extrapolate (a
    /// speed 100 times the top one heats the bearings about 1,600 times as
    /// hard, their losses going as speed^1.6). `profile` names the source
    /// in the message.
    pub fn check_top_speed(&self, max_rpm: f64, profile: &str) -> Result<()> {
        let over = self
            .speed_rpm
            .iter()
            .zip(&self.t_s)
            .find(|(v, _)| **v > max_rpm * (1.0 + 1e-9));
        match over {
            Some((v, t)) => bail!(
                "--profile {profile}: speed_rpm {v} at t_s = {t} is above the machine's max_rpm \
                 {max_rpm}: give a machine file (--machine) whose max_rpm covers it"
            ),
            None => Ok(()),
        }
    }
}

/// A run file's speed, power and tool columns.
fn from_file(path: &Path, hours: Option<f64>) -> Result<Schedule> {
    let opts = ReadOptions {
        skip_bad_rows: false,
        only: Some(vec![
            "speed_rpm".into(),
            "power_kw".into(),
            "tool_mm".into(),
        ]),
    };
    let run = RunFile::read(path, &opts)?;
    let file = path.display();
    let Some(speed) = run.column("speed_rpm") else {
        bail!("{file}: no speed_rpm column to drive the twin");
    };
    let t0 = run.t_s.first().copied().unwrap_or(0.0);
    let keep = match hours {
        Some(h) if h.is_finite() && h > 0.0 => run
            .t_s
            .iter()
            .take_while(|&&t| t - t0 <= h * 3600.0)
            .count(),
        Some(h) => bail!("--hours must be finite and > 0 (got {h})"),
        None => run.len(),
    };
    let dense = |name: &str, values: Cells<'_>| -> Result<Vec<f64>> {
        values
            .slice(0..keep)
            .iter()
            .zip(&run.t_s)
            .map(|(v, t)| v.ok_or_else(|| anyhow!("{file}: {name} is empty at t_s = {t}")))
            .collect()
    };
    let speed_rpm = dense("speed_rpm", speed)?;
    if let Some((v, t)) = speed_rpm.iter().zip(&run.t_s).find(|(v, _)| **v < 0.0) {
        bail!("{file}: speed_rpm {v} < 0 at t_s = {t}");
    }
    let power_kw = run
        .column("power_kw")
        .map(|c| dense("power_kw", c))
        .transpose()?;
    let tool_mm = run
        .column("tool_mm")
        .map(|c| dense("tool_mm", c))
        .transpose()?;
    if let Some(tool) = &tool_mm {
        let tools = crate::fivepoint::HUB_TOOL_MM;
        let bad = tool.iter().zip(&run.t_s).find(|(v, _)| !tools.contains(*v));
        if let Some((v, t)) = bad {
            bail!(
                "{file}: tool_mm {v} at t_s = {t} is outside the hub's 0 ..= {} mm",
                tools.end()
            );
        }
    }
    Ok(Schedule {
        t_s: run.t_s[..keep].to_vec(),
        speed_rpm,
        power_kw,
        tool_mm,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_go_up_hold_and_stop() {
        let s = schedule(&Profile::Steps, 10000.0, Some(10.0), 60.0, 0);
        let s = s.unwrap_or_else(|_| Schedule {
            t_s: vec![],
            speed_rpm: vec![],
            power_kw: None,
            tool_mm: None,
        });
        assert_eq!(s.t_s.len(), 601);
        let at = |h: f64| s.speed_rpm[(h * 60.0) as usize];
        assert_eq!(
            (at(0.5), at(1.5), at(4.5), at(6.0), at(8.0)),
            (2000.0, 4000.0, 10000.0, 10000.0, 0.0)
        );
    }

    #[test]
    fn spectrum_is_seeded_and_changes_level() {
        let a = spectrum_segments(86400.0, 12000.0, 5);
        assert_eq!(a, spectrum_segments(86400.0, 12000.0, 5));
        assert_ne!(a, spectrum_segments(86400.0, 12000.0, 6));
        assert!(a.windows(2).all(|w| w[0].1 != w[1].1));
        assert!(a
            .windows(2)
            .all(|w| [1800.0, 3600.0, 7200.0].contains(&(w[1].0 - w[0].0))));
    }

    #[test]
    fn parse_profiles() {
        assert_eq!(
            Profile::parse("constant:9000").ok(),
            Some(Profile::Constant(9000.0))
        );
        assert!(Profile::parse("ramp").is_err());
        assert!(Profile::parse("constant:-1").is_err());
    }
}
