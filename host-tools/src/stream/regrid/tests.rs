//! The streamed resampling against [`runner::predict`] on the whole run:
//! the same values to the bit (one interpolation rule, the same steps in
//! the same order), the same notes in the same order, the same skipped
//! rows in the same places; and the rows it holds stay few.

use super::*;
use crate::data::runfile::RunFile;
use crate::stream::{stream_run, Layout, PredictedRow};
use std::io::Write;

/// A filter bank with bounds (so bands are streamed too), model step 4 s.
const FBANK: &str = r#"
kind = "fbank"
dt_s = 4.0

[fbank]
inputs = [{ name = "T1" }, { name = "T2", reference = "absolute" }]
features = [{ input = "T1" }, { input = "T1", tau_s = 60.0 }, { input = "T2", power = 2 }]

[[fbank.output]]
output = "dz_um"
intercept = 0.5
coef = [1.0, 2.0, 0.01]

[bounds]
envelope = { T1 = [0.0, 3.0], T2 = [15.0, 30.0] }
half_width = { dz_um = 1.2 }
"#;

fn model() -> ValidModel {
    crate::data::spec::parse("fb.toml", FBANK).unwrap()
}

/// A row as handed on: time, values, bands (or a skipped row's line).
#[derive(Debug, PartialEq)]
enum Seen {
    Row(f64, Vec<Option<f64>>, Vec<Option<f64>>),
    Skipped(u64),
}

#[derive(Default)]
struct Collect(Vec<Seen>);

impl RowSink for Collect {
    fn begin(&mut self, _: &Layout<'_>) -> Result<()> {
        Ok(())
    }
    fn row(&mut self, row: &PredictedRow<'_>) -> Result<()> {
        let r = Seen::Row(row.t_s, row.values.to_vec(), row.bands.to_vec());
        self.0.push(r);
        Ok(())
    }
    fn skipped(&mut self, row: &SkippedRow) -> Result<()> {
        self.0.push(Seen::Skipped(row.line));
        Ok(())
    }
}

fn options() -> ReadOptions {
    ReadOptions {
        skip_bad_rows: true,
        ..ReadOptions::default()
    }
}

/// Streamed, and the whole-run reference, of the same file.
/// Rows handed on and the run's notes.
type Handed = (Vec<Seen>, Vec<String>);

fn both(csv: &str) -> (Handed, Handed) {
    let mut file = tempfile::NamedTempFile::new().unwrap();
    file.write_all(csv.as_bytes()).unwrap();
    let (m, map) = (model(), ColumnMap::default());
    let mut sink = Collect::default();
    let end = stream_run(&m, file.path(), &options(), &map, &mut sink).unwrap();
    let run = RunFile::read(file.path(), &options()).unwrap();
    let p = runner::predict(&m, &run, &map).unwrap();
    let mut whole = Vec::new();
    let mut skipped = run.skipped.iter().peekable();
    for (i, &t) in run.t_s.iter().enumerate() {
        while let Some(s) = skipped.next_if(|s| s.before <= i) {
            whole.push(Seen::Skipped(s.line));
        }
        let at = |c: &Vec<Option<f64>>| c[i];
        whole.push(Seen::Row(
            t,
            p.values.iter().map(at).collect(),
            p.bands.iter().map(at).collect(),
        ));
    }
    whole.extend(skipped.map(|s| Seen::Skipped(s.line)));
    ((sink.0, end.notes), (whole, p.notes))
}

/// `n` rows at times `t(k)`; `T1` empty where `gap(k)`.
fn csv(n: usize, t: impl Fn(usize) -> f64, gap: impl Fn(usize) -> bool) -> String {
    let mut s = String::from("t_s,T1,T2,dz_um\n");
    for k in 0..n {
        let tk = t(k);
        let t1 = if gap(k) {
            String::new()
        } else {
            format!(
                "{:.4}",
                20.0 + 2.0 * (1.0 - (-tk / 300.0).exp()) + 0.1 * (tk / 37.0).sin()
            )
        };
        s += &format!("{tk},{t1},{:.3},0\n", 22.0 + 0.01 * tk);
    }
    s
}

