//! What the cross-validation can judge of extrapolation, and what the
//! search leaves out where it cannot (docs/fit.md, "When the room moves").
//!
//! Every candidate is scored on calibration samples its model did not see,
//! but where those samples lie inside the envelope of the ones it was
//! fitted on, the CV error says how a candidate interpolates, not how it
//! extrapolates. Three situations leave the CV blind to what a day unlike
//! the calibration does to a model, and each restricts the search to the
//! forms that carry over to it:
//!
//! - **Alike runs or blocks.** When fewer than [`MIN_EXTRAPOLATING`] scored
//!   samples lie beyond the hub's flag outside the other folds' envelope
//!   (every input in the change form: how the inputs move, which is what
//!   the filters model; the runs' levels, which leave the envelope in the
//!   absolute form when the rooms differ, test no dynamics), no fold leaves
//!   the others' envelope and every day unlike them is an extrapolation the
//!   CV never tested.
//! - **A temperature no calibration run moved** (several runs; fit/quiet.rs
//!   left it out): whatever moves it in service, the room typically, is a
//!   cause the runs never excited. The CV's extrapolation is then along
//!   the causes the runs did vary (the spindle programme), not along that
//!   one.
//!
//! In both, temperatures enter unfiltered and the dynamic families (ARX,
//! TF) are not tried: a temperature's filter features fit the shape of the
//! responses in time, which the calibration's one way of heating fixed; a
//! temperature's own column is a sensitivity per kelvin, which carries over
//! to another cause of the same temperature change. Heat sources keep
//! their filters (they act only through the structure's lag).
//!
//! - **Runs that all start at one level** (several runs whose first values
//!   differ by less than [`MIN_LEVEL_SPREAD`] of what the runs move within
//!   themselves, and targets zeroed at each run's start, as a logger
//!   zeroes them): leaving a run out never tests how the absolute form
//!   weighs a level other than the calibration's, and another day's room
//!   starts elsewhere. Only the change form is searched: it is zero at
//!   each run's start, as the targets are.
//!
//! Measured (docs/fit.md): on the thermal twin's room protocol the first
//! rule took `auto` from 59.4 to 28.5 um summed over seeds 1-6, and from
//! 54.0 to 29.3 over seeds 7-12 held out. On an independently built lathe
//! plant (calibrated on three constant-room runs, scored on two runs whose
//! room moves), the second and third took the dx + dz sums over seeds 1-6
//! of its four variants from 212.0 to 101.8 um (numpy least squares on the
//! temperature changes: 161.0). On FL_THERMAL (one run) and the demo (one
//! run, 367 samples outside) none of them did anything.

use super::features::Role;
use super::folds::{Folds, Scheme};
use super::search::SearchSettings;
use super::table::{Family, Form};
use super::{cv_extrapolation, MIN_EXTRAPOLATING};
use crate::data::dataset::GridRun;
use crate::num::stats::kth_smallest;
use serde::Serialize;

/// Smallest spread of the calibration runs' first values, as a share of
/// what the runs move within themselves (median over the temperatures),
/// at which leaving a run out tests the absolute form's levels. The
/// independent lathe plant's runs gave 0.01-0.02 at one room level and
/// 1.25-2.80 at three (17, 20, 24 C), the twin's room protocol 1.9; half
/// of a run's own movement lies well inside that gap.
pub const MIN_LEVEL_SPREAD: f64 = 0.5;

/// Largest first value of a target, as a share of its range in that run,
/// for the target to count as zeroed at the run's start (a logger that
/// zeroes at the start gives 0; one that zeroes on the mean of the first
/// samples, about its noise).
pub const ZEROED_WITHIN: f64 = 0.05;

