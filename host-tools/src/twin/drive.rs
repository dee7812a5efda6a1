//! The simulation a calibration runs ([`super::calibrate`]), with what may
//! drive it besides the spindle's speed losses: an unmodelled effect
//! switched on with parameters that are fitted together with the machine's
//! factors (`thermcomp diagnose --machine`, docs/diagnose.md).
//!
//! The network is linear, so the calibration simulates *rises* above the
//! state at rest (the run's first row), from zero:
//!
//! | input | nominal twin | with a [`Drive`] |
//! |---|---|---|
//! | heat per node | speed losses | + `heat_w` (cutting heat, extra motor losses) |
//! | ambient air | constant (rise 0) | `ambient_k`: a logged `ambient_c` or a modelled day cycle, as a rise above its first value |
//! | coolant supply | constant (rise 0) | `coolant_k`: a logged `coolant_c` or a modelled chiller |
//! | temperature sensors | prompt | `sensor_lag_s`: a first-order lag per channel ([`super::sensors::lag_step`], the twin's own) |
//!
//! A logged boundary is the twin's boundary input taken from the run file
//! rather than from a model: `simulate` keeps its boundaries constant (or
//! modelled, with `--effects`), the calibration can replay a log.

use super::integrate::Stepper;
use super::machine::{Machine, N_NODES};
use super::network::{self, Input, Network, State, U_AMBIENT, U_COOLANT};
use super::param::ParamDef;
use super::profile::Schedule;
use super::sensors::lag_step;

/// Places a sensor can be at: the nodes, then ambient and coolant.
pub const N_PLACES: usize = N_NODES + 2;
/// Index of the ambient air among the places.
pub const P_AMBIENT: usize = N_NODES;
/// Index of the coolant supply among the places.
pub const P_COOLANT: usize = N_NODES + 1;

/// Rises above the state at rest of every place, K: the nodes, then the
/// ambient air and the coolant supply.
pub type Rises = [f64; N_PLACES];

/// Extra inputs of one simulation, row by row on the schedule's grid
/// (each `None`: as in the nominal twin). Vectors cover every row that is
/// simulated.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Drive {
    /// Extra heat per node, W, held from each row to the next.
    pub heat_w: Option<Vec<[f64; N_NODES]>>,
    /// Ambient air rise above the first row, K.
    pub ambient_k: Option<Vec<f64>>,
    /// Coolant supply rise above the first row, K.
    pub coolant_k: Option<Vec<f64>>,
    /// Lag of each temperature channel (the measured run's order), s; a
    /// channel with `None`, or past the end, reads promptly.
    pub sensor_lag_s: Option<Vec<Option<f64>>>,
}

impl Drive {
    /// The lag of temperature channel `j`, s.
    pub fn lag_s(&self, j: usize) -> Option<f64> {
        self.sensor_lag_s
            .as_ref()
            .and_then(|v| v.get(j).copied().flatten())
    }
}

/// An effect whose parameters a calibration fits together with the
/// machine's factors ([`super::calibrate::calibrate_with`]).
pub trait FittedEffect: Sync {
    /// Its parameters with bounds, appended to the machine's.
    fn params(&self) -> Vec<ParamDef>;
    /// Parameter values to start from; the one with the smallest cost on
    /// the calibration part is taken (non-empty, each of `params().len()`).
    fn starts(&self) -> Vec<Vec<f64>>;
    /// The simulation's extra inputs for parameter values `p` on every row
    /// of the run.
    fn drive(&self, p: &[f64]) -> Drive;
}

