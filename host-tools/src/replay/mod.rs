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

use crate::data::runfile::{
    is_temperature_column, uniform_grid_len, ReadOptions, RowStream, SamplingTally, StreamItem,
};
use crate::runner::ColumnMap;
use anyhow::{anyhow, bail, Result};
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
use firmware::report::StatusFlags;
use max31865::{Config, Filter, Max31865, Mode, Wires};
use model_core::rtd::{Rtd, RtdChannel, RtdCode};
use serde::Serialize;
use std::collections::{BTreeMap, VecDeque};
use std::io::Write;
use std::path::{Path, PathBuf};
use virtual_rtd::VirtualMax31865;

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
/// (The whole-run form of [`RowWindow::cnc_value`], which the replay
/// streams; the tests check that the two agree.)
#[cfg(test)]
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
    implausible: usize,
    max_abs_um: Vec<f64>,
}

/// The parameters of a replay job (what `thermcomp replay` takes, typed).
#[derive(Clone, Debug)]
pub struct ReplayParams {
    /// The model blob, as it would be flashed.
    pub model: PathBuf,
    /// The runs to replay.
    pub data: Vec<PathBuf>,
    /// `NAME=COLUMN` pairs (`--map`).
    pub map: Vec<String>,
    /// Skip bad data rows instead of failing (`--skip-bad-rows`).
    pub skip_bad_rows: bool,
    /// Where the candump log goes.
    pub candump: PathBuf,
    /// CAN interface name written in the log.
    pub interface: String,
    /// Where the per-sample trace CSV goes, if anywhere.
    pub trace: Option<PathBuf>,
}

impl ReplayParams {
    /// The checks the command line makes: at least one run, a valid
    /// interface name and `--map` pairs.
    pub fn check(&self) -> Result<()> {
        if self.data.is_empty() {
            bail!("replay: no run to replay (--data)");
        }
        crate::data::source::interface_name(&self.interface)
            .map_err(|e| anyhow!("invalid value '{}' for '--interface': {e}", self.interface))?;
        ColumnMap::parse(&self.map)?;
        Ok(())
    }
}

/// Samples per hub state (`replay --json`'s `states`).
#[derive(Clone, Debug, Serialize, serde::Deserialize)]
pub struct States {
    /// No model loaded.
    pub no_model: usize,
    /// Running normally.
    pub running: usize,
    /// Holding the last offsets (stale or faulty inputs).
    pub holding: usize,
    /// Ramping the offsets down.
    pub ramping: usize,
    /// Offsets zeroed.
    pub zeroed: usize,
}

/// One run's replay (an entry of `replay --json`'s `runs`).
#[derive(Clone, Debug, Serialize)]
pub struct RunReplay {
    /// The run file, as given.
    pub run: String,
    /// Samples the hub took.
    pub samples: usize,
    /// Frames the hub sent.
    pub frames: usize,
    /// Frames from the CNC.
    pub rx_frames: usize,
    /// Samples per hub state.
    pub states: States,
    /// Samples with a sensor fault.
    pub sensor_fault_samples: usize,
    /// Samples with a stale input.
    pub stale_samples: usize,
    /// Samples with a temperature refused by a plausibility check (outside
    /// the plausible window, rate of change, stuck) or by the spike filter:
    /// a reading that is there but not believed (STATUS bits 1, 10-12).
    pub implausible_samples: usize,
    /// Largest |offset| sent per output lane, µm.
    pub max_abs_offset_um: BTreeMap<String, f64>,
}

/// What a replay did: `serde_json::to_value` of it is `replay --json`'s object.
#[derive(Clone, Debug, Serialize)]
pub struct ReplayOutcome {
    /// The blob replayed, as given.
    pub model: String,
    /// The candump log written.
    pub candump: String,
    /// The hub's sample period, s.
    pub sample_period_s: f64,
    /// The output lanes (a five-point model's: the tip's dx, dy, dz).
    pub outputs: Vec<String>,
    /// One entry per run, in order.
    pub runs: Vec<RunReplay>,
    /// Rows skipped as bad (`--skip-bad-rows`), over all runs.
    pub skipped_rows: usize,
}

