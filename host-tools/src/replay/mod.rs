//! `thermcomp replay`: firmware in the loop on the host.
//!
//! The hub's own code runs over a run file, sample by sample, exactly as it
//! runs on the board: the blob is loaded by `firmware::hub::Hub::load`
//! (refused blobs leave the hub without a model, as on the board); every
//! temperature is turned into the 15-bit code a MAX31865 would return for a
//! PT100 at that temperature ([`virtual_rtd`]) and read back through the
//! `max31865` driver; `firmware::pipeline::Pipeline` spike-filters, steps
//! the model, supervises faults, slew-limits and clamps; and
//! `firmware::can_frames` encodes the frames, written in candump's log
//! format. The sample period is the hub's: the model's `dt_s` for a dynamic
//! model, the board's default for a static one; inputs are interpolated
//! linearly onto that grid, and a missing cell reads as a stale sample.
//!
//! What differs from the board: no timing (conversions are instant), and
//! a temperature outside the PT100's range is a converter fault.

pub mod virtual_rtd;

use crate::runfile::{is_temperature_column, resample_linear, uniform_grid, RunFile};
use crate::source::RunSource;
use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use embedded_can::Frame as _;
use firmware::can_frames::{self, Heartbeat, Message, NmtState, RawFrame, StatusInfo};
use firmware::hub::Hub;
use firmware::pipeline::{
    ChannelFault, Pipeline, PipelineConfig, Reading, POSITION_REFERENCE_MM, TOOL_INPUT,
};
use firmware::report::HubState;
use max31865::{Config, Filter, Max31865, Mode, Wires};
use model_core::rtd::{Rtd, RtdChannel, RtdCode};
use serde_json::json;
use std::io::Write;
use std::path::PathBuf;
use virtual_rtd::VirtualMax31865;

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
    #[arg(long, default_value = "can0")]
    pub interface: String,
    /// Also write a CSV of every sample: the inputs as the hub read them and
    /// the offsets decoded from the frames sent (`<output>_sent`), the
    /// slope of each positional output (`<output>_slope_um_per_m`, from the
    /// SLOPE frames), with the hub state and flags.
    #[arg(long, value_name = "FILE.csv")]
    pub trace: Option<PathBuf>,
    /// Print one JSON summary object.
    #[arg(long)]
    pub json: bool,
}

/// Where the hub gets one model input from.
enum Source {
    /// A PT100 on its own MAX31865.
    Rtd(Max31865<VirtualMax31865>, VirtualMax31865),
    /// A value the hub reads directly (speed, power).
    Direct,
    /// A positional output's axis position: the hub does not know it (it
    /// feeds the reference 0 mm and sends slopes), so the run file need not
    /// have the column; the trace shows the 0 mm the hub used.
    Position,
    /// The tool length, set by a command when it changes.
    Tool,
}

/// Whether a column is a temperature the hub reads through an RTD.
fn is_rtd_column(name: &str) -> bool {
    is_temperature_column(name) || name.ends_with("_c")
}

/// What happened over one run.
#[derive(Default)]
struct Tally {
    samples: usize,
    frames: usize,
    states: [usize; 5],
    sensor_faults: usize,
    stale: usize,
    max_abs_um: Vec<f64>,
}

/// Runs `thermcomp replay`.
pub fn run(a: &ReplayArgs) -> Result<()> {
    let summary = replay_files(a)?;
    if a.json {
        println!("{summary}");
    } else {
        let runs = summary["runs"].as_array().map(Vec::as_slice).unwrap_or(&[]);
        for r in runs {
            let st = &r["states"];
            println!(
                "{}: {} samples, {} frames; running {}, holding {}, ramping {}, zeroed {}, no model {}",
                r["run"].as_str().unwrap_or(""),
                r["samples"],
                r["frames"],
                st["running"],
                st["holding"],
                st["ramping"],
                st["zeroed"],
                st["no_model"]
            );
        }
        eprintln!("wrote {}", a.candump.display());
    }
    Ok(())
}

