//! Order structures of the dynamic trainers: the ranges a search tries
//! (`--na`, `--nb`, `--nk`) and the candidate structures within the model
//! core's limits (`MAX_ORDER`), shared by `arx` and `tf`.

use model_core::tf::MAX_ORDER;
use serde::Serialize;
use std::str::FromStr;

/// An inclusive order range given as `MIN..MAX` or a single number.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OrderRange {
    /// Smallest order tried.
    pub min: usize,
    /// Largest order tried.
    pub max: usize,
}

impl FromStr for OrderRange {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let parse = |v: &str| {
            v.trim()
                .parse::<usize>()
                .map_err(|_| format!("\"{s}\" is not an order range like 1..3"))
        };
        let (min, max) = match s.split_once("..") {
            Some((a, b)) => (parse(a)?, parse(b.trim_start_matches('='))?),
            None => (parse(s)?, parse(s)?),
        };
        if min > max || max > MAX_ORDER {
            return Err(format!(
                "order range {s}: need MIN <= MAX <= {MAX_ORDER} (the model core's highest order)"
            ));
        }
        Ok(Self { min, max })
    }
}

impl OrderRange {
    /// The range `min..=max` (unchecked: for constants).
    pub const fn new(min: usize, max: usize) -> Self {
        Self { min, max }
    }
    /// Every order of the range.
    pub fn iter(self) -> std::ops::RangeInclusive<usize> {
        self.min..=self.max
    }
}

/// One candidate structure: denominator order, numerator length, delay
/// (serialised as `{"na":..,"nb":..,"nk":..}`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Orders {
    /// Denominator order (`A` has `na + 1` coefficients).
    pub na: usize,
    /// Numerator length (`B` has `nb` coefficients).
    pub nb: usize,
    /// Input delay in samples.
    pub nk: usize,
}

impl Orders {
    /// Largest lag the structure reaches back.
    pub fn max_lag(self) -> usize {
        self.na.max(self.nk + self.nb.saturating_sub(1))
    }
    /// Whether the model core can hold it.
    pub fn fits_core(self) -> bool {
        self.na <= MAX_ORDER && self.nk + self.nb <= MAX_ORDER + 1 && self.nb >= 1
    }
}

/// The candidate structures of the given ranges that the model core holds.
pub fn candidates(na: OrderRange, nb: OrderRange, nk: OrderRange) -> Vec<Orders> {
    let mut out = Vec::new();
    for na in na.iter() {
        for nb in nb.iter() {
            for nk in nk.iter() {
                let o = Orders { na, nb, nk };
                if o.fits_core() && nb >= 1 {
                    out.push(o);
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn order_ranges_parse() {
        assert_eq!("1..3".parse::<OrderRange>().unwrap(), OrderRange::new(1, 3));
        assert_eq!("2".parse::<OrderRange>().unwrap(), OrderRange::new(2, 2));
        assert!("3..1".parse::<OrderRange>().is_err());
        assert!("0..9".parse::<OrderRange>().is_err());
    }
}
