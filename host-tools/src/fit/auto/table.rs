//! The vocabulary of `fit --model auto`'s CV table: the model families it
//! weighs ([`Family`]), the input forms ([`Form`]) and one row of the table
//! ([`CvRow`]), shared by the ridge search (search.rs) and the other
//! families (family.rs).

use super::ridge::CvScore;
use anyhow::{anyhow, bail, Result};
use serde::Serialize;

/// A model family `auto` can put in the blob.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Family {
    /// Ridge over a bank of first-order low-pass filters (search.rs): a
    /// transfer-function bank with fixed real poles (seed 004, Eq. 1-2).
    Ridge,
    /// Principal component regression (seed 003), `fit --model pcr`.
    Pcr,
    /// MISO ARX exported as a TF bank (seed 004), `fit --model arx`.
    Arx,
    /// Seed 004's bank of SISO transfer functions fitted for simulation,
    /// `fit --model tf`.
    Tf,
    /// One-hidden-layer BP network trained by Levenberg-Marquardt (seed
    /// 000), `fit --model bp`.
    Bp,
    /// The BP network with hidden size and initial weights chosen by a
    /// genetic algorithm (seed 000), `fit --model gabp`.
    Gabp,
}

/// `--auto-families` without the option: every family but gabp (gabp is bp
/// with a GA in front: slower for the same network).
pub const DEFAULT_FAMILIES: &str = "ridge,pcr,arx,tf,bp";

impl Family {
    /// Every family, in the order the CLI lists them.
    pub const ALL: [Self; 6] = [
        Self::Ridge,
        Self::Pcr,
        Self::Arx,
        Self::Tf,
        Self::Bp,
        Self::Gabp,
    ];

    /// The name `--auto-families` and the JSON use.
    pub fn name(self) -> &'static str {
        match self {
            Self::Ridge => "ridge",
            Self::Pcr => "pcr",
            Self::Arx => "arx",
            Self::Tf => "tf",
            Self::Bp => "bp",
            Self::Gabp => "gabp",
        }
    }

    /// Parses `--auto-families` (duplicates once); refuses an unknown
    /// name, and a list without the ridge the others are weighed against.
    pub fn parse_list(names: &[String]) -> Result<Vec<Self>> {
        let known: Vec<&str> = Self::ALL.iter().map(|f| f.name()).collect();
        let mut out = Vec::new();
        for name in names.iter().map(|n| n.trim()) {
            let f = Self::ALL
                .iter()
                .copied()
                .find(|f| f.name() == name)
                .ok_or_else(|| {
                    anyhow!(
                        "auto: --auto-families: unknown family \"{name}\" (known: {})",
                        known.join(", ")
                    )
                })?;
            if !out.contains(&f) {
                out.push(f);
            }
        }
        if !out.contains(&Self::Ridge) {
            bail!(
                "auto: --auto-families {}: must include ridge (the model the others are weighed against)",
                names.join(",")
            );
        }
        Ok(out)
    }

    /// Whether the family's blob is a TF bank (at most 16 entries).
    pub fn tf_bank(self) -> bool {
        matches!(self, Self::Arx | Self::Tf)
    }
}

/// The input form of a candidate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Form {
    /// Temperatures as changes from each run's first sample; no intercept
    /// (every feature and, on a run starting cold, the error start at zero).
    Change,
    /// Temperatures as logged, with an intercept.
    Absolute,
}

impl Form {
    /// Both forms, in the order the table lists them.
    pub const ALL: [Form; 2] = [Form::Change, Form::Absolute];

    /// Whether the regression has a constant term.
    pub fn intercept(self) -> bool {
        self == Self::Absolute
    }
}

