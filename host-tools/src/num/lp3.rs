//! A linear programme in three non-negative unknowns, solved exactly by
//! visiting the vertices of its feasible set:
//!
//! ```text
//! maximise g . c   subject to   a_i . c <= b_i (i = 1..m),   c >= 0
//! ```
//!
//! The optimum of a bounded, feasible LP lies on a vertex, and a vertex in
//! three dimensions is where three of the `m + 3` constraints hold with
//! equality; so every triple of constraints is solved (3 x 3, Cramer) and
//! the feasible solution with the largest objective kept. `O(m^4)`: meant
//! for the few tens of constraints of a lower envelope (one per speed bin),
//! where it is both exact and fast (40 constraints: ~0.5 ms).

/// Relative slack allowed when checking a vertex against the constraints.
const FEAS_TOL: f64 = 1e-9;

/// The maximiser of `g . c` over `{c >= 0, a_i . c <= b_i}`, or `None` when
/// no vertex is feasible (an empty set, or a problem with no vertex).
/// Unbounded problems are not detected: give the unknowns bounds through
/// the rows (a lower envelope is bounded by its data).
pub fn maximise3(g: [f64; 3], a: &[[f64; 3]], b: &[f64]) -> Option<[f64; 3]> {
    let mut rows: Vec<([f64; 3], f64)> = a.iter().copied().zip(b.iter().copied()).collect();
    rows.push(([-1.0, 0.0, 0.0], 0.0));
    rows.push(([0.0, -1.0, 0.0], 0.0));
    rows.push(([0.0, 0.0, -1.0], 0.0));
    let scale = b.iter().fold(1.0f64, |m, v| m.max(v.abs()));
    let feasible = |c: &[f64; 3]| {
        rows.iter()
            .all(|(r, bi)| dot(r, c) <= bi + FEAS_TOL * scale.max(bi.abs()))
    };
    let mut best: Option<([f64; 3], f64)> = None;
    let m = rows.len();
    for i in 0..m {
        for j in i + 1..m {
            for k in j + 1..m {
                let Some(c) = solve3(
                    [rows[i].0, rows[j].0, rows[k].0],
                    [rows[i].1, rows[j].1, rows[k].1],
                ) else {
                    continue;
                };
                if !feasible(&c) {
                    continue;
                }
                let v = dot(&g, &c);
                if best.is_none_or(|(_, bv)| v > bv) {
                    best = Some((c, v));
                }
            }
        }
    }
    best.map(|(c, _)| c)
}

fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Solves `m c = r` by Cramer's rule; `None` when `m` is (nearly) singular.
fn solve3(m: [[f64; 3]; 3], r: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(&m);
    let size = m.iter().flatten().fold(0.0f64, |a, v| a.max(v.abs()));
    if d.abs() <= 1e-12 * size.powi(3) {
        return None;
    }
    let mut c = [0.0; 3];
    for (col, ci) in c.iter_mut().enumerate() {
        let mut mc = m;
        for (row, mr) in mc.iter_mut().enumerate() {
            mr[col] = r[row];
        }
        *ci = det(&mc) / d;
    }
    Some(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_vertex_of_a_textbook_programme() {
        // max 3x + 2y + z, x + y + z <= 4, x + 3y <= 6, x <= 3, z <= 2:
        // x = 3 (bound), then y + z <= 1 and 3y <= 3: z gives 1 per unit and
        // y 2, so y = 1, z = 0: objective 11. Exact vertex: 1e-12.
        let c = maximise3(
            [3.0, 2.0, 1.0],
            &[
                [1.0, 1.0, 1.0],
                [1.0, 3.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 0.0, 1.0],
            ],
            &[4.0, 6.0, 3.0, 2.0],
        )
        .unwrap();
        for (got, want) in c.iter().zip([3.0, 1.0, 0.0]) {
            assert!((got - want).abs() < 1e-12, "{c:?}");
        }
    }

    #[test]
    fn an_empty_set_has_no_solution() {
        // x + y + z <= -1 with c >= 0 is empty.
        assert!(maximise3([1.0, 1.0, 1.0], &[[1.0, 1.0, 1.0]], &[-1.0]).is_none());
    }
}
