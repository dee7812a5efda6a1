//! The time grid of the dynamic models: the sample time (given, or the
//! first run's median step) and every run resampled onto it, with a note
//! when a run was not already uniform at that step (run files may be
//! sampled irregularly; a fixed-step model says so rather than pretending).

use crate::data::dataset::{Dataset, GridRun};
use anyhow::{anyhow, bail, Result};

/// The model sample time: `--dt-s`, else the median step of the first run.
pub fn sample_time(ds: &Dataset, dt_s: Option<f64>) -> Result<f64> {
    let dt = match dt_s {
        Some(dt) => dt,
        None => {
            let t = &ds.runs.first().ok_or_else(|| anyhow!("no runs"))?.t_s;
            let mut steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
            if steps.is_empty() {
                bail!("the first run has fewer than two rows: no sample time (give --dt-s)");
            }
            steps.sort_by(f64::total_cmp);
            steps[steps.len() / 2]
        }
    };
    if !(dt.is_finite() && dt > 0.0) {
        bail!("sample time {dt} s must be positive");
    }
    Ok(dt)
}

/// Resamples to `dt` and says so when a run was not already on that grid,
/// or when a run has no grid sample where all its columns have begun and
/// none has ended (a run of one row: it is left out).
pub fn grid_runs(ds: &Dataset, dt: f64, kind: &str) -> Result<Vec<GridRun>> {
    for run in &ds.runs {
        let off = run
            .t_s
            .windows(2)
            .any(|w| ((w[1] - w[0]) - dt).abs() > 1e-6 * dt);
        if off {
            eprintln!(
                "note: {kind}: {} is not sampled uniformly at {dt} s; inputs and targets are interpolated linearly onto a {dt} s grid",
                run.name
            );
        }
    }
    let grid = ds.on_grid(dt)?;
    // `on_grid` keeps the runs' order and skips a run without a grid sample.
    let mut kept = grid.iter().peekable();
    for run in &ds.runs {
        if kept.next_if(|g| g.name == run.name).is_none() {
            eprintln!(
                "note: {kind}: {} has no {dt} s sample where every input and target has begun and none has ended; it is left out",
                run.name
            );
        }
    }
    if grid.iter().all(|g| g.calib_end == 0) {
        bail!("{kind}: no calibration samples on the {dt} s grid");
    }
    Ok(grid)
}
