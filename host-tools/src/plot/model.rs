//! `fit --report DIR`, `eval --report DIR`, `refit --report DIR` and the
//! demo's fit page: one page that shows a model on its runs, so that a fit
//! is judged by eye as well as by its figures.
//!
//! Per run and output: the measured column beside the prediction and its
//! 95 % band (`predict --interval`'s, where the model carries bounds), and
//! the residual inside the band's half-width around zero, with the
//! hold-out start marked and the band's coverage counted. For `auto` fits,
//! each target's cross-validation table as bars (the error every candidate
//! left, the chosen ones marked) and how its band was calibrated.

use super::{band_chart, bar_chart, esc, line_chart, page, TimeAxis};
use crate::data::runfile::RunFile;
use crate::fit::auto::AutoReport;
use crate::num::stats::coverage_pct;
use crate::runner::{self, ColumnMap};
use anyhow::Result;
use model_core::ValidModel;
use std::fmt::Write as _;

/// Chart height, px.
const H: f64 = 260.0;

/// Candidates shown per target in an `auto` fit's CV chart.
const CV_ROWS: usize = 15;

/// One run on the page and how it was used.
pub struct PageRun<'a> {
    /// The run.
    pub run: &'a RunFile,
    /// Rows at or after this time were held out (`None`: none).
    pub holdout_from_s: Option<f64>,
    /// How the run was used ("calibration", "validation, held out whole", ...).
    pub role: &'a str,
}

/// What the page says beyond the runs.
pub struct PageText<'a> {
    /// The page title (the command).
    pub title: &'a str,
    /// An `auto` fit's report (its CV tables and bands).
    pub auto: Option<&'a AutoReport>,
    /// The command's text figures (its table without `--json`), shown
    /// under the heading as they print; empty: none.
    pub summary: &'a str,
}

/// The page of `model` on `runs` (columns read through `map`).
pub fn page_html(
    model: &ValidModel,
    runs: &[PageRun],
    map: &ColumnMap,
    text: &PageText,
    json: &serde_json::Value,
) -> Result<String> {
    let mut body = String::new();
    let _ = write!(
        body,
        "<h1>{}</h1><p>{} model, outputs {}, inputs {}; {}.</p>",
        esc(text.title),
        model.kind().name(),
        esc(&names(model.outputs().iter().map(|o| o.as_str()))),
        esc(&names(model.inputs().iter().map(|c| c.name.as_str()))),
        if model.bounds().is_some() {
            "the grey band is the model's 95 % band (widened where the inputs leave the calibration envelope)"
        } else {
            "the model carries no band"
        }
    );
    if !text.summary.is_empty() {
        let _ = write!(body, "<pre>{}</pre>", esc(text.summary));
    }
    if let Some(auto) = text.auto {
        body.push_str(&cv_html(auto));
    }
    for r in runs {
        body.push_str(&run_html(model, r, map)?);
    }
    // At the end, pretty-printed: the command's `--json` object (the demo:
    // the fit's report).
    Ok(page(
        text.title,
        &body,
        &serde_json::to_string_pretty(json)?,
    ))
}

fn names<'a>(v: impl Iterator<Item = &'a str>) -> String {
    v.collect::<Vec<_>>().join(", ")
}

/// Each target's CV table as bars, best first, and its band's calibration.
fn cv_html(auto: &AutoReport) -> String {
    let mut html = String::from("<h2>Cross-validation (calibration rows only)</h2>");
    if !auto.quiet_inputs.is_empty() {
        let sentence = crate::fit::quiet::left_out(&auto.quiet_inputs);
        let _ = write!(html, "<p>{}.</p>", esc(&sentence));
    }
    for sentence in auto.sight.sentences() {
        let _ = write!(html, "<p>{}.</p>", esc(&sentence));
    }
    for t in &auto.targets {
        // The best CV_ROWS, and every member of the model below them (the
        // members are the best candidates of the winner's form that fit the
        // hub together, or with several runs the simplest within one
        // standard error of the best, so one can rank lower).
        let bars: Vec<(String, f64)> = t
            .cv_table
            .iter()
            .filter(|row| row.cv_geo_rmse.is_finite())
            .enumerate()
            .filter(|(rank, row)| *rank < CV_ROWS || row.chosen)
            .map(|(_, row)| {
                let chosen = if row.chosen { " *" } else { "" };
                (format!("{}{chosen}", row.label()), row.cv_geo_rmse)
            })
            .collect();
        html.push_str(&bar_chart(
            &format!(
                "{}: CV error of the best {} candidates and the model's members \
                 (geometric-mean rmse; * in the model)",
                t.target, CV_ROWS
            ),
            &bars,
            "um",
        ));
        let b = &t.band;
        let _ = write!(
            html,
            "<p>{}: 95 % band +-{:.3} um inside the calibration envelope, widening {} per envelope \
             width outside it ({}); it covers {:.1} % of the CV residuals.</p>",
            esc(&t.target),
            b.half_width,
            b.growth,
            if b.growth_measured() {
                "measured on the CV folds that left the others' envelope"
            } else {
                "not measured: no CV fold left the others' envelope, so outside it the band is a guess"
            },
            b.cv_coverage_pct
        );
    }
    html
}

