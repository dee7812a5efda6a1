//! Lumped-parameter thermal network of a motorized spindle on a machining
//! centre.
//!
//! Seven nodes (front bearing, rear bearing, motor, shaft, housing,
//! structure, coolant jacket; [`Node`]) with heat capacities `C_i`, joined by
//! conductances `G_ij`, each with a conductance `Ga_i` to ambient air `Ta` and
//! `Gc_i` to the coolant supply `Tc`. Energy balance of node i:
//!
//! ```text
//! C_i dT_i/dt = sum_j G_ij (T_j - T_i) + Ga_i (Ta - T_i) + Gc_i (Tc - T_i) + Q_i
//! ```
//!
//! i.e. `dT/dt = A T + B u` with `u = [Q_1..Q_7, Ta, Tc]`,
//! `A = -C^-1 (L + diag(Ga + Gc))` (L the conductance Laplacian) and
//! `B = C^-1 [I, Ga, Gc]`. The heat sources `Q` come from the spindle speed:
//! bearing friction `Q = Q_ref (n / n_ref)^b` (Palmgren's viscous moment
//! gives b = 5/3), motor no-load losses (magnetising copper losses while
//! turning plus iron losses `~ n^1.5`). Effects add to `Q` (see
//! [`super::effects`]).

use super::machine::{Heat, Machine, Node, N_NODES};
use nalgebra::{SMatrix, SVector};

/// Number of inputs: one heat flow per node, then ambient and coolant.
pub const N_INPUTS: usize = N_NODES + 2;
/// Index of the ambient temperature in the input vector.
pub const U_AMBIENT: usize = N_NODES;
/// Index of the coolant supply temperature in the input vector.
pub const U_COOLANT: usize = N_NODES + 1;

/// Node temperatures, deg C.
pub type State = SVector<f64, N_NODES>;
/// Inputs `[Q_1..Q_7 (W), Ta (deg C), Tc (deg C)]`.
pub type Input = SVector<f64, N_INPUTS>;

/// The continuous-time network `dT/dt = A T + B u`.
#[derive(Debug, Clone, PartialEq)]
pub struct Network {
    /// Heat capacities, J/K.
    pub c_j_per_k: [f64; N_NODES],
    /// Conductances to ambient, W/K.
    pub g_ambient_w_per_k: [f64; N_NODES],
    /// Conductances to the coolant supply, W/K.
    pub g_coolant_w_per_k: [f64; N_NODES],
    /// Conductance matrix between nodes (symmetric, zero diagonal), W/K.
    pub g_w_per_k: SMatrix<f64, N_NODES, N_NODES>,
    /// System matrix, 1/s.
    pub a: SMatrix<f64, N_NODES, N_NODES>,
    /// Input matrix (K/J for heat inputs, 1/s for boundary temperatures).
    pub b: SMatrix<f64, N_NODES, N_INPUTS>,
}

impl Network {
    /// The network of a (validated) machine.
    pub fn new(m: &Machine) -> Network {
        let mut c = [0.0; N_NODES];
        let mut ga = [0.0; N_NODES];
        let mut gc = [0.0; N_NODES];
        for n in Node::ALL {
            let p = m.nodes.get(n);
            c[n.index()] = p.c_j_per_k;
            ga[n.index()] = p.g_ambient_w_per_k;
            gc[n.index()] = p.g_coolant_w_per_k;
        }
        let mut g = SMatrix::<f64, N_NODES, N_NODES>::zeros();
        for l in &m.links {
            // Two links between the same pair act in parallel.
            g[(l.a.index(), l.b.index())] += l.g_w_per_k;
            g[(l.b.index(), l.a.index())] += l.g_w_per_k;
        }
        let mut a = SMatrix::<f64, N_NODES, N_NODES>::zeros();
        let mut b = SMatrix::<f64, N_NODES, N_INPUTS>::zeros();
        for i in 0..N_NODES {
            let row_sum: f64 = (0..N_NODES).map(|j| g[(i, j)]).sum();
            for j in 0..N_NODES {
                a[(i, j)] = g[(i, j)] / c[i];
            }
            a[(i, i)] = -(row_sum + ga[i] + gc[i]) / c[i];
            b[(i, i)] = 1.0 / c[i];
            b[(i, U_AMBIENT)] = ga[i] / c[i];
            b[(i, U_COOLANT)] = gc[i] / c[i];
        }
        Network {
            c_j_per_k: c,
            g_ambient_w_per_k: ga,
            g_coolant_w_per_k: gc,
            g_w_per_k: g,
            a,
            b,
        }
    }