fn assert_same(csv: &str, notes_expected: usize) {
    let ((rows, notes), (want_rows, want_notes)) = both(csv);
    assert_eq!(notes, want_notes);
    assert_eq!(notes.len(), notes_expected, "{notes:?}");
    assert_eq!(rows.len(), want_rows.len());
    for (got, want) in rows.iter().zip(&want_rows) {
        assert_eq!(got, want);
    }
}

#[test]
fn finer_rows_than_the_model_step() {
    // 1 s rows, 4 s model: resampled (one note), 201 rows end on a step.
    assert_same(&csv(201, |k| k as f64, |_| false), 1);
}

#[test]
fn coarser_irregular_rows_with_a_tail_after_the_last_step() {
    // Steps of 5..7 s: irregular, and the last row lies after the last
    // whole 4 s step (the extra-step note).
    let t = |k: usize| (k * 6) as f64 + [0.0, 1.0, -1.0][k % 3];
    assert_same(&csv(120, t, |_| false), 2);
}

#[test]
fn own_grid_with_missing_cells_bridged_at_start_middle_and_end() {
    // 4 s rows on the model's grid: only the bridging note, and the
    // stepper's (no value before the first T1).
    let gap = |k: usize| k < 2 || (40..55).contains(&k) || k == 99;
    assert_same(&csv(100, |k| 4.0 * k as f64, gap), 2);
    // Only the 15 cells between two values are bridged: the 2 before the
    // first and the 1 after the last have no prediction (it said 18).
    let ((_, notes), _) = both(&csv(100, |k| 4.0 * k as f64, gap));
    assert!(
        notes[0].starts_with("15 missing input cells bridged"),
        "{notes:?}"
    );
}

#[test]
fn resampled_with_missing_cells_and_skipped_rows_in_place() {
    let mut text = csv(150, |k| 3.0 * k as f64, |k| (70..73).contains(&k));
    // Two bad rows (a letter in a number) among the good ones.
    text = text
        .replacen("\n60,", "\n60,x", 1)
        .replacen("\n300,", "\n300,y", 1);
    let ((rows, _), _) = both(&text);
    assert_eq!(
        rows.iter()
            .filter(|r| matches!(r, Seen::Skipped(_)))
            .count(),
        2
    );
    assert_same(&text, 3);
}

/// Drives the resampling over a long run, counting the rows it holds.
fn most_held(rows: usize, row_dt: f64, model_dt: f64) -> usize {
    let m =
        crate::data::spec::parse("fb.toml", &FBANK.replace("4.0", &format!("{model_dt}"))).unwrap();
    let span = Some((0.0, (rows - 1) as f64 * row_dt));
    let times: Vec<f64> = (0..rows).map(|k| k as f64 * row_dt).collect();
    let sampling = crate::data::runfile::Sampling::of(&times);
    let mut regrid = Regrid::new(&m, Some(ModelGrid::new(span, model_dt, &sampling).unwrap()));
    let mut out = RowOut::new(&m, None);
    let mut sink = Collect::default();
    let mut most = 0;
    for k in 0..rows {
        let t = k as f64 * row_dt;
        regrid.push_row(t, &[Some(20.0 + t * 1e-3), Some(21.0)], &[0, 1]);
        regrid.advance(&mut out, &mut sink).unwrap();
        most = most.max(regrid.queue.len());
    }
    regrid.finish(&mut out, &mut sink).unwrap();
    assert_eq!(sink.0.len(), rows, "every row handed on");
    most
}

#[test]
fn the_rows_held_do_not_grow_with_the_run() {
    // A row waits for the grid point after it, which waits for the input
    // sample after that point: at most model_dt / row_dt + 2 rows held.
    assert!(most_held(20_000, 1.0, 30.0) <= 32);
    assert!(most_held(2_000, 1.0, 30.0) <= 32);
    // Rows coarser than the model's step: the point after a row needs the
    // next row, so at most two rows.
    assert!(most_held(5_000, 45.0, 30.0) <= 2);
}
