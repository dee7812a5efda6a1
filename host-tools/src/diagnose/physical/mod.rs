//! `thermcomp diagnose --machine M.toml`: the gap explained with the twin
//! itself instead of linear stand-ins (docs/diagnose.md, "With the machine
//! file"). Mismatch of the twin's own parameters is separated from an
//! unmodelled effect in three named steps:
//!
//! 1. [`recalibrate`]: the machine's factors (heat, bearing exponent,
//!    capacities, ambient conductances) with its displacement gains and
//!    sensor offsets fitted by [`calibrate::calibrate_with`] on the real
//!    run's rows before the hold-out, the sensors where the machine file
//!    puts them; re-simulated over the whole run from the run's speed. What
//!    it leaves on the held-out part is not mismatch of these factors.
//! 2. [`fit_effect`]: each candidate effect switched on in that twin
//!    ([`effects`]), its parameters fitted together with the factors on the
//!    same rows, re-simulated; held-out rms before (recalibrated twin) and
//!    after (twin + effect): how far the gap shrinks once the effect is
//!    added.
//! 3. [`report_html`]: the held-out part of the main channel (and `dz_um`):
//!    real, recalibrated twin, twin + the best effect.

pub mod effects;

use super::align::Aligned;
use super::candidates::round;
use super::outcome::{self, json_number, Params, PhysicalEffect, TwinFit};
use super::{regime, spectrum};
use crate::data::runfile::{resample_linear, ReadOptions, RunFile};
use crate::num::lsq;
use crate::twin::calibrate::{self, CalibrateOptions, Calibration, Measured, Setup};
use crate::twin::drive::{P_AMBIENT, P_COOLANT};
use crate::twin::machine::{Machine, Site};
use anyhow::{Context, Result};
use effects::Candidate;
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::path::Path;

/// Power beyond air cutting below this everywhere in the fit part is no
/// cutting to fit, kW.
const MIN_CUT_KW: f64 = 0.1;

/// The physical diagnosis: its outcome (the diagnosis's `physical`) and the
/// report's section.
#[derive(Debug, Clone)]
pub struct Physical {
    /// The outcome.
    pub outcome: outcome::Physical,
    /// The report's section (heading, text, plots).
    pub html: String,
}

/// The real run as the twin sees it.
pub struct Run {
    /// Speed, power, tool and the measured channels, split at the hold-out.
    pub data: Measured,
    /// Logged ambient air, deg C, every row (gaps interpolated).
    pub ambient_c: Option<Vec<f64>>,
    /// Logged coolant supply, deg C, every row.
    pub coolant_c: Option<Vec<f64>>,
    /// Per temperature channel, the machine file's place pair for it.
    pub pinned: Vec<Option<(usize, usize)>>,
}