/// One row of the CV table.
#[derive(Clone, Debug, Serialize)]
pub struct CvRow {
    /// Model family: `ridge` (this search's filter-bank candidates) or
    /// another family scored on the same folds (family.rs).
    pub family: Family,
    /// Input form.
    pub form: Form,
    /// Temperature filter time constants, s (besides the raw temperature;
    /// empty for other families).
    pub temp_taus_s: Vec<f64>,
    /// Heat-source filter time constants, s (empty for other families).
    pub heat_taus_s: Vec<f64>,
    /// Penalty (on standardised features, alpha / n; 0 for other
    /// families, which choose their own settings).
    pub lambda: f64,
    /// Feature columns (other families: the inputs the model reads).
    pub features: usize,
    /// Cross-validated root mean square error, in the target's unit (null
    /// when the family could not be scored on every fold: see `note`).
    pub cv_rmse: f64,
    /// Standard error of the fold-mean squared error, as an rmse spread.
    pub cv_se: f64,
    /// Square root of the geometric mean of the per-fold mean squared
    /// errors: the criterion ridge candidates are ranked by (ridge.rs
    /// `CvScore`), in the target's unit.
    pub cv_geo_rmse: f64,
    /// Its standard error as an rmse spread (`geo_se / (2 sqrt(geo))`):
    /// with several runs, the ridge candidates whose `cv_geo_rmse^2` lies
    /// within `2 cv_geo_rmse cv_geo_se` of the best's square are the ones
    /// the simplest are averaged from (search.rs `simplest_within_noise`).
    pub cv_geo_se: f64,
    /// Inputs left out (indices into the fit's `inputs`): temperatures
    /// dropped by the sensor elimination; for other families the inputs
    /// that never move in calibration and (arx, tf) the heat sources when
    /// every input would overflow the 16-entry TF bank.
    pub dropped_inputs: Vec<usize>,
    /// Whether the blob holds this candidate (ridge: one of the averaged).
    pub chosen: bool,
    /// Why a family has no CV error.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

impl CvRow {
    /// A short name of the candidate: family, form and, for the filter
    /// bank, its filters (minutes), penalty and dropped sensors.
    pub fn label(&self) -> String {
        let form = match self.form {
            Form::Change => "change",
            Form::Absolute => "absolute",
        };
        if self.family != Family::Ridge {
            return format!("{} {form}", self.family.name());
        }
        let minutes = |v: &[f64]| {
            let m: Vec<String> = v.iter().map(|t| format!("{}", t / 60.0)).collect();
            format!("[{}]", m.join(" "))
        };
        let mut s = format!("{form} T{}", minutes(&self.temp_taus_s));
        if !self.heat_taus_s.is_empty() {
            s.push_str(&format!(" heat{}", minutes(&self.heat_taus_s)));
        }
        s.push_str(&format!(" l={:.0e}", self.lambda));
        if !self.dropped_inputs.is_empty() {
            s.push_str(&format!(" -{} sensors", self.dropped_inputs.len()));
        }
        s
    }

    /// A row of `family` in `form` with no settings and no score yet.
    pub fn new(family: Family, form: Form) -> Self {
        Self {
            family,
            form,
            temp_taus_s: Vec::new(),
            heat_taus_s: Vec::new(),
            lambda: 0.0,
            features: 0,
            cv_rmse: f64::NAN,
            cv_se: f64::NAN,
            cv_geo_rmse: f64::NAN,
            cv_geo_se: f64::NAN,
            dropped_inputs: Vec::new(),
            chosen: false,
            note: None,
        }
    }
}

/// One table row's CV columns from a score.
pub fn cv_columns(row: &mut CvRow, lambda: f64, features: usize, cv: &CvScore) {
    row.lambda = lambda;
    row.features = features;
    row.cv_rmse = cv.mse.sqrt();
    row.cv_se = cv.se / (2.0 * cv.mse.sqrt().max(f64::MIN_POSITIVE));
    row.cv_geo_rmse = cv.geo.sqrt();
    row.cv_geo_se = cv.geo_se / (2.0 * cv.geo.sqrt().max(f64::MIN_POSITIVE));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn families_parse_and_unknown_or_ridgeless_lists_are_refused() {
        let list = |s: &str| s.split(',').map(String::from).collect::<Vec<_>>();
        assert_eq!(
            Family::parse_list(&list(DEFAULT_FAMILIES)).unwrap(),
            [
                Family::Ridge,
                Family::Pcr,
                Family::Arx,
                Family::Tf,
                Family::Bp
            ]
        );
        let e = Family::parse_list(&list("ridge,foo")).unwrap_err();
        assert!(e.to_string().contains("unknown family \"foo\""), "{e}");
        assert!(Family::parse_list(&list("pcr")).is_err());
    }
}
