//! `thermcomp demo`: the whole job, end to end, on the built-in default
//! machine (CONTRACT.md section 1), with no arguments and in well under a
//! minute.
//!
//! Six stages, each the library function behind a subcommand, so the demo
//! shows exactly what those subcommands do (the JSON gives, per stage, the
//! command line that repeats it on the files left in the output folder):
//!
//! 1. **simulate**: a calibration run (`spectrum`, seed 1) and a validation
//!    run (`steps`, seed 2) of the nominal twin, 24 h at 30 s.
//! 2. **select**: `maxtree` (seed 003) and `grey` (seed 000, `--scale
//!    interval`, since dz starts at zero) on the calibration run for
//!    `dz_um`; the model inputs are the union of both picks.
//! 3. **fit**: auto (every temperature and the spindle speed; form,
//!    filters and penalty, and the model family, chosen by cross-validation
//!    on the calibration run),
//!    then mlr, pcr, arx, tf, bp, gabp (a small GA) and arma on the selected
//!    sensors for comparison, each scored on the validation run held out
//!    whole (`fit --validate`). `arma` forecasts dz from its own measured past: it
//!    is listed, labelled as such, and never chosen, since a machine without
//!    a displacement probe cannot run it.
//! 4. **export**: the auto model becomes `model.bin` (chosen on the
//!    calibration run, never by its score on the validation run), described
//!    as `model show` does (`model.txt`).
//! 5. **replay**: that blob through the hub's own firmware pipeline over the
//!    validation run (candump log and trace); the offsets sent are compared
//!    with the host's f64 model run on the very readings the hub took (the
//!    firmware path against the host path: frames carry 0.1 um, so they
//!    agree within half a step where no limiter acted), and with the model
//!    run on the file (which adds the PT100/MAX31865 quantisation).
//! 6. **diagnose**: a "real" run with an effect the twin leaves out
//!    (`ambient`, seed 3) and a small parameter mismatch (front bearing
//!    heat +5 %) against the nominal twin on the same profile; the verdict
//!    should name the withheld effect.
//!
//! `--quick` shrinks every budget (12 h runs at 60 s, a tinier GA, shorter
//! searches) so the test suite's unoptimised build finishes in reasonable
//! time; the figures are then coarser.

mod outcome;
mod text;

pub use outcome::{
    DemoOutcome, DemoRun, DiagnoseStage, ExportStage, FitEntry, FitStage, Metrics, ReplayStage,
    SelectStage, SimulateStage,
};
pub use text::summary_text;

use crate::data::runfile::{ReadOptions, RunFile};
use crate::diagnose::summary::Summary;
use crate::eval::MetricsReport;
use crate::fit::{self, FitKind};
use crate::replay::{self, ReplayParams};
use crate::runner::{self, ColumnMap};
use crate::select::{self, grey, Method, SelectParams};
use crate::simulate;
use crate::twin::effects::{Effect, EffectSet};
use crate::twin::machine::Machine;
use crate::twin::profile::{self, Profile};
use crate::twin::sim::SimOptions;
use anyhow::{anyhow, bail, Context, Result};
use model_core::ValidModel;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What `thermcomp demo` runs (the command line's `--out`, `--quick`).
#[derive(Clone, Debug)]
pub struct DemoParams {
    /// Folder for everything the demo writes (run files, model blobs,
    /// candump log, diagnose report); created if missing, files in it
    /// overwritten.
    pub out: PathBuf,
    /// Small budgets (12 h runs at 60 s, a 6 x 3 GA, short ARX/TF/ARMA
    /// searches): for unoptimised builds such as the test suite's.
    pub quick: bool,
}

/// The target every stage works on: axial growth, the largest thermal error.
pub const TARGET: &str = "dz_um";

/// The effect the "real" machine of stage 6 has and the twin leaves out.
pub const WITHHELD_EFFECT: Effect = Effect::Ambient;

/// The kinds stage 3 trains, in the order they are reported.
const KINDS: [FitKind; 8] = [
    FitKind::Auto,
    FitKind::Mlr,
    FitKind::Pcr,
    FitKind::Arx,
    FitKind::Tf,
    FitKind::Bp,
    FitKind::Gabp,
    FitKind::Arma,
];

/// Run lengths, sample times and search budgets.
struct Budget {
    /// Length of every simulated run, h.
    hours: f64,
    /// Sample time of every simulated run, s.
    dt_s: f64,
    /// Extra `fit` flags per kind (budgets), as the command lines the demo
    /// reports spell them; `tune` sets the same values (a test checks).
    fit_extra: fn(FitKind) -> &'static [&'static str],
    /// The same budgets set on the typed options.
    tune: fn(FitKind, &mut fit::FitOptions),
}

