//! The cross-validation folds of `fit --model auto`: which calibration
//! samples each fold holds, and which folds each fold's model is fitted on.
//!
//! - Several calibration runs: leave one run out. A fold holds conditions
//!   no other fold saw, as a new day does.
//! - One calibration run: `k` contiguous blocks, each scored by the model
//!   fitted on the blocks before it (rolling origin; the first block is
//!   never scored, nor a block whose past never saw some input move: it
//!   cannot tell how that input acts). That is the deployment's question, "calibrate on what
//!   was, predict what comes next". Scoring a block by the blocks on both
//!   sides of it asks an interpolation question instead, and on
//!   FL_THERMAL's calibration rows (the development split of docs/fit.md)
//!   the models it chose depended strongly on `k` (A' mean reduction 25 to
//!   80 % for k = 3..12) where the rolling origin stayed within 78-84 %.

use crate::data::dataset::GridRun;
use serde::Serialize;

/// Which folds train the model that scores a fold.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Scheme {
    /// Every other fold.
    LeaveOut,
    /// The folds before it; folds before `first` are not scored.
    Forward {
        /// First scored fold (at least 1).
        first: usize,
    },
}

impl Scheme {
    /// Whether the model that scores fold `scored` is fitted on fold `g`.
    pub fn trains_on(self, scored: usize, g: usize) -> bool {
        match self {
            Self::LeaveOut => g != scored,
            Self::Forward { .. } => g < scored,
        }
    }

    /// Whether fold `f` is scored at all.
    pub fn scores(self, f: usize) -> bool {
        match self {
            Self::LeaveOut => true,
            Self::Forward { first } => f >= first,
        }
    }
}

/// The folds of the calibration samples.
#[derive(Clone, Debug)]
pub struct Folds {
    /// Per grid sample (runs concatenated): its fold, `None` for a
    /// held-out sample.
    pub of: Vec<Option<usize>>,
    /// Number of folds.
    pub n: usize,
    /// How a fold's model is trained.
    pub scheme: Scheme,
    /// One line for the report.
    pub description: String,
}

impl Folds {
    /// Leave-one-run-out over the runs with calibration samples when there
    /// are at least two, else `k` forward-chained contiguous blocks of the
    /// one run.
    pub fn of_grid(grid: &[GridRun], k: usize) -> Self {
        let calib_runs: Vec<usize> = (0..grid.len()).filter(|&r| grid[r].calib_end > 0).collect();
        let loro = calib_runs.len() >= 2;
        let mut of = Vec::new();
        for (r, g) in grid.iter().enumerate() {
            let run_fold = calib_runs.iter().position(|&c| c == r);
            for i in 0..g.t_s.len() {
                of.push(if i >= g.calib_end {
                    None
                } else if loro {
                    run_fold
                } else {
                    Some(i * k / g.calib_end)
                });
            }
        }
        if loro {
            let n = calib_runs.len();
            Self {
                of,
                n,
                scheme: Scheme::LeaveOut,
                description: format!(
                    "leave one run out ({n} calibration runs); the ridge averages the candidates within one standard error of the best that have the fewest features"
                ),
            }
        } else {
            let first = first_informative(grid, &of, k);
            Self {
                of,
                n: k,
                scheme: Scheme::Forward { first },
                description: format!(
                    "{k} contiguous blocks of the calibration run, from block {first} on each scored by the fit on the blocks before it"
                ),
            }
        }
    }

    /// Whether calibration sample `k` is scored by the CV (its fold is).
    pub fn scored(&self, k: usize) -> bool {
        self.of
            .get(k)
            .copied()
            .flatten()
            .is_some_and(|f| self.scheme.scores(f))
    }
}