/// Replays every run and writes the candump log (and the trace): everything
/// `thermcomp replay` does but print. Returns `replay --json`'s object:
/// `model`, `candump`, `sample_period_s`, `outputs`, and per run `samples`,
/// `frames`, `states` (samples per hub state), `sensor_fault_samples`,
/// `stale_samples`, `max_abs_offset_um`. `thermcomp demo` calls it too.
pub fn replay_files(a: &ReplayArgs) -> Result<serde_json::Value> {
    let bytes =
        std::fs::read(&a.model).with_context(|| format!("cannot read {}", a.model.display()))?;
    let probe = Hub::load(&bytes);
    if let Some(e) = probe.load_error() {
        eprintln!(
            "note: {}: the hub refuses this blob ({e}): it runs without a model and sends zero offsets",
            a.model.display()
        );
    }
    let positional = probe.model().map_or(0, |m| m.positional_outputs());
    let position_inputs = probe.model().map_or(0, |m| m.position_inputs());
    let (inputs, outputs): (Vec<String>, Vec<String>) = probe.model().map_or_else(
        || (Vec::new(), Vec::new()),
        |m| {
            (
                m.inputs().iter().map(|c| c.name.to_string()).collect(),
                m.outputs().iter().map(|o| o.to_string()).collect(),
            )
        },
    );
    let map = a.runs.column_map()?;
    let columns: Vec<String> = inputs.iter().map(|n| map.column(n).to_string()).collect();
    let is_position = |i: usize| position_inputs & (1u32 << i.min(31)) != 0;
    let needed: Vec<String> = columns
        .iter()
        .enumerate()
        .filter(|&(i, _)| !is_position(i))
        .map(|(_, c)| c.clone())
        .collect();
    let runs = a.runs.read(needed)?;
    let mut log = std::io::BufWriter::new(
        std::fs::File::create(&a.candump)
            .with_context(|| format!("cannot write {}", a.candump.display()))?,
    );
    let mut trace = match &a.trace {
        Some(p) => {
            let mut w = std::io::BufWriter::new(
                std::fs::File::create(p)
                    .with_context(|| format!("cannot write {}", p.display()))?,
            );
            let mut header = vec!["t_s".to_string()];
            header.extend(inputs.iter().cloned());
            header.extend(outputs.iter().map(|o| format!("{o}_sent")));
            header.extend(
                outputs
                    .iter()
                    .enumerate()
                    .filter(|&(j, _)| positional & (1 << j) != 0)
                    .map(|(_, o)| format!("{o}_slope_um_per_m")),
            );
            header.extend(["state".to_string(), "flags".to_string()]);
            writeln!(w, "{}", header.join(","))?;
            Some(w)
        }
        None => None,
    };
    let mut per_run = Vec::new();
    for run in &runs {
        let shape = Shape {
            inputs: &inputs,
            columns: &columns,
            n_outputs: outputs.len(),
            positional,
            position_inputs,
        };
        let tally = replay_run(&bytes, run, &shape, a, &mut log, trace.as_mut())?;
        per_run.push((run.path.display().to_string(), tally));
    }
    log.flush()?;
    if let Some(w) = trace.as_mut() {
        w.flush()?;
    }
    let summary: Vec<_> = per_run
        .iter()
        .map(|(name, t)| {
            json!({
                "run": name,
                "samples": t.samples,
                "frames": t.frames,
                "states": {
                    "no_model": t.states[0], "running": t.states[1], "holding": t.states[2],
                    "ramping": t.states[3], "zeroed": t.states[4],
                },
                "sensor_fault_samples": t.sensor_faults,
                "stale_samples": t.stale,
                "max_abs_offset_um": outputs.iter().zip(&t.max_abs_um)
                    .map(|(o, v)| (o.clone(), json!(v))).collect::<serde_json::Map<_, _>>(),
            })
        })
        .collect();
    Ok(json!({
        "model": a.model.display().to_string(),
        "candump": a.candump.display().to_string(),
        "sample_period_s": PipelineConfig::DEFAULT.sample_period_s(&probe),
        "outputs": outputs,
        "runs": summary,
    }))
}

