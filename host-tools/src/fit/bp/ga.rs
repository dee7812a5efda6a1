//! Real-coded genetic algorithm that picks the hidden size and the initial
//! weights and thresholds of the net (seed 000, Eq. 16-17).
//!
//! A chromosome is one real gene for the hidden size (in [0, 1), decoded
//! linearly onto `hidden.0..=hidden.1`) followed by the weights and biases
//! of the largest net in [`Shape`]'s layout; a net with `n` hidden neurons
//! uses the first `n` of them. The seed runs two GAs (one for the hidden
//! size with Eq. 16's fitness, one for the weights with Eq. 17's); this
//! runs one over both at once with Eq. 17's fitness, `1 / SSE` of the
//! scaled training rows, which also ranks hidden sizes.
//!
//! Each generation: roulette selection by fitness, the best individual kept
//! unchanged (elitism, so the best SSE never rises), single-point crossover
//! of consecutive pairs with probability `crossover`, and with probability
//! `mutation` one random gene of an individual moved by a uniform step whose
//! width shrinks over the generations (non-uniform mutation). The initial
//! population is Nguyen-Widrow draws, so the GA starts where BP alone starts.
//!
//! Fitness is evaluated in parallel (rayon); every random draw happens on
//! the calling thread in a fixed order, and the parallel part only maps
//! individuals to numbers, so the result does not depend on thread timing.

use super::init::nguyen_widrow;
use super::net::{self, Data, Shape};
use crate::num::rng::SplitMix64;
use indicatif::ProgressBar;
use model_core::bp::Activation;
use rayon::prelude::*;
use std::time::Instant;

/// GA settings.
#[derive(Clone, Debug)]
pub struct GaOptions {
    /// Individuals per generation.
    pub population: usize,
    /// Generations.
    pub generations: usize,
    /// Probability that a pair exchanges tails.
    pub crossover: f64,
    /// Probability that an individual has one gene mutated.
    pub mutation: f64,
    /// Hidden sizes searched, inclusive.
    pub hidden: (usize, usize),
}

/// The GA's answer.
#[derive(Clone, Debug)]
pub struct GaResult {
    /// Hidden size of the best individual.
    pub hidden: usize,
    /// Its weights in [`Shape`]'s layout for that size.
    pub w: Vec<f64>,
    /// Best training SSE (scaled) after each generation, generation 0 = the initial population.
    pub best_sse: Vec<f64>,
    /// Seconds.
    pub seconds: f64,
}

/// Decodes the hidden-size gene.
fn hidden_of(gene: f64, (lo, hi): (usize, usize)) -> usize {
    let span = (hi - lo + 1) as f64;
    lo + ((gene.clamp(0.0, 1.0) * span) as usize).min(hi - lo)
}

/// The weights of the net with `n` hidden neurons inside a chromosome laid
/// out for `big` (its first `n` neurons).
fn weights(genes: &[f64], big: Shape, n: usize) -> Vec<f64> {
    let Shape { m, q, .. } = big;
    let w = &genes[1..];
    let (ob1, ow2) = (big.n * m, big.n * m + big.n);
    let ob2 = ow2 + q * big.n;
    let mut out = Vec::with_capacity(Shape { m, n, q }.params());
    out.extend_from_slice(&w[..n * m]);
    out.extend_from_slice(&w[ob1..ob1 + n]);
    for k in 0..q {
        out.extend_from_slice(&w[ow2 + k * big.n..ow2 + k * big.n + n]);
    }
    out.extend_from_slice(&w[ob2..ob2 + q]);
    out
}

/// Writes a net of `n` hidden neurons into the first neurons of a chromosome.
fn put(genes: &mut [f64], big: Shape, n: usize, small: &[f64]) {
    let Shape { m, q, .. } = big;
    let w = &mut genes[1..];
    let (ob1, ow2) = (big.n * m, big.n * m + big.n);
    let ob2 = ow2 + q * big.n;
    let mut s = small.iter().copied();
    let mut fill = |dst: &mut [f64]| dst.iter_mut().for_each(|v| *v = s.next().unwrap_or(0.0));
    fill(&mut w[..n * m]);
    fill(&mut w[ob1..ob1 + n]);
    for k in 0..q {
        fill(&mut w[ow2 + k * big.n..ow2 + k * big.n + n]);
    }
    fill(&mut w[ob2..ob2 + q]);
}

