//! The five-point job: from the probe readings S1..S5 of a run to the
//! spindle's elongation and tilts and the tool-tip drift (docs/fivepoint.md).
//!
//! Each probe's change is taken from its first reading in the run (the cold
//! sample, seed 001 Eq. 25–26), then, with model-core's geometry
//! ([`model_core::geometry`], seed 001 Eq. 1–4 and 27–28):
//!
//! ```text
//! E  = dS5                       e_um
//! θx = atan((dS1 − dS3) / a)     theta_x_urad
//! θy = atan((dS2 − dS4) / a)     theta_y_urad
//! (dx, dy, dz) = tip drift for l_defl and the row's tool length (exact; ≈ (l+tool)θx, (l+tool)θy, −E)
//! ```
//!
//! A row's value is empty when a reading it needs is empty: `e_um` needs S5,
//! `theta_x_urad` S1 and S3, `theta_y_urad` S2 and S4, the tip all five and
//! a tool length. No row is ever dropped.

use crate::data::cells::{Cells, LastLogged};
use anyhow::{anyhow, bail, Result};
use model_core::fivepoint::{is_five_point, FivePoint, DEFAULT_L_DEFL_MM};
use model_core::geometry::{spindle_drift, ProbeReadings, SpindleDrift};
use model_core::ValidModel;
use serde::Serialize;

/// Probe columns, S1..S5 (CONTRACT section 2).
pub const PROBE_COLUMNS: [&str; 5] = ["S1", "S2", "S3", "S4", "S5"];
/// The run column a row's tool length is read from when no fixed one is given.
pub const TOOL_COLUMN: &str = "tool_mm";
/// The tool lengths the hub takes, mm (`firmware::pipeline::MAX_TOOL_LENGTH_MM`;
/// it refuses others and keeps its last one): `hub set-tool`, a machine
/// file and a file profile are held to them.
pub const HUB_TOOL_MM: std::ops::RangeInclusive<f64> = 0.0..=firmware::pipeline::MAX_TOOL_LENGTH_MM;
/// Columns the job writes, after `t_s`, in this order.
pub const OUTPUT_COLUMNS: [&str; 6] = [
    "e_um",
    "theta_x_urad",
    "theta_y_urad",
    "dx_um",
    "dy_um",
    "dz_um",
];
/// Probe spacing of both papers, mm (seed 001: "= 120 mm").
pub const DEFAULT_A_MM: f64 = 120.0;
/// µrad per rad.
const URAD_PER_RAD: f64 = 1e6;

/// What the user asks for (unchecked).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FivePointParams {
    /// Axial distance between the near and far radial probes, mm.
    pub a_mm: f64,
    /// Distance from the spindle nose up to the deflection centre, mm.
    pub l_defl_mm: f64,
    /// A fixed tool length, mm; `None`: each row's `tool_mm`.
    pub tool_mm: Option<f64>,
}

/// [`FivePointParams`] after [`FivePointParams::check`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ValidFivePointParams(FivePointParams);

impl FivePointParams {
    /// Checks the lengths once: `a_mm` finite and positive, `l_defl_mm` and
    /// a fixed tool length finite and in `0..=5000` mm.
    pub fn check(self) -> Result<ValidFivePointParams> {
        let max = model_core::fivepoint::MAX_L_DEFL_MM;
        if !(self.a_mm.is_finite() && self.a_mm > 0.0 && self.a_mm <= max) {
            bail!("--a-mm {}: must be > 0 and <= {max} mm", self.a_mm);
        }
        if !(0.0..=max).contains(&self.l_defl_mm) {
            bail!("--l-defl-mm {}: must be in 0..={max} mm", self.l_defl_mm);
        }
        if let Some(t) = self.tool_mm.filter(|t| !(0.0..=max).contains(t)) {
            bail!("--tool-mm {t}: must be in 0..={max} mm");
        }
        Ok(ValidFivePointParams(self))
    }
}

impl ValidFivePointParams {
    /// The checked values.
    pub fn get(&self) -> &FivePointParams {
        &self.0
    }
}

