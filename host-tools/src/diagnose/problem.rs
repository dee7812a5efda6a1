//! The problem a candidate is fitted to: a channel of the aligned runs,
//! its fit rows and its scored rows (swapped for the backward fold of the
//! significance test). The candidates ([`super::candidates`]) and their
//! regressors ([`super::variants`]) both work on it.

use super::align::{Aligned, Channel};

/// A contiguous range of rows.
pub type Rows = std::ops::Range<usize>;

/// The problem a candidate is fitted to.
#[derive(Clone)]
pub struct Problem<'a> {
    /// Aligned runs.
    pub al: &'a Aligned,
    /// Channel whose residual is explained.
    pub ch: &'a Channel,
    /// Rows `0..n_fit` are the fit part, the rest the hold-out.
    pub n_fit: usize,
    /// Roles swapped (the backward fold of the significance test): fit on
    /// the hold-out rows, predict the fit part.
    pub swapped: bool,
}

impl<'a> Problem<'a> {
    /// Fit on rows `0..n_fit`, score on the rest.
    pub fn new(al: &'a Aligned, ch: &'a Channel, n_fit: usize) -> Self {
        Problem {
            al,
            ch,
            n_fit,
            swapped: false,
        }
    }

    /// The same problem with the fit and test rows swapped.
    pub fn swapped(&self) -> Self {
        Problem {
            swapped: !self.swapped,
            ..self.clone()
        }
    }

    /// Rows the candidates are fitted on.
    pub fn fit_rows(&self) -> Rows {
        if self.swapped {
            self.n_fit..self.ch.resid.len()
        } else {
            0..self.n_fit
        }
    }

    /// Rows the candidates are scored on.
    pub fn test_rows(&self) -> Rows {
        if self.swapped {
            0..self.n_fit
        } else {
            self.n_fit..self.ch.resid.len()
        }
    }
}