/// Evolves nets of `m` inputs and `q` outputs on `train`.
pub fn evolve(
    m: usize,
    q: usize,
    act: Activation,
    train: &Data,
    opts: &GaOptions,
    rng: &mut SplitMix64,
    pb: Option<&ProgressBar>,
) -> GaResult {
    let start = Instant::now();
    let big = Shape {
        m,
        n: opts.hidden.1,
        q,
    };
    let len = 1 + big.params();
    let pop_n = opts.population.max(2);
    // Initial population: Nguyen-Widrow for the largest net (the unused
    // neurons), overwritten by a draw for the individual's own size.
    let mut pop: Vec<Vec<f64>> = (0..pop_n)
        .map(|_| {
            let mut g = vec![rng.uniform()];
            g.extend(nguyen_widrow(big, act, rng));
            let n = hidden_of(g[0], opts.hidden);
            let small = nguyen_widrow(Shape { m, n, q }, act, rng);
            put(&mut g, big, n, &small);
            g
        })
        .collect();
    let sse_of = |g: &Vec<f64>| {
        let n = hidden_of(g[0], opts.hidden);
        let s = net::sse(Shape { m, n, q }, act, &weights(g, big, n), train);
        if s.is_finite() {
            s
        } else {
            f64::INFINITY
        }
    };
    let mut sse: Vec<f64> = pop.par_iter().map(sse_of).collect();
    let best_of = |sse: &[f64]| (0..sse.len()).fold(0, |b, i| if sse[i] < sse[b] { i } else { b });
    let mut best_sse = vec![sse[best_of(&sse)]];
    for gen in 0..opts.generations {
        let elite = pop[best_of(&sse)].clone();
        // Roulette on fitness 1/SSE (Eq. 17).
        let fit: Vec<f64> = sse.iter().map(|s| 1.0 / (s + 1e-300)).collect();
        let total: f64 = fit.iter().sum();
        let mut next: Vec<Vec<f64>> = Vec::with_capacity(pop_n);
        next.push(elite);
        while next.len() < pop_n {
            let mut spin = rng.uniform() * total;
            let mut pick = pop_n - 1;
            for (i, f) in fit.iter().enumerate() {
                if spin < *f {
                    pick = i;
                    break;
                }
                spin -= f;
            }
            next.push(pop[pick].clone());
        }
        // Single-point crossover of pairs (1,2), (3,4), ...; the elite is 0.
        let mut i = 1;
        while i + 1 < pop_n {
            if rng.uniform() < opts.crossover {
                let cut = 1 + rng.below(len - 1);
                let (a, b) = next.split_at_mut(i + 1);
                a[i][cut..].swap_with_slice(&mut b[0][cut..]);
            }
            i += 2;
        }
        // Non-uniform mutation of one gene, narrowing as generations pass.
        let width = 1.0 - gen as f64 / opts.generations.max(1) as f64;
        for g in next.iter_mut().skip(1) {
            if rng.uniform() < opts.mutation {
                let at = rng.below(len);
                let step = rng.symmetric() * width;
                g[at] = if at == 0 {
                    (g[0] + 0.5 * step).clamp(0.0, 1.0 - 1e-12)
                } else {
                    g[at] + step * (1.0 + g[at].abs())
                };
            }
        }
        pop = next;
        sse = pop.par_iter().map(sse_of).collect();
        best_sse.push(sse[best_of(&sse)]);
        if let Some(pb) = pb {
            pb.inc(1);
        }
    }
    let b = best_of(&sse);
    let hidden = hidden_of(pop[b][0], opts.hidden);
    GaResult {
        hidden,
        w: weights(&pop[b], big, hidden),
        best_sse,
        seconds: start.elapsed().as_secs_f64(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::bp::net::tests::toy;

    fn opts() -> GaOptions {
        GaOptions {
            population: 12,
            generations: 8,
            crossover: 0.7,
            mutation: 0.2,
            hidden: (2, 6),
        }
    }

    #[test]
    fn elitism_keeps_the_best_sse_from_rising_and_it_is_reproducible() {
        let d = toy(50, 2);
        let a = evolve(
            3,
            2,
            Activation::Tansig,
            &d,
            &opts(),
            &mut SplitMix64::new(1),
            None,
        );
        assert_eq!(a.best_sse.len(), 9);
        assert!(
            a.best_sse.windows(2).all(|p| p[1] <= p[0]),
            "{:?}",
            a.best_sse
        );
        assert!((2..=6).contains(&a.hidden));
        // The answer is the individual scored last: its SSE, recomputed, is exact.
        let s = net::sse(
            Shape {
                m: 3,
                n: a.hidden,
                q: 2,
            },
            Activation::Tansig,
            &a.w,
            &d,
        );
        assert_eq!(s, *a.best_sse.last().unwrap());
        let b = evolve(
            3,
            2,
            Activation::Tansig,
            &d,
            &opts(),
            &mut SplitMix64::new(1),
            None,
        );
        assert_eq!(a.w, b.w);
    }

    #[test]
    fn hidden_gene_decodes_onto_the_whole_range() {
        assert_eq!(hidden_of(0.0, (2, 6)), 2);
        assert_eq!(hidden_of(0.999_999, (2, 6)), 6);
        assert_eq!(hidden_of(1.0, (2, 6)), 6);
        assert_eq!(hidden_of(0.5, (3, 3)), 3);
        // weights() and put() are inverse on the used neurons.
        let big = Shape { m: 2, n: 4, q: 2 };
        let mut g = vec![0.0; 1 + big.params()];
        let small: Vec<f64> = (0..Shape { m: 2, n: 3, q: 2 }.params())
            .map(|v| v as f64)
            .collect();
        put(&mut g, big, 3, &small);
        assert_eq!(weights(&g, big, 3), small);
    }
}