/// The model file's bytes as the hub's upload takes them: exactly one valid
/// blob, or nothing (the upload refuses anything else, trailing bytes
/// included, and the hub runs without a model: a note says so). A flash
/// slot may hold bytes after its blob; an uploaded file may not.
fn uploaded(model: &Path) -> Result<Vec<u8>> {
    let bytes = crate::data::fsio::read_capped(model, model_core::blob::MAX_BLOB_LEN as u64)?;
    // The upload's own check (decoded in its own frame and dropped; the
    // hub then loads the bytes once).
    match model_core::blob::check_split(&[], &bytes) {
        Ok(()) => Ok(bytes),
        Err(e) => {
            eprintln!(
                "note: {}: the hub refuses this blob ({e}): it runs without a model and sends zero offsets",
                model.display()
            );
            Ok(Vec::new())
        }
    }
}

/// The replay job: every run through a fresh hub, streamed row by row,
/// the candump log (and the trace) written as it goes (atomically: a
/// failed run leaves no half log behind). Memory is bounded by a few rows
/// whatever the runs' length.
pub fn replay(p: &ReplayParams) -> Result<ReplayOutcome> {
    check_paths(p)?;
    let bytes = uploaded(&p.model)?;
    let probe = Hub::load(&bytes);
    let map = ColumnMap::parse(&p.map)?;
    let shape = ModelShape::of(&probe, &map);
    let needed: Vec<String> = shape
        .columns
        .iter()
        .cloned()
        .chain(shape.tip_tool.clone())
        .collect();
    let opts = ReadOptions {
        skip_bad_rows: p.skip_bad_rows,
        only: Some(needed),
    };
    let mut runs = Vec::new();
    let mut skipped_rows = 0;
    crate::data::fsio::write_atomic(&p.candump, |log| match &p.trace {
        Some(trace) => crate::data::fsio::write_atomic(trace, |w| {
            writeln!(w, "{}", shape.trace_header())?;
            replay_runs(
                p,
                &bytes,
                &shape,
                &opts,
                log,
                Some(w),
                &mut runs,
                &mut skipped_rows,
            )
        }),
        None => replay_runs(
            p,
            &bytes,
            &shape,
            &opts,
            log,
            None,
            &mut runs,
            &mut skipped_rows,
        ),
    })?;
    Ok(ReplayOutcome {
        model: p.model.display().to_string(),
        candump: p.candump.display().to_string(),
        sample_period_s: PipelineConfig::DEFAULT.sample_period_s(&probe),
        outputs: shape.outputs.clone(),
        runs,
        skipped_rows,
    })
}

/// Never writes over an input, nor one output over the other.
fn check_paths(p: &ReplayParams) -> Result<()> {
    let reads: Vec<_> = std::iter::once(crate::data::fsio::named("--model", &p.model))
        .chain(p.data.iter().map(|d| crate::data::fsio::named("--data", d)))
        .collect();
    let writes: Vec<_> = std::iter::once(crate::data::fsio::named("--candump", &p.candump))
        .chain(
            p.trace
                .as_deref()
                .map(|t| crate::data::fsio::named("--trace", t)),
        )
        .collect();
    crate::data::fsio::check_distinct(&reads, &writes)
}

/// Every run in turn into the open log (and trace).
#[allow(clippy::too_many_arguments)]
fn replay_runs(
    p: &ReplayParams,
    blob: &[u8],
    shape: &ModelShape,
    opts: &ReadOptions,
    log: &mut dyn Write,
    mut trace: Option<&mut dyn Write>,
    runs: &mut Vec<RunReplay>,
    skipped_rows: &mut usize,
) -> Result<()> {
    for path in &p.data {
        let (tally, skipped) = replay_run(
            blob,
            path,
            shape,
            opts,
            &p.interface,
            log,
            reborrow(&mut trace),
        )?;
        *skipped_rows += skipped;
        runs.push(shape.run_replay(path, &tally));
    }
    Ok(())
}

