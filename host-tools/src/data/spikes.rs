//! Isolated readings in a run's temperature columns: one row that jumps
//! away from both neighbours by more than a temperature can move (the
//! hub's spike limit, `firmware::spike::SpikeConfig::DEFAULT`: 0.5 K/s plus
//! 0.5 K of noise, over the rows' own time steps) while the neighbours
//! agree. A broken reading (a loose wire, a converter glitch) looks like
//! this; `fit` and `diagnose` take it as a figure, so they say where it is.
//! A spike two rows long is not found (its rows agree with each other);
//! the hub's filter refuses those too (`persist_samples = 3`).

use crate::data::runfile::{printable, Quantity, RunFile};
use firmware::spike::SpikeConfig;

/// One column's isolated readings in one run.
#[derive(Clone, Debug, PartialEq)]
pub struct Isolated {
    /// The column.
    pub column: String,
    /// How many rows.
    pub count: usize,
    /// The first one's time, s.
    pub first_t_s: f64,
    /// The first one's value.
    pub first_value: f64,
}

impl Isolated {
    /// The note for `run`'s file; `taker` ("the fit", "the diagnosis")
    /// takes the readings as they are.
    fn note(&self, run: &RunFile, taker: &str) -> String {
        format!(
            "{}: {}: {} reading(s) jump away from both neighbours faster than a temperature \
             moves (the first {} at t_s = {}): broken readings? {taker} takes them as they \
             are; clear such a cell to leave it out",
            printable(&run.path.display().to_string()),
            printable(&self.column),
            self.count,
            self.first_value,
            self.first_t_s
        )
    }
}

/// The notes on every run of `runs` (`taker` as in [`Isolated::note`]).
pub fn notes(runs: &[RunFile], columns: &[String], taker: &str) -> Vec<String> {
    runs.iter()
        .flat_map(|run| {
            isolated(run, columns)
                .into_iter()
                .map(move |i| i.note(run, taker))
        })
        .collect()
}

/// The isolated readings of `run`'s temperature columns among `columns`.
fn isolated(run: &RunFile, columns: &[String]) -> Vec<Isolated> {
    columns
        .iter()
        .filter(|c| Quantity::of(c) == Some(Quantity::Temperature))
        .filter_map(|c| isolated_in(run, c))
        .collect()
}

/// Row `k` of `v` (times `t`) is isolated when both neighbours are
/// present, agree with each other within the limit over their span, and
/// each differs from it by more than the limit over its own step.
fn isolated_in(run: &RunFile, column: &str) -> Option<Isolated> {
    let cells = run.column(column)?;
    let (t, cfg) = (&run.t_s, SpikeConfig::DEFAULT);
    let mut found: Option<Isolated> = None;
    for k in 1..t.len().saturating_sub(1) {
        let (Some(a), Some(x), Some(b)) = (cells.get(k - 1), cells.get(k), cells.get(k + 1)) else {
            continue;
        };
        let apart = |u: f64, v: f64, dt: f64| (u - v).abs() > cfg.limit_k(dt);
        let jump = apart(x, a, t[k] - t[k - 1]) && apart(x, b, t[k + 1] - t[k]);
        if jump && !apart(a, b, t[k + 1] - t[k - 1]) {
            let f = found.get_or_insert(Isolated {
                column: column.to_string(),
                count: 0,
                first_t_s: t[k],
                first_value: x,
            });
            f.count += 1;
        }
    }
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(t1: &[f64]) -> RunFile {
        let t_s = (0..t1.len()).map(|k| 10.0 * k as f64).collect();
        RunFile::from_columns("run.csv", t_s, vec![("T1".into(), Some(t1.to_vec()))])
            .unwrap_or_else(|e| panic!("{e}"))
    }

    /// A 900 C reading among 20 C ones is isolated; a step that stays, a
    /// fast but physical rise (0.3 K/s over 10 s rows: 3 K < 5.5 K) and a
    /// missing neighbour are not.
    #[test]
    fn a_one_row_jump_is_found_and_steps_and_ramps_are_not() {
        let cols = ["T1".to_string()];
        let got = isolated(&run(&[20.0, 20.1, 900.0, 20.2, 20.2]), &cols);
        assert_eq!(got.len(), 1);
        assert_eq!(
            (got[0].count, got[0].first_t_s, got[0].first_value),
            (1, 20.0, 900.0)
        );
        let note = got[0].note(&run(&[20.0]), "The fit");
        assert!(note.contains("T1: 1 reading(s) jump") && note.contains("The fit takes"));
        assert!(isolated(&run(&[20.0, 20.0, 40.0, 40.0, 40.0]), &cols).is_empty());
        assert!(isolated(&run(&[20.0, 23.0, 26.0, 29.0, 32.0]), &cols).is_empty());
        assert!(isolated(&run(&[20.0, f64::NAN, 900.0, 20.0, 20.0]), &cols).is_empty());
        // Within the limit (0.5 K/s x 10 s + 0.5 K = 5.5 K): not a jump.
        assert!(isolated(&run(&[20.0, 20.0, 25.0, 20.0, 20.0]), &cols).is_empty());
        assert_eq!(
            isolated(&run(&[20.0, 20.0, 26.0, 20.0, 20.0]), &cols).len(),
            1
        );
    }
}
