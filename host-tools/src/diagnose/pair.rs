//! Two effects at once: the best joint model of two candidates on top of
//! the baseline, for the `second` of the diagnosis ([`super::with_pair`]).
//!
//! Each candidate's grid is cut to its [`PAIR_GRID`] best variants on their
//! own; for each pair of cuts, coordinate descent (start from `b`'s best,
//! then the best of `a` given `b`, the best of `b` given `a`, twice) picks
//! one variant of each, and the two are fitted jointly and scored on the
//! hold-out. A cut is kept as the positions of its variants in the grid,
//! not as their columns: a grid is walked again, one variant made at a
//! time, whenever the descent looks at it (the harmonic and day-cycle
//! grids have three or four columns of their own per variant, so five
//! cuts held at once were up to 40 full-length columns).

use super::batch::batches;
use super::candidates::{below, params_of, score, Design, Scored, NAMES};
use super::outcome::Params;
use super::problem::Problem;
use super::variants::{variants, Variant};
use crate::num::lsq::{self, LinearFit};
use std::cmp::Ordering;

/// Grid points kept per candidate for the pair search.
const PAIR_GRID: usize = 8;

/// One candidate's grid cut: its name, the walk positions of its
/// [`PAIR_GRID`] best variants on their own (best first) and its model
/// text.
struct Cut {
    name: &'static str,
    top: Vec<usize>,
    model: String,
}

/// What a cut's variants are made from again: the problem and the
/// baseline's prediction (the `coolant` grid's harmonic fallback reads it).
struct Ctx<'p, 'a> {
    p: &'p Problem<'a>,
    base_pred: &'p [f64],
}

impl Cut {
    /// The cut of candidate `name`: its grid walked once, each variant
    /// fitted on its own, the positions of the [`PAIR_GRID`] best kept in
    /// the order a stable sort of the whole grid gives them (ties: the
    /// earlier variant first).
    fn of(c: &Ctx, d: &Design, name: &'static str) -> Cut {
        let (vars, model) = variants(name, c.p, c.base_pred);
        let (y, rows) = (&c.p.ch.resid, c.p.fit_rows());
        let mut top: Vec<(f64, usize)> = Vec::with_capacity(PAIR_GRID + 1);
        for batch in batches(vars.enumerate(), |x| &x.1) {
            let refs: Vec<&Variant> = batch.iter().map(|x| &x.1).collect();
            for ((i, _), f) in batch.iter().zip(d.solve_many(&refs, y, &rows)) {
                let Some(f) = f else {
                    continue;
                };
                let at = top.partition_point(|(e, _)| !below(f.sse_fit, *e));
                if at < PAIR_GRID {
                    top.insert(at, (f.sse_fit, *i));
                    top.truncate(PAIR_GRID);
                }
            }
        }
        Cut {
            name,
            top: top.into_iter().map(|x| x.1).collect(),
            model,
        }
    }

    /// The cut's variants with their rank in it (0: the best), made one at
    /// a time in grid order.
    fn walk<'a>(&'a self, c: &Ctx<'_, 'a>) -> impl Iterator<Item = (usize, Variant)> + 'a {
        let (vars, _) = variants(self.name, c.p, c.base_pred);
        vars.enumerate().filter_map(move |(i, v)| {
            let rank = self.top.iter().position(|&t| t == i)?;
            Some((rank, v))
        })
    }

    /// The best variant of the cut on top of `d` for `y` (smallest fit-part
    /// error; of equal ones the better ranked, as walking the cut best
    /// first and keeping the first of equal errors would pick).
    fn best_on(&self, c: &Ctx, d: &Design, y: &[f64]) -> Option<Variant> {
        let rows = c.p.fit_rows();
        let mut best: Option<(f64, usize, Variant)> = None;
        let solved = batches(self.walk(c), |x| &x.1).flat_map(|batch| {
            let refs: Vec<&Variant> = batch.iter().map(|x| &x.1).collect();
            let fits = d.solve_many(&refs, y, &rows);
            batch.into_iter().zip(fits)
        });
        for ((rank, v), f) in solved {
            let Some(f) = f else {
                continue;
            };
            let better = best
                .as_ref()
                .is_none_or(|(e, r, _)| match f.sse_fit.total_cmp(e) {
                    Ordering::Less => true,
                    Ordering::Equal => rank < *r,
                    Ordering::Greater => false,
                });
            if better {
                best = Some((f.sse_fit, rank, v));
            }
        }
        best.map(|b| b.2)
    }
}