impl Budget {
    fn new(quick: bool) -> Budget {
        if quick {
            Budget {
                hours: 12.0,
                dt_s: 60.0,
                fit_extra: |k| match k {
                    FitKind::Arx | FitKind::Tf => &[
                        "--lm-iterations",
                        "15",
                        "--backfit-rounds",
                        "1",
                        "--search-folds",
                        "2",
                    ],
                    FitKind::Bp => &["--epochs", "60"],
                    FitKind::Gabp => &[
                        "--epochs",
                        "60",
                        "--ga-population",
                        "6",
                        "--ga-generations",
                        "3",
                        "--ga-hidden",
                        "2..8",
                        "--gd-epochs",
                        "0",
                    ],
                    FitKind::Arma => &["--max-p", "2", "--max-q", "2", "--max-diff", "1"],
                    _ => &[],
                },
                tune: |k, o| match k {
                    FitKind::Arx | FitKind::Tf => {
                        o.arx.lm_iterations = 15;
                        o.arx.backfit_rounds = 1;
                        o.arx.search_folds = 2;
                    }
                    FitKind::Bp => o.bp.epochs = 60,
                    FitKind::Gabp => {
                        o.bp.epochs = 60;
                        o.bp.ga_population = 6;
                        o.bp.ga_generations = 3;
                        o.bp.ga_hidden = Some("2..8".into());
                        o.bp.gd_epochs = 0;
                    }
                    FitKind::Arma => {
                        o.arma.max_p = 2;
                        o.arma.max_q = 2;
                        o.arma.max_diff = 1;
                    }
                    _ => {}
                },
            }
        } else {
            Budget {
                // 24 h covers a day of spectrum segments and the whole steps
                // test; 30 s resolves the fastest thermal time constant (the
                // bearings', minutes) and keeps each run to 2 881 rows.
                hours: 24.0,
                dt_s: 30.0,
                fit_extra: |k| match k {
                    // A 12 x 6 GA: ~2 s in a release build (the default 40 x 30 is
                    // ~15x that); no gradient-descent convergence comparison.
                    FitKind::Gabp => &[
                        "--ga-population",
                        "12",
                        "--ga-generations",
                        "6",
                        "--gd-epochs",
                        "0",
                    ],
                    _ => &[],
                },
                tune: |k, o| {
                    if k == FitKind::Gabp {
                        o.bp.ga_population = 12;
                        o.bp.ga_generations = 6;
                        o.bp.gd_epochs = 0;
                    }
                },
            }
        }
    }
}

/// `thermcomp NAME ARGS..` as a shell line (paths quoted only if needed).
fn command_line(name: &str, argv: &[String]) -> String {
    let mut s = format!("thermcomp {name}");
    for a in argv {
        if a.is_empty() || a.contains(|c: char| c.is_whitespace() || "'\"$\\".contains(c)) {
            let _ = write!(s, " '{}'", a.replace('\'', "'\\''"));
        } else {
            let _ = write!(s, " {a}");
        }
    }
    s
}

fn path_arg(p: &Path) -> String {
    p.display().to_string()
}

/// The `thermcomp select` command that repeats one pick of stage 2 on the
/// calibration run `cal` (the flags that differ from the defaults).
fn select_command(cal: &Path, method: Method, scale: grey::Scale) -> String {
    let mut argv = vec!["--data".to_string(), path_arg(cal)];
    argv.extend(["--target".into(), TARGET.into()]);
    argv.extend(["--method".into(), method.name().into()]);
    if scale != grey::Scale::Initial {
        argv.extend(["--scale".into(), scale.name().into()]);
    }
    command_line("select", &argv)
}

/// Stage headers and timings on stderr.
struct Progress {
    started: Instant,
    stage_started: Instant,
}

impl Progress {
    const STAGES: usize = 6;

    fn new() -> Progress {
        Progress {
            started: Instant::now(),
            stage_started: Instant::now(),
        }
    }

    fn begin(&mut self, n: usize, what: &str) {
        self.stage_started = Instant::now();
        eprintln!("[{n}/{}] {what}", Self::STAGES);
    }

    /// Ends a stage with its key figures; returns its time, s.
    fn end(&self, figures: &str) -> f64 {
        let s = self.stage_started.elapsed().as_secs_f64();
        eprintln!("      {figures} ({s:.1} s)");
        s
    }
}

/// What the stages share: the arguments, budgets, output folder, machine,
/// stage timing, and the two run files of stage 1.
struct Demo<'a> {
    budget: Budget,
    dir: &'a Path,
    machine: Machine,
    p: Progress,
    cal: PathBuf,
    val: PathBuf,
}

/// A fitted kind: its model and blob file.
type FittedKind = (FitKind, ValidModel, PathBuf);

