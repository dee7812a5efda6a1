//! A candidate's grid walked in batches: consecutive grid points whose
//! own columns, together, are few (the pairs of one input's responses
//! share five or six), so that their fits take the rows in one walk
//! ([`crate::num::batch`]) while the grid is still made one point at a
//! time and each point's columns live only while its batch is looked at.

use super::align::Col;
use super::variants::Variant;
use crate::num::lsq;
use std::ops::Range;

/// Distinct columns of their own (regressors and fixed parts) the
/// variants of one batch may hold: the six responses of the coolant
/// grid's pairs, two grid points of the day cycle. The batch also holds
/// the first variant that did not fit in, made to find out.
const MAX_BATCH_COLUMNS: usize = 6;

/// The items of `vars` (each a [`Variant`], `of` reading it from an item)
/// in consecutive batches with at most [`MAX_BATCH_COLUMNS`] distinct
/// columns of their own (at least one item each), in order.
pub fn batches<T>(
    vars: impl Iterator<Item = T>,
    of: fn(&T) -> &Variant,
) -> impl Iterator<Item = Vec<T>> {
    let mut vars = vars.peekable();
    std::iter::from_fn(move || {
        let mut batch = vec![vars.next()?];
        let mut seen: Vec<*const f64> = Vec::new();
        add_columns(&mut seen, of(&batch[0]));
        while let Some(next) = vars.peek() {
            let mut with = seen.clone();
            add_columns(&mut with, of(next));
            if with.len() > MAX_BATCH_COLUMNS {
                break;
            }
            seen = with;
            batch.extend(vars.next());
        }
        Some(batch)
    })
}

/// Adds to `seen` the columns of `v`'s own (by address) not in it yet.
fn add_columns(seen: &mut Vec<*const f64>, v: &Variant) {
    let own = v
        .extra
        .iter()
        .map(|c| c.as_ptr())
        .chain(v.fixed_part.iter().map(|f| f.as_ptr()));
    for p in own {
        if !seen.contains(&p) {
            seen.push(p);
        }
    }
}

/// The scales of shared columns on the fit rows
/// ([`lsq::column_scales`]), each column's computed once.
pub struct Scales {
    rows: Range<usize>,
    known: Vec<(*const f64, f64)>,
}

impl Scales {
    /// None known yet, for rows `rows`.
    pub fn new(rows: Range<usize>) -> Self {
        Scales {
            rows,
            known: Vec::new(),
        }
    }

    /// The scale of column `c`.
    pub fn of(&mut self, c: &Col) -> f64 {
        let at = c.as_ptr();
        if let Some(&(_, s)) = self.known.iter().find(|k| k.0 == at) {
            return s;
        }
        let s = lsq::column_scales(&[c.as_slice()], &self.rows)[0];
        self.known.push((at, s));
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn var(cols: &[&Col]) -> Variant {
        Variant {
            extra: cols.iter().map(|&c| c.clone()).collect(),
            fixed: Vec::new(),
            labels: Vec::new(),
            gains: Vec::new(),
            taus: Vec::new(),
            total: None,
            sign: None,
            fixed_part: None,
        }
    }

    #[test]
    fn batches_keep_the_order_and_bound_their_own_columns() {
        // Pairs of four shared responses (one batch), then grid points of
        // three columns each (two a batch).
        let r: Vec<Col> = (0..4).map(|k| Col::new(vec![k as f64; 10])).collect();
        let mut grid = Vec::new();
        for i in 0..4 {
            for j in i + 1..4 {
                grid.push(var(&[&r[i], &r[j]]));
            }
        }
        for k in 0..3 {
            let own: Vec<Col> = (0..3)
                .map(|m| Col::new(vec![(10 * k + m) as f64; 10]))
                .collect();
            grid.push(var(&own.iter().collect::<Vec<_>>()));
        }
        let sizes: Vec<usize> = batches(grid.clone().into_iter(), |v| v)
            .map(|b| b.len())
            .collect();
        assert_eq!(sizes, [6, 2, 1]);
        let order: Vec<*const f64> = batches(grid.iter(), |v| *v)
            .flatten()
            .map(|v| v.extra[0].as_ptr())
            .collect();
        let want: Vec<*const f64> = grid.iter().map(|v| v.extra[0].as_ptr()).collect();
        assert_eq!(order, want);
    }
}
