//! A lumped thermal network of any size: nodes with heat capacities,
//! conductances between them (the topology), and conductances from each
//! node to the room air and to the coolant supply.
//!
//! ```text
//! C_i dT_i/dt = Q_i + sum_j g_ij (T_j - T_i) + ga_i (T_air - T_i) + gc_i (T_cool - T_i)
//! ```
//!
//! Written for the plant zoo on its own (no code of the twin): the zoo must
//! stay a structure the diagnosis was not built around.

use anyhow::{bail, Result};
use nalgebra::{DMatrix, DVector};

/// A place a temperature is taken from: a node or a boundary.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Site {
    /// Node `i` of the network.
    Node(usize),
    /// The room air.
    Ambient,
    /// The coolant supply.
    Coolant,
}

/// A lumped body.
#[derive(Debug, Clone, PartialEq)]
pub struct Node {
    /// Name (for tables and messages).
    pub name: &'static str,
    /// Heat capacity, J/K.
    pub c_j_per_k: f64,
    /// Conductance to the room air, W/K.
    pub g_ambient_w_per_k: f64,
    /// Conductance to the coolant supply, W/K.
    pub g_coolant_w_per_k: f64,
}

/// A conductance between two nodes.
#[derive(Debug, Clone, PartialEq)]
pub struct Link {
    /// One end (node index).
    pub a: usize,
    /// The other end (node index).
    pub b: usize,
    /// Conductance, W/K.
    pub g_w_per_k: f64,
}

/// The network: nodes and links.
#[derive(Debug, Clone, PartialEq)]
pub struct Network {
    /// The nodes, in index order.
    pub nodes: Vec<Node>,
    /// The links between them.
    pub links: Vec<Link>,
}

impl Network {
    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Whether there are no nodes.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Checks capacities (> 0), conductances (>= 0, finite), link ends, and
    /// that every node reaches the air or the coolant (a steady state exists).
    pub fn check(&self) -> Result<()> {
        let n = self.len();
        if n == 0 {
            bail!("a network needs at least one node");
        }
        for nd in &self.nodes {
            let gs = [nd.g_ambient_w_per_k, nd.g_coolant_w_per_k];
            if !(nd.c_j_per_k.is_finite() && nd.c_j_per_k > 0.0)
                || gs.iter().any(|g| !(g.is_finite() && *g >= 0.0))
            {
                bail!(
                    "node {}: capacity must be > 0 and conductances >= 0",
                    nd.name
                );
            }
        }
        for l in &self.links {
            if l.a >= n
                || l.b >= n
                || l.a == l.b
                || !(l.g_w_per_k.is_finite() && l.g_w_per_k >= 0.0)
            {
                bail!("link {}-{}: bad ends or conductance", l.a, l.b);
            }
        }
        if !self.grounded() {
            bail!("some node is coupled neither to the air nor to the coolant, even through links");
        }
        Ok(())
    }

    /// Whether every node reaches a boundary through links with g > 0.
    fn grounded(&self) -> bool {
        let mut reach: Vec<bool> = self
            .nodes
            .iter()
            .map(|n| n.g_ambient_w_per_k > 0.0 || n.g_coolant_w_per_k > 0.0)
            .collect();
        for _ in 0..self.len() {
            for l in self.links.iter().filter(|l| l.g_w_per_k > 0.0) {
                let r = reach[l.a] || reach[l.b];
                reach[l.a] = r;
                reach[l.b] = r;
            }
        }
        reach.iter().all(|&r| r)
    }

    /// Heat flow into each node, W (heat `q` plus conduction), for node
    /// temperatures `x`, air `ta` and coolant `tc`.
    pub fn net_heat_w(&self, x: &[f64], q: &[f64], ta: f64, tc: f64, out: &mut [f64]) {
        for (i, nd) in self.nodes.iter().enumerate() {
            out[i] = q[i] + nd.g_ambient_w_per_k * (ta - x[i]) + nd.g_coolant_w_per_k * (tc - x[i]);
        }
        for l in &self.links {
            let f = l.g_w_per_k * (x[l.b] - x[l.a]);
            out[l.a] += f;
            out[l.b] -= f;
        }
    }

    /// Heat the nodes give to the coolant, W (what a chiller must remove).
    pub fn coolant_load_w(&self, x: &[f64], tc: f64) -> f64 {
        self.nodes
            .iter()
            .zip(x)
            .map(|(nd, xi)| nd.g_coolant_w_per_k * (xi - tc))
            .sum()
    }