/// One run's readings, in memory.
#[derive(Debug, Clone, Copy)]
pub struct ProbeRun<'a> {
    /// Sample times, s (for messages).
    pub t_s: &'a [f64],
    /// S1..S5, µm, one value per row (`None`: empty cell).
    pub probes: [Cells<'a>; 5],
    /// The run's `tool_mm` column, if it has one.
    pub tool_mm: Option<Cells<'a>>,
}

/// The computed columns, one value per row, in [`OUTPUT_COLUMNS`] order.
#[derive(Debug, Clone, PartialEq)]
pub struct FivePointColumns {
    /// `columns[i][row]`.
    pub columns: [Vec<Option<f64>>; 6],
}

/// Largest magnitudes and counts over a run (the JSON summary).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FivePointOutcome {
    /// Rows written.
    pub rows: usize,
    /// Rows with a tool-tip drift (all five probes and a tool length).
    pub tip_rows: usize,
    /// Where the tool length came from: `"--tool-mm"` or `"tool_mm"`.
    pub tool_from: &'static str,
    /// Rows whose `tool_mm` cell is empty and that took the last length
    /// logged before them (a CNC logs the tool when it changes; the hub
    /// holds the last one received the same way).
    pub tool_held_rows: usize,
    /// Probe spacing used, mm.
    pub a_mm: f64,
    /// Deflection-centre distance used, mm.
    pub l_defl_mm: f64,
    /// Largest |value| of each written column, keyed by its name; `None`
    /// (JSON null) where no row has a value.
    pub max_abs: std::collections::BTreeMap<&'static str, Option<f64>>,
}

/// Each probe's first reading: the reference its changes are taken from.
fn references(run: &ProbeRun<'_>) -> [Option<f64>; 5] {
    run.probes
        .map(|col| col.iter().find_map(|v| v.filter(|x| x.is_finite())))
}

/// Change of probe `i` at `row` from its reference.
fn change(run: &ProbeRun<'_>, refs: &[Option<f64>; 5], i: usize, row: usize) -> Option<f64> {
    let v = run.probes.get(i)?.get(row)?;
    Some(v - refs.get(i).copied().flatten()?)
}

/// Each row's tool length: `--tool-mm`, else the row's `tool_mm`, else
/// the last one logged before it (`None` before the first); and how many
/// rows took a held length.
fn tool_lengths(p: &FivePointParams, run: &ProbeRun<'_>) -> (Vec<Option<f64>>, usize) {
    let n = run.t_s.len();
    if let Some(t) = p.tool_mm {
        return (vec![Some(t); n], 0);
    }
    let mut hold = LastLogged::default();
    let tools = (0..n)
        .map(|row| hold.next(run.tool_mm.and_then(|c| c.get(row))))
        .collect();
    (tools, hold.held())
}

/// One row: E, θx, θy (each when its probes have values) and the tip.
fn row_values(
    p: &FivePointParams,
    run: &ProbeRun<'_>,
    refs: &[Option<f64>; 5],
    (row, tool): (usize, Option<f64>),
) -> Result<[Option<f64>; 6]> {
    let d = |i| change(run, refs, i, row);
    let angle = |near: Option<f64>, far: Option<f64>| -> Result<Option<f64>> {
        let (Some(n), Some(f)) = (near, far) else {
            return Ok(None);
        };
        let c = ProbeReadings {
            s1_um: n,
            s3_um: f,
            ..ProbeReadings::default()
        };
        Ok(Some(spindle_drift(&c, p.a_mm)?.yaw_rad * URAD_PER_RAD))
    };
    let e = d(4);
    let tx = angle(d(0), d(2))?;
    let ty = angle(d(1), d(3))?;
    let tip = match (e, tx, ty, tool) {
        (Some(e), Some(tx), Some(ty), Some(tool)) => {
            let drift = SpindleDrift {
                elongation_um: e,
                yaw_rad: tx / URAD_PER_RAD,
                pitch_rad: ty / URAD_PER_RAD,
            };
            let t = drift.tool_tip_drift(p.l_defl_mm, tool)?;
            [Some(t.x_um), Some(t.y_um), Some(t.z_um)]
        }
        _ => [None; 3],
    };
    Ok([e, tx, ty, tip[0], tip[1], tip[2]])
}