/// A candidate to fit, or why it cannot be.
enum Plan {
    Fit(Box<dyn Candidate>),
    Skip(&'static str, String),
}

/// One candidate fitted (or not).
struct Outcome {
    name: &'static str,
    model: String,
    params: Params,
    cal: Option<Calibration>,
}

impl Outcome {
    /// A candidate not fitted, and why.
    fn without(name: &'static str, why: String) -> Outcome {
        Outcome {
            name,
            model: why,
            params: Params::new(),
            cal: None,
        }
    }
}

/// The twin's machine file, read and checked.
#[derive(Debug, Clone)]
pub struct Twin {
    /// The machine.
    pub machine: Machine,
    /// Its file, as given.
    pub path: String,
}

impl Twin {
    /// Reads `--machine` (a bad file is an error naming file, line and
    /// column).
    pub fn load(path: &Path) -> Result<Twin> {
        Ok(Twin {
            machine: Machine::load(path).context("--machine")?,
            path: path.display().to_string(),
        })
    }
}

/// The physical diagnosis of the real run `real` with the twin, fitted
/// before `holdout_s`; `al`, `n_fit` and `main` are the statistical
/// diagnosis's alignment, fit rows and main channel.
pub fn diagnose(
    twin: &Twin,
    real: &Path,
    al: &Aligned,
    (n_fit, holdout_s): (usize, f64),
    main: &str,
) -> Result<Physical> {
    let started = std::time::Instant::now();
    let m = &twin.machine;
    let run = read_run(real, holdout_s, m)?;
    let recal = recalibrate(m, &run)?;
    let outcomes = plan(m, &run, &recal)
        .into_par_iter()
        .map(|p| fit_effect(m, &run, &recal, p))
        .collect::<Vec<_>>();
    let channel = scored_channel(&recal, main);
    let about = About {
        noise: noise_sigma(&run, &recal, &outcomes, channel),
        machine: twin.path.clone(),
        started,
    };
    let outcome = outcome_of(&recal, &outcomes, channel, (al, n_fit), about);
    let html = report_html(&run, &recal, &outcomes, channel, main);
    Ok(Physical { outcome, html })
}

/// Reads the real run, split at `holdout_s`, with its logged boundaries
/// and the machine's sensor places.
pub fn read_run(real: &Path, holdout_s: f64, m: &Machine) -> Result<Run> {
    let data = Measured::read(real, Some(holdout_s))?;
    let opts = ReadOptions {
        skip_bad_rows: false,
        only: Some(vec!["ambient_c".into(), "coolant_c".into()]),
    };
    let file = RunFile::read(real, &opts)?;
    // A log is the boundary, even a flat one: the air or coolant did not
    // move (the statistical candidates infer a cycle below a 0.1 K swing).
    let logged = |name: &str| -> Option<Vec<f64>> {
        let col = file.column(name)?;
        dense(&resample_linear(&file.t_s, col, &data.schedule.t_s))
    };
    let pinned = data
        .temps
        .iter()
        .map(|s| machine_place(m, &s.name))
        .collect();
    Ok(Run {
        ambient_c: logged("ambient_c"),
        coolant_c: logged("coolant_c"),
        pinned,
        data,
    })
}

/// Gaps at the edges filled with the nearest value; `None` if empty.
fn dense(v: &[Option<f64>]) -> Option<Vec<f64>> {
    let first = v.iter().flatten().next().copied()?;
    let mut last = first;
    Some(
        v.iter()
            .map(|x| {
                last = x.unwrap_or(last);
                last
            })
            .collect(),
    )
}

/// The place pair of the machine's sensor called `name` (its node and the
/// place it leans toward), as calibration place indices.
fn machine_place(m: &Machine, name: &str) -> Option<(usize, usize)> {
    let i = m.sensors.names.iter().position(|n| n == name)?;
    let site = m.sensors.sites.get(i)?;
    let index = |s: Site| match s {
        Site::Node(n) => n.index(),
        Site::Ambient => P_AMBIENT,
        Site::Coolant => P_COOLANT,
    };
    let a = index(site.node);
    let b = if site.share > 0.0 {
        index(site.toward)
    } else {
        a
    };
    Some((a, b))
}

/// Step 1: the machine's own factors fitted on the fit part (start: the
/// best of the calibration's 3 x 3 grid), nominal twin.
pub fn recalibrate(m: &Machine, run: &Run) -> Result<Calibration> {
    let setup = Setup {
        start: None,
        pinned: &run.pinned,
        effect: None,
    };
    calibrate::calibrate_with(m, &run.data, &setup, &CalibrateOptions::default())
        .context("recalibrating the machine on the fit part")
}

/// The candidates in CONTRACT order, each in the form the run's logs
/// allow.
fn plan(m: &Machine, run: &Run, recal: &Calibration) -> Vec<Plan> {
    let s = &run.data.schedule;
    let t0 = s.t_s[0];
    let t_rel_s: Vec<f64> = s.t_s.iter().map(|t| t - t0).collect();
    let rise = |v: &[f64]| v.iter().map(|x| x - v[0]).collect::<Vec<f64>>();
    let ambient: Box<dyn Candidate> = match &run.ambient_c {
        Some(v) => Box::new(effects::Logged {
            boundary: effects::Boundary::Ambient,
            rise_k: rise(v),
        }),
        None => Box::new(effects::DayCycle {
            t_rel_s: t_rel_s.clone(),
        }),
    };
    let coolant = match &run.coolant_c {
        Some(v) => Plan::Fit(Box::new(effects::Logged {
            boundary: effects::Boundary::Coolant,
            rise_k: rise(v),
        })),
        None => chiller(m, run, recal, t_rel_s),
    };
    let cutting = match cut_kw(run) {
        Some(cut_kw) => Plan::Fit(Box::new(effects::Cutting {
            cut_kw,
            file: m.effects.cutting.clone(),
        })),
        None => Plan::Skip(
            "cutting",
            format!("no power_kw beyond air cutting (>= {MIN_CUT_KW} kW) in the fit part"),
        ),
    };
    let motor = Box::new(effects::MotorLoss {
        speed_rpm: s.speed_rpm.clone(),
        max_rpm: m.max_rpm,
    });
    let lag = sensor_lag(run);
    vec![Plan::Fit(ambient), coolant, cutting, Plan::Fit(motor), lag]
}

/// Power beyond air cutting, if the fit part has any.
fn cut_kw(run: &Run) -> Option<Vec<f64>> {
    let s = &run.data.schedule;
    let cut = regime::cutting_excess_kw(&s.speed_rpm, s.power_kw.as_deref()?);
    cut[..run.data.n_fit]
        .iter()
        .any(|&c| c >= MIN_CUT_KW)
        .then_some(cut)
}

/// The sensor-lag candidate: every temperature channel lags unless the
/// machine puts it on the air or the coolant alone.
fn sensor_lag(run: &Run) -> Plan {
    let channels: Vec<(String, bool)> = run
        .data
        .temps
        .iter()
        .zip(&run.pinned)
        .map(|(s, p)| {
            let on_boundary = matches!(p, Some((a, b)) if a == b && *a >= P_AMBIENT);
            (s.name.clone(), !on_boundary)
        })
        .collect();
    if channels.iter().any(|c| c.1) {
        Plan::Fit(Box::new(effects::SensorLag { channels }))
    } else {
        Plan::Skip("sensor_lag", "no temperature sensor on a part".into())
    }
}

/// The coolant candidate when `coolant_c` is not logged: the machine's
/// chiller, if the residual shows a period to start from.
fn chiller(m: &Machine, run: &Run, recal: &Calibration, t_rel_s: Vec<f64>) -> Plan {
    match chiller_period_s(run, recal) {
        Some(p) => Plan::Fit(Box::new(effects::Chiller {
            t_rel_s,
            period0_s: p,
            warm_over_cool: m.effects.coolant.warm_c_per_min / m.effects.coolant.cool_c_per_min,
        })),
        None => Plan::Skip(
            "coolant",
            "coolant_c not logged and no 10 min - 2 h peak in the recalibrated residual".into(),
        ),
    }
}

/// The chiller's period to start from: the 10 min - 2 h peak of the
/// recalibrated twin's fit-part residual on the channel with the most
/// energy in that band.
fn chiller_period_s(run: &Run, recal: &Calibration) -> Option<f64> {
    let d = &run.data;
    let t = &d.schedule.t_s;
    d.disp
        .iter()
        .chain(&d.temps)
        .zip(&recal.channels)
        .filter_map(|(s, c)| {
            let (ts, r): (Vec<f64>, Vec<f64>) = s
                .fit_rows
                .iter()
                .filter_map(|&k| s.values[k].map(|y| (t[k], y - c.pred[k])))
                .unzip();
            let mid = spectrum::bands(&ts, &r).mid_pct;
            let peak =
                spectrum::peak_period_s(&ts, &r, spectrum::FAST_BELOW_S, spectrum::SLOW_ABOVE_S)?;
            Some((mid, peak))
        })
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, p)| p)
}