/// What the CV could judge, and what was left out for it.
#[derive(Clone, Debug, Serialize)]
pub struct Sight {
    /// Scored CV samples beyond the flag threshold outside the envelope of
    /// the folds their model was fitted on.
    pub outside_samples: usize,
    /// With several calibration runs, the temperatures left out because no
    /// run moved them (fit/quiet.rs): causes the runs never excited.
    pub unexcited: Vec<String>,
    /// Whether temperatures entered unfiltered and ARX/TF were left out
    /// (`outside_samples` below [`MIN_EXTRAPOLATING`], or `unexcited` not
    /// empty).
    pub static_only: bool,
    /// With several calibration runs, the spread of their first values
    /// over what they move within themselves (median over the
    /// temperatures); `None` with one run or no temperature.
    pub level_spread: Option<f64>,
    /// Whether only the change form was searched (`level_spread` below
    /// [`MIN_LEVEL_SPREAD`] and every target zeroed at each run's start).
    pub change_only: bool,
}

impl Sight {
    /// Measured on the calibration grid: `change_x` the change-form inputs
    /// (`[run][input][k]`), `unmoved` the inputs fit/quiet.rs left out.
    pub fn of(
        grid: &[GridRun],
        change_x: &[Vec<Vec<f64>>],
        roles: &[Role],
        folds: &Folds,
        unmoved: &[&str],
    ) -> Self {
        let columns: Vec<(&[Vec<Vec<f64>>], usize)> =
            (0..roles.len()).map(|i| (change_x, i)).collect();
        let flag = model_core::model::EXTRAPOLATION_FLAG_AT;
        let outside_samples = cv_extrapolation(&columns, folds)
            .iter()
            .filter(|d| **d > flag)
            .count();
        let several = folds.scheme == Scheme::LeaveOut;
        let unexcited: Vec<String> = unmoved
            .iter()
            .filter(|q| several && Role::of(q) == Role::Temperature)
            .map(|q| (*q).to_string())
            .collect();
        let level_spread = several.then(|| level_spread(grid, roles)).flatten();
        let change_only =
            level_spread.is_some_and(|s| s < MIN_LEVEL_SPREAD) && targets_zeroed(grid);
        Self {
            outside_samples,
            static_only: outside_samples < MIN_EXTRAPOLATING || !unexcited.is_empty(),
            unexcited,
            level_spread,
            change_only,
        }
    }

    /// What it means for the fit, one sentence per restriction (stderr's
    /// notes, the report page); empty when the CV saw everything.
    pub fn sentences(&self) -> Vec<String> {
        let unfiltered = "temperatures enter unfiltered and arx/tf are not tried";
        let mut out = Vec::new();
        if self.outside_samples < MIN_EXTRAPOLATING {
            out.push(format!(
                "cross-validation samples outside the other folds' input envelope: {}, fewer \
                 than {MIN_EXTRAPOLATING} (the calibration runs, or one run's blocks, are alike), \
                 so the CV cannot judge how a model extrapolates: {unfiltered}",
                self.outside_samples
            ));
        } else if self.static_only {
            out.push(format!(
                "no calibration run moved {}, so the CV cannot judge how a model carries over \
                 to what moves {} in service (the room, typically): {unfiltered}",
                self.unexcited.join(", "),
                if self.unexcited.len() == 1 {
                    "it"
                } else {
                    "them"
                }
            ));
        }
        if let (true, Some(s)) = (self.change_only, self.level_spread) {
            out.push(format!(
                "the calibration runs start at one level (their first values differ by {s:.2} \
                 of what they move within themselves, below {MIN_LEVEL_SPREAD}) and every \
                 target starts at zero, so the CV cannot judge how the absolute form weighs \
                 another day's level: changes from each run's start only"
            ));
        }
        out
    }

    /// The search settings, families and input forms to weigh.
    pub fn restrict(
        &self,
        s: &SearchSettings,
        families: &[Family],
    ) -> (SearchSettings, Vec<Family>, Vec<Form>) {
        let forms = if self.change_only {
            vec![Form::Change]
        } else {
            Form::ALL.to_vec()
        };
        if !self.static_only {
            return (s.clone(), families.to_vec(), forms);
        }
        let settings = SearchSettings {
            temp_sets: vec![Vec::new()],
            ..s.clone()
        };
        let dynamic = [Family::Arx, Family::Tf];
        let families = families
            .iter()
            .copied()
            .filter(|f| !dynamic.contains(f))
            .collect();
        (settings, families, forms)
    }
}