/// Runs every stage, writes everything to `a.out`, and returns `demo
/// --json`'s object.
pub fn demo(a: &DemoParams) -> Result<DemoOutcome> {
    let dir = &a.out;
    std::fs::create_dir_all(dir.join("models"))
        .and_then(|()| std::fs::create_dir_all(dir.join("diagnose")))
        .with_context(|| format!("cannot create the output folder {}", dir.display()))?;
    let shown = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.clone());
    eprintln!(
        "thermcomp demo: the whole job on the built-in default machine{}; writing to {}",
        if a.quick { " (--quick budgets)" } else { "" },
        shown.display()
    );
    let mut d = Demo {
        budget: Budget::new(a.quick),
        dir,
        machine: Machine::default_machine(),
        p: Progress::new(),
        cal: dir.join("calibration.csv"),
        val: dir.join("validation.csv"),
    };
    let simulate = d.simulate()?;
    let select = d.select()?;
    let (fit, fitted) = d.fit(&select.selected)?;
    let (export, best_model, model_bin) = d.export(&fit.best, &fitted)?;
    let (replay, replay_files) = d.replay(&best_model, &model_bin)?;
    let (diagnose, diagnose_files, report) = d.diagnose()?;
    let fivepoint = crate::fivepoint_demo::step(&d.val)?;
    let written: Vec<PathBuf> = [
        d.cal.clone(),
        d.val.clone(),
        model_bin,
        dir.join("model.txt"),
    ]
    .into_iter()
    .chain(std::iter::once(PathBuf::from(&fit.report)))
    .chain(replay_files)
    .chain(diagnose_files)
    .chain(fitted.iter().map(|(_, _, b)| b.clone()))
    .collect();
    let files = d.files(&written, &report)?;
    let elapsed_s = d.p.started.elapsed().as_secs_f64();
    eprintln!(
        "done in {elapsed_s:.1} s: {} files in {}",
        files.len(),
        shown.display()
    );
    Ok(DemoOutcome {
        out: path_arg(dir),
        quick: a.quick,
        hours: d.budget.hours,
        dt_s: d.budget.dt_s,
        target: TARGET.into(),
        simulate,
        select,
        fit,
        export,
        replay,
        fivepoint,
        diagnose,
        files,
        elapsed_s,
    })
}

