//! Fuzzy clustering by the maximal-tree method and the choice of how many
//! clusters to keep (seed 003, Sections 3.1-3.3 and 4.2, Eq. 7-12,
//! Tables 3-8).
//!
//! 1. Similarity: `|r_ij|`, Pearson's correlation of temperature variables i
//!    and j (Eq. 11-12). Seed 003's variables were all positively correlated;
//!    the absolute value keeps the fuzzy similarity in [0, 1] and treats a
//!    strongly negative pair as the redundant pair it is.
//! 2. The maximal spanning tree of the complete graph weighted by the
//!    similarity, by Prim's method from variable 1 ([`prim`]).
//! 3. Levels ([`levels`]): for every distinct edge weight `lambda` of the tree,
//!    ascending, the partition left when the edges lighter than `lambda` are
//!    cut (edges with weight >= lambda kept). The first level is one group of
//!    every variable; each next one splits off more. Seed 003 Table 3 lists
//!    the same partitions by threshold interval: its row `[a, b)` is the level
//!    `lambda = b` here (the interval's upper end is the first weight still
//!    kept), and its last row (all singletons, above the heaviest edge) has no
//!    level, since there is one level per distinct edge weight.
//! 4. Representatives ([`representatives`]): in each group, the variable with
//!    the largest `|r|` with the target (seed 003 Table 4 -> Table 5).
//! 5. How many ([`choose`]): regress the target on each level's
//!    representatives (least squares with intercept) and score R^2 and the
//!    regression's F test (Eq. 7-8). Seed 003 takes the largest R^2 among the
//!    levels whose regression is significant (Tables 6-8: five variables,
//!    Sig. 0.008; six, 0.058, rejected at 0.05). On a long time series every
//!    F test is significant, so two guards follow:
//!    - a level with a regressor whose tolerance `1/VIF` is below
//!      `min_tolerance` is left out (SPSS REGRESSION's default
//!      TOLERANCE(.0001), which is how seed 003 reports "the tolerance is
//!      exceeded" for more than six variables);
//!    - parsimony: with `R*` the best R^2 among the remaining significant
//!      levels, the chosen level is the smallest one whose R^2 is at least
//!      `R* - min_gain`: a larger set must buy at least `min_gain` of R^2.
//!      With `min_gain = 0` this is exactly seed 003's rule.
//!
//!    When no level passes, the level with the smallest p-value is taken and
//!    the choice says so ([`Choice::fallback`]).

/// An edge of the maximal tree.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Edge {
    /// One end (variable index).
    pub a: usize,
    /// The other end, the vertex Prim's method added with this edge.
    pub b: usize,
    /// Similarity between them.
    pub weight: f64,
}

/// Maximal spanning tree of the symmetric similarity matrix by Prim's method
/// from vertex 0, in the order the edges were added (O(m^2)). Ties go to the
/// lower index.
pub fn prim(sim: &[Vec<f64>]) -> Vec<Edge> {
    let m = sim.len();
    if m == 0 {
        return Vec::new();
    }
    let mut in_tree = vec![false; m];
    in_tree[0] = true;
    // best[v] = (weight, tree vertex) of v's heaviest edge into the tree.
    let mut best: Vec<(f64, usize)> = (0..m).map(|v| (sim[0][v], 0)).collect();
    let mut edges = Vec::with_capacity(m - 1);
    for _ in 1..m {
        let mut pick: Option<usize> = None;
        for v in 0..m {
            if !in_tree[v] && pick.is_none_or(|p| best[v].0 > best[p].0) {
                pick = Some(v);
            }
        }
        let Some(v) = pick else { break };
        in_tree[v] = true;
        edges.push(Edge {
            a: best[v].1,
            b: v,
            weight: best[v].0,
        });
        for u in 0..m {
            if !in_tree[u] && sim[v][u] > best[u].0 {
                best[u] = (sim[v][u], v);
            }
        }
    }
    edges
}

