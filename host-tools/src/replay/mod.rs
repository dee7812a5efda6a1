//! `thermcomp replay`: firmware in the loop on the host.
//!
//! The hub's own code runs over a run file, sample by sample, exactly as it
//! runs on the board: the blob is loaded by `firmware::hub::Hub::load`
//! (refused blobs leave the hub without a model, as on the board); every
//! temperature is turned into the 15-bit code a MAX31865 would return for a
//! PT100 at that temperature ([`virtual_rtd`]) and read back through the
//! `max31865` driver; `firmware::pipeline::Pipeline` spike-filters, steps
//! the model, supervises faults, slew-limits and clamps; and
//! `firmware::canopen::Node` sends the frames (boot-up, TPDOs, EMCYs,
//! heartbeat; the TPDOs are `firmware::can_frames`' layouts), written in candump's log
//! format. The sample period is the hub's: the model's `dt_s` for a dynamic
//! model, the board's default for a static one. Inputs reach that grid
//! causally, as the hub would read them ([`causal_values`]): at each sample
//! the latest row at or before it, never a row after it; an empty cell, or
//! a row older than the log's own period (a dropout or a logging gap), is
//! a stale sample, which holds and then ramps the offsets as on the board.
//! A run logged more coarsely than the hub samples is held between rows
//! (not interpolated towards the next row, which the hub cannot know).
//!
//! The inputs the CNC sends the hub over CAN (`speed_rpm`, `power_kw`,
//! `tool_mm`, a positional output's position; `firmware::can_rx`) arrive
//! as CAN frames: at each sample, the run's values at that time are
//! encoded into SPINDLE (0x201) and TOOL_POSITION (0x301) frames (an empty
//! cell or an absent column is "not available"; a frame with nothing
//! available is not sent), written to the candump log before that sample's
//! own frames, and decoded by `firmware::cnc_inputs::CncInputs` as on the
//! board. Between two rows with a value it is interpolated (a frame every
//! sample), but never across an empty cell: a run of empty cells is a CNC
//! that stopped sending, and the input goes stale after the timeout
//! (`board::CNC_INPUT_TIMEOUT_MS`), holding and then ramping the offsets.
//! The tool length is latched in the pipeline as the board does.
//!
//! What differs from the board: no timing (conversions are instant, a
//! frame arrives at its sample's time), a temperature outside the PT100's
//! range is a converter fault, and an input with no source on the board
//! (neither an RTD nor a CNC signal) is read from its column.

pub mod virtual_rtd;

use crate::data::runfile::{is_temperature_column, uniform_grid, RunFile};
use crate::data::source::RunSource;
use anyhow::{anyhow, bail, Result};
use clap::Args;
use embedded_can::Frame as _;
use firmware::board::CNC_INPUT_TIMEOUT_MS;
use firmware::can_frames::{self, Message, RawFrame, StatusInfo};
use firmware::can_rx::{encode_spindle, encode_tool_position, Spindle, ToolPosition};
use firmware::canopen::{Event, Node, Settings};
use firmware::cnc_inputs::{CncInput, CncInputs};
use firmware::hub::Hub;
use firmware::pipeline::{
    ChannelFault, Pipeline, PipelineConfig, Reading, POSITION_REFERENCE_MM, TOOL_INPUT,
};
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

/// Where the hub gets one model input from.
enum Source {
    /// A PT100 on its own MAX31865.
    Rtd(Max31865<VirtualMax31865>, VirtualMax31865),
    /// An input the board has no source for, read from its column.
    Direct,
    /// Speed, power or a positional output's axis position, received from
    /// the CNC in frames. The pipeline feeds a position the reference
    /// 0 mm and sends slopes, so the run file need not have that column;
    /// the trace shows the 0 mm the hub used.
    Cnc(CncInput),
    /// The tool length, received from the CNC and latched.
    Tool,
}

/// What the CNC sends at each grid time: the cell of a row at that time,
/// or, between two rows that both have the value, the value interpolated
/// between them (a run logged more coarsely than the hub samples does not
/// mean the CNC sent more rarely); `None` (no frame) from a row with an
/// empty cell to the next row with a value, and outside the run: a gap of
/// rows is a CNC that stopped sending.
fn cnc_values(t_s: &[f64], x: &[Option<f64>], grid: &[f64]) -> Vec<Option<f64>> {
    let cell = |r: usize| x.get(r).copied().flatten().filter(|v| v.is_finite());
    let mut r = 0;
    grid.iter()
        .map(|&g| {
            while t_s.get(r + 1).is_some_and(|&t| t <= g) {
                r += 1;
            }
            let t0 = *t_s.get(r)?;
            let x0 = cell(r)?;
            if t0 == g {
                return Some(x0);
            }
            let (t1, x1) = (*t_s.get(r + 1)?, cell(r + 1)?);
            if !(t0 < g && g < t1) {
                return None;
            }
            let w = (g - t0) / (t1 - t0);
            Some(x0 * (1.0 - w) + x1 * w)
        })
        .collect()
}

