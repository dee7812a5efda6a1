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
