//! The summary `thermcomp demo` prints without `--json`: a line or two per
//! stage, from the typed outcome.

use super::outcome::{DemoOutcome, DiagnoseStage, FitStage};
use super::TARGET;
use crate::diagnose::summary::Summary;
use std::fmt::Write as _;

/// The summary `demo` prints without `--json`.
pub fn summary_text(d: &DemoOutcome) -> String {
    let mut s = String::new();
    let sim = &d.simulate;
    let _ = writeln!(
        s,
        "thermcomp demo: built-in machine \"{}\", target {TARGET}, runs of {:?} h at {:?} s{}",
        sim.machine,
        d.hours,
        d.dt_s,
        if d.quick { " (--quick)" } else { "" }
    );
    let _ = writeln!(
        s,
        "1 simulate   calibration spectrum seed 1 (max |dz| {:.1} um), validation steps seed 2 (max |dz| {:.1} um)",
        sim.calibration.max_abs_dz_um, sim.validation.max_abs_dz_um
    );
    let sel = &d.select;
    let pick = |m: &str| sel.methods.get(m).map_or(String::new(), |v| v.join(","));
    let _ = writeln!(
        s,
        "2 select     maxtree {}, grey {} -> inputs {}",
        pick("maxtree"),
        pick("grey"),
        sel.selected.join(",")
    );
    fit_lines(&mut s, &d.fit);
    let ex = &d.export;
    let _ = writeln!(
        s,
        "4 export     model.bin: the {} fit (a {} blob), {} bytes, CRC {}, inputs {}",
        ex.kind,
        ex.blob_kind,
        ex.bytes,
        ex.crc32,
        ex.inputs.join(",")
    );
    let r = &d.replay;
    let st = &r.states;
    let _ = writeln!(
        s,
        "5 replay     {} frames over {} samples every {:?} s (running {}, holding {}, ramping {}, zeroed {})",
        r.frames, r.samples, r.sample_period_s, st.running, st.holding, st.ramping, st.zeroed
    );
    let _ = writeln!(
        s,
        "             max |sent - model| {:.3} um on the hub's readings ({} samples without a limiter; frames carry 0.1 um), \
         {:.3} um on the logged temperatures (adds PT100 quantisation)",
        r.max_abs_sent_minus_model_um,
        r.compared_samples,
        r.max_abs_sent_minus_model_on_file_um
    );
    diagnose_lines(&mut s, &d.diagnose);
    let _ = writeln!(
        s,
        "{} files in {} ({:.1} s); --json for every figure",
        d.files.len(),
        d.out,
        d.elapsed_s
    );
    s
}

/// Stage 3's lines of the summary: each kind's held-out figures on the
/// validation run, the exported one marked.
fn fit_lines(s: &mut String, fit: &FitStage) {
    let _ = writeln!(
        s,
        "3 fit        held-out on the validation run:\n  {:<6} {:>9} {:>9} {:>10} {:>10}",
        "kind", "rmse_um", "fit_%", "max|r|_um", "reduce_%"
    );
    for m in &fit.models {
        let v = &m.validation;
        let note = if m.forecaster {
            "  forecaster: needs the measured dz_um, not a compensation model"
        } else if m.kind == fit.best {
            "  <- exported (chosen by CV on the calibration run)"
        } else {
            ""
        };
        let _ = writeln!(
            s,
            "  {:<6} {:>9.3} {:>9.2} {:>10.3} {:>10.2}{note}",
            m.kind, v.rmse_um, v.fit_pct, v.max_abs_um, v.reduction_pct
        );
    }
    let _ = writeln!(
        s,
        "  plots of the auto fit (CV table, measured/predicted/band): {}",
        fit.report
    );
}

/// Stage 6's lines of the summary: the verdict on the withheld effect and,
/// if figured, the deployment comparison.
fn diagnose_lines(s: &mut String, g: &DiagnoseStage) {
    let brief = Summary::of(&g.result);
    let (channel, unit) = super::gap_channel(&brief);
    let _ = writeln!(
        s,
        "6 diagnose   withheld {}: verdict {} ({}), best {} shrinks the held-out gap on {channel} {:.1} % ({:.2} -> {:.2} {unit} rms)",
        g.withheld,
        g.verdict,
        if g.found_withheld { "found" } else { "missed" },
        g.best_effect.as_deref().unwrap_or("?"),
        g.best_shrink_pct.unwrap_or(f64::NAN),
        g.rms_before_um.unwrap_or(f64::NAN),
        g.rms_after_um.unwrap_or(f64::NAN)
    );
    if let Some(dep) = &brief.deployment {
        let _ = writeln!(
            s,
            "             deployment: {} on the real hold-out, trained on the sim {:.2} um rms{}, on the real fit part {:.2} um",
            dep.model,
            dep.on_sim_um,
            dep.on_sim_plus_effect_um.map_or(String::new(), |w| format!(
                ", on sim + {} {w:.2} um",
                dep.effect.as_deref().unwrap_or("?")
            )),
            dep.on_real_fit_part_um.unwrap_or(f64::NAN)
        );
    }
}