/// What the hub reads from a logged column at each `grid` time, causally:
/// the value of the latest row at or before the time (row times `t_s`,
/// cells `x`), while that row is younger than `period_s`; `None` (a stale
/// sample) for an empty or non-finite cell, a row `period_s` old or older,
/// or before the first row. `period_s` is the longer of the hub's sample
/// period and the log's own (its median row interval), so a run logged
/// every 60 s is held between rows, and a gap longer than that period
/// (missing rows or empty cells) is stale for every sample inside it, as
/// on the board: no sample uses a row from after its time.
///
/// A relative slack of 1e-6 of the period absorbs rounding in the grid
/// times; a log whose rows jitter by more than that around the hub's
/// period reads a late row as one stale sample.
pub fn causal_values(
    t_s: &[f64],
    x: &[Option<f64>],
    grid: &[f64],
    period_s: f64,
) -> Vec<Option<f64>> {
    let slack = 1e-6 * period_s;
    let mut r = 0usize;
    grid.iter()
        .map(|&g| {
            // The latest row at or before g (within the slack).
            while t_s.get(r + 1).is_some_and(|&t| t <= g + slack) {
                r += 1;
            }
            let t0 = *t_s.get(r)?;
            if t0 > g + slack || g - t0 >= period_s - slack {
                return None;
            }
            x.get(r).copied().flatten().filter(|v| v.is_finite())
        })
        .collect()
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
    rx_frames: usize,
    states: [usize; 5],
    sensor_faults: usize,
    stale: usize,
    max_abs_um: Vec<f64>,
}

/// Runs `thermcomp replay`.
pub fn run(a: &ReplayArgs) -> Result<()> {
    let summary = replay_files(a)?;
    if a.json {
        crate::data::fsio::print_line(&summary.to_string())?;
    } else {
        let runs = summary["runs"].as_array().map(Vec::as_slice).unwrap_or(&[]);
        for r in runs {
            let st = &r["states"];
            crate::data::fsio::print_line(&format!(
                "{}: {} samples, {} frames ({} from the CNC); running {}, holding {}, ramping {}, zeroed {}, no model {}",
                r["run"].as_str().unwrap_or(""),
                r["samples"],
                r["frames"],
                r["rx_frames"],
                st["running"],
                st["holding"],
                st["ramping"],
                st["zeroed"],
                st["no_model"]
            ))?;
        }
        eprintln!("wrote {}", a.candump.display());
    }
    Ok(())
}

