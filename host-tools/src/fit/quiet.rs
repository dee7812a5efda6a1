//! Inputs that did not move in calibration: left out of an auto model,
//! named in a note for the other kinds.
//!
//! A weight on an input can be calibrated only from how the input moved in
//! the calibration rows. A sensor that moved no more than its own white
//! noise there (a room sensor in a climate-controlled hall, a spare channel,
//! a sensor on a part the calibration runs never heated) gives the fit
//! nothing but noise to regress on: auto's penalty works on standardised
//! columns, so a noise-sized column buys a weight per kelvin as large as the
//! noise is small, and the first day its sensor moves (the room swings by
//! 2 K where it held 0.02 K) the model extrapolates by that weight times the
//! swing. On the thermal twin's "room moves" protocol such weights sent
//! `auto`'s dx and dy on new runs to 31-58 um rms against displacements
//! that move about 1.3 um (docs/fit.md, "When the room moves").
//!
//! So each measured input (a temperature's role: not a commanded heat
//! source) is judged on the calibration samples: its *swing*, the rms of
//! its deviation from each run's mean (pooled over the runs, so a sensor
//! that only sat at another level in another run has not moved), against
//! its *noise*, the white-noise sigma from second differences within each
//! stretch of consecutive samples ([`white_sigma_pooled`], blind to smooth
//! motion), at least that of its resolution (the smallest step it took,
//! over sqrt 12). An input whose swing is at most [`MIN_SWING_OVER_NOISE`]
//! times its noise is quiet. White noise alone has a ratio of about 1;
//! every temperature of the real FL_THERMAL run has 9.9 or more over each
//! of its calibration parts (the first 16 h and 24 h, the first 40 % and
//! 60 % of the rows), the twin's heated sensors 19 or more.
//!
//! [`white_sigma_pooled`]: crate::num::lsq::white_sigma_pooled

use super::auto::features::Role;
use crate::data::dataset::GridRun;
use crate::data::runfile::RunFile;
use crate::num;
use serde::Serialize;

/// The swing an input needs, in multiples of its white noise, to be
/// calibrated on: its deviations then hold a signal of at least
/// `sqrt(3^2 - 1) = 2.8` times the noise. The ratio is about 1 for noise
/// alone and 9.9 or more for every temperature we have seen move.
pub const MIN_SWING_OVER_NOISE: f64 = 3.0;

/// An input left out: it moved no more than its noise in calibration.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct QuietInput {
    /// The input column.
    pub input: String,
    /// Rms of its deviation from each run's mean over the calibration
    /// samples, in the column's unit.
    pub swing: f64,
    /// Its white-noise sigma, same unit.
    pub noise: f64,
}

impl std::fmt::Display for QuietInput {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        let shown = |v: f64| num::shown::figure(Some(v), 0, 4);
        let (swing, noise) = (shown(self.swing), shown(self.noise));
        write!(f, "{} swing {swing}, noise {noise}", self.input)
    }
}

/// The inputs of `names` (roles `roles`) that did not move beyond
/// [`MIN_SWING_OVER_NOISE`] times their noise in the calibration samples
/// of `grid`, with their dataset indices.
pub fn quiet_inputs(
    grid: &[GridRun],
    roles: &[Role],
    names: &[String],
) -> Vec<(usize, QuietInput)> {
    roles
        .iter()
        .enumerate()
        .filter(|(_, r)| **r == Role::Temperature)
        .filter_map(|(i, _)| {
            let runs: Vec<Vec<&[f64]>> =
                grid.iter().map(|g| vec![&g.x[i][..g.calib_end]]).collect();
            judge(&names[i], &runs).map(|q| (i, q))
        })
        .collect()
}

/// The columns of `columns` (measured ones: not heat sources) that did not
/// move beyond [`MIN_SWING_OVER_NOISE`] times their noise in the rows of
/// `runs` before `until_s` (every row: `None`), each run's missing cells
/// splitting it into stretches: what `fit` says of the inputs of a kind
/// that reads whatever it is given.
pub fn in_runs(runs: &[RunFile], columns: &[String], until_s: Option<f64>) -> Vec<QuietInput> {
    columns
        .iter()
        .filter(|c| Role::of(c) == Role::Temperature)
        .filter_map(|c| {
            let stretches: Vec<Vec<Vec<f64>>> =
                runs.iter().map(|r| stretches(r, c, until_s)).collect();
            let runs: Vec<Vec<&[f64]>> = stretches
                .iter()
                .map(|run| run.iter().map(Vec::as_slice).collect())
                .collect();
            judge(c, &runs)
        })
        .collect()
}