impl Demo<'_> {
    /// Stage 1: the calibration and validation runs.
    fn simulate(&mut self) -> Result<SimulateStage> {
        let (budget, machine, cal, val, p) = (
            &self.budget,
            &self.machine,
            &self.cal,
            &self.val,
            &mut self.p,
        );
        // 1. Simulate.
        p.begin(
        1,
        &format!(
            "simulate: calibration (spectrum, seed 1) and validation (steps, seed 2) runs, {} h at {} s",
            budget.hours, budget.dt_s
        ),
    );
        let cal_run = simulate_run(
            machine,
            &Profile::Spectrum,
            budget,
            1,
            EffectSet::none(),
            cal,
        )?;
        let val_run = simulate_run(machine, &Profile::Steps, budget, 2, EffectSet::none(), val)?;
        let t = p.end(&format!(
            "{} rows each; max |dz| {:.1} um (calibration), {:.1} um (validation)",
            cal_run.rows, cal_run.max_abs_dz_um, val_run.max_abs_dz_um
        ));
        Ok(SimulateStage {
            machine: machine.name.clone(),
            calibration: cal_run,
            validation: val_run,
            elapsed_s: t,
        })
    }

    /// Stage 2: sensors picked by maxtree and grey on the calibration run.
    fn select(&mut self) -> Result<SelectStage> {
        let (cal, p) = (&self.cal, &mut self.p);
        // 2. Select.
        p.begin(
            2,
            &format!("select: maxtree and grey on the calibration run for {TARGET}"),
        );
        let cal_run = RunFile::read(cal, &ReadOptions::default())?;
        let mut picks: BTreeMap<String, Vec<String>> = BTreeMap::new();
        let mut commands = Vec::new();
        let mut selected: Vec<String> = Vec::new();
        for (method, scale) in [
            (Method::Maxtree, grey::Scale::Initial),
            (Method::Grey, grey::Scale::Interval),
        ] {
            let params = SelectParams {
                scale,
                ..SelectParams::new(vec![TARGET.into()], method)
            };
            let o = select::select(&params.check()?, std::slice::from_ref(&cal_run))
                .with_context(|| format!("demo: select {}", method.name()))?;
            let pick = o.selected().to_vec();
            for s in &pick {
                if !selected.contains(s) {
                    selected.push(s.clone());
                }
            }
            picks.insert(method.name().to_string(), pick);
            commands.push(select_command(cal, method, scale));
        }
        if selected.is_empty() {
            bail!("demo: select picked no sensors");
        }
        // File order (T1, T2, ...), as a user would list them.
        selected.sort_by_key(|s| s[1..].parse::<u32>().unwrap_or(u32::MAX));
        let t = p.end(&format!(
            "maxtree {}, grey {}: inputs {}",
            picks["maxtree"].join(","),
            picks["grey"].join(","),
            selected.join(",")
        ));
        Ok(SelectStage {
            target: TARGET.into(),
            methods: picks,
            selected,
            commands,
            elapsed_s: t,
        })
    }

    /// Stage 3: every kind fitted on the calibration run, scored on the
    /// validation run; the blobs written to `models/`.
    fn fit(&mut self, selected: &[String]) -> Result<(FitStage, Vec<FittedKind>)> {
        let (budget, dir, cal, val, p) =
            (&self.budget, self.dir, &self.cal, &self.val, &mut self.p);
        // 3. Fit and validate.
        let names: Vec<&str> = KINDS.iter().map(|k| kind_name(*k)).collect();
        p.begin(
            3,
            &format!(
                "fit: {} on the calibration run, scored on the validation run",
                names.join(", ")
            ),
        );
        let bar = crate::num::progress::progress(KINDS.len(), "fit");
        let read = |path: &Path| RunFile::read(path, &ReadOptions::default());
        let (cal_run, val_run) = (read(cal)?, read(val)?);
        let mut models = Vec::new();
        let mut fitted: Vec<FittedKind> = Vec::new();
        let mut report = None;
        for kind in KINDS {
            let name = kind_name(kind);
            bar.set_message(format!("fit {name}"));
            let blob = dir.join("models").join(format!("{name}.bin"));
            let params = fit_params(budget, kind, selected)?.check()?;
            let started = Instant::now();
            let o = fit::fit(
                &params,
                std::slice::from_ref(&cal_run),
                std::slice::from_ref(&val_run),
            )
            .with_context(|| format!("demo: fit {name}"))?;
            crate::data::fsio::write_bytes_atomic(&blob, &o.bytes)?;
            let elapsed = started.elapsed().as_secs_f64();
            let command = fit_command(budget, kind, selected, [cal, val, &blob]);
            models.push(fit_entry(kind, &o, &blob, elapsed, command)?);
            if kind == FitKind::Auto {
                report = Some(fit_report(dir, &o, [&cal_run, &val_run])?);
            }
            fitted.push((kind, o.model, blob));
            bar.inc(1);
        }
        bar.finish_and_clear();
        // The model is chosen on the calibration run only (auto's cross-
        // validation); the validation run scores it beside the other kinds.
        let best = models
            .iter()
            .find(|m| m.kind == kind_name(FitKind::Auto))
            .ok_or_else(|| anyhow!("demo: no auto model fitted"))?;
        let report = report.ok_or_else(|| anyhow!("demo: no auto model fitted"))?;
        let t = p.end(&format!(
        "exported: auto (chosen by cross-validation on the calibration run), validation reduction {:.1} %, rmse {:.2} um",
        best.validation.reduction_pct, best.validation.rmse_um
    ));
        let stage = FitStage {
            target: TARGET.into(),
            inputs: selected.to_vec(),
            best: best.kind.clone(),
            models,
            report: path_arg(&report),
            elapsed_s: t,
        };
        Ok((stage, fitted))
    }

    /// Stage 4: the chosen blob as `model.bin`, described as `model show` does.
    fn export(
        &mut self,
        best_kind: &str,
        fitted: &[FittedKind],
    ) -> Result<(ExportStage, ValidModel, PathBuf)> {
        let (dir, p) = (self.dir, &mut self.p);
        // 4. Export the best blob.
        p.begin(
            4,
            &format!(
            "export: {best_kind} (chosen on the calibration run by cross-validation) to model.bin"
        ),
        );
        let (_, best_model, best_blob) = fitted
            .iter()
            .find(|(k, _, _)| kind_name(*k) == best_kind)
            .ok_or_else(|| anyhow!("demo: lost the {best_kind} blob"))?;
        let model_bin = dir.join("model.bin");
        let bytes = std::fs::read(best_blob)
            .with_context(|| format!("cannot read {}", best_blob.display()))?;
        crate::data::fsio::write_bytes_atomic(&model_bin, &bytes)?;
        let header = crate::show::Header::of(best_model, &bytes);
        let inputs: Vec<String> = best_model
            .inputs()
            .iter()
            .map(|c| c.name.to_string())
            .collect();
        let model_txt = dir.join("model.txt");
        let text = crate::show::describe_text(&model_bin, best_model, &bytes);
        crate::data::fsio::write_bytes_atomic(&model_txt, text.as_bytes())?;
        let t = p.end(&format!(
            "{} bytes, {} model, format v{}, CRC {}, dt {} s, inputs {}",
            bytes.len(),
            header.kind,
            header.format_version,
            header.crc32,
            header.dt_s,
            inputs.join(",")
        ));
        let stage = ExportStage {
            kind: best_kind.to_string(),
            model: path_arg(&model_bin),
            show: path_arg(&model_txt),
            blob_kind: header.kind.to_string(),
            bytes: bytes.len(),
            format_version: header.format_version,
            crc32: header.crc32,
            dt_s: header.dt_s,
            inputs,
            outputs: best_model.outputs().iter().map(|o| o.to_string()).collect(),
            command: command_line("model show", &["--model".into(), path_arg(&model_bin)]),
            elapsed_s: t,
        };
        Ok((stage, best_model.clone(), model_bin))
    }

    /// Stage 5: `model.bin` through the hub's firmware pipeline.
    fn replay(
        &mut self,
        best_model: &ValidModel,
        model_bin: &Path,
    ) -> Result<(ReplayStage, Vec<PathBuf>)> {
        let (dir, val, p) = (self.dir, &self.val, &mut self.p);
        // 5. Replay through the firmware.
        p.begin(
            5,
            "replay: model.bin through the hub's firmware pipeline over the validation run",
        );
        let candump = dir.join("replay.log");
        let trace = dir.join("replay-trace.csv");
        let params = ReplayParams {
            model: model_bin.to_path_buf(),
            data: vec![val.clone()],
            map: Vec::new(),
            skip_bad_rows: false,
            candump: candump.clone(),
            interface: "can0".to_string(),
            trace: Some(trace.clone()),
        };
        params.check()?;
        let argv = vec![
            "--model".to_string(),
            path_arg(model_bin),
            "--data".into(),
            path_arg(val),
            "--candump".into(),
            path_arg(&candump),
            "--trace".into(),
            path_arg(&trace),
        ];
        let outcome = replay::replay(&params).context("demo: replay")?;
        let run0 = outcome
            .runs
            .first()
            .ok_or_else(|| anyhow!("demo: replay reported no run"))?;
        let agreement = replay_agreement(best_model, &trace, val)?;
        let t = p.end(&format!(
        "{} frames over {} samples; running {} of {}; max |sent - model| {:.3} um on the hub's readings ({} of {} samples, no limiter), {:.3} um on the file",
        run0.frames,
        run0.samples,
        run0.states.running,
        run0.samples,
        agreement.max_on_readings_um,
        agreement.compared,
        agreement.samples,
        agreement.max_on_file_um
    ));
        let stage = ReplayStage {
            model: path_arg(model_bin),
            candump: path_arg(&candump),
            trace: path_arg(&trace),
            sample_period_s: outcome.sample_period_s,
            samples: run0.samples,
            frames: run0.frames,
            states: run0.states.clone(),
            sensor_fault_samples: run0.sensor_fault_samples,
            stale_samples: run0.stale_samples,
            max_abs_offset_um: run0.max_abs_offset_um.get(TARGET).copied(),
            limited_samples: agreement.limited,
            compared_samples: agreement.compared,
            max_abs_sent_minus_model_um: agreement.max_on_readings_um,
            max_abs_sent_minus_model_on_file_um: agreement.max_on_file_um,
            frame_half_step_um: FRAME_HALF_STEP_UM,
            command: command_line("replay", &argv),
            elapsed_s: t,
        };
        Ok((stage, vec![candump, trace]))
    }

    /// Stage 6: a sim-to-real gap with a withheld effect, diagnosed.
    fn diagnose(&mut self) -> Result<(DiagnoseStage, Vec<PathBuf>, PathBuf)> {
        let (budget, dir, machine, p) = (&self.budget, self.dir, &self.machine, &mut self.p);
        // 6. Diagnose a sim-to-real gap.
        let withheld = WITHHELD_EFFECT.name();
        p.begin(
        6,
        &format!(
            "diagnose: \"real\" = default machine + {withheld} (withheld) + front bearing heat +{:.0} %, \"sim\" = nominal twin, same spectrum (seed 3)",
            (MISMATCH_FRONT_BEARING - 1.0) * 100.0
        ),
    );
        let ddir = dir.join("diagnose");
        let sim_csv = ddir.join("sim.csv");
        let real_csv = ddir.join("real.csv");
        let report = ddir.join("report");
        let schedule = profile::schedule(
            &Profile::Spectrum,
            machine.max_rpm,
            Some(budget.hours),
            budget.dt_s,
            3,
        )?;
        let mut real_machine = machine.clone();
        real_machine.heat.front_bearing_w_at_ref *= MISMATCH_FRONT_BEARING;
        let real_opts = SimOptions {
            effects: EffectSet::none().with(WITHHELD_EFFECT),
            seed: 3,
            sensors: None,
        };
        // The twin's own noise is another draw than the "measurement"'s.
        let sim_opts = SimOptions {
            effects: EffectSet::none(),
            seed: 103,
            sensors: None,
        };
        let (real_sum, _) = simulate::write_run(&real_machine, &schedule, &real_opts, &real_csv)?;
        let (sim_sum, _) = simulate::write_run(machine, &schedule, &sim_opts, &sim_csv)?;
        let diag =
            diagnose_call(&sim_csv, &real_csv, None, Some(&report)).context("demo: diagnose")?;
        let brief = Summary::of(&diag);
        let found = brief.verdict == withheld;
        let best = brief.best.as_ref();
        let (channel, unit) = gap_channel(&brief);
        let figures = format!(
            "verdict {} ({}); best {} shrinks the held-out gap on {channel} {:.1} % ({:.2} -> {:.2} {unit} rms)",
            brief.verdict,
            if found {
                "the withheld effect: found"
            } else {
                "not the withheld effect"
            },
            best.map_or("?", |b| b.name.as_str()),
            best.map_or(f64::NAN, |b| b.shrink_pct),
            best.map_or(f64::NAN, |b| b.rms_before),
            best.map_or(f64::NAN, |b| b.rms_after)
        );
        let t = p.end(&figures);
        let stage = DiagnoseStage {
            withheld: withheld.to_string(),
            mismatch: BTreeMap::from([(
                "front_bearing_w_at_ref_factor".to_string(),
                MISMATCH_FRONT_BEARING,
            )]),
            profile: "spectrum".into(),
            seed: 3,
            sim: path_arg(&sim_csv),
            real: path_arg(&real_csv),
            max_abs_dz_um: BTreeMap::from([
                ("sim".to_string(), sim_sum.max_abs_dz_um),
                ("real".to_string(), real_sum.max_abs_dz_um),
            ]),
            command: command_line(
                "diagnose",
                &[
                    "--sim".into(),
                    path_arg(&sim_csv),
                    "--real".into(),
                    path_arg(&real_csv),
                    "--report".into(),
                    path_arg(&report),
                    "--json".into(),
                ],
            ),
            report: path_arg(&report),
            verdict: brief.verdict.clone(),
            found_withheld: found,
            best_effect: best.map(|b| b.name.clone()),
            best_shrink_pct: best.map(|b| b.shrink_pct),
            rms_before_um: best.map(|b| b.rms_before),
            rms_after_um: best.map(|b| b.rms_after),
            holdout_from_t_s: brief.holdout_from_t_s,
            gap_dz_rms_um: brief.gap_rms.get(TARGET).copied(),
            result: diag,
            elapsed_s: t,
        };
        Ok((stage, vec![sim_csv, real_csv], report))
    }

    /// What this run wrote (not whatever else the folder holds): the known
    /// files, and whatever diagnose put in its report folder.
    fn files(&self, written: &[PathBuf], report: &Path) -> Result<Vec<String>> {
        let dir = self.dir;
        let mut files: Vec<String> = written
            .iter()
            .map(|f| f.strip_prefix(dir).unwrap_or(f).display().to_string())
            .collect();
        if report.is_dir() {
            list_files(dir, report, &mut files)?;
        }
        files.sort();
        Ok(files)
    }
}