/// The open trace again, for one call.
fn reborrow<'a>(trace: &'a mut Option<&mut dyn Write>) -> Option<&'a mut dyn Write> {
    match trace {
        Some(w) => Some(&mut **w),
        None => None,
    }
}

/// The model's inputs and outputs as the replay sees them.
struct ModelShape {
    /// Model input names.
    inputs: Vec<String>,
    /// The run-file column of each input.
    columns: Vec<String>,
    /// Output lanes (a five-point model's: the tip's dx, dy, dz).
    outputs: Vec<String>,
    /// Bit `j`: output `j` is positional (sent as a slope).
    positional: u8,
    /// Bit `i`: input `i` is an axis position (not read by the hub).
    position_inputs: u32,
    /// A five-point model's tool-length column (sent to the hub in
    /// TOOL_POSITION frames even though no model input reads it).
    tip_tool: Option<String>,
}

impl ModelShape {
    /// The shape of the hub's model (none: no inputs, no outputs).
    fn of(probe: &Hub, map: &ColumnMap) -> Self {
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
        // The CNC's columns are optional (absent: no frames), so every
        // column the model names is read if the file has it. A five-point
        // model turns its outputs into the tool tip with the tool length
        // the CNC sends: the run's tool_mm column.
        let columns = inputs.iter().map(|n| map.column(n).to_string()).collect();
        let tip_tool = probe
            .model()
            .and_then(|m| m.five_point())
            .map(|_| map.column(TOOL_INPUT).to_string());
        ModelShape {
            inputs,
            columns,
            outputs,
            positional: probe.model().map_or(0, |m| m.positional_outputs()),
            position_inputs: probe.model().map_or(0, |m| m.position_inputs()),
            tip_tool,
        }
    }

    fn is_position(&self, i: usize) -> bool {
        self.position_inputs & (1u32 << i.min(31)) != 0
    }

    /// The trace CSV's header line.
    fn trace_header(&self) -> String {
        let mut header = vec!["t_s".to_string()];
        header.extend(self.inputs.iter().cloned());
        header.extend(self.outputs.iter().map(|o| format!("{o}_sent")));
        header.extend(
            self.outputs
                .iter()
                .enumerate()
                .filter(|&(j, _)| self.positional & (1 << j) != 0)
                .map(|(_, o)| format!("{o}_slope_um_per_m")),
        );
        if self.tip_tool.is_some() {
            header.push(TOOL_INPUT.to_string());
        }
        header.extend(["state".to_string(), "flags".to_string()]);
        let header: Vec<String> = header
            .iter()
            .map(|h| crate::data::rawcells::csv_field(h))
            .collect();
        header.join(",")
    }

    /// A run's entry in the outcome.
    fn run_replay(&self, path: &Path, t: &Tally) -> RunReplay {
        RunReplay {
            run: path.display().to_string(),
            samples: t.samples,
            frames: t.frames,
            rx_frames: t.rx_frames,
            states: States {
                no_model: t.states[0],
                running: t.states[1],
                holding: t.states[2],
                ramping: t.states[3],
                zeroed: t.states[4],
            },
            sensor_fault_samples: t.sensor_faults,
            stale_samples: t.stale,
            implausible_samples: t.implausible,
            max_abs_offset_um: self
                .outputs
                .iter()
                .zip(&t.max_abs_um)
                .map(|(o, v)| (o.clone(), *v))
                .collect(),
        }
    }

