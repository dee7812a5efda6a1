//! `--report DIR`: `DIR/index.html`, one self-contained page with inline SVG
//! plots (drawn here: text in SVG needs no font files, so the report needs
//! no system libraries) and the JSON.

use super::align::Aligned;
use super::candidates::Scored;
use super::outcome::{finite, json_number, Band, Deployment, Diagnosis, Segment, Trained};
use anyhow::{Context, Result};
use std::fmt::Write as _;
use std::path::Path;

const W: f64 = 1100.0;
const COLORS: [&str; 4] = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd"];

pub(super) fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Margins of a line chart's plot area, px: left, right, top, bottom.
const MARGINS: (f64, f64, f64, f64) = (70.0, 20.0, 28.0, 32.0);

/// A line chart's plot area and data ranges, and the maps from data to
/// pixels.
#[derive(Debug, Clone, Copy)]
struct Frame {
    /// Chart height, px.
    h: f64,
    /// Data range on x (hours).
    x0: f64,
    x1: f64,
    /// Data range on y (padded by 5 % on each side).
    y0: f64,
    y1: f64,
}

impl Frame {
    /// The frame of `series` over `t_h`, `h` px high.
    fn new(t_h: &[f64], series: &[(&str, &[f64])], h: f64) -> Self {
        let x0 = t_h.first().copied().unwrap_or(0.0);
        let x1 = t_h.last().copied().unwrap_or(1.0).max(1e-9);
        let (mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY);
        for &v in series.iter().flat_map(|(_, s)| s.iter()) {
            y0 = y0.min(v);
            y1 = y1.max(v);
        }
        if y1.partial_cmp(&y0) != Some(std::cmp::Ordering::Greater) {
            y0 -= 1.0;
            y1 += 1.0;
        }
        let pad = 0.05 * (y1 - y0);
        Frame {
            h,
            x0,
            x1,
            y0: y0 - pad,
            y1: y1 + pad,
        }
    }

    /// Pixel column of time `x`.
    fn px(&self, x: f64) -> f64 {
        let (l, r, _, _) = MARGINS;
        l + (x - self.x0) / (self.x1 - self.x0).max(1e-12) * (W - l - r)
    }

    /// Pixel row of value `y` (top of the plot area = `y1`).
    fn py(&self, y: f64) -> f64 {
        let (_, _, top, bot) = MARGINS;
        top + (self.y1 - y) / (self.y1 - self.y0) * (self.h - top - bot)
    }

    /// Five evenly spaced tick values from `y0` to `y1`.
    fn y_ticks(&self) -> [f64; 5] {
        std::array::from_fn(|k| self.y0 + (self.y1 - self.y0) * k as f64 / 4.0)
    }
}

/// The frame, title, y grid with labels, x labels and the optional
/// vertical line of a line chart.
fn chart_axes(title: &str, f: &Frame, vline_h: Option<f64>) -> String {
    let (l, r, top, bot) = MARGINS;
    let h = f.h;
    let mut s = format!(
        r##"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{h}" font-family="sans-serif" font-size="12">"##
    );
    let _ = write!(
        s,
        r##"<rect x="{l}" y="{top}" width="{}" height="{}" fill="none" stroke="#888"/>"##,
        W - l - r,
        h - top - bot
    );
    let _ = write!(
        s,
        r##"<text x="{l}" y="18" font-size="14" font-weight="bold">{}</text>"##,
        esc(title)
    );
    for (k, y) in f.y_ticks().into_iter().enumerate() {
        let (ypx, xr) = (f.py(y), W - r);
        let _ = write!(
            s,
            r##"<text x="{}" y="{}" text-anchor="end">{y:.2}</text><line x1="{l}" x2="{xr}" y1="{ypx}" y2="{ypx}" stroke="#eee"/>"##,
            l - 4.0,
            ypx + 4.0,
        );
        let x = f.x0 + (f.x1 - f.x0) * k as f64 / 4.0;
        let _ = write!(
            s,
            r##"<text x="{}" y="{}" text-anchor="middle">{x:.1} h</text>"##,
            f.px(x),
            h - bot + 16.0,
        );
    }
    if let Some(v) = vline_h {
        let _ = write!(
            s,
            r##"<line x1="{0}" x2="{0}" y1="{top}" y2="{1}" stroke="#555" stroke-dasharray="5,4"/><text x="{2}" y="{3}">hold-out</text>"##,
            f.px(v),
            h - bot,
            f.px(v) + 4.0,
            top + 14.0
        );
    }
    s
}

/// A time-series chart: x in hours, several series, optional vertical
/// line (the hold-out start).
pub(super) fn line_chart(
    title: &str,
    t_h: &[f64],
    series: &[(&str, &[f64])],
    vline_h: Option<f64>,
    h: f64,
) -> String {
    let f = Frame::new(t_h, series, h);
    let mut s = chart_axes(title, &f, vline_h);
    let stride = (t_h.len() / 1500).max(1);
    for (i, (name, ys)) in series.iter().enumerate() {
        let c = COLORS[i % COLORS.len()];
        let pts: String = (0..t_h.len().min(ys.len()))
            .step_by(stride)
            .map(|k| format!("{:.1},{:.1} ", f.px(t_h[k]), f.py(ys[k])))
            .collect();
        let _ = write!(
            s,
            r##"<polyline fill="none" stroke="{c}" stroke-width="1.2" points="{pts}"/>"##
        );
        let _ = write!(
            s,
            r##"<text x="{}" y="18" fill="{c}">{}</text>"##,
            W - MARGINS.1 - 130.0 * (series.len() - i) as f64,
            esc(name)
        );
    }
    s.push_str("</svg>");
    s
}