/// Step 2 for one candidate: the effect's parameters and the machine's
/// factors fitted together from the recalibrated twin. A fit that fails
/// is listed with its error (`model`), as a candidate that does not apply.
fn fit_effect(m: &Machine, run: &Run, recal: &Calibration, plan: Plan) -> Outcome {
    let c = match plan {
        Plan::Fit(c) => c,
        Plan::Skip(name, why) => return Outcome::without(name, format!("not applicable: {why}")),
    };
    let setup = Setup {
        start: Some(recal.theta),
        pinned: &run.pinned,
        effect: Some(c.as_ref()),
    };
    match calibrate::calibrate_with(m, &run.data, &setup, &CalibrateOptions::default()) {
        Ok(cal) => Outcome {
            name: c.name(),
            model: c.model(),
            params: c.describe(&cal.effect),
            cal: Some(cal),
        },
        Err(e) => Outcome::without(c.name(), format!("fit failed: {e:#}")),
    }
}

/// The channel the shrink is reported on: the statistical main channel if
/// the twin models it, else `dz_um`, else the first.
fn scored_channel(recal: &Calibration, main: &str) -> usize {
    let at = |name: &str| recal.channels.iter().position(|c| c.name == name);
    at(main).or_else(|| at("dz_um")).unwrap_or(0)
}