/// The calibration runs (those with calibration samples) of `grid`.
fn calibrating(grid: &[GridRun]) -> impl Iterator<Item = &GridRun> {
    grid.iter().filter(|g| g.calib_end > 0)
}

/// Largest minus smallest of `v` (0 when empty).
fn extent(v: &[f64]) -> f64 {
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    if hi >= lo {
        hi - lo
    } else {
        0.0
    }
}

/// Median over the temperatures that move of: the spread of the runs'
/// first values (where the hub takes a change's reference: the lead's
/// start, else the grid's) over the runs' mean within-run extent.
fn level_spread(grid: &[GridRun], roles: &[Role]) -> Option<f64> {
    let mut ratios: Vec<f64> = roles
        .iter()
        .enumerate()
        .filter(|(_, r)| **r == Role::Temperature)
        .filter_map(|(i, _)| {
            let runs: Vec<&GridRun> = calibrating(grid).collect();
            let starts: Vec<f64> = runs
                .iter()
                .filter_map(|g| g.x_lead[i].first().or(g.x[i].first()).copied())
                .collect();
            let moved = runs
                .iter()
                .map(|g| extent(&g.x[i][..g.calib_end]))
                .sum::<f64>()
                / runs.len().max(1) as f64;
            (moved > 0.0).then(|| extent(&starts) / moved)
        })
        .collect();
    let mid = ratios.len().checked_sub(1)? / 2;
    Some(kth_smallest(&mut ratios, mid))
}

/// Whether every target starts at zero in every calibration run (its first
/// value within [`ZEROED_WITHIN`] of its range in the run).
fn targets_zeroed(grid: &[GridRun]) -> bool {
    calibrating(grid).all(|g| {
        g.y.iter().all(|y| {
            let y = &y[..g.calib_end];
            y.first()
                .is_some_and(|y0| y0.abs() <= ZEROED_WITHIN * extent(y))
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run of one temperature and one target on a 3-sample grid.
    fn run(t: [f64; 3], y: [f64; 3]) -> GridRun {
        GridRun {
            name: "r".into(),
            t_s: vec![0.0, 1.0, 2.0],
            x: vec![t.to_vec()],
            x_lead: vec![Vec::new()],
            y: vec![y.to_vec()],
            calib_end: 3,
        }
    }

    #[test]
    fn one_level_is_told_from_several() {
        let roles = [Role::Temperature];
        // Both runs start at 20 C and move 2 K: spread 0 of 2.
        let same = [
            run([20.0, 21.0, 22.0], [0.0, 1.0, 2.0]),
            run([20.0, 22.0, 21.0], [0.0, 2.0, 1.0]),
        ];
        assert_eq!(level_spread(&same, &roles), Some(0.0));
        assert!(targets_zeroed(&same));
        // Starts 3 K apart over 2 K of movement: 1.5.
        let apart = [
            run([20.0, 21.0, 22.0], [0.0, 1.0, 2.0]),
            run([23.0, 25.0, 24.0], [0.0, 2.0, 1.0]),
        ];
        assert_eq!(level_spread(&apart, &roles), Some(1.5));
        // A target that starts 0.2 into a range of 2 (10 %) is not zeroed;
        // 0.1 (5 %) is.
        let offset = [run([20.0, 21.0, 22.0], [0.2, 1.0, 2.2]), same[1].clone()];
        assert!(!targets_zeroed(&offset));
        let zeroed = [run([20.0, 21.0, 22.0], [0.1, 1.0, 2.1]), same[1].clone()];
        assert!(targets_zeroed(&zeroed));
        // A heat source is not a level; no temperature: no spread.
        assert_eq!(level_spread(&same, &[Role::HeatSource]), None);
    }
}
