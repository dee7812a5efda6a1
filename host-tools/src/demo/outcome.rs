//! What `thermcomp demo` reports, stage by stage: typed, serialised as
//! `demo --json`'s object (every stage's figures and the command line that
//! repeats it on the files left in the output folder).

use crate::replay::States;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::collections::BTreeMap;

/// The whole demo.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct DemoOutcome {
    /// The output folder.
    pub out: String,
    /// Whether the small budgets were used.
    pub quick: bool,
    /// Length of each simulated run, h.
    pub hours: f64,
    /// Sample time of each simulated run, s.
    pub dt_s: f64,
    /// The target every stage works on.
    pub target: String,
    /// Stage 1.
    pub simulate: SimulateStage,
    /// Stage 2.
    pub select: SelectStage,
    /// Stage 3.
    pub fit: FitStage,
    /// Stage 4.
    pub export: ExportStage,
    /// Stage 5.
    pub replay: ReplayStage,
    /// The five-point geometry on the validation run (fivepoint_demo.rs).
    pub fivepoint: Value,
    /// Stage 6.
    pub diagnose: DiagnoseStage,
    /// Every file the demo wrote, relative to `out`.
    pub files: Vec<String>,
    /// Wall time, s.
    pub elapsed_s: f64,
}

/// Stage 1: the calibration and validation runs.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SimulateStage {
    /// The twin's machine.
    pub machine: String,
    /// The calibration run (spectrum, seed 1).
    pub calibration: DemoRun,
    /// The validation run (steps, seed 2).
    pub validation: DemoRun,
    /// Wall time, s.
    pub elapsed_s: f64,
}

/// One simulated run.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct DemoRun {
    /// The run file.
    pub file: String,
    /// Speed profile.
    pub profile: String,
    /// Seed.
    pub seed: u64,
    /// Length, h.
    pub hours: f64,
    /// Sample time, s.
    pub dt_s: f64,
    /// Rows written.
    pub rows: usize,
    /// Temperature sensors.
    pub sensors: usize,
    /// Largest |dz|, um.
    pub max_abs_dz_um: f64,
    /// Largest node temperature rise, K.
    pub max_rise_c: f64,
    /// The `thermcomp simulate` line that writes it.
    pub command: String,
}

/// Stage 2: the sensors maxtree and grey pick.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SelectStage {
    /// The target.
    pub target: String,
    /// Each method's pick.
    pub methods: BTreeMap<String, Vec<String>>,
    /// Their union, in file order: the other kinds' inputs.
    pub selected: Vec<String>,
    /// The `thermcomp select` lines that repeat the picks.
    pub commands: Vec<String>,
    /// Wall time, s.
    pub elapsed_s: f64,
}

/// Stage 3: every kind fitted and scored.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FitStage {
    /// The target.
    pub target: String,
    /// The selected sensors (auto and arma choose their own).
    pub inputs: Vec<String>,
    /// Each kind, in the order fitted.
    pub models: Vec<FitEntry>,
    /// The kind exported (auto: chosen on the calibration run only).
    pub best: String,
    /// The auto fit's page (CV table; measured, predicted and the band).
    pub report: String,
    /// Wall time, s.
    pub elapsed_s: f64,
}

/// One kind's fit.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FitEntry {
    /// Model kind.
    pub kind: String,
    /// What the model is for.
    pub label: String,
    /// Whether it forecasts from the measured error itself (arma).
    pub forecaster: bool,
    /// The inputs the model reads.
    pub inputs: Vec<String>,
    /// Its blob.
    pub blob: String,
    /// The blob's size.
    pub bytes: usize,
    /// Figures on the calibration run.
    pub calibration: Option<Metrics>,
    /// Figures on the validation run (held out whole).
    pub validation: Metrics,
    /// Wall time, s.
    pub elapsed_s: f64,
    /// The `thermcomp fit` line that repeats it.
    pub command: String,
}