/// One level of the clustering: the partition at threshold `lambda`.
#[derive(Clone, Debug, PartialEq)]
pub struct Level {
    /// The threshold: edges with weight >= lambda are kept.
    pub lambda: f64,
    /// The groups, ordered by their first member, members ascending.
    pub groups: Vec<Vec<usize>>,
}

/// The partition of `0..m` left by keeping the `edges` with weight >=
/// `lambda`.
pub fn partition(m: usize, edges: &[Edge], lambda: f64) -> Vec<Vec<usize>> {
    let mut parent: Vec<usize> = (0..m).collect();
    fn root(parent: &mut [usize], mut x: usize) -> usize {
        while parent[x] != x {
            parent[x] = parent[parent[x]];
            x = parent[x];
        }
        x
    }
    for e in edges.iter().filter(|e| e.weight >= lambda) {
        let (ra, rb) = (root(&mut parent, e.a), root(&mut parent, e.b));
        if ra != rb {
            parent[ra.max(rb)] = ra.min(rb);
        }
    }
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut slot = vec![usize::MAX; m];
    for v in 0..m {
        let r = root(&mut parent, v);
        if slot[r] == usize::MAX {
            slot[r] = groups.len();
            groups.push(Vec::new());
        }
        groups[slot[r]].push(v);
    }
    groups
}

/// One level per distinct edge weight, ascending `lambda` (module docs).
pub fn levels(m: usize, edges: &[Edge]) -> Vec<Level> {
    let mut weights: Vec<f64> = edges.iter().map(|e| e.weight).collect();
    weights.sort_by(f64::total_cmp);
    weights.dedup();
    weights
        .into_iter()
        .map(|lambda| Level {
            lambda,
            groups: partition(m, edges, lambda),
        })
        .collect()
}

/// The member of each group with the largest `|r|` with the target (the
/// first on ties), ascending.
pub fn representatives(groups: &[Vec<usize>], target_r: &[f64]) -> Vec<usize> {
    let mut reps: Vec<usize> = groups
        .iter()
        .filter_map(|g| {
            g.iter().copied().reduce(|best, j| {
                if target_r[j].abs() > target_r[best].abs() {
                    j
                } else {
                    best
                }
            })
        })
        .collect();
    reps.sort_unstable();
    reps
}

/// What [`choose`] needs to know about one level's regression.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LevelScore {
    /// R^2 of the target on the level's representatives.
    pub r2: f64,
    /// p-value of the regression's F test (NaN when it has none).
    pub p_value: f64,
    /// Smallest tolerance `1/VIF` among the representatives.
    pub min_tolerance: f64,
}

/// Which level [`choose`] took, and why.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Choice {
    /// Index into the levels.
    pub index: usize,
    /// Whether no level passed the tests and the smallest p-value was taken.
    pub fallback: bool,
}

