//! Filter-bank features on the host: the very recursion model-core's
//! `fbank` kind runs on the hub, so a model fitted on these columns predicts
//! on the hub what it predicted here.
//!
//! A feature is `v = x^power` of one reference-adjusted input, either as it
//! is (`tau_s = 0`) or through a first-order low-pass filter with pole
//! `p = exp(-dt / tau)`: `s(0) = v(0)` (the run starts in steady state),
//! `s(k) = p s(k-1) + (1 - p) v(k)`. A linear model over such features is a
//! transfer-function bank with fixed real poles (seed 004 Eq. 1-2 with
//! first-order sections), which is why it runs exactly on the hub.

/// What drives the machine's temperatures, as opposed to a temperature.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Role {
    /// A measured temperature (`T<n>`, `ambient_c`, `coolant_c`, ...):
    /// enters as it is and through the temperature filters, in the
    /// candidate's input form.
    Temperature,
    /// A heat source (`speed_rpm`, `power_kw`): enters only through the
    /// heat-source filters, as logged (0 = off) and squared (losses grow as
    /// n^1..n^2).
    HeatSource,
}

impl Role {
    /// The role of a run-file column.
    pub fn of(column: &str) -> Self {
        match column {
            "speed_rpm" | "power_kw" => Self::HeatSource,
            _ => Self::Temperature,
        }
    }
}

/// One feature column: which input, which power, which filter.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct FeatureDef {
    /// Index of the input (in the dataset's input order).
    pub input: usize,
    /// 1 or 2.
    pub power: u8,
    /// Filter time constant, s; 0 = unfiltered.
    pub tau_s: f64,
}

/// `v` through a first-order low-pass filter of time constant `tau_s` at
/// sample time `dt_s`, started in steady state (`tau_s = 0`: `v` itself).
pub fn low_pass(v: &[f64], tau_s: f64, dt_s: f64) -> Vec<f64> {
    if tau_s <= 0.0 {
        return v.to_vec();
    }
    let p = (-dt_s / tau_s).exp();
    let mut s = v.first().copied().unwrap_or(0.0);
    v.iter()
        .map(|&u| {
            s = p * s + (1.0 - p) * u;
            s
        })
        .collect()
}

/// The feature column of `def` over one run's reference-adjusted inputs `x`.
pub fn column(x: &[Vec<f64>], def: &FeatureDef, dt_s: f64) -> Vec<f64> {
    let u = &x[def.input];
    let v: Vec<f64> = if def.power == 2 {
        u.iter().map(|a| a * a).collect()
    } else {
        u.clone()
    };
    low_pass(&v, def.tau_s, dt_s)
}

/// [`column`] over `lead ++ x` with the lead's samples left out: the
/// feature on a run's grid whose filters started before it (`lead`, the
/// run's inputs from where the hub starts; empty inputs: [`column`]).
pub fn column_after(lead: &[Vec<f64>], x: &[Vec<f64>], def: &FeatureDef, dt_s: f64) -> Vec<f64> {
    let skip = lead.get(def.input).map_or(0, Vec::len);
    if skip == 0 {
        return column(x, def, dt_s);
    }
    let i = def.input;
    let whole = [lead[i].iter().chain(&x[i]).copied().collect()];
    let one = FeatureDef { input: 0, ..*def };
    column(&whole, &one, dt_s).split_off(skip)
}

/// Every feature of a candidate's filter sets over `inputs` (their roles):
/// temperatures raw and through `temp_taus`, heat sources to the powers 1
/// and 2 through `heat_taus`.
pub fn bank(roles: &[Role], temp_taus: &[f64], heat_taus: &[f64]) -> Vec<FeatureDef> {
    let mut out = Vec::new();
    for (input, role) in roles.iter().enumerate() {
        match role {
            Role::Temperature => {
                for &tau_s in std::iter::once(&0.0).chain(temp_taus) {
                    out.push(FeatureDef {
                        input,
                        power: 1,
                        tau_s,
                    });
                }
            }
            Role::HeatSource => {
                for power in [1, 2] {
                    for &tau_s in heat_taus {
                        out.push(FeatureDef {
                            input,
                            power,
                            tau_s,
                        });
                    }
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
    fn low_pass_starts_in_steady_state_and_reaches_63_pct_after_tau() {
        // A step from 0 to 1 at k = 1: after tau / dt samples the filter has
        // covered 1 - 1/e of the step (exact for the discrete pole exp(-dt/tau)).
        let dt = 1.0;
        let tau = 50.0;
        let mut v = vec![1.0; 101];
        v[0] = 0.0;
        let s = low_pass(&v, tau, dt);
        assert_eq!(s[0], 0.0);
        let expect = 1.0 - (-1.0f64).exp();
        assert!((s[50] - expect).abs() < 1e-12, "{}", s[50]);
    }

    /// A step at k = 1 of which the grid sees only k >= 3: the filter
    /// started two samples before the grid is where the hub's stands (the
    /// step's 1 - p^3 covered), not in steady state at the grid's value.
    #[test]
    fn a_lead_starts_the_filter_before_the_grid() {
        let (dt, tau) = (1.0, 10.0);
        let lead = [vec![0.0, 1.0, 1.0], vec![5.0, 5.0, 5.0]];
        let x = [vec![1.0; 4], vec![5.0; 4]];
        let def = FeatureDef {
            input: 0,
            power: 2,
            tau_s: tau,
        };
        let got = column_after(&lead, &x, &def, dt);
        let whole = low_pass(&[0.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0], tau, dt);
        assert_eq!(got, whole[3..]);
        let p: f64 = (-dt / tau).exp();
        assert!((got[0] - (1.0 - p.powi(3))).abs() < 1e-15, "{}", got[0]);
        // Without a lead: the grid's first value, steady.
        let none: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
        assert_eq!(column_after(&none, &x, &def, dt), [1.0; 4]);
    }

    #[test]
    fn bank_lists_raw_and_filtered_temperatures_and_both_powers_of_heat() {
        let roles = [Role::Temperature, Role::HeatSource];
        let b = bank(&roles, &[600.0], &[900.0, 3600.0]);
        assert_eq!(b.len(), 2 + 4);
        assert_eq!(b[0].tau_s, 0.0);
        assert_eq!(b[1].tau_s, 600.0);
        assert!(b[2..].iter().all(|d| d.input == 1 && d.tau_s > 0.0));
        assert_eq!(b.iter().filter(|d| d.power == 2).count(), 2);
    }
}
