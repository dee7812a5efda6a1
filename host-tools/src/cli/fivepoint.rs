//! `thermcomp fivepoint`: the command line around [`crate::fivepoint`].

use crate::data::fsio::{self, named};
use crate::data::rawcells::{self, RawTable};
use crate::data::runfile::{ReadOptions, RunFile};
use crate::fivepoint::{
    compute, FivePointColumns, FivePointOutcome, FivePointParams, ProbeRun, DEFAULT_A_MM,
    OUTPUT_COLUMNS, PROBE_COLUMNS, TOOL_COLUMN,
};
use anyhow::{anyhow, Result};
use clap::Args;
use std::io::Write;
use std::path::PathBuf;

/// Arguments of `thermcomp fivepoint`.
#[derive(Args)]
pub struct FivePointArgs {
    /// The run with the five probes S1..S5 (um).
    #[arg(long)]
    pub data: PathBuf,
    /// Where to write t_s, e_um, theta_x_urad, theta_y_urad, dx_um, dy_um,
    /// dz_um and the run's other columns (a run column with one of those
    /// names is kept as <name>_run).
    #[arg(long)]
    pub out: PathBuf,
    /// Axial distance between the near (S1, S2) and far (S3, S4) radial probes, mm.
    #[arg(long, default_value_t = DEFAULT_A_MM)]
    pub a_mm: f64,
    /// Distance from the spindle nose up to the deflection centre, mm.
    #[arg(long, default_value_t = model_core::fivepoint::DEFAULT_L_DEFL_MM)]
    pub l_defl_mm: f64,
    /// A fixed tool length, mm (default: each row's tool_mm, an empty cell
    /// holding the last length logged).
    #[arg(long)]
    pub tool_mm: Option<f64>,
    /// Print one JSON summary object.
    #[arg(long)]
    pub json: bool,
}

/// Runs `thermcomp fivepoint`.
pub fn run(a: &FivePointArgs) -> Result<()> {
    fsio::check_distinct(&[named("--data", &a.data)], &[named("--out", &a.out)])?;
    let params = FivePointParams {
        a_mm: a.a_mm,
        l_defl_mm: a.l_defl_mm,
        tool_mm: a.tool_mm,
    }
    .check()?;
    let only = PROBE_COLUMNS
        .iter()
        .chain(&[TOOL_COLUMN])
        .map(|c| (*c).to_owned())
        .collect();
    let opts = ReadOptions {
        skip_bad_rows: false,
        only: Some(only),
    };
    let run = RunFile::read(&a.data, &opts)?;
    let column = |name: &str| {
        run.column(name).ok_or_else(|| {
            anyhow!(
                "{}: no column {name} (a five-point run has S1..S5)",
                a.data.display()
            )
        })
    };
    let probes = [
        column("S1")?,
        column("S2")?,
        column("S3")?,
        column("S4")?,
        column("S5")?,
    ];
    let probe_run = ProbeRun {
        t_s: &run.t_s,
        probes,
        tool_mm: run.column(TOOL_COLUMN),
    };
    let (computed, outcome) =
        compute(&params, &probe_run).map_err(|e| anyhow!("{}: {e}", a.data.display()))?;
    let raw = rawcells::read(&a.data, run.len())?;
    fsio::write_atomic(&a.out, |w| write_table(w, &run.t_s, &computed, &raw))?;
    if a.json {
        fsio::print_line(&serde_json::to_string(&outcome)?)?;
    } else {
        print_summary(&a.out, &outcome);
    }
    Ok(())
}

/// The text summary (stderr): rows, tip rows, the largest tip drifts ("-"
/// where no row has one), the rows that held a tool length.
fn print_summary(out: &std::path::Path, o: &FivePointOutcome) {
    let largest = |name: &str| {
        o.max_abs
            .get(name)
            .copied()
            .flatten()
            .map_or_else(|| "-".to_string(), |v| format!("{v:.3} um"))
    };
    eprintln!(
        "wrote {} ({} rows, {} with a tool-tip drift; max |dx| {}, |dy| {}, |dz| {})",
        out.display(),
        o.rows,
        o.tip_rows,
        largest("dx_um"),
        largest("dy_um"),
        largest("dz_um"),
    );
    if o.tip_rows == 0 {
        eprintln!("note: no row has all five probes and a tool length: no tip drift computed");
    }
    if o.tool_held_rows > 0 {
        eprintln!(
            "note: {} rows with an empty {TOOL_COLUMN} took the length logged before them",
            o.tool_held_rows
        );
    }
}

/// Writes `t_s`, the computed columns, then every other run column as it
/// was written (renamed `<name>_run` when it clashes with a computed one).
fn write_table(
    w: &mut dyn Write,
    t_s: &[f64],
    computed: &FivePointColumns,
    raw: &RawTable,
) -> Result<()> {
    let kept: Vec<usize> = (0..raw.header.len())
        .filter(|&i| raw.header[i] != "t_s")
        .collect();
    let mut out = csv::Writer::from_writer(w);
    let header = std::iter::once("t_s".to_owned())
        .chain(OUTPUT_COLUMNS.iter().map(|c| (*c).to_owned()))
        .chain(kept.iter().map(|&i| {
            let name = &raw.header[i];
            if OUTPUT_COLUMNS.contains(&name.as_str()) {
                format!("{name}_run")
            } else {
                name.clone()
            }
        }));
    out.write_record(header)?;
    let cell = |v: Option<f64>| v.map_or_else(String::new, |x| format!("{x}"));
    for (row, t) in t_s.iter().enumerate() {
        let fields = std::iter::once(format!("{t}"))
            .chain(computed.columns.iter().map(|c| cell(c[row])))
            .chain(kept.iter().map(|&i| {
                raw.rows
                    .get(row)
                    .and_then(|r| r.get(i))
                    .cloned()
                    .unwrap_or_default()
            }));
        out.write_record(fields)?;
    }
    out.flush()?;
    Ok(())
}