/// `y` minus a fixed part, if any.
fn minus(y: &[f64], fixed: &Option<Vec<f64>>) -> Vec<f64> {
    match fixed {
        Some(fp) => y.iter().zip(fp).map(|(a, b)| a - b).collect(),
        None => y.to_vec(),
    }
}

/// Coordinate descent over two cuts on top of the baseline: start from
/// `b`'s best, then best of `a` given `b`, best of `b` given `a`, twice.
fn descend(c: &Ctx, d: &Design, ca: &Cut, cb: &Cut) -> Option<(Variant, Variant)> {
    let y = &c.p.ch.resid;
    let mut sel_b = cb.walk(c).find(|(rank, _)| *rank == 0)?.1;
    let mut sel_a = None;
    for _ in 0..2 {
        let (db, fb) = d.with_variant(&sel_b);
        let Some(a) = ca.best_on(c, &db, &minus(y, &fb)) else {
            break;
        };
        let (da, fa) = d.with_variant(&a);
        let Some(b) = cb.best_on(c, &da, &minus(y, &fa)) else {
            break;
        };
        sel_a = Some(a);
        sel_b = b;
    }
    Some((sel_a?, sel_b))
}

/// Variants `a` and `b` as one (regressors of `a` first, fixed parts
/// summed).
fn merged(a: &Variant, b: &Variant) -> Variant {
    let mut m = a.clone();
    m.extra.extend(b.extra.iter().cloned());
    m.gains.extend(b.gains.iter().cloned());
    m.sign = None;
    m.fixed_part = match (&a.fixed_part, &b.fixed_part) {
        (Some(x), Some(y)) => Some(x.iter().zip(y).map(|(u, v)| u + v).collect()),
        (Some(x), None) | (None, Some(x)) => Some(x.clone()),
        (None, None) => None,
    };
    m
}

/// A joint model of two effects ([`best_pair`]).
#[derive(Debug, Clone)]
pub struct Pair {
    /// The joint fit, scored (named `a+b`).
    pub joint: Scored,
    /// The more important member (its removal from the joint prediction
    /// raises the held-out rms more).
    pub first: String,
    /// The other member.
    pub second: String,
    /// The errors the joint fit leaves on the test rows.
    pub errors: Vec<f64>,
}

/// The joint fit of two cuts' selected variants, scored, with its members
/// ordered by importance (the one whose removal from the joint prediction
/// raises the held-out rms more first).
fn joint(c: &Ctx, d: &Design, ca: &Cut, cb: &Cut) -> Option<Pair> {
    let p = c.p;
    let y = &p.ch.resid;
    let (sel_a, sel_b) = descend(c, d, ca, cb)?;
    let both = merged(&sel_a, &sel_b);
    let f = d.fit(&both, y, &p.fit_rows())?;
    let (ka, kb) = (d.len(), d.len() + sel_a.extra.len());
    let mut params = Params::new();
    for (prefix, v, from) in [(ca.name, &sel_a, ka), (cb.name, &sel_b, kb)] {
        for (k, val) in params_of(v, &f.coef[from - d.len()..], d.len()) {
            params.insert(format!("{prefix}.{k}"), val);
        }
    }
    let (s, errors) = score(
        &format!("{}+{}", ca.name, cb.name),
        p,
        (&f, &[]),
        format!("{}; {}", ca.model, cb.model),
        params,
    );
    let without = |v: &Variant, from: usize| -> f64 {
        let left: Vec<f64> = p
            .test_rows()
            .map(|k| y[k] - (f.pred[k] - Design::part(v, &f, from, k)))
            .collect();
        lsq::rms(&left)
    };
    let (wa, wb) = (without(&sel_a, ka), without(&sel_b, kb));
    let (first, second) = if wa >= wb {
        (ca.name, cb.name)
    } else {
        (cb.name, ca.name)
    };
    Some(Pair {
        joint: s,
        first: first.to_string(),
        second: second.to_string(),
        errors,
    })
}

