//! Charts for the HTML reports (`diagnose --report`, `fit --report`,
//! `eval --report`): inline SVG drawn here (text in SVG needs no font
//! files, so a report needs no system libraries), and the page around them.

pub mod model;

use anyhow::{Context, Result};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

const W: f64 = 1100.0;
const COLORS: [&str; 4] = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd"];

/// `s` with `&`, `<` and `>` escaped for HTML text.
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// A run's time axis on the charts: hours from its first row, and where
/// its held-out rows start.
pub struct TimeAxis {
    /// Hours from the first row, one per row.
    pub t_h: Vec<f64>,
    /// Rows at or after this time (s) are held out; `None` when nothing
    /// is, or when the time lies outside the run (everything or nothing
    /// held out: no line to draw).
    pub hold_s: Option<f64>,
    t0: f64,
}

impl TimeAxis {
    /// The axis of rows at times `t_s`, rows from `hold_from_s` held out.
    pub fn new(t_s: &[f64], hold_from_s: Option<f64>) -> Self {
        let t0 = t_s.first().copied().unwrap_or(0.0);
        let inside = |h: f64| h > t0 && t_s.last().is_some_and(|&l| h <= l);
        Self {
            t_h: t_s.iter().map(|t| (t - t0) / 3600.0).collect(),
            hold_s: hold_from_s.filter(|&h| inside(h)),
            t0,
        }
    }