/// The stretches of present cells of `column` in `run` before `until_s`.
fn stretches(run: &RunFile, column: &str, until_s: Option<f64>) -> Vec<Vec<f64>> {
    let Some(cells) = run.column(column) else {
        return Vec::new();
    };
    let mut out = vec![Vec::new()];
    for (k, t) in run.t_s.iter().enumerate() {
        if until_s.is_some_and(|u| *t >= u) {
            break;
        }
        match cells.get(k) {
            Some(v) => out.last_mut().expect("one").push(v),
            None if out.last().is_some_and(|s| !s.is_empty()) => out.push(Vec::new()),
            None => {}
        }
    }
    out.retain(|s| !s.is_empty());
    out
}

/// `input` judged over `runs` (each run's stretches of consecutive
/// samples): quiet when its swing is at most [`MIN_SWING_OVER_NOISE`]
/// times its noise.
pub fn judge(input: &str, runs: &[Vec<&[f64]>]) -> Option<QuietInput> {
    let (swing, noise) = (swing(runs), noise(runs));
    (swing <= MIN_SWING_OVER_NOISE * noise).then(|| QuietInput {
        input: input.to_string(),
        swing,
        noise,
    })
}

/// The input's noise: its white-noise sigma from second differences, and
/// at least the noise of its resolution, `q / sqrt 12` with `q` the smallest
/// step it ever took (a room sensor logged to 0.1 K that sits at one
/// reading and flips to the next now and then has second differences of
/// median 0, yet moved no more than its last digit).
fn noise(runs: &[Vec<&[f64]>]) -> f64 {
    let stretches = || runs.iter().flatten().copied();
    let step = stretches()
        .flat_map(|x| x.windows(2).map(|w| (w[1] - w[0]).abs()))
        .filter(|d| *d > 0.0)
        .fold(f64::INFINITY, f64::min);
    let resolution = if step.is_finite() {
        step / 12f64.sqrt()
    } else {
        0.0
    };
    crate::num::lsq::white_sigma_pooled(stretches()).max(resolution)
}