/// The model's inputs and outputs as the replay sees them.
struct Shape<'a> {
    /// Model input names.
    inputs: &'a [String],
    /// The run-file column of each input.
    columns: &'a [String],
    /// Model outputs.
    n_outputs: usize,
    /// Bit `j`: output `j` is positional (sent as a slope).
    positional: u8,
    /// Bit `i`: input `i` is an axis position (not read by the hub).
    position_inputs: u32,
}

/// One run through a fresh hub (a run is a power cycle).
fn replay_run(
    blob: &[u8],
    run: &RunFile,
    shape: &Shape<'_>,
    a: &ReplayArgs,
    log: &mut impl Write,
    mut trace: Option<&mut std::io::BufWriter<std::fs::File>>,
) -> Result<Tally> {
    let mut pipeline = Pipeline::new(Hub::load(blob), PipelineConfig::DEFAULT)
        .map_err(|e| anyhow!("pipeline configuration: {e:?}"))?;
    let dt = pipeline.sample_period_s();
    let (Some(&t0), Some(&t1)) = (run.t_s.first(), run.t_s.last()) else {
        bail!("{}: no rows", run.path.display());
    };
    let grid = uniform_grid(t0, t1, dt).map_err(|e| anyhow!("{}: {e}", run.path.display()))?;
    let sampling = run.sampling();
    if !(sampling.is_uniform
        && sampling
            .dt_median_s
            .is_some_and(|m| (m - dt).abs() <= 1e-6 * dt))
    {
        eprintln!(
            "note: {}: the hub samples every {dt} s: inputs interpolated onto that grid ({} samples)",
            run.path.display(),
            grid.len()
        );
    }
    let Shape {
        inputs,
        columns,
        n_outputs,
        positional,
        position_inputs,
    } = *shape;
    let is_position = |i: usize| position_inputs & (1u32 << i.min(31)) != 0;
    let values: Vec<Vec<Option<f64>>> = columns
        .iter()
        .enumerate()
        .map(|(i, c)| {
            if is_position(i) {
                return Ok(vec![None; grid.len()]);
            }
            run.column(c)
                .map(|col| resample_linear(&run.t_s, col, &grid))
                .ok_or_else(|| {
                    anyhow!(
                        "{}: the model needs column \"{c}\" (columns: {})",
                        run.path.display(),
                        run.columns.join(", ")
                    )
                })
        })
        .collect::<Result<_>>()?;
    let rtd_cfg = Config::new(Wires::Three, Filter::Hz50, Mode::Auto);
    let mut sources: Vec<Source> = inputs
        .iter()
        .enumerate()
        .map(|(i, name)| -> Result<Source> {
            Ok(if is_position(i) {
                Source::Position
            } else if name == TOOL_INPUT {
                Source::Tool
            } else if is_rtd_column(name) {
                let chip = VirtualMax31865::new();
                let driver = Max31865::new(chip.clone(), rtd_cfg)
                    .map_err(|e| anyhow!("virtual MAX31865 for {name}: {e}"))?;
                Source::Rtd(driver, chip)
            } else {
                Source::Direct
            })
        })
        .collect::<Result<_>>()?;
    let channel = RtdChannel::MAX31865_PT100;
    let mut heartbeat = Heartbeat::new(can_frames::DEFAULT_HEARTBEAT_MS);
    let mut tally = Tally {
        max_abs_um: vec![0.0; n_outputs],
        ..Tally::default()
    };
    let mut tool_set: Option<f64> = None;
    let mut readings = vec![Reading::Stale; inputs.len()];
    let mut seen = vec![f64::NAN; inputs.len()];
    for (k, &t) in grid.iter().enumerate() {
        for (i, src) in sources.iter_mut().enumerate() {
            let v = values[i][k];
            readings[i] = match (src, v) {
                // What the hub feeds a position it does not know.
                (Source::Position, _) => Reading::Direct(POSITION_REFERENCE_MM),
                (_, None) => Reading::Stale,
                (Source::Direct, Some(v)) => Reading::Direct(v),
                (Source::Tool, Some(v)) => {
                    if tool_set != Some(v) {
                        pipeline
                            .set_tool_length_mm(v)
                            .map_err(|e| anyhow!("{}: tool_mm {v}: {e:?}", run.path.display()))?;
                        tool_set = Some(v);
                    }
                    Reading::Direct(v)
                }
                (Source::Rtd(driver, chip), Some(t_c)) => {
                    match Rtd::PT100
                        .resistance_ohm(t_c)
                        .and_then(|r| channel.adc.code_for_resistance(r))
                    {
                        Ok(RtdCode(code)) => chip.set_code(u16::try_from(code).unwrap_or(0)),
                        // Out of the sensor's range: the chip flags a threshold fault.
                        Err(_) => chip.set_fault(0x80),
                    }
                    match driver.read_code() {
                        Ok(code) => Reading::from_rtd(&channel, RtdCode(u32::from(code.value()))),
                        Err(_) => {
                            let _ = driver.clear_fault();
                            Reading::Fault(ChannelFault::Converter)
                        }
                    }
                }
            };
            seen[i] = match readings[i] {
                Reading::Value(v) | Reading::Direct(v) => v,
                _ => f64::NAN,
            };
        }
        let report = pipeline.on_sample(&readings);
        tally.samples += 1;
        tally.states[usize::from(report.state.code()).min(4)] += 1;
        if readings.iter().any(|r| matches!(r, Reading::Fault(_))) {
            tally.sensor_faults += 1;
        }
        if readings.iter().any(|r| matches!(r, Reading::Stale)) {
            tally.stale += 1;
        }
        let info = StatusInfo {
            n_inputs: pipeline.hub().input_count(),
            consecutive_faults: pipeline.hub().faults().consecutive,
        };
        let now_ms = ((t - t0) * 1000.0).round() as u32;
        let mut frames: Vec<RawFrame> = can_frames::encode_report(&report, &info)
            .into_iter()
            .collect();
        let nmt = if report.state == HubState::NoModel {
            NmtState::PreOperational
        } else {
            NmtState::Operational
        };
        frames.extend(heartbeat.poll::<RawFrame>(now_ms, nmt));
        let mut sent = [0.0f64; 4];
        let mut slopes = [0.0f64; 4];
        for f in &frames {
            writeln!(log, "({t:.6}) {} {f}", a.interface)?;
            match can_frames::decode(f) {
                Ok(Message::Offsets(m)) => sent[..3].copy_from_slice(&m.offsets_um),
                Ok(Message::OffsetsExt(m)) => sent[3] = m.offsets_um[0],
                Ok(Message::Slope(m)) => {
                    if let Some(s) = slopes.get_mut(usize::from(m.output)) {
                        *s = m.slope_um_per_m;
                    }
                }
                _ => {}
            }
            debug_assert!(f.is_standard());
        }
        tally.frames += frames.len();
        for (m, v) in tally.max_abs_um.iter_mut().zip(&sent) {
            *m = m.max(v.abs());
        }
        if let Some(w) = trace.as_deref_mut() {
            let mut row = vec![format!("{t}")];
            row.extend(seen.iter().map(|v| {
                if v.is_finite() {
                    format!("{v}")
                } else {
                    String::new()
                }
            }));
            row.extend(sent.iter().take(n_outputs).map(|v| format!("{v:.1}")));
            row.extend(
                slopes
                    .iter()
                    .enumerate()
                    .take(n_outputs)
                    .filter(|&(j, _)| positional & (1 << j) != 0)
                    .map(|(_, v)| format!("{v:.3}")),
            );
            row.push(format!("{}", report.state.code()));
            row.push(format!("{}", report.flags.0));
            writeln!(w, "{}", row.join(","))?;
        }
    }
    Ok(tally)
}