/// Held-out rms per channel (`None` where the channel has no hold-out figure).
fn held_out(cal: &Calibration) -> BTreeMap<String, Option<f64>> {
    cal.channels
        .iter()
        .map(|c| (c.name.clone(), c.rest.map(|r| round(r.rmse))))
        .collect()
}

fn rest_rms(cal: &Calibration, channel: usize) -> f64 {
    cal.channels
        .get(channel)
        .and_then(|c| c.rest)
        .map_or(f64::NAN, |r| r.rmse)
}

/// The machine's refitted factors (relative to the machine file).
fn twin_fit(cal: &Calibration) -> TwinFit {
    let values = calibrate::values(&cal.theta);
    let factor = |name: &str| {
        calibrate::PARAMS
            .iter()
            .position(|p| p.name == name)
            .map_or(f64::NAN, |i| round(values[i]))
    };
    TwinFit {
        bearing_exponent: factor("bearing_exponent"),
        capacity_factor: factor("capacity_factor"),
        converged: cal.converged,
        g_ambient_factor: factor("g_ambient_factor"),
        heat_factor: factor("heat_factor"),
        simulations: cal.evaluations,
    }
}

/// One effect's entry and its held-out rms on `channel`.
fn effect_outcome(o: &Outcome, before: f64, channel: usize) -> (f64, PhysicalEffect) {
    let after = o.cal.as_ref().map_or(before, |c| rest_rms(c, channel));
    let shrink = 100.0 * (1.0 - after / before);
    let e = PhysicalEffect {
        held_out_rms: o.cal.as_ref().map(held_out),
        model: o.model.clone(),
        name: o.name.to_string(),
        params: o.params.clone(),
        rms_after: round(after),
        rms_before: round(before),
        shrink_pct: round(shrink),
        twin: o.cal.as_ref().map(twin_fit),
    };
    (after, e)
}

/// The physical outcome: effects sorted by held-out rms, best first; the
/// figures of the run (`noise`, `gap_snr`, `machine`, `seconds`) are the
/// caller's.
/// What the physical outcome reports beside the fits: the scored
/// channel's noise, the machine file and when the diagnosis began.
struct About {
    noise: f64,
    machine: String,
    started: std::time::Instant,
}

fn outcome_of(
    recal: &Calibration,
    outcomes: &[Outcome],
    channel: usize,
    (al, n_fit): (&Aligned, usize),
    about: About,
) -> outcome::Physical {
    let before = rest_rms(recal, channel);
    let mut effects: Vec<(f64, PhysicalEffect)> = outcomes
        .iter()
        .map(|o| effect_outcome(o, before, channel))
        .collect();
    effects.sort_by(|a, b| a.0.total_cmp(&b.0));
    let gap_of_sim = al
        .channels
        .each()
        .filter(|c| recal.channels.iter().any(|r| r.name == c.name))
        .map(|c| (c.name.clone(), round(lsq::rms(&c.resid[n_fit..]))))
        .collect();
    outcome::Physical {
        best: best(outcomes, channel).map(|o| o.name.to_string()),
        channel: recal.channels.get(channel).map(|c| c.name.clone()),
        effects: effects.into_iter().map(|e| e.1).collect(),
        gap_after_recalibration: held_out(recal),
        gap_of_sim,
        gap_snr: round(before / about.noise.max(1e-12)),
        machine: about.machine,
        method: METHOD.into(),
        noise_sigma: round(about.noise),
        recalibrated: twin_fit(recal),
        seconds: round(about.started.elapsed().as_secs_f64()),
        simulations: recal.evaluations
            + outcomes
                .iter()
                .filter_map(|o| o.cal.as_ref())
                .map(|c| c.evaluations)
                .sum::<usize>(),
    }
}