/// The auto fit's page (`fit --report`'s): its CV table, and measured,
/// predicted and the band on the calibration and the validation run.
/// Returns the page's path.
fn fit_report(dir: &Path, o: &fit::FitOutcome, [cal, val]: [&RunFile; 2]) -> Result<PathBuf> {
    use crate::plot::model::{page_html, PageRun, PageText};
    let runs = [
        PageRun {
            run: cal,
            holdout_from_s: None,
            role: "calibration",
        },
        PageRun {
            run: val,
            holdout_from_s: None,
            role: "validation, held out whole",
        },
    ];
    let text = PageText {
        title: "thermcomp fit --model auto (demo)",
        auto: o.auto_report(),
        summary: "",
    };
    let json = serde_json::to_value(&o.report)?;
    let html = page_html(
        &o.model,
        &runs,
        &crate::runner::ColumnMap::default(),
        &text,
        &json,
    )?;
    crate::plot::write_page(&dir.join("fit"), &html)
}

/// Stage 3's parameters for `kind`: the selected sensors (auto and arma
/// choose their own inputs) and the budget's options.
fn fit_params(budget: &Budget, kind: FitKind, selected: &[String]) -> Result<fit::FitParams> {
    let mut options = fit::FitOptions::default();
    (budget.tune)(kind, &mut options);
    let own_inputs = kind == FitKind::Arma || kind == FitKind::Auto;
    Ok(fit::FitParams {
        targets: vec![TARGET.into()],
        inputs: if own_inputs {
            Vec::new()
        } else {
            selected.to_vec()
        },
        kind,
        holdout_from_s: None,
        reference: crate::data::dataset::InputForm::Change,
        l_defl_mm: None,
        options,
    })
}