    /// The hold-out start in hours from the first row (the charts' line).
    pub fn hold_h(&self) -> Option<f64> {
        self.hold_s.map(|h| (h - self.t0) / 3600.0)
    }
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
            if v.is_finite() {
                y0 = y0.min(v);
                y1 = y1.max(v);
            }
        }
        if !(y0.is_finite() && y1.is_finite()) {
            (y0, y1) = (0.0, 0.0);
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
/// line (the hold-out start). A non-finite value leaves a gap.
pub fn line_chart(
    title: &str,
    t_h: &[f64],
    series: &[(&str, &[f64])],
    vline_h: Option<f64>,
    h: f64,
) -> String {
    band_chart(title, t_h, series, None, vline_h, h)
}

/// [`line_chart`] over a shaded band `(lo, hi)` (drawn first, grey; where
/// either edge is not finite the band has a gap).
pub fn band_chart(
    title: &str,
    t_h: &[f64],
    series: &[(&str, &[f64])],
    band: Option<(&[f64], &[f64])>,
    vline_h: Option<f64>,
    h: f64,
) -> String {
    let mut ranged: Vec<(&str, &[f64])> = series.to_vec();
    if let Some((lo, hi)) = band {
        ranged.extend([("", lo), ("", hi)]);
    }
    let f = Frame::new(t_h, &ranged, h);
    // At most MAX_POINTS points a line.
    let stride = t_h.len().div_ceil(MAX_POINTS).max(1);
    let mut s = chart_axes(title, &f, vline_h);
    if let Some(band) = band {
        s.push_str(&band_polygons(&f, t_h, band, stride));
    }
    for (i, (name, ys)) in series.iter().enumerate() {
        let c = COLORS[i % COLORS.len()];
        s.push_str(&polylines(&f, t_h, ys, stride, c));
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

/// Most points drawn per line (a longer series is thinned evenly).
const MAX_POINTS: usize = 1500;

/// The band `(lo, hi)` as grey polygons, one per stretch where both edges
/// are finite.
fn band_polygons(f: &Frame, t_h: &[f64], (lo, hi): (&[f64], &[f64]), stride: usize) -> String {
    let n = t_h.len().min(lo.len()).min(hi.len());
    let point = |k: usize, v: f64| format!("{:.1},{:.1} ", f.px(t_h[k]), f.py(v));
    finite_runs(n, stride, |k| lo[k].is_finite() && hi[k].is_finite())
        .iter()
        .map(|run| {
            let upper = run.iter().map(|&k| point(k, hi[k]));
            let lower = run.iter().rev().map(|&k| point(k, lo[k]));
            let pts: String = upper.chain(lower).collect();
            format!(r##"<polygon fill="#ddd" stroke="none" points="{pts}"/>"##)
        })
        .collect()
}

/// Series `ys` as polylines of colour `c`, one per stretch of finite values.
fn polylines(f: &Frame, t_h: &[f64], ys: &[f64], stride: usize, c: &str) -> String {
    let n = t_h.len().min(ys.len());
    finite_runs(n, stride, |k| ys[k].is_finite())
        .iter()
        .map(|run| {
            let pts: String = run
                .iter()
                .map(|&k| format!("{:.1},{:.1} ", f.px(t_h[k]), f.py(ys[k])))
                .collect();
            format!(r##"<polyline fill="none" stroke="{c}" stroke-width="1.2" points="{pts}"/>"##)
        })
        .collect()
}

/// The samples `0, stride, 2 stride, ... < n` where `ok`, in runs of
/// consecutive kept samples (a sample that is not `ok` ends a run).
fn finite_runs(n: usize, stride: usize, ok: impl Fn(usize) -> bool) -> Vec<Vec<usize>> {
    let mut runs = vec![Vec::new()];
    for k in (0..n).step_by(stride) {
        if ok(k) {
            runs.last_mut().expect("never empty").push(k);
        } else if runs.last().is_some_and(|r| !r.is_empty()) {
            runs.push(Vec::new());
        }
    }
    runs.retain(|r| !r.is_empty());
    runs
}

/// Horizontal bars (label, value in `unit`), values may be negative.
pub fn bar_chart(title: &str, items: &[(String, f64)], unit: &str) -> String {
    let row = 22.0;
    let h = 40.0 + row * items.len() as f64;
    // The label column: 260 px, wider for long labels (about 7 px a character).
    let longest = items.iter().map(|i| i.0.chars().count()).max().unwrap_or(0);
    let (l, r) = ((7.0 * longest as f64).clamp(260.0, 600.0), 80.0);
    let lo = items.iter().fold(0.0f64, |a, i| a.min(i.1));
    let hi = items.iter().fold(0.0f64, |a, i| a.max(i.1));
    let hi = if hi > lo { hi } else { lo + 1.0 };
    let px = |v: f64| l + (v - lo) / (hi - lo) * (W - l - r);
    // Three significant figures for the largest bar.
    let decimals = match lo.abs().max(hi.abs()) {
        m if m < 1.0 => 3,
        m if m < 10.0 => 2,
        _ => 1,
    };
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
            r##"<text x="{}" y="{}" text-anchor="end">{}</text><rect x="{a}" y="{y}" width="{}" height="{}" fill="{c}"/><text x="{}" y="{}">{v:.decimals$} {unit}</text>"##,
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

/// Writes `html` to `dir/index.html` (creating `dir`, the file replaced
/// atomically); returns the page's path.
pub fn write_page(dir: &Path, html: &str) -> Result<PathBuf> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let path = dir.join("index.html");
    crate::data::fsio::write_bytes_atomic(&path, html.as_bytes())?;
    Ok(path)
}

/// A whole HTML page: `body` (HTML) and, at its end, `json` shown as text.
pub fn page(title: &str, body: &str, json: &str) -> String {
    format!(
        "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>{}</title><style>body{{font-family:sans-serif;margin:20px;max-width:1150px}}pre{{background:#f6f6f6;padding:8px;font-size:11px;white-space:pre-wrap}}table{{border-collapse:collapse;font-size:12px}}td,th{{border:1px solid #ccc;padding:2px 6px;text-align:right}}</style></head><body>{body}<h2>JSON</h2><pre>{}</pre></body></html>",
        esc(title),
        esc(json)
    )
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
    fn the_hold_out_line_is_drawn_only_inside_the_run() {
        // A run from t = 1000 s to 8200 s: hours count from its first row.
        let t_s = [1000.0, 4600.0, 8200.0];
        let ax = TimeAxis::new(&t_s, Some(4600.0));
        assert_eq!(ax.t_h, [0.0, 1.0, 2.0]);
        assert_eq!(ax.hold_h(), Some(1.0));
        // Held out from the last row: still a line (one row held out).
        assert_eq!(TimeAxis::new(&t_s, Some(8200.0)).hold_h(), Some(2.0));
        // At or before the first row (everything held out) or after the
        // last (nothing): no line.
        for h in [1000.0, 500.0, 8200.5] {
            assert_eq!(TimeAxis::new(&t_s, Some(h)).hold_s, None, "{h}");
        }
        assert_eq!(TimeAxis::new(&[], Some(1.0)).hold_s, None);
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

    #[test]
    fn a_missing_value_leaves_a_gap_in_the_line_and_the_band() {
        let t = [0.0, 1.0, 2.0, 3.0, 4.0];
        let y = [1.0, 2.0, f64::NAN, 4.0, 5.0];
        let svg = line_chart("y", &t, &[("y", &y)], None, 200.0);
        assert_eq!(svg.matches("<polyline").count(), 2, "{svg}");
        let (lo, hi) = ([0.0, 0.0, 0.0, f64::NAN, 0.0], [2.0; 5]);
        let svg = band_chart("y", &t, &[("y", &y)], Some((&lo, &hi)), None, 200.0);
        assert_eq!(svg.matches("<polygon").count(), 2, "{svg}");
        assert!(!svg.contains("NaN"), "{svg}");
        // Runs of kept samples, at the stride.
        assert_eq!(finite_runs(7, 2, |k| k != 2), vec![vec![0], vec![4, 6]]);
    }

    #[test]
    fn a_chart_with_no_finite_value_still_has_finite_axes() {
        let t = [0.0, 1.0];
        let svg = line_chart("empty", &t, &[("y", &[f64::NAN, f64::NAN])], None, 200.0);
        assert!(!svg.contains("NaN") && !svg.contains("inf"), "{svg}");
        assert_eq!(svg.matches("<polyline").count(), 0);
    }
}