/// The first block `f >= 1` before which every input that moves in the
/// calibration has moved (taken a value other than its first calibration
/// sample's). An input that never moves is left out (it carries nothing
/// any fold could learn, and must not switch the rule off for the
/// others); 1 when some input first moves only in the last block (no
/// block's past saw it move: every block but the first is scored).
fn first_informative(grid: &[GridRun], of: &[Option<usize>], k: usize) -> usize {
    let n_inputs = grid.first().map_or(0, |g| g.x.len());
    // moved_by[i]: the block in which input i first differs from its
    // first calibration value.
    let mut moved_by = vec![None; n_inputs];
    let mut first: Option<Vec<f64>> = None;
    let samples = grid
        .iter()
        .flat_map(|g| (0..g.t_s.len()).map(move |s| (g, s)));
    for ((g, s), f) in samples.zip(of) {
        let Some(f) = *f else { continue };
        let first = first.get_or_insert_with(|| g.x.iter().map(|c| c[s]).collect());
        for (i, m) in moved_by.iter_mut().enumerate() {
            if m.is_none() && g.x[i][s] != first[i] {
                *m = Some(f);
            }
        }
    }
    let latest = moved_by.iter().flatten().copied().max().unwrap_or(0);
    if latest >= k - 1 {
        1
    } else {
        latest + 1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn forward_folds_train_only_on_the_past_and_never_score_the_first() {
        let s = Scheme::Forward { first: 1 };
        assert!(!s.scores(0));
        assert!(s.scores(1));
        assert!(s.trains_on(3, 0) && s.trains_on(3, 2));
        assert!(!s.trains_on(3, 3) && !s.trains_on(3, 4));
        let l = Scheme::LeaveOut;
        assert!(l.scores(0));
        assert!(l.trains_on(3, 4) && !l.trains_on(3, 3));
    }

    fn grid(x: Vec<Vec<f64>>) -> GridRun {
        let n = x[0].len();
        GridRun {
            name: "r".into(),
            t_s: (0..n).map(|k| k as f64).collect(),
            x_lead: vec![Vec::new(); x.len()],
            x,
            y: vec![vec![0.0; n]],
            calib_end: n,
        }
    }

    #[test]
    fn a_block_whose_past_never_saw_an_input_move_is_not_scored() {
        // 6 blocks of 10: input 0 moves from sample 3 (block 0), input 1
        // (a spindle held at one speed) only from sample 25 (block 2): the
        // first block with both moved before it is block 3.
        let a: Vec<f64> = (0..60).map(|k| if k < 3 { 20.0 } else { 21.0 }).collect();
        let b: Vec<f64> = (0..60).map(|k| if k < 25 { 2000.0 } else { 0.0 }).collect();
        let f = Folds::of_grid(&[grid(vec![a.clone(), b])], 6);
        assert_eq!(f.scheme, Scheme::Forward { first: 3 });
        assert!(!f.scored(29) && f.scored(30));
        // Both inputs moving in block 0: every block but the first scored.
        let c: Vec<f64> = (0..60).map(|k| if k < 5 { 1.0 } else { 0.0 }).collect();
        let f = Folds::of_grid(&[grid(vec![a.clone(), c])], 6);
        assert_eq!(f.scheme, Scheme::Forward { first: 1 });
        // A third input that never moves (a coolant held constant) leaves
        // the rule to the others: still block 3 (it gave 1 before).
        let b: Vec<f64> = (0..60).map(|k| if k < 25 { 2000.0 } else { 0.0 }).collect();
        let f = Folds::of_grid(&[grid(vec![a, b, vec![18.0; 60]])], 6);
        assert_eq!(f.scheme, Scheme::Forward { first: 3 });
    }

    #[test]
    fn an_input_moves_against_its_first_calibration_sample() {
        // Two runs, the first held out whole (calib_end 0, input 0 at 19):
        // in the calibration run input 0 is 20 and moves to 19 in block 3,
        // input 1 moves in block 2. Against the held-out run's first value
        // input 0 would have "moved" in block 0 (first scored block 3).
        let mut held = grid(vec![vec![19.0; 60], vec![0.0; 60]]);
        held.calib_end = 0;
        let a: Vec<f64> = (0..60).map(|k| if k < 35 { 20.0 } else { 19.0 }).collect();
        let b: Vec<f64> = (0..60).map(|k| if k < 25 { 2000.0 } else { 0.0 }).collect();
        let f = Folds::of_grid(&[held, grid(vec![a, b])], 6);
        assert_eq!(f.scheme, Scheme::Forward { first: 4 });
    }
}