    /// Where the hub gets each input from.
    fn sources(&self) -> Result<Vec<Source>> {
        let rtd_cfg = Config::new(Wires::Three, Filter::Hz50, Mode::Auto);
        self.inputs
            .iter()
            .enumerate()
            .map(|(i, name)| -> Result<Source> {
                Ok(
                    if let Some(input) = CncInput::for_input(name, self.is_position(i)) {
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
            .collect()
    }
}

/// A run's time base, from a first pass over its times: the hub's grid and
/// how long a logged row stands for a reading.
struct TimeBase {
    t0: f64,
    /// Grid points `t0 + k dt` (the last one clamped to the run's end).
    n: usize,
    dt: f64,
    t_end: f64,
    /// How long a logged row stands for the hub's reading ([`causal_values`]).
    hold_s: f64,
}

impl TimeBase {
    /// Reads the run's times (the cells are not kept) and says, as a note,
    /// when the hub's samples are not the run's rows.
    fn scan(path: &Path, opts: &ReadOptions, dt: f64) -> Result<TimeBase> {
        let file = path.display();
        let mut stream = RowStream::open(path, opts)?;
        let mut tally = SamplingTally::default();
        let mut first_skipped = None;
        while let Some(item) = stream.next_item()? {
            match item {
                StreamItem::Row(t) => tally.push(t),
                StreamItem::Skipped(s) => {
                    first_skipped.get_or_insert(s.reason);
                }
            }
        }
        stream.finish(first_skipped.as_ref())?;
        crate::data::source::note_skipped(path, stream.skipped(), first_skipped.as_ref());
        let Some((t0, t_end)) = tally.span() else {
            bail!("{file}: no rows");
        };
        let n = uniform_grid_len(t0, t_end, dt).map_err(|e| anyhow!("{file}: {e}"))?;
        let sampling = tally.sampling();
        sampling
            .check_grid(n, dt)
            .map_err(|e| anyhow!("{file}: {e}"))?;
        if !(sampling.is_uniform
            && sampling
                .dt_median_s
                .is_some_and(|m| (m - dt).abs() <= 1e-6 * dt))
        {
            eprintln!(
                "note: {file}: the hub samples every {dt} s: each logged value is read until the next row ({n} samples)"
            );
        }
        Ok(TimeBase {
            t0,
            n,
            dt,
            t_end,
            hold_s: sampling.dt_median_s.map_or(dt, |m| m.max(dt)),
        })
    }

    /// Grid point `k`, as `uniform_grid` computes it.
    fn at(&self, k: usize) -> f64 {
        (self.t0 + k as f64 * self.dt).min(self.t_end)
    }
}

/// The rows around the current grid time: from the latest row at or
/// before it to the first row past it (and its slack): what
/// [`cnc_values`] and [`causal_values`] look at, a few rows at a time.
struct RowWindow<R> {
    stream: RowStream<R>,
    rows: VecDeque<(f64, Vec<Option<f64>>)>,
    done: bool,
}

impl<R: std::io::Read> RowWindow<R> {
    /// Moves to grid time `g` (times only increase): reads rows until one
    /// lies past `g + slack`, drops rows no longer the latest at or before `g`.
    fn advance(&mut self, g: f64, slack: f64) -> Result<()> {
        while !self.done && self.rows.back().is_none_or(|r| r.0 <= g + slack) {
            match self.stream.next_item()? {
                Some(StreamItem::Row(t)) => self.rows.push_back((t, self.stream.row().to_vec())),
                Some(StreamItem::Skipped(_)) => {}
                None => self.done = true,
            }
        }
        while self.rows.get(1).is_some_and(|r| r.0 <= g) {
            self.rows.pop_front();
        }
        Ok(())
    }

    /// The cell of column `c` (an index in the row) at row `r` of the window.
    fn cell(&self, r: usize, c: usize) -> Option<f64> {
        let row = self.rows.get(r)?;
        row.1.get(c).copied().flatten().filter(|v| v.is_finite())
    }

    /// What the CNC sends at `g` ([`cnc_values`]).
    fn cnc_value(&self, c: usize, g: f64) -> Option<f64> {
        let t0 = self.rows.front()?.0;
        let x0 = self.cell(0, c)?;
        if t0 == g {
            return Some(x0);
        }
        let (t1, x1) = (self.rows.get(1)?.0, self.cell(1, c)?);
        if !(t0 < g && g < t1) {
            return None;
        }
        let w = (g - t0) / (t1 - t0);
        Some(x0 * (1.0 - w) + x1 * w)
    }

    /// What the hub reads at `g` ([`causal_values`], period `period_s`).
    fn causal_value(&self, c: usize, g: f64, period_s: f64) -> Option<f64> {
        let slack = 1e-6 * period_s;
        let mut r = 0;
        while self.rows.get(r + 1).is_some_and(|row| row.0 <= g + slack) {
            r += 1;
        }
        let t0 = self.rows.get(r)?.0;
        if t0 > g + slack || g - t0 >= period_s - slack {
            return None;
        }
        self.cell(r, c)
    }
}

/// Where each input's value comes from in a row: its column's index
/// (`None`: the file has no such column), and whether the CNC sends it.
struct InputColumns {
    index: Vec<Option<usize>>,
    from_cnc: Vec<bool>,
    /// The tool length's column (the CNC's TOOL_POSITION frame).
    tool: Option<usize>,
}

impl InputColumns {
    /// The run's columns for `shape`; the error for an absent column the
    /// hub reads (a CNC column may be absent: the CNC never sends it).
    fn of<R>(shape: &ModelShape, stream: &RowStream<R>, sources: &[Source]) -> Result<Self> {
        let from_cnc: Vec<bool> = shape
            .inputs
            .iter()
            .enumerate()
            .map(|(i, name)| {
                name == TOOL_INPUT || CncInput::for_input(name, shape.is_position(i)).is_some()
            })
            .collect();
        let index = shape
            .columns
            .iter()
            .zip(&from_cnc)
            .map(|(c, &cnc)| match stream.index_of(c) {
                None if !cnc => Err(anyhow!(
                    "{}: the model needs column \"{c}\" (columns: {})",
                    stream.file(),
                    stream.columns().join(", ")
                )),
                None => {
                    eprintln!(
                        "note: {}: no column \"{c}\": the CNC never sends it in this replay, so \
                         the model's input is stale throughout (hold, then ramp to zero)",
                        stream.file()
                    );
                    Ok(None)
                }
                i => Ok(i),
            })
            .collect::<Result<Vec<_>>>()?;
        // The tool input's column, or a five-point model's tool column
        // (the same name: `map.column(TOOL_INPUT)`).
        let tool = sources
            .iter()
            .zip(&index)
            .find(|(s, _)| matches!(s, Source::Tool))
            .and_then(|(_, i)| *i)
            .or_else(|| shape.tip_tool.as_deref().and_then(|c| stream.index_of(c)));
        Ok(InputColumns {
            index,
            from_cnc,
            tool,
        })
    }

    /// The column the CNC's signal `want` is read from, if any.
    fn cnc_column(&self, sources: &[Source], want: fn(&Source) -> bool) -> Option<usize> {
        sources
            .iter()
            .zip(&self.index)
            .find(|(s, _)| want(s))
            .and_then(|(_, i)| *i)
    }
}

/// The hub and its CANopen node over one run.
struct HubRun<'a> {
    pipeline: Pipeline,
    node: Node,
    cnc: CncInputs,
    sources: Vec<Source>,
    readings: Vec<Reading>,
    seen: Vec<f64>,
    shape: &'a ModelShape,
    interface: &'a str,
    tally: Tally,
}

/// One run through a fresh hub (a run is a power cycle): a first pass
/// over its times ([`TimeBase`]), then its rows streamed onto the hub's
/// grid. Returns the tally and the rows skipped as bad.
fn replay_run(
    blob: &[u8],
    path: &Path,
    shape: &ModelShape,
    opts: &ReadOptions,
    interface: &str,
    log: &mut dyn Write,
    mut trace: Option<&mut dyn Write>,
) -> Result<(Tally, usize)> {
    let pipeline = Pipeline::new(Hub::load(blob), PipelineConfig::DEFAULT)
        .map_err(|e| anyhow!("pipeline configuration: {e:?}"))?;
    let base = TimeBase::scan(path, opts, pipeline.sample_period_s())?;
    let stream = RowStream::open(path, opts)?;
    let sources = shape.sources()?;
    let cols = InputColumns::of(shape, &stream, &sources)?;
    let cnc_cols = [
        cols.cnc_column(&sources, |s| matches!(s, Source::Cnc(CncInput::Speed))),
        cols.cnc_column(&sources, |s| matches!(s, Source::Cnc(CncInput::Power))),
        cols.tool,
        cols.cnc_column(&sources, |s| matches!(s, Source::Cnc(CncInput::Position))),
    ];
    let mut hub = HubRun::boot(pipeline, sources, shape, interface, base.t0, log)?;
    let mut window = RowWindow {
        stream,
        rows: VecDeque::new(),
        done: false,
    };
    let slack = 1e-6 * base.hold_s;
    let mut values = vec![None; shape.inputs.len()];
    for k in 0..base.n {
        let t = base.at(k);
        window.advance(t, slack)?;
        for (v, (c, &cnc)) in values.iter_mut().zip(cols.index.iter().zip(&cols.from_cnc)) {
            *v = c.and_then(|c| {
                if cnc {
                    window.cnc_value(c, t)
                } else {
                    window.causal_value(c, t, base.hold_s)
                }
            });
        }
        let cnc = cnc_cols.map(|c| c.and_then(|c| window.cnc_value(c, t)));
        hub.sample(path, base.t0, t, cnc, &values, log, reborrow(&mut trace))?;
    }
    Ok((hub.tally, window.stream.skipped()))
}

impl<'a> HubRun<'a> {
    /// The hub powered up at `t0`: its boot-up frame logged.
    fn boot(
        pipeline: Pipeline,
        sources: Vec<Source>,
        shape: &'a ModelShape,
        interface: &'a str,
        t0: f64,
        log: &mut dyn Write,
    ) -> Result<Self> {
        // The hub as a CANopen node with its default settings: boot-up
        // first, then (operational without an NMT master) RPDOs in, EMCYs,
        // TPDOs and the heartbeat out, as on the board.
        let mut node = Node::new(Settings::DEFAULT).map_err(|e| anyhow!("CANopen node: {e}"))?;
        if let Some(boot_up) = node.boot::<RawFrame>(0) {
            writeln!(log, "({t0:.6}) {interface} {boot_up}")?;
        }
        let n = shape.inputs.len();
        Ok(HubRun {
            pipeline,
            node,
            cnc: CncInputs::new(CNC_INPUT_TIMEOUT_MS),
            sources,
            readings: vec![Reading::Stale; n],
            seen: vec![f64::NAN; n],
            shape,
            interface,
            tally: Tally {
                max_abs_um: vec![0.0; shape.outputs.len()],
                ..Tally::default()
            },
        })
    }

    /// One sample at `t`: the CNC's frames (`cnc`: speed, power, tool,
    /// position) received, the inputs (`values`) read, the pipeline
    /// stepped and its frames sent.
    #[allow(clippy::too_many_arguments)]
    fn sample(
        &mut self,
        path: &Path,
        t0: f64,
        t: f64,
        cnc: [Option<f64>; 4],
        values: &[Option<f64>],
        log: &mut dyn Write,
        trace: Option<&mut dyn Write>,
    ) -> Result<()> {
        let now_ms = ((t - t0) * 1000.0).round() as u32;
        self.receive_cnc(path, t, now_ms, cnc, log)?;
        self.read_inputs(now_ms, values);
        let report = self.pipeline.on_sample(&self.readings);
        // A position input is fed the reference (`pipeline`): that is what
        // the hub used, whatever arrived.
        for (i, (r, v)) in self.readings.iter_mut().zip(&mut self.seen).enumerate() {
            if self.shape.is_position(i) {
                *r = Reading::Direct(POSITION_REFERENCE_MM);
                *v = POSITION_REFERENCE_MM;
            }
        }
        let tally = &mut self.tally;
        tally.samples += 1;
        tally.states[usize::from(report.state.code()).min(4)] += 1;
        if self.readings.iter().any(|r| matches!(r, Reading::Fault(_))) {
            tally.sensor_faults += 1;
        }
        if self.readings.iter().any(|r| matches!(r, Reading::Stale)) {
            tally.stale += 1;
        }
        const NOT_BELIEVED: u16 = StatusFlags::SPIKE_REJECTED
            | StatusFlags::IMPLAUSIBLE
            | StatusFlags::RATE_OF_CHANGE
            | StatusFlags::STUCK;
        if report.flags.0 & NOT_BELIEVED != 0 {
            tally.implausible += 1;
        }
        let (sent, slopes) = self.send(t, now_ms, &report, log)?;
        if let Some(w) = trace {
            self.trace_row(w, t, &sent, &slopes, &report)?;
        }
        Ok(())
    }

    /// The CNC's frames for this sample, as the board receives them.
    fn receive_cnc(
        &mut self,
        path: &Path,
        t: f64,
        now_ms: u32,
        cnc: [Option<f64>; 4],
        log: &mut dyn Write,
    ) -> Result<()> {
        let [speed_rpm, power_kw, tool_mm, position_mm] = cnc;
        let spindle = Spindle {
            speed_rpm,
            power_kw,
        };
        let tool = ToolPosition {
            tool_mm,
            position_mm,
        };
        let mut rx: Vec<RawFrame> = Vec::new();
        if spindle.speed_rpm.is_some() || spindle.power_kw.is_some() {
            rx.extend(encode_spindle::<RawFrame>(&spindle));
        }
        if tool.tool_mm.is_some() || tool.position_mm.is_some() {
            rx.extend(encode_tool_position::<RawFrame>(&tool));
        }
        for f in &rx {
            writeln!(log, "({t:.6}) {} {f}", self.interface)?;
            // RPDO1/RPDO2 through the node, which hands their values on.
            match self.node.on_frame(f, now_ms).event {
                Some(Event::Input(msg)) => self.cnc.receive(&msg, now_ms),
                other => bail!("CNC frame {f}: not taken as an RPDO ({other:?})"),
            }
        }
        self.tally.rx_frames += rx.len();
        // The sampling task: the tool length received goes into the latch.
        self.cnc.expire(now_ms);
        if let Some(mm) = self.cnc.take_tool_mm() {
            self.pipeline
                .set_tool_length_mm(mm)
                .map_err(|e| anyhow!("{}: tool_mm {mm} at t = {t} s: {e}", path.display()))?;
        }
        Ok(())
    }

    /// Each input as the hub reads it (an RTD through its converter).
    fn read_inputs(&mut self, now_ms: u32, values: &[Option<f64>]) {
        let channel = RtdChannel::MAX31865_PT100;
        for (i, src) in self.sources.iter_mut().enumerate() {
            let v = values[i];
            self.readings[i] = match (src, v) {
                (Source::Cnc(input), _) => self.cnc.reading(*input, now_ms),
                // What the pipeline fills the tool input with.
                (Source::Tool, _) => self
                    .pipeline
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
            self.seen[i] = match self.readings[i] {
                Reading::Value(v) | Reading::Direct(v) => v,
                _ => f64::NAN,
            };
        }
    }

    /// The node's frames for this sample, logged: the offsets and slopes
    /// they carry.
    fn send(
        &mut self,
        t: f64,
        now_ms: u32,
        report: &firmware::report::Report,
        log: &mut dyn Write,
    ) -> Result<([f64; 4], [f64; 4])> {
        let info = StatusInfo {
            n_inputs: self.pipeline.hub().input_count(),
            consecutive_faults: self.pipeline.hub().faults().consecutive,
        };
        let mut frames: Vec<RawFrame> = self
            .node
            .on_sample::<RawFrame>(report, &info)
            .into_iter()
            .collect();
        frames.extend(self.node.poll_heartbeat::<RawFrame>(now_ms));
        let mut sent = [0.0f64; 4];
        let mut slopes = [0.0f64; 4];
        for f in &frames {
            writeln!(log, "({t:.6}) {} {f}", self.interface)?;
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
        self.tally.frames += frames.len();
        for (m, v) in self.tally.max_abs_um.iter_mut().zip(&sent) {
            *m = m.max(v.abs());
        }
        Ok((sent, slopes))
    }

    /// The sample's trace row.
    fn trace_row(
        &self,
        w: &mut dyn Write,
        t: f64,
        sent: &[f64; 4],
        slopes: &[f64; 4],
        report: &firmware::report::Report,
    ) -> Result<()> {
        let n_outputs = self.shape.outputs.len();
        let mut row = vec![format!("{t}")];
        row.extend(self.seen.iter().map(|v| {
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
                .filter(|&(j, _)| self.shape.positional & (1 << j) != 0)
                .map(|(_, v)| format!("{v:.3}")),
        );
        if self.shape.tip_tool.is_some() {
            // The tool length the hub computed the tip with.
            row.push(
                self.pipeline
                    .tool_length_mm()
                    .map_or(String::new(), |v| format!("{v}")),
            );
        }
        row.push(format!("{}", report.state.code()));
        row.push(format!("{}", report.flags.0));
        writeln!(w, "{}", row.join(","))?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::{causal_values, cnc_values, RowWindow};
    use crate::data::runfile::{ReadOptions, RowStream};
    use std::collections::VecDeque;

    /// The streaming window reads what the whole-run forms read, at every
    /// grid time: rows finer, coarser and irregular against the grid, with
    /// empty cells and a row a hair after a grid time.
    #[test]
    fn row_window_agrees_with_the_whole_run_forms() {
        let t = [0.0, 7.0, 30.0, 30.00001, 61.0, 90.0, 95.0, 200.0, 260.0];
        let x = [
            Some(1.0),
            None,
            Some(3.0),
            Some(4.0),
            Some(5.0),
            None,
            Some(7.0),
            Some(8.0),
            Some(9.0),
        ];
        let mut csv = String::from("t_s,x\n");
        for (ti, xi) in t.iter().zip(&x) {
            csv.push_str(&format!(
                "{ti},{}\n",
                xi.map_or(String::new(), |v| v.to_string())
            ));
        }
        for (dt, hold) in [(15.0, 30.0), (30.0, 30.0), (60.0, 60.0), (7.0, 45.0)] {
            let n = ((260.0 / dt) as usize) + 1;
            let grid: Vec<f64> = (0..n).map(|k| (k as f64 * dt).min(260.0)).collect();
            let want_cnc = cnc_values(&t, &x, &grid);
            let want_causal = causal_values(&t, &x, &grid, hold);
            let stream =
                RowStream::start("w.csv".into(), csv.as_bytes(), &ReadOptions::default()).unwrap();
            let mut w = RowWindow {
                stream,
                rows: VecDeque::new(),
                done: false,
            };
            for (k, &g) in grid.iter().enumerate() {
                w.advance(g, 1e-6 * hold).unwrap();
                assert_eq!(w.cnc_value(0, g), want_cnc[k], "cnc dt {dt} at {g}");
                assert_eq!(
                    w.causal_value(0, g, hold),
                    want_causal[k],
                    "causal dt {dt} at {g}"
                );
                assert!(w.rows.len() <= 4, "window of {} rows", w.rows.len());
            }
        }
    }

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