/// The charts of one run: per output, measured and predicted with the
/// band, and the residual with the band's half-width.
fn run_html(model: &ValidModel, r: &PageRun, map: &ColumnMap) -> Result<String> {
    let run = r.run;
    let p = runner::predict(model, run, map)?;
    let axis = TimeAxis::new(&run.t_s, r.holdout_from_s);
    let mut html = format!(
        "<h2>{} ({})</h2>",
        esc(&run.path.display().to_string()),
        esc(r.role)
    );
    for (k, name) in model.outputs().iter().enumerate() {
        let col = map.column(name.as_str());
        match Series::of(run, &p, k, col) {
            Some(s) => html.push_str(&output_html(name.as_str(), &s, &axis, &run.t_s)),
            None => {
                let _ = write!(
                    html,
                    "<p>{}: no measured column {}.</p>",
                    esc(name.as_str()),
                    esc(col)
                );
            }
        }
    }
    Ok(html)
}

/// One output on one run, row for row (`NaN` where there is no value).
struct Series {
    y: Vec<f64>,
    yhat: Vec<f64>,
    resid: Vec<f64>,
    /// The band's half-width (`None`: the model has no band).
    half: Option<Vec<f64>>,
}

impl Series {
    /// Output `k` of prediction `p` beside the run's column `col` (`None`
    /// without that column).
    fn of(run: &RunFile, p: &runner::Prediction, k: usize, col: &str) -> Option<Self> {
        let nan = |v: &Option<f64>| v.unwrap_or(f64::NAN);
        let y: Vec<f64> = run.column(col)?.iter().map(|v| nan(&v)).collect();
        let yhat: Vec<f64> = p.values.get(k)?.iter().map(nan).collect();
        let resid = y.iter().zip(&yhat).map(|(a, b)| a - b).collect();
        let half = p.bands.get(k).map(|b| b.iter().map(nan).collect());
        Some(Self {
            y,
            yhat,
            resid,
            half,
        })
    }
}

/// An output's two charts (measured and predicted over the band; the
/// residual inside the band's half-width) and the band's coverage.
fn output_html(name: &str, s: &Series, axis: &TimeAxis, t_s: &[f64]) -> String {
    let (t_h, hold_h) = (&axis.t_h, axis.hold_h());
    let title = format!("{name}: measured and predicted, um");
    let series = [("measured", &s.y[..]), ("predicted", &s.yhat[..])];
    let Some(half) = &s.half else {
        let title2 = format!("{name}: residual (measured - predicted), um");
        return line_chart(&title, t_h, &series, hold_h, H)
            + &line_chart(&title2, t_h, &[("residual", &s.resid[..])], hold_h, H);
    };
    let lo: Vec<f64> = s.yhat.iter().zip(half).map(|(p, h)| p - h).collect();
    let hi: Vec<f64> = s.yhat.iter().zip(half).map(|(p, h)| p + h).collect();
    let neg: Vec<f64> = half.iter().map(|h| -h).collect();
    let mut html = band_chart(&title, t_h, &series, Some((&lo, &hi)), hold_h, H);
    let title = format!("{name}: residual (measured - predicted) inside the band, um");
    let series = [("residual", &s.resid[..])];
    html.push_str(&band_chart(
        &title,
        t_h,
        &series,
        Some((&neg, half)),
        hold_h,
        H,
    ));
    html.push_str(&coverage_html(name, t_s, &s.resid, half, axis.hold_s));
    html
}

/// The band's coverage of the residuals on the run, and on its held-out
/// rows when it has some.
fn coverage_html(
    name: &str,
    t_s: &[f64],
    resid: &[f64],
    half: &[f64],
    hold: Option<f64>,
) -> String {
    let cover = |from: f64| {
        coverage_pct(
            t_s.iter()
                .zip(resid.iter().zip(half))
                .filter(|(t, _)| **t >= from)
                .map(|(_, (r, h))| (*r, *h)),
        )
    };
    let mut s = format!("<p>{}: ", esc(name));
    match cover(f64::NEG_INFINITY) {
        Some((c, n)) => {
            let _ = write!(
                s,
                "the band covers {c:.1} % of the {n} rows with both values"
            );
        }
        None => s.push_str("no row has both a measured value and a band"),
    }
    if let Some((c, n)) = hold.and_then(cover) {
        let _ = write!(s, "; {c:.1} % of the {n} held-out rows");
    }
    s.push_str(".</p>");
    s
}
