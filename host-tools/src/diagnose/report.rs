//! `--report DIR`: `DIR/index.html`, one self-contained page with inline SVG
//! plots (drawn here: text in SVG needs no font files, so the report needs
//! no system libraries) and the JSON.

use super::align::Aligned;
use super::candidates::Scored;
use super::outcome::{finite, json_number, Band, Deployment, Diagnosis, Segment, Trained};
use crate::plot::{bar_chart, esc, line_chart, page, write_page, TimeAxis};
use anyhow::Result;
use std::fmt::Write as _;
use std::path::Path;

/// The deployment view as a small table: the real held-out error of a
/// compensation model trained on the sim, on the sim plus the effect and on
/// the real fit part.
fn deployment_html(d: &Deployment) -> String {
    let mut h = String::from("<h2>Deployment: a compensation model trained on the twin</h2>");
    let c = d.comparison();
    let note = match d {
        Deployment::Compared(c) => c.note.as_deref().unwrap_or(""),
        Deployment::Skipped { note, .. } => note,
    };
    let _ = write!(
        h,
        "<p>{} ({}) regressed on {} by least squares, trained on the rows before the hold-out, scored on the real run's held-out rows (uncompensated rms {} um). {}</p><table border=\"1\" cellpadding=\"4\" style=\"border-collapse:collapse\"><tr><th>trained on</th><th>rmse, um</th><th>reduction, %</th></tr>",
        esc(d.model()),
        esc(c.map_or("?", |c| c.target.as_str())),
        esc(&serde_json::to_string(&c.map(|c| &c.inputs)).unwrap_or_default()),
        json_number(c.map_or(f64::NAN, |c| c.held_out_uncompensated_rms_um)),
        esc(note)
    );
    let Some(c) = c else {
        h.push_str("</table>");
        return h;
    };
    let effect = c.effect.as_deref().unwrap_or("effect");
    for (label, trained) in [
        ("nominal sim".to_string(), Some(&c.trained_on_sim)),
        (
            format!("sim + {effect}"),
            c.trained_on_sim_plus_effect.as_ref(),
        ),
        (
            "real fit part (reference)".to_string(),
            Some(&c.trained_on_real_fit_part),
        ),
    ] {
        let (rmse, reduction) = match trained {
            Some(Trained::Scored {
                rmse_um,
                reduction_pct,
            }) => (*rmse_um, *reduction_pct),
            Some(Trained::Failed { .. }) => (f64::NAN, f64::NAN),
            None => continue,
        };
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td></tr>",
            esc(&label),
            json_number(rmse),
            json_number(reduction)
        );
    }
    h.push_str("</table>");
    h
}

/// Writes `dir/index.html`: the verdict, the candidates, the main
/// channel's residual, the deployment view, where the gap is, every
/// channel, `extra` (HTML: the physical diagnosis with `--machine`), and
/// the JSON.
pub fn write(
    dir: &Path,
    al: &Aligned,
    main: usize,
    n_fit: usize,
    best: (&[Scored], Option<&[f64]>),
    d: &Diagnosis,
    extra: &str,
) -> Result<()> {
    let t0 = al.t_s[0];
    let ax = TimeAxis::new(&al.t_s, al.t_s.get(n_fit).copied());
    let mut html = String::new();
    let _ = write!(
        html,
        "<h1>Sim-to-real gap diagnosis</h1><p>Verdict: <b>{}</b> &mdash; main channel <b>{}</b>, candidates fitted before t = {} s and scored after it. {}</p>",
        esc(&d.verdict),
        esc(&d.main_channel),
        json_number(d.holdout_from_t_s),
        esc(&d.rule)
    );
    html.push_str(&candidates_html(al, main, best, &ax));
    html.push_str(&deployment_html(&d.deployment));
    html.push_str(&where_html(&d.where_, &d.bands, t0));
    html.push_str(&channels_html(al, &ax));
    html.push_str(extra);
    let pretty = serde_json::to_string_pretty(d).unwrap_or_default();
    write_page(dir, &page("thermcomp diagnose", &html, &pretty))?;
    Ok(())
}