/// Computes the five-point columns of one run. Fails (naming the row's
/// time) only on a tool length outside `0..=5000` mm or readings so large
/// the geometry overflows.
pub fn compute(
    params: &ValidFivePointParams,
    run: &ProbeRun<'_>,
) -> Result<(FivePointColumns, FivePointOutcome)> {
    let p = params.get();
    if p.tool_mm.is_none() && run.tool_mm.is_none() {
        bail!("the run has no {TOOL_COLUMN} column: give --tool-mm");
    }
    let n = run.t_s.len();
    if run.probes.iter().any(|c| c.len() != n) || run.tool_mm.is_some_and(|c| c.len() != n) {
        bail!("probe and tool columns must have one value per row");
    }
    let refs = references(run);
    let (tools, tool_held_rows) = tool_lengths(p, run);
    let max = model_core::fivepoint::MAX_L_DEFL_MM;
    let mut columns: [Vec<Option<f64>>; 6] = Default::default();
    for (row, &tool) in tools.iter().enumerate() {
        let t = run.t_s.get(row).copied().unwrap_or(f64::NAN);
        if let Some(tool) = tool.filter(|v| !(0.0..=max).contains(v)) {
            bail!("t_s = {t}: {TOOL_COLUMN} {tool} is outside 0..={max} mm");
        }
        let values =
            row_values(p, run, &refs, (row, tool)).map_err(|e| anyhow!("t_s = {t}: {e}"))?;
        for (col, v) in columns.iter_mut().zip(values) {
            col.push(v);
        }
    }
    let max_abs = OUTPUT_COLUMNS
        .iter()
        .zip(&columns)
        .map(|(name, col)| {
            (
                *name,
                col.iter().flatten().map(|v| v.abs()).reduce(f64::max),
            )
        })
        .collect();
    let outcome = FivePointOutcome {
        rows: n,
        tip_rows: columns[3].iter().filter(|v| v.is_some()).count(),
        tool_from: if p.tool_mm.is_some() {
            "--tool-mm"
        } else {
            TOOL_COLUMN
        },
        tool_held_rows,
        a_mm: p.a_mm,
        l_defl_mm: p.l_defl_mm,
        max_abs,
    };
    Ok((FivePointColumns { columns }, outcome))
}