/// Replays every run and writes the candump log (and the trace): everything
/// `thermcomp replay` does but print. Returns `replay --json`'s object:
/// `model`, `candump`, `sample_period_s`, `outputs`, and per run `samples`,
/// `frames` (sent by the hub), `rx_frames` (from the CNC), `states`
/// (samples per hub state), `sensor_fault_samples`,
/// `stale_samples`, `max_abs_offset_um`. `thermcomp demo` calls it too.
pub fn replay_files(a: &ReplayArgs) -> Result<serde_json::Value> {
    let reads = [
        vec![crate::data::fsio::named("--model", &a.model)],
        a.runs.paths(),
    ]
    .concat();
    let writes = [Some(crate::data::fsio::named("--candump", &a.candump))]
        .into_iter()
        .chain([a
            .trace
            .as_deref()
            .map(|p| crate::data::fsio::named("--trace", p))])
        .flatten()
        .collect::<Vec<_>>();
    crate::data::fsio::check_distinct(&reads, &writes)?;
    let bytes = crate::data::fsio::read_capped(&a.model, model_core::blob::MAX_BLOB_LEN as u64)?;
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
                // A five-point model's lanes are the tip's dx, dy, dz.
                (0..m.outputs().len())
                    .filter_map(|j| firmware::tip::lane_name(m, j))
                    .map(str::to_string)
                    .collect(),
            )
        },
    );
    let map = a.runs.column_map()?;
    let columns: Vec<String> = inputs.iter().map(|n| map.column(n).to_string()).collect();
    // The CNC's columns are optional (absent: no frames), so every column
    // the model names is read if the file has it.
    // A five-point model turns its outputs into the tool tip with the tool
    // length the CNC sends: the run's tool_mm column.
    let tip_tool = probe
        .model()
        .and_then(|m| m.five_point())
        .map(|_| map.column(TOOL_INPUT).to_string());
    let needed: Vec<String> = columns.iter().cloned().chain(tip_tool.clone()).collect();
    let runs = a.runs.read(needed)?;
    // Both outputs are built in memory and written atomically at the end,
    // so a failed run leaves no half log behind.
    let mut log = Vec::new();
    let mut trace = match &a.trace {
        Some(_) => {
            let mut w = Vec::new();
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
            if tip_tool.is_some() {
                header.push(TOOL_INPUT.to_string());
            }
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
            tip_tool: tip_tool.as_deref(),
        };
        let tally = replay_run(&bytes, run, &shape, a, &mut log, trace.as_mut())?;
        per_run.push((run.path.display().to_string(), tally));
    }
    crate::data::fsio::write_bytes_atomic(&a.candump, &log)?;
    if let (Some(p), Some(w)) = (&a.trace, &trace) {
        crate::data::fsio::write_bytes_atomic(p, w)?;
    }
    let summary: Vec<_> = per_run
        .iter()
        .map(|(name, t)| {
            json!({
                "run": name,
                "samples": t.samples,
                "frames": t.frames,
                "rx_frames": t.rx_frames,
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
        "skipped_rows": crate::data::source::skipped_rows(&runs),
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
    /// A five-point model's tool-length column (sent to the hub in
    /// TOOL_POSITION frames even though no model input reads it).
    tip_tool: Option<&'a str>,
}

/// One run through a fresh hub (a run is a power cycle).
fn replay_run(
    blob: &[u8],
    run: &RunFile,
    shape: &Shape<'_>,
    a: &ReplayArgs,
    log: &mut impl Write,
    mut trace: Option<&mut Vec<u8>>,
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
            "note: {}: the hub samples every {dt} s: each logged value is read until the next row ({} samples)",
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
        tip_tool,
    } = *shape;
    // How long a logged row stands for the hub's reading (`causal_values`).
    let hold_s = sampling.dt_median_s.map_or(dt, |m| m.max(dt));
    let is_position = |i: usize| position_inputs & (1u32 << i.min(31)) != 0;
    let from_cnc = |i: usize, name: &str| {
        name == TOOL_INPUT || CncInput::for_input(name, is_position(i)).is_some()
    };
    let values: Vec<Vec<Option<f64>>> = columns
        .iter()
        .enumerate()
        .map(|(i, c)| {
            if from_cnc(i, &inputs[i]) {
                // Absent column: the CNC never sends it.
                return Ok(run.column(c).map_or_else(
                    || vec![None; grid.len()],
                    |col| cnc_values(&run.t_s, col, &grid),
                ));
            }
            run.column(c)
                .map(|col| causal_values(&run.t_s, col, &grid, hold_s))
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
            Ok(
                if let Some(input) = CncInput::for_input(name, is_position(i)) {
                    Source::Cnc(input)
                } else if name == TOOL_INPUT {
                    Source::Tool
                } else if is_rtd_column(name) {
                    let chip = VirtualMax31865::new();
                    let driver = Max31865::new(chip.clone(), rtd_cfg)
                        .map_err(|e| anyhow!("virtual MAX31865 for {name}: {e}"))?;
                    Source::Rtd(driver, chip)
                } else {
                    Source::Direct
                },
            )
        })
        .collect::<Result<_>>()?;
    let channel = RtdChannel::MAX31865_PT100;
    // The hub as a CANopen node with its default settings: boot-up first,
    // then (operational without an NMT master) RPDOs in, EMCYs, TPDOs and
    // the heartbeat out, as on the board.
    let mut node = Node::new(Settings::DEFAULT).map_err(|e| anyhow!("CANopen node: {e}"))?;
    if let Some(boot_up) = node.boot::<RawFrame>(0) {
        writeln!(log, "({t0:.6}) {} {boot_up}", a.interface)?;
    }
    let mut tally = Tally {
        max_abs_um: vec![0.0; n_outputs],
        ..Tally::default()
    };
    let mut cnc = CncInputs::new(CNC_INPUT_TIMEOUT_MS);
    // The CNC's value of each of its signals at sample `k` (None: not sent).
    let cnc_value = |want: fn(&Source) -> bool, k: usize| {
        sources
            .iter()
            .zip(&values)
            .find(|(s, _)| want(s))
            .and_then(|(_, v)| v[k])
    };
    let mut cnc_columns: Vec<Vec<Option<f64>>> = [
        (|s: &Source| matches!(s, Source::Cnc(CncInput::Speed))) as fn(&Source) -> bool,
        |s| matches!(s, Source::Cnc(CncInput::Power)),
        |s| matches!(s, Source::Tool),
        |s| matches!(s, Source::Cnc(CncInput::Position)),
    ]
    .into_iter()
    .map(|want| (0..grid.len()).map(|k| cnc_value(want, k)).collect())
    .collect();
    if let Some(col) = tip_tool.and_then(|c| run.column(c)) {
        if let Some(tool) = cnc_columns.get_mut(2) {
            if tool.iter().all(Option::is_none) {
                *tool = cnc_values(&run.t_s, col, &grid);
            }
        }
    }
    let mut readings = vec![Reading::Stale; inputs.len()];
    let mut seen = vec![f64::NAN; inputs.len()];
    for (k, &t) in grid.iter().enumerate() {
        let now_ms = ((t - t0) * 1000.0).round() as u32;
        // The CNC's frames for this sample, as the board receives them.
        let spindle = Spindle {
            speed_rpm: cnc_columns[0][k],
            power_kw: cnc_columns[1][k],
        };
        let tool = ToolPosition {
            tool_mm: cnc_columns[2][k],
            position_mm: cnc_columns[3][k],
        };
        let mut rx: Vec<RawFrame> = Vec::new();
        if spindle.speed_rpm.is_some() || spindle.power_kw.is_some() {
            rx.extend(encode_spindle::<RawFrame>(&spindle));
        }
        if tool.tool_mm.is_some() || tool.position_mm.is_some() {
            rx.extend(encode_tool_position::<RawFrame>(&tool));
        }
        for f in &rx {
            writeln!(log, "({t:.6}) {} {f}", a.interface)?;
            // RPDO1/RPDO2 through the node, which hands their values on.
            match node.on_frame(f, now_ms).event {
                Some(Event::Input(msg)) => cnc.receive(&msg, now_ms),
                other => bail!("CNC frame {f}: not taken as an RPDO ({other:?})"),
            }
        }
        tally.rx_frames += rx.len();
        // The sampling task: the tool length received goes into the latch.
        cnc.expire(now_ms);
        if let Some(mm) = cnc.take_tool_mm() {
            pipeline
                .set_tool_length_mm(mm)
                .map_err(|e| anyhow!("{}: tool_mm {mm} at t = {t} s: {e}", run.path.display()))?;
        }
        for (i, src) in sources.iter_mut().enumerate() {
            let v = values[i][k];
            readings[i] = match (src, v) {
                (Source::Cnc(input), _) => cnc.reading(*input, now_ms),
                // What the pipeline fills the tool input with.
                (Source::Tool, _) => pipeline
                    .tool_length_mm()
                    .map_or(Reading::Stale, Reading::Direct),
                (_, None) => Reading::Stale,
                (Source::Direct, Some(v)) => Reading::Direct(v),
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
        // A position input is fed the reference (`pipeline`): that is what
        // the hub used, whatever arrived.
        for (i, (r, v)) in readings.iter_mut().zip(&mut seen).enumerate() {
            if is_position(i) {
                *r = Reading::Direct(POSITION_REFERENCE_MM);
                *v = POSITION_REFERENCE_MM;
            }
        }
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
        let mut frames: Vec<RawFrame> = node
            .on_sample::<RawFrame>(&report, &info)
            .into_iter()
            .collect();
        frames.extend(node.poll_heartbeat::<RawFrame>(now_ms));
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
            if tip_tool.is_some() {
                // The tool length the hub computed the tip with.
                row.push(
                    pipeline
                        .tool_length_mm()
                        .map_or(String::new(), |v| format!("{v}")),
                );
            }
            row.push(format!("{}", report.state.code()));
            row.push(format!("{}", report.flags.0));
            writeln!(w, "{}", row.join(","))?;
        }
    }
    Ok(tally)
}

#[cfg(test)]
mod tests {
    /// Interpolated between rows that both have the value, never across
    /// an empty cell (the CNC stopped sending), nothing outside the run.
    #[test]
    fn cnc_values_bridge_rows_but_not_gaps() {
        let t = [0.0, 60.0, 120.0, 180.0];
        let x = [Some(0.0), Some(600.0), None, Some(1200.0)];
        let grid: Vec<f64> = (0..=8).map(|k| f64::from(k) * 30.0).collect();
        assert_eq!(
            super::cnc_values(&t, &x, &grid),
            [
                Some(0.0),
                Some(300.0),
                Some(600.0),
                None,
                None,
                None,
                Some(1200.0),
                None,
                None
            ]
        );
    }
}