/// The candidates: held-out shrink bars (with confidences), their table,
/// and the main channel's residual with the best candidate's prediction.
/// `scored`: the main look's candidates, best first, and the best one's
/// prediction on every row.
fn candidates_html(
    al: &Aligned,
    main: usize,
    (scored, best_pred): (&[Scored], Option<&[f64]>),
    ax: &TimeAxis,
) -> String {
    let mut html = String::from("<h2>How far each candidate shrinks the held-out gap</h2>");
    let bars: Vec<(String, f64)> = scored
        .iter()
        .map(|s| {
            (
                format!(
                    "{} (rms {:.3} -> {:.3}{})",
                    s.name,
                    s.rms_before,
                    s.rms_after,
                    s.confidence()
                        .map_or(String::new(), |c| format!(", confidence {c:.3}"))
                ),
                s.shrink_pct,
            )
        })
        .collect();
    html.push_str(&bar_chart(
        "held-out shrink of the main channel's rms, %",
        &bars,
        "%",
    ));
    html.push_str(&candidates_table(scored));
    let ch = &al.channels.load(main);
    if let (Some(best), Some(pred)) = (scored.first(), best_pred) {
        let after: Vec<f64> = ch.resid.iter().zip(pred).map(|(r, p)| r - p).collect();
        html.push_str(&line_chart(
            &format!(
                "{}: residual, best candidate ({}) and what is left",
                ch.name, best.name
            ),
            &ax.t_h,
            &[
                ("residual", &ch.resid),
                (&best.name, pred),
                ("left", &after),
            ],
            ax.hold_h(),
            300.0,
        ));
    }
    html
}

/// Where: the regime segments' shares (bars) and the bands table.
fn where_html(segments: &[Segment], bands: &[Band], t0: f64) -> String {
    let mut html = String::from("<h2>Where: regime segments</h2>");
    let seg: Vec<(String, f64)> = segments
        .iter()
        .map(|w| {
            (
                format!(
                    "{} {} {:.1}-{:.1} h",
                    w.channel,
                    w.regime,
                    (w.from_t_s - t0) / 3600.0,
                    (w.to_t_s - t0) / 3600.0
                ),
                w.share_pct,
            )
        })
        .collect();
    html.push_str(&bar_chart(
        "share of the residual energy (sum r^2), largest segments",
        &seg,
        "%",
    ));
    html.push_str(&bands_table(bands));
    html
}

/// Sim vs real per displacement, and the residual of every displacement
/// and temperature channel.
fn channels_html(al: &Aligned, ax: &TimeAxis) -> String {
    let mut html = String::from("<h2>Sim vs real</h2>");
    for c in al.channels.each().filter(|c| c.is_displacement()) {
        html.push_str(&line_chart(
            &format!("{} (um)", c.name),
            &ax.t_h,
            &[("sim", &c.sim), ("real", &c.real())],
            ax.hold_h(),
            220.0,
        ));
    }
    html.push_str("<h2>Residual real - sim per channel</h2>");
    for c in al.channels.each().filter(|c| !c.name.starts_with('S')) {
        let unit = if c.is_displacement() { "um" } else { "K" };
        html.push_str(&line_chart(
            &format!("{} residual ({unit})", c.name),
            &ax.t_h,
            &[("real - sim", &c.resid)],
            ax.hold_h(),
            160.0,
        ));
    }
    html
}

/// The candidates' figures: held-out rms, shrink, ratio to the baseline,
/// p-value and confidence (1 - Holm-adjusted p).
fn candidates_table(scored: &[Scored]) -> String {
    let mut t = String::from(
        "<table border=\"1\" cellpadding=\"4\" style=\"border-collapse:collapse\">\
         <tr><th>candidate</th><th>held-out rms</th><th>shrink, %</th><th>ratio to none</th>\
         <th>p-value</th><th>confidence</th></tr>",
    );
    let opt = |v: Option<f64>| v.map_or("-".to_string(), |x| format!("{x:.3}"));
    for c in scored {
        let _ = write!(
            t,
            "<tr><td>{}</td><td>{:.4}</td><td>{:.1}</td><td>{:.3}</td><td>{}</td><td>{}</td></tr>",
            esc(&c.name),
            c.rms_after,
            c.shrink_pct,
            c.ratio_to_none,
            opt(c.p_value),
            opt(c.confidence())
        );
    }
    t.push_str("</table>");
    t
}

/// The residual energy by period band, one row per channel analysed.
fn bands_table(bands: &[Band]) -> String {
    let mut t = String::from(
        "<h3>Frequency bands: share of the residual energy</h3>\
         <table border=\"1\" cellpadding=\"4\" style=\"border-collapse:collapse\">\
         <tr><th>channel</th><th>slow (&gt; 2 h), %</th><th>mid (10 min - 2 h), %</th>\
         <th>fast (&lt; 10 min), %</th><th>mid-band peak, min</th></tr>",
    );
    for b in bands {
        let pct = |x: f64| finite(x).map_or("-".into(), |x| format!("{x:.1}"));
        let peak = b
            .mid_peak_period_s
            .and_then(finite)
            .map_or("-".into(), |s| format!("{:.0}", s / 60.0));
        let _ = write!(
            t,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            esc(&b.channel),
            pct(b.slow_pct),
            pct(b.mid_pct),
            pct(b.fast_pct),
            peak
        );
    }
    t.push_str("</table>");
    t
}