/// The `thermcomp fit` command that repeats stage 3 for `kind` on the
/// files `[calibration, validation, blob]`.
fn fit_command(budget: &Budget, kind: FitKind, selected: &[String], files: [&Path; 3]) -> String {
    let [cal, val, blob] = files.map(path_arg);
    let name = kind_name(kind).to_string();
    let mut argv = vec!["--data".to_string(), cal, "--validate".into(), val];
    argv.extend(["--target".into(), TARGET.into(), "--model".into(), name]);
    argv.extend(["--out".into(), blob]);
    if kind != FitKind::Arma && kind != FitKind::Auto {
        argv.extend(["--inputs".into(), selected.join(",")]);
    }
    argv.extend((budget.fit_extra)(kind).iter().map(|s| s.to_string()));
    command_line("fit", &argv)
}

/// Stage 3's figures for one kind.
fn fit_entry(
    kind: FitKind,
    o: &fit::FitOutcome,
    blob: &Path,
    elapsed_s: f64,
    command: String,
) -> Result<FitEntry> {
    let name = kind_name(kind);
    let target = o
        .report
        .targets
        .get(TARGET)
        .ok_or_else(|| anyhow!("demo: fit {name}: no figures for {TARGET}"))?;
    let Some(val_m) = target.holdout.as_ref() else {
        bail!("demo: fit {name}: no held-out figures");
    };
    let forecaster = kind == FitKind::Arma;
    let label = if forecaster {
        "forecaster: one step ahead from the measured dz_um itself (needs a displacement probe on the machine)"
    } else {
        "compensation model: dz_um from temperatures"
    };
    Ok(FitEntry {
        kind: name.into(),
        label: label.into(),
        forecaster,
        inputs: o.inputs.clone(),
        blob: path_arg(blob),
        bytes: o.bytes.len(),
        calibration: target.calibration.as_ref().map(pick_metrics),
        validation: pick_metrics(val_m),
        elapsed_s,
        command,
    })
}

