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
//! So each measured input (a temperature's role) is judged on the
//! calibration rows as logged (a resampling grid would bridge gaps with
//! straight lines, which have no noise): its *swing*, the rms of its
//! deviation from each run's mean (pooled over the runs, so a sensor that
//! only sat at another level in another run has not moved: [`judge`] says
//! why), against its *noise*, the white-noise sigma from second
//! differences of its present cells within each run
//! ([`white_sigma_pooled`], blind to smooth motion), and when its readings
//! repeat in short holds (a logger faster than its sensor, a reading
//! dithering by its last digit) at least that of the readings with the
//! repeats taken out. An input whose swing is at most [`MIN_SWING_OVER_NOISE`]
//! times its noise is quiet. White noise alone has a ratio of about 1;
//! every temperature of the real FL_THERMAL run has 9.9 or more over each
//! of its calibration parts (the first 16 h and 24 h, the first 40 % and
//! 60 % of the rows), the twin's heated sensors 19 or more
//! (`scripts/quiet_ratios.py`). A heat source
//! (speed, power) is a commanded value: quiet only when it never changes.
//!
//! [`white_sigma_pooled`]: crate::num::lsq::white_sigma_pooled

use super::auto::features::Role;
use crate::data::dataset::Dataset;
use crate::num;
use serde::Serialize;

/// The swing an input needs, in multiples of its white noise, to be
/// calibrated on: its deviations then hold a signal of at least
/// `sqrt(3^2 - 1) = 2.8` times the noise. The ratio is about 1 for noise
/// alone and 9.9 or more for every temperature we have seen move.
pub const MIN_SWING_OVER_NOISE: f64 = 3.0;

/// An input that did not move beyond its noise in calibration.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct QuietInput {
    /// The input column.
    pub input: String,
    /// Rms of its deviation from each run's mean over the calibration
    /// samples, in the column's unit (a heat source's: from the mean of
    /// every run's together).
    pub swing: f64,
    /// Its white-noise sigma, same unit (0 for a heat source).
    pub noise: f64,
}

impl std::fmt::Display for QuietInput {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        let shown = |v: f64| num::shown::figure(Some(v), 0, 4);
        let (swing, noise) = (shown(self.swing), shown(self.noise));
        write!(f, "{} swing {swing}, noise {noise}", self.input)
    }
}

/// What an auto fit left out, as a sentence (stderr's note, the report
/// page): the inputs, and why no weight on them can be calibrated.
pub fn left_out(quiet: &[QuietInput]) -> String {
    format!(
        "auto left out {}: in the calibration rows each moved no more than {} times its white \
         noise, so no weight on it can be calibrated",
        listed(quiet),
        MIN_SWING_OVER_NOISE
    )
}

/// The same of inputs a kind fitted anyway (`fit`'s note for the kinds
/// that read whatever they are given).
pub fn fitted_anyway(quiet: &[QuietInput]) -> String {
    format!(
        "{}: in the calibration rows each moved no more than {} times its white noise, so the \
         weights on them are fitted to noise and turn any later swing of theirs into offset \
         (auto leaves such inputs out; or leave them out of --inputs)",
        listed(quiet),
        MIN_SWING_OVER_NOISE
    )
}

/// The inputs with their swing and noise, `; `-separated.
fn listed(quiet: &[QuietInput]) -> String {
    let each: Vec<String> = quiet.iter().map(ToString::to_string).collect();
    each.join("; ")
}

/// The inputs of `ds` that did not move beyond [`MIN_SWING_OVER_NOISE`]
/// times their noise in its calibration rows, with their indices. The
/// rows are taken as logged, each run's missing cells skipped (not a
/// resampling grid, whose straight lines across a gap have no noise; and
/// second differences across a missing cell still see the noise, where a
/// sparsely filled column would otherwise have none). A run's reference
/// (the change form's first sample) shifts it whole, which neither the
/// swing within it nor its differences see.
pub fn quiet_inputs(ds: &Dataset) -> Vec<(usize, QuietInput)> {
    (0..ds.inputs.len())
        .filter_map(|i| {
            let runs: Vec<Vec<f64>> = ds
                .runs
                .iter()
                .map(|r| (0..r.calib_end).filter_map(|row| r.x(i, row)).collect())
                .collect();
            let name = &ds.inputs[i];
            judge(name, Role::of(name), &runs).map(|q| (i, q))
        })
        .collect()
}