/// Seed 003's rule with the collinearity and parsimony guards (module docs).
/// `scores` are in level order (growing sets). `None` only for no levels.
pub fn choose(
    scores: &[LevelScore],
    alpha: f64,
    min_gain: f64,
    min_tolerance: f64,
) -> Option<Choice> {
    let passes =
        |s: &LevelScore| s.p_value < alpha && s.min_tolerance >= min_tolerance && s.r2.is_finite();
    let best = scores
        .iter()
        .filter(|s| passes(s))
        .map(|s| s.r2)
        .fold(f64::NEG_INFINITY, f64::max);
    if best.is_finite() {
        let index = scores
            .iter()
            .position(|s| passes(s) && s.r2 >= best - min_gain)?;
        return Some(Choice {
            index,
            fallback: false,
        });
    }
    let p = |s: &LevelScore| if s.p_value.is_nan() { 1.0 } else { s.p_value };
    let index =
        (0..scores.len()).reduce(|a, b| if p(&scores[b]) < p(&scores[a]) { b } else { a })?;
    Some(Choice {
        index,
        fallback: true,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prim_by_hand() {
        // Weights: 0-1 0.9, 0-2 0.2, 0-3 0.5, 1-2 0.3, 1-3 0.8, 2-3 0.7.
        // From 0: take 1 (0.9); then 3 via 1 (0.8); then 2 via 3 (0.7).
        let s = vec![
            vec![1.0, 0.9, 0.2, 0.5],
            vec![0.9, 1.0, 0.3, 0.8],
            vec![0.2, 0.3, 1.0, 0.7],
            vec![0.5, 0.8, 0.7, 1.0],
        ];
        let e = prim(&s);
        let got: Vec<(usize, usize, f64)> = e.iter().map(|e| (e.a, e.b, e.weight)).collect();
        assert_eq!(got, vec![(0, 1, 0.9), (1, 3, 0.8), (3, 2, 0.7)]);
        let l = levels(4, &e);
        assert_eq!(l.len(), 3);
        assert_eq!(l[0].groups, vec![vec![0, 1, 2, 3]]);
        assert_eq!(l[1].groups, vec![vec![0, 1, 3], vec![2]]);
        assert_eq!(l[2].lambda, 0.9);
        assert_eq!(l[2].groups, vec![vec![0, 1], vec![2], vec![3]]);
    }

    #[test]
    fn tied_weights_make_one_level() {
        let s = vec![
            vec![1.0, 0.8, 0.1],
            vec![0.8, 1.0, 0.8],
            vec![0.1, 0.8, 1.0],
        ];
        let l = levels(3, &prim(&s));
        assert_eq!(l.len(), 1);
        assert_eq!(l[0].groups, vec![vec![0, 1, 2]]);
    }

    /// Kruskal's algorithm, the second implementation for the property test.
    fn kruskal_weight(sim: &[Vec<f64>]) -> f64 {
        let m = sim.len();
        let mut e: Vec<(f64, usize, usize)> = (0..m)
            .flat_map(|i| ((i + 1)..m).map(move |j| (i, j)))
            .map(|(i, j)| (sim[i][j], i, j))
            .collect();
        e.sort_by(|a, b| b.0.total_cmp(&a.0));
        let mut comp: Vec<usize> = (0..m).collect();
        let mut total = 0.0;
        for (w, i, j) in e {
            let (ci, cj) = (comp[i], comp[j]);
            if ci != cj {
                total += w;
                comp.iter_mut().filter(|c| **c == cj).for_each(|c| *c = ci);
            }
        }
        total
    }

    #[test]
    fn prim_agrees_with_kruskal() {
        // Two implementations agree on the total weight of the maximal tree
        // (the tree itself is unique only without ties). Exact sums of the
        // same terms in another order: tolerance 1e-12.
        let mut s = 7u64;
        let mut rnd = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        for m in 2..12 {
            let mut sim = vec![vec![1.0; m]; m];
            let pairs: Vec<(usize, usize)> = (0..m)
                .flat_map(|i| ((i + 1)..m).map(move |j| (i, j)))
                .collect();
            for (i, j) in pairs {
                let v = rnd();
                sim[i][j] = v;
                sim[j][i] = v;
            }
            let e = prim(&sim);
            assert_eq!(e.len(), m - 1);
            let w: f64 = e.iter().map(|e| e.weight).sum();
            assert!((w - kruskal_weight(&sim)).abs() < 1e-12, "m = {m}");
            let l = levels(m, &e);
            // Each level splits off one more group (distinct random weights).
            for (k, lv) in l.iter().enumerate() {
                assert_eq!(lv.groups.len(), k + 1);
                assert_eq!(lv.groups.iter().map(Vec::len).sum::<usize>(), m);
            }
        }
    }

    /// Seed 003 Table 3, keyed as here by `lambda` = the upper end of each
    /// threshold interval (1-based variable numbers).
    fn seed003_table3() -> Vec<(f64, Vec<Vec<usize>>)> {
        vec![
            (0.94943, vec![vec![1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11]]),
            (0.96927, vec![vec![1, 2, 3, 4, 5, 6, 7, 8, 9, 10], vec![11]]),
            (
                0.97348,
                vec![vec![1, 2, 3, 4, 5, 6, 8, 9, 10], vec![7], vec![11]],
            ),
            (
                0.97891,
                vec![vec![1, 5, 6, 9, 10], vec![2, 3, 4, 8], vec![7], vec![11]],
            ),
            (
                0.98226,
                vec![
                    vec![1],
                    vec![2, 3, 4, 8],
                    vec![5, 6, 9, 10],
                    vec![7],
                    vec![11],
                ],
            ),
            (
                0.98288,
                vec![
                    vec![1],
                    vec![2, 3, 4, 8],
                    vec![5, 6],
                    vec![7],
                    vec![9, 10],
                    vec![11],
                ],
            ),
            (
                0.98366,
                vec![
                    vec![1],
                    vec![2, 3, 4, 8],
                    vec![5],
                    vec![6],
                    vec![7],
                    vec![9, 10],
                    vec![11],
                ],
            ),
            (
                0.98747,
                vec![
                    vec![1],
                    vec![2],
                    vec![3, 4, 8],
                    vec![5],
                    vec![6],
                    vec![7],
                    vec![9, 10],
                    vec![11],
                ],
            ),
            (
                0.98947,
                vec![
                    vec![1],
                    vec![2],
                    vec![3],
                    vec![4, 8],
                    vec![5],
                    vec![6],
                    vec![7],
                    vec![9, 10],
                    vec![11],
                ],
            ),
            (
                0.9921,
                vec![
                    vec![1],
                    vec![2],
                    vec![3],
                    vec![4, 8],
                    vec![5],
                    vec![6],
                    vec![7],
                    vec![9],
                    vec![10],
                    vec![11],
                ],
            ),
        ]
    }

    /// The similarity matrix of seed 003's maximal tree.
    ///
    /// Eq. 12's 66 numbers survive in the extracted text but not their
    /// layout: no row- or column-wise reading of a triangle puts its eleven
    /// 1s on the diagonal, so the full matrix cannot be rebuilt. What the
    /// paper does state fixes the tree: the ten distinct thresholds of
    /// Table 3 are its edge weights, the groups each threshold separates say
    /// which subtrees each edge joins, and Section 4.2 (2) names r_1,9 =
    /// 0.97891, r_9,10 = 0.98947 and r_1,5 = 0.97532. Where the paper does
    /// not name the pair across two groups, any pair gives the same
    /// partitions; the ones below are marked "(pair chosen)". Every other
    /// entry is 0.5, below every tree edge, so the tree is exactly this one.
    fn seed003_similarity() -> Vec<Vec<f64>> {
        let edges = [
            (1, 9, 0.97891),  // stated
            (9, 10, 0.98947), // stated
            (5, 6, 0.98288),  // the only pair
            (4, 8, 0.9921),   // the only pair
            (5, 9, 0.98226),  // {5,6} - {9,10} (pair chosen)
            (6, 8, 0.97348),  // {1,5,6,9,10} - {2,3,4,8} (pair chosen)
            (2, 4, 0.98366),  // {2} - {3,4,8} (pair chosen)
            (3, 8, 0.98747),  // {3} - {4,8} (pair chosen)
            (4, 7, 0.96927),  // {7} - rest (pair chosen)
            (2, 11, 0.94943), // {11} - rest (pair chosen)
            (1, 5, 0.97532),  // stated; not a tree edge (5 joins 9 at 0.98226)
        ];
        let mut s = vec![vec![0.5; 11]; 11];
        for (i, row) in s.iter_mut().enumerate() {
            row[i] = 1.0;
        }
        for (a, b, w) in edges {
            s[a - 1][b - 1] = w;
            s[b - 1][a - 1] = w;
        }
        s
    }

    #[test]
    fn seed003_table3_partitions() {
        let sim = seed003_similarity();
        let e = prim(&sim);
        // Section 4.2 (2): from variable 1 the first edge is r_1,9, then
        // r_9,10 beats r_1,5.
        assert_eq!((e[0].a, e[0].b, e[0].weight), (0, 8, 0.97891));
        assert_eq!((e[1].a, e[1].b, e[1].weight), (8, 9, 0.98947));
        let got = levels(11, &e);
        let want = seed003_table3();
        assert_eq!(got.len(), want.len(), "one level per distinct edge weight");
        for (g, (lambda, groups)) in got.iter().zip(want) {
            assert_eq!(g.lambda, lambda);
            let one_based: Vec<Vec<usize>> = g
                .groups
                .iter()
                .map(|grp| grp.iter().map(|v| v + 1).collect())
                .collect();
            assert_eq!(one_based, groups, "lambda = {lambda}");
        }
    }

    #[test]
    fn seed003_table5_representatives() {
        // Table 4: |r| of T1..T11 with the slope k_i; Table 5 rows 1-10 are
        // the representatives of the ten levels (row 11, all eleven, is the
        // all-singletons row that has no level here).
        let r = [
            0.9725, 0.9660, 0.9538, 0.9160, 0.9814, 0.9673, 0.8536, 0.9382, 0.9667, 0.9440, 0.8889,
        ];
        let table5: [&[usize]; 10] = [
            &[5],
            &[5, 11],
            &[5, 7, 11],
            &[2, 5, 7, 11],
            &[1, 2, 5, 7, 11],
            &[1, 2, 5, 7, 9, 11],
            &[1, 2, 5, 6, 7, 9, 11],
            &[1, 2, 3, 5, 6, 7, 9, 11],
            &[1, 2, 3, 5, 6, 7, 8, 9, 11],
            &[1, 2, 3, 5, 6, 7, 8, 9, 10, 11],
        ];
        let lv = levels(11, &prim(&seed003_similarity()));
        for (l, want) in lv.iter().zip(table5) {
            let got: Vec<usize> = representatives(&l.groups, &r)
                .iter()
                .map(|v| v + 1)
                .collect();
            assert_eq!(got, want);
        }
    }

    #[test]
    fn seed003_tables6_to_8_choice() {
        // Table 6's R^2 for 1..6 variables; p-values of levels 5 and 6 from
        // Tables 7-8, the others from F on n = 8 rows (all far below 0.05).
        let r2 = [0.963, 0.963, 0.971, 0.989, 0.997, 0.999];
        let p = [2e-5, 3e-4, 1e-3, 2e-3, 0.008, 0.058];
        let scores: Vec<LevelScore> = r2
            .iter()
            .zip(p)
            .map(|(&r2, p_value)| LevelScore {
                r2,
                p_value,
                min_tolerance: 0.5,
            })
            .collect();
        // Seed 003's own rule (no parsimony): five variables (index 4).
        assert_eq!(
            choose(&scores, 0.05, 0.0, 1e-4),
            Some(Choice {
                index: 4,
                fallback: false
            })
        );
        // The default guard: five variables buy 0.008 of R^2 over four,
        // less than 0.01, so four are kept.
        assert_eq!(choose(&scores, 0.05, 0.01, 1e-4).map(|c| c.index), Some(3));
        // At alpha = 0.1 the sixth is significant and best.
        assert_eq!(choose(&scores, 0.1, 0.0, 1e-4).map(|c| c.index), Some(5));
        // A level whose tolerance is exceeded is out.
        let mut s2 = scores.clone();
        s2[4].min_tolerance = 1e-6;
        assert_eq!(choose(&s2, 0.05, 0.0, 1e-4).map(|c| c.index), Some(3));
        // Nothing significant: the smallest p-value, flagged.
        assert_eq!(
            choose(&scores, 1e-9, 0.0, 1e-4),
            Some(Choice {
                index: 0,
                fallback: true
            })
        );
        assert_eq!(choose(&[], 0.05, 0.0, 1e-4), None);
    }
}