/// The "real" machine's front bearing makes this much more heat than the
/// twin's nominal value: a 5 % error, well inside what a bearing-loss
/// estimate (Palmgren's moment, preload) gets right.
const MISMATCH_FRONT_BEARING: f64 = 1.05;

/// Half the resolution of an offset in a CAN frame (0.1 um, docs/wire-format.md).
pub const FRAME_HALF_STEP_UM: f64 = 0.05;

/// The call into `diagnose` (CONTRACT.md's diagnose JSON), kept behind one
/// small function so the demo depends on nothing else of that module.
fn diagnose_call(
    sim: &Path,
    real: &Path,
    holdout_from_s: Option<f64>,
    report: Option<&Path>,
) -> Result<crate::diagnose::outcome::Diagnosis> {
    crate::diagnose::diagnose_files(sim, real, holdout_from_s, report)
}

/// One simulated run written to `out`; its figures.
fn simulate_run(
    machine: &Machine,
    profile: &Profile,
    budget: &Budget,
    seed: u64,
    effects: EffectSet,
    out: &Path,
) -> Result<DemoRun> {
    let schedule = profile::schedule(
        profile,
        machine.max_rpm,
        Some(budget.hours),
        budget.dt_s,
        seed,
    )?;
    let opts = SimOptions {
        effects,
        seed,
        sensors: None,
    };
    let (s, n_sensors) = simulate::write_run(machine, &schedule, &opts, out)?;
    Ok(DemoRun {
        file: path_arg(out),
        profile: profile.label(),
        seed,
        hours: budget.hours,
        dt_s: budget.dt_s,
        rows: s.rows,
        sensors: n_sensors,
        max_abs_dz_um: s.max_abs_dz_um,
        max_rise_c: s.max_rise_c.0,
        command: format!(
            "thermcomp simulate --out {} --hours {} --profile {} --seed {seed} --dt-s {}",
            out.display(),
            budget.hours,
            profile.label(),
            budget.dt_s
        ),
    })
}

/// How the offsets the hub sent compare with the host's model.
struct Agreement {
    /// Samples replayed.
    samples: usize,
    /// Samples where a limiter, spike filter or fault acted (flags set) or
    /// the hub was not running: left out of the comparison.
    limited: usize,
    /// Samples compared.
    compared: usize,
    /// max |sent - model| with the model run on the hub's own readings, um.
    max_on_readings_um: f64,
    /// max |sent - model| with the model run on the run file, um.
    max_on_file_um: f64,
}

/// Compares the trace's `<target>_sent` with the host model, run once on
/// the inputs as the hub read them (the trace's columns) and once on the
/// run file (matched by time).
fn replay_agreement(model: &ValidModel, trace: &Path, data: &Path) -> Result<Agreement> {
    let all = ReadOptions {
        skip_bad_rows: false,
        only: None,
    };
    let tr = RunFile::read(trace, &all)?;
    let sent_col = format!("{TARGET}_sent");
    let sent = tr
        .column(&sent_col)
        .ok_or_else(|| anyhow!("{}: no column {sent_col}", trace.display()))?;
    let state = tr
        .column("state")
        .ok_or_else(|| anyhow!("{}: no column state", trace.display()))?;
    let flags = tr
        .column("flags")
        .ok_or_else(|| anyhow!("{}: no column flags", trace.display()))?;
    let k = model
        .outputs()
        .iter()
        .position(|o| o.as_str() == TARGET)
        .ok_or_else(|| anyhow!("the model has no output {TARGET}"))?;
    let map = ColumnMap::default();
    let on_readings = runner::predict(model, &tr, &map)?;
    let file = RunFile::read(data, &all)?;
    let on_file = runner::predict(model, &file, &map)?;
    let running = f64::from(firmware::report::HubState::Running.code());
    let mut a = Agreement {
        samples: tr.len(),
        limited: 0,
        compared: 0,
        max_on_readings_um: 0.0,
        max_on_file_um: 0.0,
    };
    let mut j = 0;
    for row in 0..tr.len() {
        let (Some(s), Some(st), Some(fl)) = (sent.get(row), state.get(row), flags.get(row)) else {
            a.limited += 1;
            continue;
        };
        // Any flag but Extrapolating (information: the offsets are the
        // model's, outside its calibration envelope) means the hub changed
        // or held what the model said. So do the plausibility faults, but
        // in Running they name an input no output reads (an input the
        // model reads and the hub does not believe holds the hub).
        use firmware::report::StatusFlags as F;
        let informational = F::EXTRAPOLATING | F::IMPLAUSIBLE | F::RATE_OF_CHANGE | F::STUCK;
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let acted = (fl as u16) & !informational != 0;
        if st != running || acted {
            a.limited += 1;
            continue;
        }
        let Some(yhat) = on_readings.values[k][row] else {
            continue;
        };
        a.compared += 1;
        a.max_on_readings_um = a.max_on_readings_um.max((s - yhat).abs());
        // The hub's grid may be finer than the file's: compare where the times meet.
        let t = tr.t_s[row];
        while j + 1 < file.t_s.len() && file.t_s[j] < t - 1e-6 {
            j += 1;
        }
        if (file.t_s[j] - t).abs() <= 1e-6 {
            if let Some(y) = on_file.values[k][j] {
                a.max_on_file_um = a.max_on_file_um.max((s - y).abs());
            }
        }
    }
    if a.compared == 0 {
        bail!(
            "{}: no sample where the hub ran unlimited: nothing to compare",
            trace.display()
        );
    }
    Ok(a)
}

