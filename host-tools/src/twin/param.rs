//! A fitted parameter of a calibration: its name and unit, its bounds and
//! whether the optimiser moves its logarithm; the machine's factors
//! ([`super::calibrate::PARAMS`]) and an effect's own
//! ([`super::drive::FittedEffect::params`]) are both described this way.

/// One fitted parameter's name, unit, bounds and whether it is a log.
#[derive(Debug, Clone, Copy)]
pub struct ParamDef {
    /// JSON name.
    pub name: &'static str,
    /// Unit of the value shown.
    pub unit: &'static str,
    /// Lower bound of the value.
    pub lo: f64,
    /// Upper bound of the value.
    pub hi: f64,
    /// Fitted as ln(value).
    pub log: bool,
}

impl ParamDef {
    /// Which bound the value `x` sits on, if any ("lower" / "upper"): a
    /// value there is the bound's answer, not the data's. Within 1e-9 of
    /// the value (log parameters) or of the range (the others).
    pub fn bound_hit(&self, x: f64) -> Option<&'static str> {
        let tol = if self.log {
            1e-9 * x.abs()
        } else {
            1e-9 * (self.hi - self.lo)
        };
        if x <= self.lo + tol {
            Some("lower")
        } else if x >= self.hi - tol {
            Some("upper")
        } else {
            None
        }
    }
}

/// Values from optimiser coordinates (`exp` of the logs).
pub fn to_values(defs: &[ParamDef], theta: &[f64]) -> Vec<f64> {
    defs.iter()
        .zip(theta)
        .map(|(d, x)| if d.log { x.exp() } else { *x })
        .collect()
}

/// Optimiser coordinates from values, clamped into the bounds.
pub fn to_theta(defs: &[ParamDef], values: &[f64]) -> Vec<f64> {
    defs.iter()
        .zip(values)
        .map(|(d, v)| {
            let v = v.clamp(d.lo, d.hi);
            if d.log {
                v.ln()
            } else {
                v
            }
        })
        .collect()
}
