//! Numbers as text: a table's figure (fixed decimals, right-aligned, "-"
//! where there is none, never `NaN`) and a number in a message ([`Num`]:
//! plain for everyday magnitudes, scientific otherwise).

use std::fmt;

/// `x` in `width` columns with `decimals`, or "-" where there is no figure
/// (nothing held out, nothing to score, no case to take a rate of).
pub fn figure(x: Option<f64>, width: usize, decimals: usize) -> String {
    match x.filter(|v| v.is_finite()) {
        Some(v) => format!("{v:>width$.decimals$}"),
        None => format!("{:>width$}", "-"),
    }
}

/// A number as shown in messages: plain notation for everyday magnitudes,
/// scientific otherwise, because Rust prints `1e300` as 301 digits.
#[derive(Clone, Copy, Debug)]
pub struct Num(pub f64);

impl fmt::Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let magnitude = self.0.abs();
        if magnitude == 0.0 || (1e-4..1e15).contains(&magnitude) {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figures_and_numbers() {
        assert_eq!(figure(Some(1.23456), 7, 2), "   1.23");
        assert_eq!(figure(Some(f64::NAN), 4, 1), "   -");
        assert_eq!(figure(None, 0, 1), "-");
        assert_eq!(Num(3000.0).to_string(), "3000");
        assert_eq!(Num(1e300).to_string(), "1e300");
    }
}