fn kind_name(k: FitKind) -> &'static str {
    match k {
        FitKind::Auto => "auto",
        FitKind::Mlr => "mlr",
        FitKind::Pcr => "pcr",
        FitKind::Arx => "arx",
        FitKind::Tf => "tf",
        FitKind::Gain => "gain",
        FitKind::Bp => "bp",
        FitKind::Gabp => "gabp",
        FitKind::Arma => "arma",
    }
}

/// The figures the summary needs from eval's metrics.
fn pick_metrics(m: &MetricsReport) -> Metrics {
    Metrics {
        n: m.n,
        rmse_um: m.rmse_um,
        fit_pct: m.fit_pct,
        r2: m.r2,
        max_abs_um: m.max_abs_um,
        reduction_pct: m.reduction_pct,
    }
}

/// Every file under `dir`, relative to `root`.
fn list_files(root: &Path, dir: &Path, out: &mut Vec<String>) -> Result<()> {
    let entries =
        std::fs::read_dir(dir).with_context(|| format!("cannot list {}", dir.display()))?;
    for e in entries {
        let path = e?.path();
        if path.is_dir() {
            list_files(root, &path, out)?;
        } else {
            let rel = path.strip_prefix(root).unwrap_or(&path);
            out.push(rel.display().to_string());
        }
    }
    Ok(())
}

/// The channel a diagnosis verdict explains and its unit: a displacement
/// (um) or, for a sensor-lag or ambient verdict, possibly a temperature
/// (K); the demo's target when the verdict names none.
pub(crate) fn gap_channel(brief: &Summary) -> (&str, &'static str) {
    let channel = if brief.main_channel.is_empty() {
        TARGET
    } else {
        brief.main_channel.as_str()
    };
    (channel, if channel.ends_with("_um") { "um" } else { "K" })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn budgets_become_typed_fit_options() {
        let selected = vec!["T3".to_string(), "T9".into()];
        let quick = fit_params(&Budget::new(true), FitKind::Gabp, &selected).unwrap();
        let bp = &quick.options.bp;
        assert_eq!((bp.ga_population, bp.gd_epochs, bp.epochs), (6, 0, 60));
        assert_eq!(quick.inputs, selected);
        let full = fit_params(&Budget::new(false), FitKind::Bp, &selected).unwrap();
        assert_eq!(full.options.bp.ga_population, 40, "the CLI's default");
        let auto = fit_params(&Budget::new(false), FitKind::Auto, &selected).unwrap();
        assert!(auto.inputs.is_empty(), "auto chooses its own inputs");
        assert!(auto.check().is_ok());
    }

    #[test]
    #[cfg(feature = "cli")]
    fn the_reported_flags_are_the_budgets_set() {
        for quick in [true, false] {
            let budget = Budget::new(quick);
            for kind in KINDS {
                let pairs: Vec<(String, String)> = (budget.fit_extra)(kind)
                    .chunks(2)
                    .map(|c| (c[0].trim_start_matches("--").to_string(), c[1].to_string()))
                    .collect();
                let from_flags = crate::cli::fit::options_from_pairs(&pairs).unwrap();
                let set = fit_params(&budget, kind, &[]).unwrap().options;
                assert_eq!(
                    format!("{from_flags:?}"),
                    format!("{set:?}"),
                    "{kind:?} quick {quick}"
                );
            }
        }
    }

    #[test]
    fn command_lines_quote_what_a_shell_would_split() {
        let line = command_line("fit", &["--out".into(), "a b/m.bin".into()]);
        assert_eq!(line, "thermcomp fit --out 'a b/m.bin'");
    }
}