/// Rises of every place for the first `rows` rows of `s`: machine `m` from
/// rest, its speed losses plus `d`, inputs held from each row to the next
/// (as [`super::sim::run`] does).
pub fn rises(m: &Machine, s: &Schedule, rows: usize, d: &Drive) -> Vec<Rises> {
    let rows = rows.min(s.t_s.len());
    let mut stepper = Stepper::new(Network::new(m));
    let mut x = State::zeros();
    let at = |v: &Option<Vec<f64>>, k: usize| v.as_ref().map_or(0.0, |v| v[k]);
    let mut out = Vec::with_capacity(rows);
    for k in 0..rows {
        let mut r = [0.0; N_PLACES];
        r[..N_NODES].copy_from_slice(x.as_slice());
        r[P_AMBIENT] = at(&d.ambient_k, k);
        r[P_COOLANT] = at(&d.coolant_k, k);
        out.push(r);
        if k + 1 < rows {
            let q = network::speed_heat_w(&m.heat, s.speed_rpm[k]);
            let mut u = Input::zeros();
            for (i, qi) in q.iter().enumerate() {
                u[i] = qi + d.heat_w.as_ref().map_or(0.0, |h| h[k][i]);
            }
            u[U_AMBIENT] = r[P_AMBIENT];
            u[U_COOLANT] = r[P_COOLANT];
            x = stepper.step(&x, &u, s.t_s[k + 1] - s.t_s[k]);
        }
    }
    out
}

/// `rises` as a sensor with a first-order lag `tau_s` reads them (every
/// place lagged, starting at rest like the twin's sensors).
pub fn lagged(rises: &[Rises], t_s: &[f64], tau_s: f64) -> Vec<Rises> {
    let mut out: Vec<Rises> = Vec::with_capacity(rises.len());
    for (k, r) in rises.iter().enumerate() {
        let next = if k == 0 {
            *r
        } else {
            let (prev, dt) = (out[k - 1], t_s[k] - t_s[k - 1]);
            std::array::from_fn(|p| lag_step(prev[p], rises[k - 1][p], r[p], dt, tau_s))
        };
        out.push(next);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::twin::machine::Node;

    fn schedule(n: usize, dt: f64, rpm: f64) -> Schedule {
        Schedule {
            t_s: (0..n).map(|k| k as f64 * dt).collect(),
            speed_rpm: vec![rpm; n],
            power_kw: None,
            tool_mm: None,
        }
    }

    #[test]
    fn a_uniform_boundary_rise_heats_every_node_to_it() {
        // Ambient and coolant both 1 K up, spindle at rest: the steady state
        // is every node 1 K up (the Laplacian conserves heat).
        let m = Machine::default_machine();
        let s = schedule(400, 3600.0, 0.0);
        let d = Drive {
            ambient_k: Some(vec![1.0; 400]),
            coolant_k: Some(vec![1.0; 400]),
            ..Drive::default()
        };
        let r = rises(&m, &s, 400, &d);
        let last = r[399];
        assert!(last.iter().all(|v| (v - 1.0).abs() < 1e-9), "{last:?}");
        assert_eq!(r[0], [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0]);
    }

    #[test]
    fn extra_heat_adds_to_the_speed_losses() {
        // The network is linear: speed losses + extra = the sum of both runs.
        let m = Machine::default_machine();
        let s = schedule(200, 60.0, 6000.0);
        let mut extra = [0.0; N_NODES];
        extra[Node::Motor.index()] = 300.0;
        let d = Drive {
            heat_w: Some(vec![extra; 200]),
            ..Drive::default()
        };
        let both = rises(&m, &s, 200, &d);
        let speed = rises(&m, &s, 200, &Drive::default());
        let alone = rises(&m, &schedule(200, 60.0, 0.0), 200, &d);
        for k in [1, 50, 199] {
            for p in 0..N_NODES {
                let sum = speed[k][p] + alone[k][p];
                assert!((both[k][p] - sum).abs() < 1e-9, "{k} {p}");
            }
        }
    }

    #[test]
    fn a_lagged_ramp_is_tau_behind() {
        let t: Vec<f64> = (0..2000).map(|k| k as f64 * 13.0).collect();
        let r: Vec<Rises> = t.iter().map(|&t| [1e-3 * t; N_PLACES]).collect();
        let l = lagged(&r, &t, 300.0);
        let behind = r[1999][0] - l[1999][0];
        assert!((behind - 0.3).abs() < 1e-9, "{behind}");
        assert_eq!(l[0], r[0]);
    }
}