/// `model` with its five-point geometry: `l_defl_mm` (default
/// [`DEFAULT_L_DEFL_MM`]) when its outputs are `e_um`, `theta_x_urad`,
/// `theta_y_urad`; unchanged otherwise, where a given `l_defl_mm` is an
/// error (it would be silently unused).
pub fn with_geometry(model: ValidModel, l_defl_mm: Option<f64>) -> Result<ValidModel> {
    if !is_five_point(model.outputs()) {
        return match l_defl_mm {
            Some(_) => {
                bail!("--l-defl-mm is for five-point targets only (e_um,theta_x_urad,theta_y_urad)")
            }
            None => Ok(model),
        };
    }
    let mut m = model.model().clone();
    m.five_point = Some(FivePoint {
        l_defl_mm: l_defl_mm.unwrap_or(DEFAULT_L_DEFL_MM),
    });
    m.validate().map_err(|e| {
        anyhow!(
            "--l-defl-mm {}: {e}",
            l_defl_mm.unwrap_or(DEFAULT_L_DEFL_MM)
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(tool_mm: Option<f64>) -> ValidFivePointParams {
        FivePointParams {
            a_mm: 120.0,
            l_defl_mm: 300.0,
            tool_mm,
        }
        .check()
        .unwrap_or_else(|e| panic!("{e}"))
    }

    #[test]
    fn changes_are_from_the_first_reading_and_gaps_stay_empty() {
        // S1 moves +12 um from 100 (row 2); S5 +20 um; row 1 has no S3.
        let s1 = [100.0, 106.0, 112.0];
        let s3 = [50.0, f64::NAN, 50.0];
        let zero = [7.0; 3];
        let s5 = [-3.0, 7.0, 17.0];
        let [s1, s3, zero, s5] = [&s1, &s3, &zero, &s5].map(|c| Cells::new(c));
        let run = ProbeRun {
            t_s: &[0.0, 1.0, 2.0],
            probes: [s1, zero, s3, zero, s5],
            tool_mm: None,
        };
        let (c, o) = compute(&params(Some(100.0)), &run).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(c.columns[0], vec![Some(0.0), Some(10.0), Some(20.0)]);
        assert_eq!(c.columns[1][1], None, "theta_x needs S3");
        assert_eq!(c.columns[3][1], None, "the tip needs every probe");
        // θx = atan(12 / 120000) rad = 99.99999967 urad (1e-9 covers rounding).
        let tx = c.columns[1][2].unwrap_or(f64::NAN);
        assert!((tx - 1e6 * (1e-4f64).atan()).abs() < 1e-9, "{tx}");
        assert_eq!(o.tip_rows, 2);
        assert_eq!(o.rows, 3);
    }

    /// A tool length logged only when it changes: the empty rows take the
    /// last one logged (as the hub holds the last one received); rows
    /// before the first have no tip. The tip's dx is (l_defl + tool) θx,
    /// so the held row's dx is the logged row's (same probes, same tool).
    #[test]
    fn an_empty_tool_cell_holds_the_last_length_logged() {
        let s1 = [100.0, 106.0, 106.0, 106.0];
        let zero = [7.0; 4];
        let tool = [f64::NAN, 100.0, f64::NAN, 200.0];
        let [s1, zero, tool] = [&s1, &zero, &tool].map(|c| Cells::new(c));
        let run = ProbeRun {
            t_s: &[0.0, 1.0, 2.0, 3.0],
            probes: [s1, zero, zero, zero, zero],
            tool_mm: Some(tool),
        };
        let (c, o) = compute(&params(None), &run).unwrap_or_else(|e| panic!("{e}"));
        let dx = &c.columns[3];
        assert_eq!(dx[0], None, "no tool length logged yet");
        assert_eq!(dx[2], dx[1], "the held row");
        // θx = 6 um / 120 mm = 50 urad: dx = (300 + 100) mm x 50 urad =
        // 20 um, then (300 + 200) mm x 50 urad = 25 um (to 1e-6 um: the
        // exact geometry's tan and q differ from the product by ~1e-12).
        let got = dx.iter().map(|v| v.unwrap_or(f64::NAN)).collect::<Vec<_>>();
        assert!(
            (got[1] - 20.0).abs() < 1e-6 && (got[3] - 25.0).abs() < 1e-6,
            "{got:?}"
        );
        assert_eq!((o.tip_rows, o.tool_held_rows), (3, 1));
        assert_eq!(
            o.max_abs["dx_um"].map(|v| (v - 25.0).abs() < 1e-6),
            Some(true)
        );
    }

    /// No row with every probe: the largest tip drifts are absent, not 0.
    #[test]
    fn no_tip_anywhere_has_no_largest_drift() {
        let s1 = [100.0, 106.0];
        let none = [f64::NAN; 2];
        let [s1, none] = [&s1, &none].map(|c| Cells::new(c));
        let run = ProbeRun {
            t_s: &[0.0, 1.0],
            probes: [s1, s1, s1, s1, none],
            tool_mm: None,
        };
        let (_, o) = compute(&params(Some(100.0)), &run).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(o.tip_rows, 0);
        assert_eq!(o.max_abs["dz_um"], None);
        assert_eq!(o.max_abs["e_um"], None);
        assert!(o.max_abs["theta_x_urad"].is_some());
    }

    #[test]
    fn refuses_bad_settings() {
        let bad = |a_mm, l_defl_mm, tool_mm| {
            FivePointParams {
                a_mm,
                l_defl_mm,
                tool_mm,
            }
            .check()
            .is_err()
        };
        assert!(bad(0.0, 300.0, None));
        assert!(bad(f64::NAN, 300.0, None));
        assert!(bad(120.0, -1.0, None));
        assert!(bad(120.0, 300.0, Some(f64::INFINITY)));
        assert!(!bad(120.0, 0.0, Some(0.0)));
    }
}