/// The method in words (`method`).
const METHOD: &str = "the machine's factors refitted on the fit part (recalibrated twin); then each effect switched on in the twin, its parameters refitted with the factors on the fit part; held-out rms of the recalibrated twin (rms_before) and of the twin with the effect (rms_after) on `channel`";

fn effect_after(o: &Outcome, channel: usize) -> f64 {
    o.cal
        .as_ref()
        .map_or(f64::INFINITY, |c| rest_rms(c, channel))
}

/// The fitted effect with the smallest held-out rms on `channel` (a
/// description, not a verdict: with nothing left to explain it is the one
/// that happened to fit the noise best).
fn best(outcomes: &[Outcome], channel: usize) -> Option<&Outcome> {
    outcomes
        .iter()
        .filter(|o| o.cal.is_some())
        .min_by(|a, b| effect_after(a, channel).total_cmp(&effect_after(b, channel)))
}

/// The noise on channel `c`: of the whitest held-out residual (the twin
/// that explains most); the recalibrated twin's alone would count fast
/// unexplained swings (cutting cycles) as noise.
fn noise_sigma(run: &Run, recal: &Calibration, outcomes: &[Outcome], c: usize) -> f64 {
    outcomes
        .iter()
        .filter_map(|o| o.cal.as_ref())
        .chain([recal])
        .map(|cal| held_out_noise(run, cal, c))
        .fold(f64::INFINITY, f64::min)
}

/// Noise of a twin's held-out residual on channel `c` (first-difference
/// MAD, [`lsq::noise_sigma`]).
fn held_out_noise(run: &Run, recal: &Calibration, c: usize) -> f64 {
    let d = &run.data;
    let Some(s) = d.disp.iter().chain(&d.temps).nth(c) else {
        return f64::NAN;
    };
    let r: Vec<f64> = s
        .rest_rows
        .iter()
        .filter_map(|&k| s.values[k].map(|y| y - recal.channels[c].pred[k]))
        .collect();
    lsq::noise_sigma(&r)
}

/// Step 3: the report's section: for the scored channel (and `dz_um`),
/// the held-out part of real, the recalibrated twin and the twin with the
/// best effect.
fn report_html(
    run: &Run,
    recal: &Calibration,
    outcomes: &[Outcome],
    channel: usize,
    main: &str,
) -> String {
    let best = best(outcomes, channel);
    let mut html = format!(
        "<h2>With the machine file: the twin recalibrated, then each effect added to it</h2><p>The machine's factors are refitted on the rows before the hold-out (main channel {}); each effect is then switched on in the twin with its parameters fitted on the same rows. Held-out part only.</p>",
        crate::plot::esc(main)
    );
    let mut focus = vec![channel];
    if let Some(dz) = recal.channels.iter().position(|c| c.name == "dz_um") {
        if dz != channel {
            focus.push(dz);
        }
    }
    for c in focus {
        html.push_str(&held_out_plot(run, recal, best, c));
    }
    html
}