/// Horizontal bars (label, value in %), values may be negative.
fn bar_chart(title: &str, items: &[(String, f64)]) -> String {
    let row = 22.0;
    let h = 40.0 + row * items.len() as f64;
    let (l, r) = (260.0, 80.0);
    let lo = items.iter().fold(0.0f64, |a, i| a.min(i.1));
    let hi = items.iter().fold(0.0f64, |a, i| a.max(i.1)).max(1.0);
    let px = |v: f64| l + (v - lo) / (hi - lo) * (W - l - r);
    let mut s = format!(
        r##"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{h}" font-family="sans-serif" font-size="12">"##
    );
    let _ = write!(
        s,
        r##"<text x="10" y="18" font-size="14" font-weight="bold">{}</text>"##,
        esc(title)
    );
    for (i, (label, v)) in items.iter().enumerate() {
        let y = 30.0 + row * i as f64;
        let (a, b) = (px(0.0).min(px(*v)), px(0.0).max(px(*v)));
        let c = if *v >= 0.0 { COLORS[0] } else { COLORS[1] };
        let _ = write!(
            s,
            r##"<text x="{}" y="{}" text-anchor="end">{}</text><rect x="{a}" y="{y}" width="{}" height="{}" fill="{c}"/><text x="{}" y="{}">{v:.1} %</text>"##,
            l - 6.0,
            y + 14.0,
            esc(label),
            (b - a).max(0.5),
            row - 6.0,
            b + 4.0,
            y + 14.0
        );
    }
    s.push_str("</svg>");
    s
}

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

/// The time axis of the plots: hours from the first row, and the hold-out
/// start in hours.
struct Axis {
    t_h: Vec<f64>,
    hold_h: Option<f64>,
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
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let t0 = al.t_s[0];
    let t_h: Vec<f64> = al.t_s.iter().map(|t| (t - t0) / 3600.0).collect();
    let ax = Axis {
        hold_h: t_h.get(n_fit).copied(),
        t_h,
    };
    let mut html = String::from("<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>thermcomp diagnose</title><style>body{font-family:sans-serif;margin:20px;max-width:1150px}pre{background:#f6f6f6;padding:8px;font-size:11px;white-space:pre-wrap}</style></head><body>");
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
    let _ = write!(
        html,
        "<h2>JSON</h2><pre>{}</pre></body></html>",
        esc(&pretty)
    );
    let path = dir.join("index.html");
    crate::data::fsio::write_bytes_atomic(&path, html.as_bytes())?;
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
    ax: &Axis,
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
            ax.hold_h,
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
    ));
    html.push_str(&bands_table(bands));
    html
}

/// Sim vs real per displacement, and the residual of every displacement
/// and temperature channel.
fn channels_html(al: &Aligned, ax: &Axis) -> String {
    let mut html = String::from("<h2>Sim vs real</h2>");
    for c in al.channels.each().filter(|c| c.is_displacement()) {
        html.push_str(&line_chart(
            &format!("{} (um)", c.name),
            &ax.t_h,
            &[("sim", &c.sim), ("real", &c.real())],
            ax.hold_h,
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
            ax.hold_h,
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The value of attribute `name` in an SVG element's text.
    fn attr(el: &str, name: &str) -> f64 {
        let key = format!(" {name}=\"");
        let from = el.find(&key).map(|i| i + key.len()).expect("attribute");
        let to = el[from..].find('"').expect("closing quote") + from;
        el[from..to].parse().expect("number")
    }

    #[test]
    fn grid_lines_sit_in_the_plot_area_at_their_tick_values() {
        // Data in the thousands: the old code drew the lines at y = the
        // data values (e.g. 1000 px), far below a 200 px chart.
        let t: Vec<f64> = (0..50).map(|k| k as f64 * 0.5).collect();
        let y: Vec<f64> = (0..50).map(|k| 1000.0 + 40.0 * k as f64).collect();
        let h = 200.0;
        let svg = line_chart("t", &t, &[("y", &y)], None, h);
        let (_, _, top, bot) = MARGINS;
        let lines: Vec<&str> = svg
            .split("<line ")
            .skip(1)
            .filter(|e| e.contains("#eee"))
            .collect();
        let labels: Vec<f64> = svg
            .split("<text ")
            .skip(1)
            .filter(|e| e.contains("text-anchor=\"end\""))
            .map(|e| {
                let v = &e[e.find('>').expect(">") + 1..e.find('<').expect("<")];
                v.parse::<f64>().expect("tick value")
            })
            .collect();
        assert_eq!(lines.len(), 5);
        assert_eq!(labels.len(), 5);
        // Span of the data with the 5 % pad: 1000 - 98 .. 2960 + 98.
        let (lo, hi) = (1000.0 - 0.05 * 1960.0, 2960.0 + 0.05 * 1960.0);
        for (el, v) in lines.iter().zip(&labels) {
            let (y1, y2) = (attr(el, "y1"), attr(el, "y2"));
            assert_eq!(y1, y2, "horizontal");
            assert!(
                (top - 1e-9..=h - bot + 1e-9).contains(&y1),
                "{y1} px outside"
            );
            // The label's value maps to the line's pixel row (labels are
            // rounded to 0.01, 1e-5 of the span: far below 0.01 px).
            let want = top + (hi - v) / (hi - lo) * (h - top - bot);
            assert!((y1 - want).abs() < 0.01, "{v}: line at {y1}, want {want}");
        }
        // The lowest tick is the bottom edge, the highest the top edge.
        let ys: Vec<f64> = lines.iter().map(|e| attr(e, "y1")).collect();
        assert!(
            (ys[0] - (h - bot)).abs() < 1e-9 && (ys[4] - top).abs() < 1e-9,
            "{ys:?}"
        );
    }
}