/// The best joint model of two effects: for each pair, coordinate descent
/// over the two grids, each cut to its 8 best variants on their own.
/// Returns the joint fit (named `a+b`) with its members ordered by
/// importance.
pub fn best_pair(p: &Problem) -> Option<Pair> {
    let d = Design::of(p);
    let bf: LinearFit = d.fit_alone(&p.ch.resid, &p.fit_rows())?;
    let c = Ctx {
        p,
        base_pred: &bf.pred,
    };
    let cuts: Vec<Cut> = NAMES
        .iter()
        .map(|&n| Cut::of(&c, &d, n))
        .filter(|g| !g.top.is_empty())
        .collect();
    let mut best: Option<Pair> = None;
    for i in 0..cuts.len() {
        for j in i + 1..cuts.len() {
            let Some(cand) = joint(&c, &d, &cuts[i], &cuts[j]) else {
                continue;
            };
            if best
                .as_ref()
                .is_none_or(|b| cand.joint.rms_after < b.joint.rms_after)
            {
                best = Some(cand);
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::align;

    /// 48 h at 60 s: speed steps, a 40 min ripple and a slow drift that
    /// the sim lacks on `T1` and `dz_um`.
    fn runs(dir: &std::path::Path) -> align::Aligned {
        let write = |name: &str, gap: f64| {
            let mut text = String::from("t_s,speed_rpm,T1,dz_um\n");
            for k in 0..2880 {
                let t = 60.0 * k as f64;
                let speed = [0.0, 3000.0, 6000.0, 9000.0][(k / 180) % 4];
                let lag = 20.0 + 8.0 * (1.0 - (-(t % 10_800.0) / 3600.0).exp()) * speed / 9000.0;
                let extra = gap * (0.3 * (t / 2400.0 * std::f64::consts::TAU).sin() + t / 86_400.0);
                let noise = 0.01 * ((k * 7919 % 13) as f64 - 6.0);
                let (temp, dz) = (lag + extra + noise, 3.0 * (lag - 20.0) + 2.0 * extra);
                text.push_str(&format!("{t},{speed},{temp:.6},{dz:.6}\n"));
            }
            let path = dir.join(name);
            std::fs::write(&path, text).unwrap();
            path
        };
        let (sim, real) = (write("sim.csv", 0.0), write("real.csv", 1.0));
        align::read(&sim, &real).unwrap()
    }

    /// What a variant is, for comparing two picks.
    fn key(v: &Variant) -> String {
        format!("{:?} {:?} {:?}", v.fixed, v.labels, v.gains)
    }

    #[test]
    fn a_cut_walked_again_picks_what_the_cut_held_whole_picks() {
        // The reference holds each cut's variants at once, best first, and
        // keeps the first of equal errors ([`Design::best`], the search as
        // it was); the cut walked again one variant at a time must pick the
        // same variant, on the baseline alone and with another cut's best.
        let dir = tempfile::tempdir().unwrap();
        let al = runs(dir.path());
        for c in 0..al.channels.len() {
            let ch = al.channels.load(c);
            let p = Problem::new(&al, &ch, 1440);
            let d = Design::of(&p);
            let bf = d.fit_alone(&ch.resid, &p.fit_rows()).unwrap();
            let ctx = Ctx {
                p: &p,
                base_pred: &bf.pred,
            };
            let cuts: Vec<Cut> = NAMES.iter().map(|&n| Cut::of(&ctx, &d, n)).collect();
            assert!(cuts.iter().filter(|c| c.top.len() > 1).count() >= 2);
            let whole = |cut: &Cut| -> Vec<Variant> {
                let mut v: Vec<(usize, Variant)> = cut.walk(&ctx).collect();
                v.sort_by_key(|x| x.0);
                v.into_iter().map(|x| x.1).collect()
            };
            for (ca, cb) in cuts.iter().zip(cuts.iter().skip(1)) {
                let Some(b0) = whole(cb).into_iter().next() else {
                    continue;
                };
                let (db, fb) = d.with_variant(&b0);
                for (design, y) in [(&d, ch.resid.clone()), (&db, minus(&ch.resid, &fb))] {
                    let reference = design.best(whole(ca), &y, &p.fit_rows()).map(|x| key(&x.1));
                    let walked = ca.best_on(&ctx, design, &y).map(|v| key(&v));
                    assert_eq!(walked, reference, "{} {}", ch.name, ca.name);
                }
            }
        }
    }
}