/// `input` (of `role`) judged over `runs` (each run's calibration
/// readings, in order). A temperature is quiet when its swing within the
/// runs is at most [`MIN_SWING_OVER_NOISE`] times its noise. Its level in
/// one run against another does not count: with displacements zeroed at
/// each run's start it teaches the absolute form that the room's level
/// moves nothing, and on the twin's room protocol (docs/fit.md, "When the
/// room moves") letting such sensors into the absolute form sent dz on
/// three of 18 seeds from 1.7-3.6 to 9.0-10.2 um. A heat source is a
/// commanded value without noise: quiet only when it never changes.
pub fn judge(input: &str, role: Role, runs: &[Vec<f64>]) -> Option<QuietInput> {
    if runs.iter().all(Vec::is_empty) {
        return None; // no calibration value: nothing to judge (the fit says so)
    }
    let (swing, noise) = match role {
        Role::Temperature => (swing(runs, false), noise(runs)),
        Role::HeatSource => (swing(runs, true), 0.0),
    };
    (swing <= MIN_SWING_OVER_NOISE * noise).then(|| QuietInput {
        input: input.to_string(),
        swing,
        noise,
    })
}

/// Longest median hold, in samples, at which repeated readings are taken
/// for a logger sampling faster than its sensor updates (or a reading
/// dithering by its last digit) rather than for levels held on purpose: a
/// logger 20 times faster than its sensor; a programme or a controller
/// holds a level for longer.
pub const MAX_HOLD_SAMPLES: usize = 20;

/// The input's noise: its white-noise sigma from second differences; and
/// when its readings repeat in short holds (median at most
/// [`MAX_HOLD_SAMPLES`]), at least that of the readings with the repeats
/// taken out. A room sensor logged to 0.1 K that sits at one reading and
/// flips to the next now and then, or one logged ten times per update, has
/// second differences of median 0, yet what it reports is its noise: with
/// the repeats out it is a plain noisy series. A coarse sensor that climbs
/// or falls level by level has straight stretches there too, so it keeps
/// the sigma of its climb.
fn noise(runs: &[Vec<f64>]) -> f64 {
    let plain = crate::num::lsq::white_sigma_pooled(runs.iter().map(Vec::as_slice));
    let mut holds: Vec<f64> = runs.iter().flat_map(|x| hold_lengths(x)).collect();
    if holds.is_empty() {
        return plain;
    }
    let k = holds.len() / 2;
    if crate::num::stats::kth_smallest(&mut holds, k) > MAX_HOLD_SAMPLES as f64 {
        return plain;
    }
    let distinct: Vec<Vec<f64>> = runs.iter().map(|x| without_repeats(x)).collect();
    plain.max(crate::num::lsq::white_sigma_pooled(
        distinct.iter().map(Vec::as_slice),
    ))
}

/// The lengths of the runs of equal consecutive readings in `x`.
fn hold_lengths(x: &[f64]) -> Vec<f64> {
    x.chunk_by(|a, b| a == b).map(|c| c.len() as f64).collect()
}

/// `x` with each run of equal consecutive readings kept once.
fn without_repeats(x: &[f64]) -> Vec<f64> {
    x.chunk_by(|a, b| a == b).map(|c| c[0]).collect()
}

