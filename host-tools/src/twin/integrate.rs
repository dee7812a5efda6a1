//! Exact discretisation of `dT/dt = A T + B u` for inputs held constant over
//! each step (zero-order hold).
//!
//! ```text
//! exp([[A, B], [0, 0]] dt) = [[Phi, Gamma], [0, I]]
//! T(k+1) = Phi T(k) + Gamma u(k)
//! ```
//!
//! with `Phi = e^(A dt)` and `Gamma = int_0^dt e^(A s) ds B` (Van Loan's
//! augmented-matrix identity), so the step is exact for any dt (no
//! stability limit, no truncation error) as long as `u` is constant over the
//! step. The matrix exponential is nalgebra 0.35's `Matrix::exp` (Padé
//! approximants with scaling and squaring, Al-Mohy & Higham 2009, as in
//! scipy's `expm`); the tests check it against closed forms and a fine RK4
//! integration. `Phi` and `Gamma` are recomputed only when dt changes.

use super::machine::N_NODES;
use super::network::{Input, Network, State, N_INPUTS};
use nalgebra::{DMatrix, SMatrix};

/// `Phi = e^(A dt)` and `Gamma = int_0^dt e^(A s) ds B` for any sizes.
pub fn zoh(a: &DMatrix<f64>, b: &DMatrix<f64>, dt_s: f64) -> (DMatrix<f64>, DMatrix<f64>) {
    let n = a.nrows();
    let m = b.ncols();
    let mut aug = DMatrix::<f64>::zeros(n + m, n + m);
    aug.view_mut((0, 0), (n, n)).copy_from(&(a * dt_s));
    aug.view_mut((0, n), (n, m)).copy_from(&(b * dt_s));
    let e = aug.exp();
    (
        e.view((0, 0), (n, n)).into_owned(),
        e.view((0, n), (n, m)).into_owned(),
    )
}

/// A discretised network: `T(k+1) = Phi T(k) + Gamma u(k)` for one step size.
#[derive(Debug, Clone)]
pub struct Discrete {
    /// The step the matrices are for, s.
    pub dt_s: f64,
    /// State transition `e^(A dt)`.
    pub phi: SMatrix<f64, N_NODES, N_NODES>,
    /// Input matrix of the held input.
    pub gamma: SMatrix<f64, N_NODES, N_INPUTS>,
}

impl Discrete {
    /// Discretises `net` for steps of `dt_s` seconds.
    pub fn new(net: &Network, dt_s: f64) -> Discrete {
        let a = DMatrix::from_column_slice(N_NODES, N_NODES, net.a.as_slice());
        let b = DMatrix::from_column_slice(N_NODES, N_INPUTS, net.b.as_slice());
        let (phi, gamma) = zoh(&a, &b, dt_s);
        Discrete {
            dt_s,
            phi: SMatrix::from_column_slice(phi.as_slice()),
            gamma: SMatrix::from_column_slice(gamma.as_slice()),
        }
    }

    /// One step from `t` with input `u` held over it.
    pub fn step(&self, t: &State, u: &Input) -> State {
        self.phi * t + self.gamma * u
    }
}

/// Steps a network with any sequence of step sizes, rediscretising only
/// when the step changes (uniform runs discretise once; an irregular run
/// file keeps a small cache of the steps it uses).
#[derive(Debug, Clone)]
pub struct Stepper {
    net: Network,
    cache: Vec<Discrete>,
}

/// Most distinct step sizes kept; a logger with jitter would otherwise grow
/// the cache without bound.
const CACHE_LEN: usize = 16;

impl Stepper {
    /// A stepper for `net`.
    pub fn new(net: Network) -> Stepper {
        Stepper {
            net,
            cache: Vec::new(),
        }
    }

    /// The network being stepped.
    pub fn network(&self) -> &Network {
        &self.net
    }

    /// Advances `t` by `dt_s` with `u` held.
    pub fn step(&mut self, t: &State, u: &Input, dt_s: f64) -> State {
        if let Some(pos) = self.cache.iter().position(|d| d.dt_s == dt_s) {
            // Most recently used first, so a uniform run finds it at once.
            if pos != 0 {
                self.cache.swap(0, pos);
            }
        } else {
            if self.cache.len() == CACHE_LEN {
                self.cache.pop();
            }
            self.cache.insert(0, Discrete::new(&self.net, dt_s));
        }
        self.cache[0].step(t, u)
    }

    /// How many discretisations are cached (for tests).
    pub fn cached(&self) -> usize {
        self.cache.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_node_closed_form() {
        // C dT/dt = -G T + Q: Phi = e^(-dt/tau), Gamma = (1 - Phi) tau / C.
        let (c, g, dt) = (1500.0, 12.5, 7.0);
        let tau = c / g;
        let a = DMatrix::from_element(1, 1, -g / c);
        let b = DMatrix::from_element(1, 1, 1.0 / c);
        let (phi, gamma) = zoh(&a, &b, dt);
        let phi_x = (-dt / tau).exp();
        let gamma_x = -(-dt / tau).exp_m1() * tau / c;
        assert!((phi[(0, 0)] - phi_x).abs() <= 1e-12 * phi_x);
        assert!((gamma[(0, 0)] - gamma_x).abs() <= 1e-12 * gamma_x);
    }
}