/// The figures the summary uses of eval's metrics.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Metrics {
    /// Rows scored.
    pub n: usize,
    /// Root mean square error, um.
    pub rmse_um: f64,
    /// Fit, %.
    pub fit_pct: f64,
    /// Coefficient of determination.
    pub r2: f64,
    /// Largest |error|, um.
    pub max_abs_um: f64,
    /// Reduction of the mean |error|, %.
    pub reduction_pct: f64,
}

/// Stage 4: the exported blob.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ExportStage {
    /// The kind fitted.
    pub kind: String,
    /// `model.bin`.
    pub model: String,
    /// `model.txt` (`model show`'s text).
    pub show: String,
    /// The blob's model kind (auto writes a tf, fbank, pcr or bp blob).
    pub blob_kind: String,
    /// Size, bytes.
    pub bytes: usize,
    /// Blob format version.
    pub format_version: u16,
    /// CRC-32 of the blob, as `model show` prints it.
    pub crc32: String,
    /// Sample time, s.
    pub dt_s: f64,
    /// Input channels.
    pub inputs: Vec<String>,
    /// Outputs.
    pub outputs: Vec<String>,
    /// The `thermcomp model show` line.
    pub command: String,
    /// Wall time, s.
    pub elapsed_s: f64,
}

/// Stage 5: the blob through the hub's firmware pipeline.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ReplayStage {
    /// The blob.
    pub model: String,
    /// The candump log.
    pub candump: String,
    /// The trace.
    pub trace: String,
    /// The hub's sample period, s.
    pub sample_period_s: f64,
    /// Samples replayed.
    pub samples: usize,
    /// Frames sent.
    pub frames: usize,
    /// Samples per hub state.
    pub states: States,
    /// Samples with a sensor fault.
    pub sensor_fault_samples: usize,
    /// Samples with a stale input.
    pub stale_samples: usize,
    /// Largest |offset| sent for the target, um.
    pub max_abs_offset_um: Option<f64>,
    /// Samples where a limiter, filter or fault acted (not compared).
    pub limited_samples: usize,
    /// Samples compared.
    pub compared_samples: usize,
    /// max |sent - model| with the model on the hub's readings, um.
    pub max_abs_sent_minus_model_um: f64,
    /// max |sent - model| with the model on the run file, um.
    pub max_abs_sent_minus_model_on_file_um: f64,
    /// Half a frame step, um (frames carry 0.1 um).
    pub frame_half_step_um: f64,
    /// The `thermcomp replay` line.
    pub command: String,
    /// Wall time, s.
    pub elapsed_s: f64,
}

/// Stage 6: a sim-to-real gap with a withheld effect, diagnosed.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct DiagnoseStage {
    /// The effect the "real" machine has and the twin leaves out.
    pub withheld: String,
    /// The parameter mismatch of the "real" machine.
    pub mismatch: BTreeMap<String, f64>,
    /// Speed profile of both runs.
    pub profile: String,
    /// Seed of the "real" run.
    pub seed: u64,
    /// The sim run file.
    pub sim: String,
    /// The "real" run file.
    pub real: String,
    /// Largest |dz| of each, um.
    pub max_abs_dz_um: BTreeMap<String, f64>,
    /// The `thermcomp diagnose` line.
    pub command: String,
    /// The HTML report's folder.
    pub report: String,
    /// The verdict.
    pub verdict: String,
    /// Whether it names the withheld effect.
    pub found_withheld: bool,
    /// The deciding look's best candidate.
    pub best_effect: Option<String>,
    /// Its held-out shrink, %.
    pub best_shrink_pct: Option<f64>,
    /// Held-out rms before it, in the channel's unit.
    pub rms_before_um: Option<f64>,
    /// Held-out rms after it.
    pub rms_after_um: Option<f64>,
    /// Where the held-out part starts, s.
    pub holdout_from_t_s: f64,
    /// Rms of the dz gap, um.
    pub gap_dz_rms_um: Option<f64>,
    /// The whole diagnosis (`diagnose --json`'s object).
    pub result: crate::diagnose::outcome::Diagnosis,
    /// Wall time, s.
    pub elapsed_s: f64,
}