/// Rms of each sample's deviation from its run's mean over every run, or
/// (`across`) from the mean of all of them together; exactly 0 where the
/// readings never change (a mean of equal readings can miss them by a
/// rounding, which would count as a swing against a noise of 0).
fn swing(runs: &[Vec<f64>], across: bool) -> f64 {
    let all: Vec<f64> = runs.iter().flatten().copied().collect();
    let constant = |x: &[f64]| x.iter().all(|v| Some(v) == x.first());
    if all.is_empty() || (across && constant(&all)) {
        return 0.0;
    }
    let overall = crate::num::stats::mean(&all);
    let mut sum = 0.0;
    for x in runs
        .iter()
        .filter(|x| !x.is_empty() && (across || !constant(x)))
    {
        let mean = if across {
            overall
        } else {
            crate::num::stats::mean(x)
        };
        sum += x.iter().map(|v| (v - mean).powi(2)).sum::<f64>();
    }
    (sum / all.len() as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::dataset::InputForm;
    use crate::data::runfile::RunFile;
    use crate::twin::rng::{Rng, Stream};

    fn noise(n: usize, sigma: f64, rng: &mut Rng) -> Vec<f64> {
        (0..n).map(|_| sigma * rng.normal()).collect()
    }

    /// `judge` of one temperature.
    fn judged(runs: &[Vec<f64>]) -> Option<QuietInput> {
        judge("T", Role::Temperature, runs)
    }

    /// [`quiet_inputs`] of run files with `inputs` (a `dz_um` target),
    /// calibrated before `until_s`.
    fn in_files(runs: &[RunFile], inputs: &[&str], until_s: Option<f64>) -> Vec<QuietInput> {
        let inputs: Vec<String> = inputs.iter().map(|c| c.to_string()).collect();
        let targets = ["dz_um".to_string()];
        let ds = Dataset::new(runs, &[], &inputs, &targets, InputForm::Absolute, until_s).unwrap();
        quiet_inputs(&ds).into_iter().map(|(_, q)| q).collect()
    }

    /// A run file of `columns` at 1 s with a `dz_um` ramp.
    fn run_file(columns: Vec<(&str, Vec<f64>)>) -> RunFile {
        let n = columns[0].1.len();
        let t: Vec<f64> = (0..n).map(|k| k as f64).collect();
        let mut cols: Vec<(String, Option<Vec<f64>>)> = columns
            .into_iter()
            .map(|(c, v)| (c.to_string(), Some(v)))
            .collect();
        cols.push(("dz_um".into(), Some(t.clone())));
        RunFile::from_columns("r.csv", t, cols).unwrap()
    }

    /// Over two runs of 720 samples (8 h at 40 s, the twin's calibration
    /// runs): noise of 0.02 K alone is quiet (ratio about 1), and so is the
    /// same noise at 20 C in one run and 23 C in the other (only the level
    /// differs); a heating of 1 K over each run under the same noise is not
    /// (ratio ~14).
    #[test]
    fn noise_is_quiet_at_any_level_a_heating_under_it_is_not() {
        let mut rng = Rng::new(7, Stream::SensorNoise);
        let n = 720;
        let heat = |k: usize| 1.0 - (-(k as f64) / 200.0).exp();
        let alone = judged(&[noise(n, 0.02, &mut rng), noise(n, 0.02, &mut rng)]).unwrap();
        // 1440 samples: the ratio of noise alone is 1 within ~10 % (the
        // median's sampling spread at this count).
        let ratio = alone.swing / alone.noise;
        assert!((0.85..1.15).contains(&ratio), "{ratio}");
        let at = |level: f64, rng: &mut Rng| -> Vec<f64> {
            noise(n, 0.02, rng).iter().map(|v| v + level).collect()
        };
        let levels = judged(&[at(20.0, &mut rng), at(23.0, &mut rng)]).unwrap();
        assert!(levels.swing < 0.03, "{}", levels.swing);
        let heating =
            |rng: &mut Rng| -> Vec<f64> { (0..n).map(|k| heat(k) + 0.02 * rng.normal()).collect() };
        assert_eq!(judged(&[heating(&mut rng), heating(&mut rng)]), None);
    }

    /// A noise-only sensor logged ten times per update (sample and hold)
    /// is quiet: with the repeats out its second differences are its noise.
    /// A constant at a value whose mean is inexact (2.2) is quiet too.
    #[test]
    fn a_held_noise_and_an_inexact_constant_are_quiet() {
        let mut rng = Rng::new(5, Stream::SensorNoise);
        let updates = noise(200, 0.02, &mut rng);
        let held: Vec<f64> = updates.iter().flat_map(|v| [20.0 + v; 10]).collect();
        let q = judged(&[held]).unwrap();
        // 200 updates: noise alone within ~25 % of ratio 1.
        assert!((0.75..1.25).contains(&(q.swing / q.noise)), "{q:?}");
        let q = judged(&[vec![2.2; 333]]).unwrap();
        assert_eq!((q.swing, q.noise), (0.0, 0.0));
    }

    /// A heat source is a commanded value: quiet only when constant over
    /// every run (an on/off programme of two levels is not, however few
    /// its steps, nor one speed per run at different speeds).
    #[test]
    fn a_heat_source_is_quiet_only_when_constant() {
        let on_off: Vec<f64> = (0..100)
            .map(|k| if k % 40 < 20 { 0.0 } else { 3000.0 })
            .collect();
        let speed = |runs: &[Vec<f64>]| judge("speed_rpm", Role::HeatSource, runs);
        assert_eq!(speed(&[on_off]), None);
        assert_eq!(speed(&[vec![2000.0; 50], vec![4000.0; 50]]), None);
        let q = speed(&[vec![2.2; 100], vec![2.2; 100]]).unwrap();
        assert_eq!((q.swing, q.noise), (0.0, 0.0));
    }

    /// A room sensor logged to 0.1 K that sits at 20.1 and reads 20.2 for
    /// one sample in ten is quiet (its second differences have median 0;
    /// without its repeats it is a noisy series). Readings held for longer
    /// are levels, not noise: a climb of 1 K at 0.1 K resolution, 20 -> 21
    /// -> 22 -> 21 -> 20 at 1 K, and a single 100 K jump all moved.
    #[test]
    fn a_sensor_that_moves_by_its_last_digit_is_quiet_a_climb_in_steps_is_not() {
        let flips: Vec<f64> = (0..500)
            .map(|k| if k % 10 == 3 { 20.2 } else { 20.1 })
            .collect();
        let q = judged(&[flips]).unwrap();
        // sd of a 0/0.1 flip with p = 0.1: 0.1 * sqrt(0.09) = 0.03; without
        // its repeats it alternates, second differences +-0.2 K: sigma
        // 0.2 / 0.6745 / sqrt 6 = 0.121 K.
        assert!((q.swing - 0.03).abs() < 1e-9, "{}", q.swing);
        let alternating = 0.2 / 0.6745 / 6f64.sqrt();
        assert!((q.noise - alternating).abs() < 1e-9, "{}", q.noise);
        let climbs: Vec<f64> = (0..500).map(|k| 20.0 + (k / 50) as f64 * 0.1).collect();
        let coarse: Vec<f64> = (0..500)
            .map(|k| 20.0 + [0.0, 1.0, 2.0, 1.0, 0.0][k / 100])
            .collect();
        let jump: Vec<f64> = (0..300)
            .map(|k| if k < 150 { 20.0 } else { 120.0 })
            .collect();
        for x in [climbs, coarse, jump] {
            assert_eq!(judged(&[x]), None);
        }
    }

    /// A noise-only sensor logged in one row of three (the others empty) is
    /// quiet: its second differences are taken over the cells it has.
    #[test]
    fn a_sparsely_logged_noise_is_quiet() {
        let mut rng = Rng::new(3, Stream::SensorNoise);
        let n = 900;
        let sparse: Vec<f64> = (0..n)
            .map(|k| {
                if k % 3 == 0 {
                    20.0 + 0.02 * rng.normal()
                } else {
                    f64::NAN
                }
            })
            .collect();
        let q = in_files(&[run_file(vec![("T7", sparse)])], &["T7"], None);
        assert_eq!(q.len(), 1);
        // 300 cells: noise alone within ~20 % of ratio 1.
        let ratio = q[0].swing / q[0].noise;
        assert!((0.8..1.2).contains(&ratio), "{ratio}");
    }

    /// From a run file: a sensor that sat at 20 C before a missing
    /// cell and at 23 C after it moved (swing 1.5 K about the run's mean;
    /// the jump is one second difference of many, so the noise stays 0);
    /// rows held out are not judged (the same sensor before the
    /// jump alone is quiet); a heat source held at one speed is quiet.
    #[test]
    fn from_run_files_a_jump_moves_and_held_out_rows_are_not_judged() {
        let mut level: Vec<f64> = (0..100).map(|k| if k < 50 { 20.0 } else { 23.0 }).collect();
        level[50] = f64::NAN;
        let speed = vec![0.0; 100];
        let run = run_file(vec![("T1", level), ("speed_rpm", speed)]);
        let names = ["T1", "speed_rpm"];
        let found = |q: Vec<QuietInput>| -> Vec<(String, f64)> {
            q.into_iter().map(|q| (q.input, q.swing)).collect()
        };
        let all = in_files(std::slice::from_ref(&run), &names, None);
        assert_eq!(found(all), [("speed_rpm".to_string(), 0.0)]);
        let before = in_files(&[run], &names, Some(50.0));
        assert_eq!(
            found(before),
            [("T1".to_string(), 0.0), ("speed_rpm".to_string(), 0.0)]
        );
    }
}
