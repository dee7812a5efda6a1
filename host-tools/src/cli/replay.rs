//! `thermcomp replay`: the flags, the typed job ([`crate::replay::replay`])
//! and its outcome printed as one line per run or one JSON object.

use super::source::RunSource;
use crate::data::fsio;
use crate::replay::{replay, ReplayParams};
use anyhow::Result;
use clap::Args;
use std::path::PathBuf;

/// Arguments of `thermcomp replay`.
#[derive(Args)]
pub struct ReplayArgs {
    /// The model blob, as it would be flashed (a refused blob runs as "no model").
    #[arg(long)]
    pub model: PathBuf,
    /// The runs to replay.
    #[command(flatten)]
    pub runs: RunSource,
    /// Where to write the CAN frames (candump log format).
    #[arg(long)]
    pub candump: PathBuf,
    /// CAN interface name written in the log.
    #[arg(long, default_value = "can0", value_parser = crate::data::source::interface_name)]
    pub interface: String,
    /// Also write a CSV of every sample: the inputs as the hub read them and
    /// the offsets decoded from the frames sent (`<output>_sent`; for a
    /// five-point model `dx_um_sent`, `dy_um_sent`, `dz_um_sent` and the
    /// `tool_mm` the hub used), the
    /// slope of each positional output (`<output>_slope_um_per_m`, from the
    /// SLOPE frames), with the hub state and flags.
    #[arg(long, value_name = "FILE.csv")]
    pub trace: Option<PathBuf>,
    /// Print one JSON summary object.
    #[arg(long)]
    pub json: bool,
}

impl ReplayArgs {
    /// The replay job's parameters.
    pub fn params(&self) -> ReplayParams {
        let a = self;
        ReplayParams {
            model: a.model.clone(),
            data: a.runs.data.clone(),
            map: a.runs.map.clone(),
            skip_bad_rows: a.runs.skip_bad_rows,
            candump: a.candump.clone(),
            interface: a.interface.clone(),
            trace: a.trace.clone(),
        }
    }
}

/// Runs `thermcomp replay`.
pub fn run(a: &ReplayArgs) -> Result<()> {
    let params = a.params();
    params.check()?;
    let outcome = replay(&params)?;
    if a.json {
        let summary = serde_json::to_value(&outcome)?;
        fsio::print_line(&summary.to_string())?;
    } else {
        for r in &outcome.runs {
            let st = &r.states;
            fsio::print_line(&format!(
                "{}: {} samples, {} frames ({} from the CNC); running {}, holding {}, ramping {}, zeroed {}, no model {}; samples with a sensor fault {}, a stale input {}, a reading not believed {}",
                r.run,
                r.samples,
                r.frames,
                r.rx_frames,
                st.running,
                st.holding,
                st.ramping,
                st.zeroed,
                st.no_model,
                r.sensor_fault_samples,
                r.stale_samples,
                r.implausible_samples
            ))?;
        }
        eprintln!("wrote {}", a.candump.display());
    }
    Ok(())
}