    /// The conductance matrix `K` (`C dx/dt = -K x + ...`).
    pub fn conductance_matrix(&self) -> DMatrix<f64> {
        let n = self.len();
        let mut k = DMatrix::zeros(n, n);
        for (i, nd) in self.nodes.iter().enumerate() {
            k[(i, i)] = nd.g_ambient_w_per_k + nd.g_coolant_w_per_k;
        }
        for l in &self.links {
            k[(l.a, l.a)] += l.g_w_per_k;
            k[(l.b, l.b)] += l.g_w_per_k;
            k[(l.a, l.b)] -= l.g_w_per_k;
            k[(l.b, l.a)] -= l.g_w_per_k;
        }
        k
    }

    /// Steady state for constant heat `q` (W per node), air and coolant:
    /// solves `K x = q + ga ta + gc tc`.
    pub fn steady_state(&self, q: &[f64], ta: f64, tc: f64) -> Result<Vec<f64>> {
        let rhs = DVector::from_iterator(
            self.len(),
            self.nodes
                .iter()
                .zip(q)
                .map(|(nd, qi)| qi + nd.g_ambient_w_per_k * ta + nd.g_coolant_w_per_k * tc),
        );
        match self.conductance_matrix().lu().solve(&rhs) {
            Some(x) => Ok(x.iter().copied().collect()),
            None => bail!("the network has no steady state (a node is not grounded)"),
        }
    }

    /// Time constants of the network, s, slowest first: `1/lambda` for the
    /// eigenvalues of `C^-1/2 K C^-1/2` (symmetric, so real and positive).
    pub fn time_constants_s(&self) -> Vec<f64> {
        let k = self.conductance_matrix();
        let s: Vec<f64> = self
            .nodes
            .iter()
            .map(|n| n.c_j_per_k.sqrt().recip())
            .collect();
        let m = DMatrix::from_fn(self.len(), self.len(), |i, j| s[i] * k[(i, j)] * s[j]);
        let mut taus: Vec<f64> = m
            .symmetric_eigen()
            .eigenvalues
            .iter()
            .map(|l| 1.0 / l.max(1e-300))
            .collect();
        taus.sort_by(|a, b| b.total_cmp(a));
        taus
    }

    /// An upper bound of the fastest rate, 1/s (Gershgorin on `C^-1 K`).
    pub fn max_rate_per_s(&self) -> f64 {
        let k = self.conductance_matrix();
        (0..self.len())
            .map(|i| {
                let row: f64 = (0..self.len()).map(|j| k[(i, j)].abs()).sum();
                row / self.nodes[i].c_j_per_k
            })
            .fold(0.0, f64::max)
    }
}

/// Test network: two nodes in series to the air, heat into node 0.
#[cfg(test)]
pub(crate) fn two_nodes() -> Network {
    Network {
        nodes: vec![
            Node {
                name: "core",
                c_j_per_k: 2000.0,
                g_ambient_w_per_k: 0.0,
                g_coolant_w_per_k: 0.0,
            },
            Node {
                name: "shell",
                c_j_per_k: 50_000.0,
                g_ambient_w_per_k: 10.0,
                g_coolant_w_per_k: 0.0,
            },
        ],
        links: vec![Link {
            a: 0,
            b: 1,
            g_w_per_k: 4.0,
        }],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steady_state_of_two_nodes_is_the_series_resistance() {
        // q flows through 1/g01 + 1/ga: rises q/ga on the shell and
        // q (1/g01 + 1/ga) on the core. Exact up to rounding (1e-9 K).
        let net = two_nodes();
        let x = net.steady_state(&[100.0, 0.0], 20.0, 0.0).unwrap();
        assert!((x[1] - (20.0 + 100.0 / 10.0)).abs() < 1e-9, "{x:?}");
        assert!(
            (x[0] - (20.0 + 100.0 / 4.0 + 100.0 / 10.0)).abs() < 1e-9,
            "{x:?}"
        );
    }

    #[test]
    fn an_ungrounded_node_is_refused() {
        let mut net = two_nodes();
        net.nodes[1].g_ambient_w_per_k = 0.0;
        assert!(net.check().is_err());
        assert!(two_nodes().check().is_ok());
    }
}