    /// Time derivative `A T + B u`, K/s.
    pub fn derivative(&self, t: &State, u: &Input) -> State {
        self.a * t + self.b * u
    }

    /// Equilibrium temperatures for constant inputs: `A T = -B u`.
    ///
    /// Solved on the symmetric form `(L + diag(Ga + Gc)) T = Q + Ga Ta + Gc Tc`,
    /// which is positive definite for a grounded network (the machine file
    /// checks that every node has a path to a boundary).
    pub fn steady_state(&self, u: &Input) -> State {
        let mut k = SMatrix::<f64, N_NODES, N_NODES>::zeros();
        let mut rhs = State::zeros();
        for i in 0..N_NODES {
            let row_sum: f64 = (0..N_NODES).map(|j| self.g_w_per_k[(i, j)]).sum();
            for j in 0..N_NODES {
                k[(i, j)] = -self.g_w_per_k[(i, j)];
            }
            k[(i, i)] = row_sum + self.g_ambient_w_per_k[i] + self.g_coolant_w_per_k[i];
            rhs[i] = u[i]
                + self.g_ambient_w_per_k[i] * u[U_AMBIENT]
                + self.g_coolant_w_per_k[i] * u[U_COOLANT];
        }
        // Cholesky exists for a grounded network; LU is the fallback for a
        // hand-built one.
        match k.cholesky() {
            Some(ch) => ch.solve(&rhs),
            None => k.lu().solve(&rhs).unwrap_or_else(State::zeros),
        }
    }

    /// Heat balance at temperatures `t`: (heat generated, heat leaving to
    /// ambient and coolant), W. Equal at equilibrium.
    pub fn heat_balance(&self, t: &State, u: &Input) -> (f64, f64) {
        let generated: f64 = (0..N_NODES).map(|i| u[i]).sum();
        let out: f64 = (0..N_NODES)
            .map(|i| {
                self.g_ambient_w_per_k[i] * (t[i] - u[U_AMBIENT])
                    + self.g_coolant_w_per_k[i] * (t[i] - u[U_COOLANT])
            })
            .sum();
        (generated, out)
    }

    /// Time constants of the network's modes, s, slowest first.
    pub fn time_constants_s(&self) -> Vec<f64> {
        // A = -C^-1 K is similar to the symmetric -C^-1/2 K C^-1/2, so its
        // eigenvalues are real and negative.
        let mut s = SMatrix::<f64, N_NODES, N_NODES>::zeros();
        for i in 0..N_NODES {
            for j in 0..N_NODES {
                s[(i, j)] = self.a[(i, j)] * (self.c_j_per_k[i] / self.c_j_per_k[j]).sqrt();
            }
        }
        let s = (s + s.transpose()) * 0.5;
        let mut tau: Vec<f64> = s.symmetric_eigenvalues().iter().map(|l| -1.0 / l).collect();
        tau.sort_by(|a, b| b.total_cmp(a));
        tau
    }
}

/// Air-cutting heat sources at `rpm` (bearings and motor no-load losses), W,
/// per node.
pub fn speed_heat_w(h: &Heat, rpm: f64) -> [f64; N_NODES] {
    let mut q = [0.0; N_NODES];
    let n = rpm.abs();
    if n <= 0.0 {
        return q;
    }
    let r = n / h.bearing_ref_rpm;
    let bearing = r.powf(h.bearing_exponent);
    q[Node::FrontBearing.index()] = h.front_bearing_w_at_ref * bearing;
    q[Node::RearBearing.index()] = h.rear_bearing_w_at_ref * bearing;
    q[Node::Motor.index()] = h.motor_idle_w + h.motor_iron_w_at_ref * r.powf(h.motor_iron_exponent);
    q
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn laplacian_rows_conserve_heat() {
        // With Ta = Tc = T everywhere, a uniform field is an equilibrium.
        let net = Network::new(&Machine::default_machine());
        let t = State::repeat(23.0);
        let mut u = Input::zeros();
        u[U_AMBIENT] = 23.0;
        u[U_COOLANT] = 23.0;
        let d = net.derivative(&t, &u);
        assert!(d.amax() < 1e-15, "{d}");
    }

    #[test]
    fn bearing_heat_follows_the_power_law() {
        let h = Machine::default_machine().heat;
        let q1 = speed_heat_w(&h, 5000.0)[0];
        let q2 = speed_heat_w(&h, 10000.0)[0];
        assert!((q2 / q1 - 2f64.powf(h.bearing_exponent)).abs() < 1e-12);
        assert_eq!(speed_heat_w(&h, 0.0), [0.0; N_NODES]);
    }
}
