//! `thermcomp demo`'s five-point line: E, the tilts and the tool-tip drift
//! of a run from its probes S1..S5 (docs/fivepoint.md), and how much a tool
//! change would move the radial offsets. In memory, on a run the demo has
//! already written; one line of progress on stderr.

use crate::data::runfile::{ReadOptions, RunFile};
use crate::fivepoint::{
    compute, FivePointParams, ProbeRun, DEFAULT_A_MM, PROBE_COLUMNS, TOOL_COLUMN,
};
use anyhow::{anyhow, Result};
use model_core::fivepoint::DEFAULT_L_DEFL_MM;
use serde_json::{json, Value};
use std::path::Path;

/// A second tool length to compare with, mm (a long boring bar).
const OTHER_TOOL_MM: f64 = 250.0;

/// Runs the step on `run` (a twin run with S1..S5, tool_mm, dx_um): the
/// demo's `"fivepoint"` object.
pub fn step(run: &Path) -> Result<Value> {
    let needed = PROBE_COLUMNS
        .iter()
        .chain(&[TOOL_COLUMN, "dx_um", "dy_um", "dz_um"])
        .map(|c| (*c).to_owned())
        .collect();
    let opts = ReadOptions {
        skip_bad_rows: false,
        only: Some(needed),
    };
    let r = RunFile::read(run, &opts)?;
    let col = |c: &str| {
        r.column(c)
            .ok_or_else(|| anyhow!("{}: no {c}", run.display()))
    };
    let probes = [col("S1")?, col("S2")?, col("S3")?, col("S4")?, col("S5")?];
    let params = FivePointParams {
        a_mm: DEFAULT_A_MM,
        l_defl_mm: DEFAULT_L_DEFL_MM,
        tool_mm: None,
    }
    .check()?;
    let probe_run = ProbeRun {
        t_s: &r.t_s,
        probes,
        tool_mm: Some(col(TOOL_COLUMN)?),
    };
    let (c, o) = compute(&params, &probe_run)?;
    // Agreement with the twin's own tip (its probes carry noise from the
    // first row on: a fraction of a um).
    let mut worst: f64 = 0.0;
    for (k, axis) in ["dx_um", "dy_um", "dz_um"].iter().enumerate() {
        for (ours, twin) in c.columns[k + 3].iter().zip(col(axis)?) {
            if let (Some(a), Some(b)) = (ours, twin) {
                worst = worst.max((a - b).abs());
            }
        }
    }
    // The state at the end of the run (the warmest, for the demo's runs).
    let last = (0..r.len()).rev().find(|&k| c.columns[3][k].is_some());
    let end = |k: usize| last.and_then(|row| c.columns[k][row]).unwrap_or(0.0);
    let tool_now = last
        .and_then(|row| col(TOOL_COLUMN).ok()?.get(row))
        .unwrap_or(0.0);
    // theta [urad] x delta tool [mm] = 1e-3 um.
    let moved = end(1) * (OTHER_TOOL_MM - tool_now) * 1e-3;
    eprintln!(
        "      fivepoint (end of the validation run): E {:.1} um, theta_x {:.2} urad, theta_y {:.2} urad -> tool tip dx {:.2}, dy {:.2}, dz {:.2} um with the {tool_now} mm tool (the twin's tip within {worst:.2} um: it keeps the first row's probe noise); a {OTHER_TOOL_MM} mm tool moves dx by {moved:+.2} um on the hub",
        end(0),
        end(1),
        end(2),
        end(3),
        end(4),
        end(5),
    );
    Ok(json!({
        "run": run.display().to_string(),
        "summary": o,
        "max_abs_vs_twin_um": worst,
        "tool_mm": tool_now,
        "other_tool_mm": OTHER_TOOL_MM,
        "dx_moves_um": moved,
    }))
}