/// Rms of each sample's deviation from its run's mean, over every run.
fn swing(runs: &[Vec<&[f64]>]) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for run in runs {
        let x: Vec<f64> = run.iter().flat_map(|s| s.iter().copied()).collect();
        if x.is_empty() {
            continue;
        }
        let mean = crate::num::stats::mean(&x);
        sum += x.iter().map(|v| (v - mean).powi(2)).sum::<f64>();
        n += x.len();
    }
    if n == 0 {
        0.0
    } else {
        (sum / n as f64).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::twin::rng::{Rng, Stream};

    /// A grid run of the given input columns, every sample calibration.
    fn run(x: Vec<Vec<f64>>) -> GridRun {
        let n = x[0].len();
        GridRun {
            name: "r".into(),
            t_s: (0..n).map(|k| k as f64).collect(),
            x,
            x_lead: Vec::new(),
            y: vec![vec![0.0; n]],
            calib_end: n,
        }
    }

    fn noise(n: usize, sigma: f64, rng: &mut Rng) -> Vec<f64> {
        (0..n).map(|_| sigma * rng.normal()).collect()
    }

    /// Of four columns over two runs of 720 samples (8 h at 40 s, the
    /// twin's calibration runs): noise of 0.02 K alone, and sitting at
    /// another level in the second run, are quiet (ratio about 1); a
    /// heating of 1 K over the run under the same noise is not (ratio
    /// ~14); a heat source is never judged.
    #[test]
    fn noise_is_quiet_and_a_heating_under_it_is_not() {
        let mut rng = Rng::new(7, Stream::SensorNoise);
        let n = 720;
        let heat = |k: usize| 1.0 - (-(k as f64) / 200.0).exp();
        let mut runs = Vec::new();
        for level in [20.0, 23.0] {
            let cols = vec![
                noise(n, 0.02, &mut rng),
                noise(n, 0.02, &mut rng).iter().map(|v| v + level).collect(),
                (0..n).map(|k| heat(k) + 0.02 * rng.normal()).collect(),
                vec![0.0; n],
            ];
            runs.push(run(cols));
        }
        let roles = [
            Role::Temperature,
            Role::Temperature,
            Role::Temperature,
            Role::HeatSource,
        ];
        let names: Vec<String> = ["T1", "ambient_c", "T2", "speed_rpm"]
            .map(String::from)
            .into();
        let quiet = quiet_inputs(&runs, &roles, &names);
        let found: Vec<&str> = quiet.iter().map(|(_, q)| q.input.as_str()).collect();
        assert_eq!(found, ["T1", "ambient_c"]);
        for (_, q) in &quiet {
            // 1440 samples: the ratio of noise alone is 1 within ~10 %
            // (the median's sampling spread at this count).
            let ratio = q.swing / q.noise;
            assert!((0.85..1.15).contains(&ratio), "{}: {ratio}", q.input);
        }
    }

    /// A room sensor logged to 0.1 K that sits at 20.1 and reads 20.2 for
    /// one sample in ten is quiet (swing 0.03 K against its resolution's
    /// 0.029 K; its second differences have median 0); one that climbs
    /// 1 K at that resolution is not (swing ~0.3 K).
    #[test]
    fn a_sensor_that_moves_by_its_last_digit_is_quiet() {
        let flips: Vec<f64> = (0..500)
            .map(|k| if k % 10 == 3 { 20.2 } else { 20.1 })
            .collect();
        let climbs: Vec<f64> = (0..500).map(|k| 20.0 + (k / 50) as f64 * 0.1).collect();
        let names: Vec<String> = ["T1", "T2"].map(String::from).into();
        let quiet = quiet_inputs(&[run(vec![flips, climbs])], &[Role::Temperature; 2], &names);
        assert_eq!(quiet.len(), 1);
        let q = &quiet[0].1;
        assert_eq!(q.input, "T1");
        // sd of a 0/0.1 flip with p = 0.1: 0.1 * sqrt(0.09) = 0.03.
        assert!((q.swing - 0.03).abs() < 1e-9, "{}", q.swing);
        assert!((q.noise - 0.1 / 12f64.sqrt()).abs() < 1e-9, "{}", q.noise);
    }

    /// `fit`'s note on a run file: a gap splits the stretches (a sensor that
    /// sat at 20 C before a gap and at 23 C after moved: swing 1.5 K about
    /// the run's mean, the noise from within the stretches, 0), and rows
    /// from `until_s` on are not judged (the same sensor before the gap
    /// alone is quiet); a heat source is never judged.
    #[test]
    fn in_run_files_gaps_split_and_held_out_rows_are_not_judged() {
        let t: Vec<f64> = (0..100).map(f64::from).collect();
        let mut level: Vec<f64> = (0..100).map(|k| if k < 50 { 20.0 } else { 23.0 }).collect();
        level[50] = f64::NAN;
        let speed = vec![0.0; 100];
        let columns = vec![
            ("T1".to_string(), Some(level)),
            ("speed_rpm".to_string(), Some(speed)),
        ];
        let run = RunFile::from_columns("r.csv", t, columns).unwrap();
        let names: Vec<String> = ["T1", "speed_rpm"].map(String::from).into();
        assert!(in_runs(std::slice::from_ref(&run), &names, None).is_empty());
        let before = in_runs(&[run], &names, Some(50.0));
        assert_eq!(before.len(), 1);
        assert_eq!((before[0].input.as_str(), before[0].swing), ("T1", 0.0));
    }

    /// A column that never changes is quiet (swing 0, noise 0); with the
    /// calibration ending before its only movement, it is judged on the
    /// calibration samples alone.
    #[test]
    fn a_constant_column_and_a_move_after_calibration_are_quiet() {
        let mut moved = vec![5.0; 100];
        for v in &mut moved[60..] {
            *v = 9.0;
        }
        let mut g = run(vec![vec![1.5; 100], moved]);
        g.calib_end = 50;
        let names: Vec<String> = ["T1", "T2"].map(String::from).into();
        let quiet = quiet_inputs(&[g], &[Role::Temperature; 2], &names);
        assert_eq!(quiet.len(), 2);
        assert!(quiet.iter().all(|(_, q)| q.swing == 0.0 && q.noise == 0.0));
    }
}