/// One channel's held-out plots: the values (real drawn last, on top),
/// then what each twin leaves of the real value.
fn held_out_plot(run: &Run, recal: &Calibration, best: Option<&Outcome>, c: usize) -> String {
    let d = &run.data;
    let Some(series) = d.disp.iter().chain(&d.temps).nth(c) else {
        return String::new();
    };
    let t = &d.schedule.t_s;
    let rows = &series.rest_rows;
    let t_h: Vec<f64> = rows.iter().map(|&k| (t[k] - t[0]) / 3600.0).collect();
    let real: Vec<f64> = rows.iter().filter_map(|&k| series.values[k]).collect();
    let pick =
        |cal: &Calibration| -> Vec<f64> { rows.iter().map(|&k| cal.channels[c].pred[k]).collect() };
    // Short legend labels: the chart gives each 130 px.
    let mut twins = vec![("recalibrated".to_string(), pick(recal))];
    if let Some((o, cal)) = best.and_then(|o| o.cal.as_ref().map(|cal| (o, cal))) {
        twins.push((format!("+ {}", o.name), pick(cal)));
    }
    let left: Vec<(String, Vec<f64>)> = twins
        .iter()
        .map(|(n, v)| (n.clone(), real.iter().zip(v).map(|(y, p)| y - p).collect()))
        .collect();
    let mut values = twins;
    values.push(("real".into(), real));
    let unit = if series.name.ends_with("_um") {
        "um"
    } else {
        "C"
    };
    let chart = |title: String, lines: &[(String, Vec<f64>)], h: f64| -> String {
        let refs: Vec<(&str, &[f64])> = lines
            .iter()
            .map(|(n, v)| (n.as_str(), v.as_slice()))
            .collect();
        crate::plot::line_chart(&title, &t_h, &refs, None, h)
    };
    let name = &series.name;
    chart(
        format!("{name} ({unit}), held-out: real, recalibrated twin, twin + effect"),
        &values,
        260.0,
    ) + &chart(
        format!("{name}: real minus each twin ({unit})"),
        &left,
        200.0,
    )
}

/// The text table's lines for the physical diagnosis.
pub fn text(p: &outcome::Physical) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let r = &p.recalibrated;
    let _ = writeln!(
        s,
        "\nwith the machine file: recalibrated heat x{}, bearing exponent {}, capacity x{}, ambient conductance x{}",
        json_number(r.heat_factor),
        json_number(r.bearing_exponent),
        json_number(r.capacity_factor),
        json_number(r.g_ambient_factor)
    );
    let ch = p.channel.as_deref().unwrap_or("?");
    let _ = writeln!(
        s,
        "{:<12} {:>11} {:>10} {:>9}   (twin re-simulated, {ch}, held-out rms)",
        "effect", "recalib.", "+ effect", "shrink %"
    );
    for e in &p.effects {
        let _ = writeln!(
            s,
            "{:<12} {:>11.3} {:>10.3} {:>9.1}",
            e.name, e.rms_before, e.rms_after, e.shrink_pct
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::twin::machine::Node;

    #[test]
    fn the_machines_sensor_places_are_kept() {
        let m = Machine::default_machine();
        let s = Node::Structure.index();
        // T10: column skin, 30 % toward the air; T7: the air itself.
        assert_eq!(machine_place(&m, "T10"), Some((s, P_AMBIENT)));
        assert_eq!(machine_place(&m, "T7"), Some((P_AMBIENT, P_AMBIENT)));
        assert_eq!(machine_place(&m, "T5"), Some((s, s)));
        assert_eq!(machine_place(&m, "T11"), None);
    }

    #[test]
    fn the_twin_fit_has_a_field_for_every_calibrated_factor() {
        // twin_fit reads the factors by name: a new one needs a field.
        let mut names: Vec<&str> = calibrate::PARAMS.iter().map(|p| p.name).collect();
        names.sort_unstable();
        let fields = [
            "bearing_exponent",
            "capacity_factor",
            "g_ambient_factor",
            "heat_factor",
        ];
        assert_eq!(names, fields);
    }

    #[test]
    fn gaps_are_filled_with_the_nearest_value() {
        let v = [None, Some(1.0), None, Some(3.0), None];
        assert_eq!(dense(&v), Some(vec![1.0, 1.0, 1.0, 3.0, 3.0]));
        assert_eq!(dense(&[None, None]), None);
    }
}
