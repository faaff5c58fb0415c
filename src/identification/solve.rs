//! Stage 2 of an identification: the constrained least-squares problem on
//! the triangular factor — its numerical rank (singular values), the
//! non-negative least-squares solve by the Lawson–Hanson active-set method in
//! the shifted partial sums, and the weights rebuilt from the sums so that
//! (11) and (17) hold in floating point.

use faer::Mat;

use super::settings::IdentificationError;

/// Singular values of `R` below this fraction of the largest span directions
/// of the weights that the input does not determine: a column whose part
/// independent of the others is below 1e-10 of the largest could be seen
/// only at a noise level of 1e-10 of the signal.
pub const RANK_TOLERANCE: f64 = 1e-10;

/// The singular values of a small square matrix, descending.
pub(super) fn singular_values(a: &Mat<f64>) -> Vec<f64> {
    if a.nrows() == 0 {
        return Vec::new();
    }
    match a.singular_values() {
        Ok(s) => s,
        Err(_) => vec![f64::NAN; a.nrows()],
    }
}

/// The columns (operators) with a large share in the null space of `r`
/// beyond its numerical `rank`: those whose weights the data do not fix.
pub(super) fn null_space_members(r: &Mat<f64>, rank: usize) -> Vec<usize> {
    let p = r.ncols();
    if rank >= p {
        return Vec::new();
    }
    let Ok(svd) = r.svd() else {
        return Vec::new();
    };
    let v = svd.V();
    // per column: its weight in the null space (the rows of V beyond rank)
    let share: Vec<f64> = (0..p)
        .map(|j| (rank..p).map(|k| v[(j, k)] * v[(j, k)]).sum::<f64>().sqrt())
        .collect();
    let big = share.iter().fold(0.0f64, |m, x| m.max(*x));
    (0..p).filter(|&j| share[j] > 0.1 * big).collect()
}

/// The result of [`nnls`].
pub(super) struct NnlsSolution {
    pub(super) x: Vec<f64>,
    pub(super) kkt_residual: f64,
    pub(super) iterations: usize,
}

/// Minimum-norm least squares `min ‖A_P z − d‖` on the columns `P` of `a`,
/// through the SVD with the rank cut of [`RANK_TOLERANCE`].
fn least_squares(a: &Mat<f64>, cols: &[usize], d: &[f64]) -> Vec<f64> {
    let rows = a.nrows();
    let sub = Mat::from_fn(rows, cols.len(), |i, k| a[(i, cols[k])]);
    let Ok(svd) = sub.thin_svd() else {
        return vec![0.0; cols.len()];
    };
    let (u, s, v) = (svd.U(), svd.S(), svd.V());
    let smax = (0..s.dim()).map(|k| s[k]).fold(0.0f64, f64::max);
    let mut z = vec![0.0; cols.len()];
    for k in 0..s.dim() {
        if s[k] <= RANK_TOLERANCE * smax || s[k] == 0.0 {
            continue;
        }
        let coef = (0..rows).map(|i| u[(i, k)] * d[i]).sum::<f64>() / s[k];
        for (j, zj) in z.iter_mut().enumerate() {
            *zj += coef * v[(j, k)];
        }
    }
    z
}

/// `min ‖a x − d‖` subject to `x ≥ 0`: the Lawson–Hanson active-set method
/// (Lawson & Hanson, *Solving Least Squares Problems*, 1974, ch. 23). It
/// moves one variable at a time into the passive (free) set where the
/// gradient says the cost falls, solves the least-squares problem on the
/// passive set, and steps back along the segment where a passive variable
/// would turn negative; it ends at the exact optimum.
pub(super) fn nnls(a: &Mat<f64>, d: &[f64]) -> Result<NnlsSolution, IdentificationError> {
    let (rows, p) = (a.nrows(), a.ncols());
    let a_norm = (0..rows)
        .flat_map(|i| (0..p).map(move |j| (i, j)))
        .map(|(i, j)| a[(i, j)] * a[(i, j)])
        .sum::<f64>()
        .sqrt();
    let d_norm = d.iter().map(|x| x * x).sum::<f64>().sqrt();
    let scale = (a_norm * d_norm).max(f64::MIN_POSITIVE);
    let tol = 10.0 * p.max(1) as f64 * f64::EPSILON * scale;
    // gradient of −½‖a x − d‖²: aᵀ(d − a x)
    let descent = |x: &[f64]| -> Vec<f64> {
        let r: Vec<f64> = (0..rows)
            .map(|i| d[i] - (0..p).map(|j| a[(i, j)] * x[j]).sum::<f64>())
            .collect();
        (0..p)
            .map(|j| (0..rows).map(|i| a[(i, j)] * r[i]).sum())
            .collect()
    };
    let mut x = vec![0.0; p];
    let mut passive = vec![false; p];
    let mut iterations = 0;
    let limit = 30 * (p + 1);
    loop {
        let w = descent(&x);
        let candidate = (0..p)
            .filter(|&j| !passive[j] && w[j] > tol)
            .max_by(|&i, &j| w[i].total_cmp(&w[j]));
        let Some(t) = candidate else { break };
        passive[t] = true;
        loop {
            iterations += 1;
            if iterations > limit {
                return Err(IdentificationError::NotSolved {
                    reason: format!("no convergence in {limit} active-set steps"),
                });
            }
            let cols: Vec<usize> = (0..p).filter(|&j| passive[j]).collect();
            let zp = least_squares(a, &cols, d);
            let mut z = vec![0.0; p];
            for (k, &j) in cols.iter().enumerate() {
                z[j] = zp[k];
            }
            if cols.iter().all(|&j| z[j] > 0.0) {
                x = z;
                break;
            }
            // step from x toward z until the first passive variable hits 0
            let alpha = cols
                .iter()
                .filter(|&&j| z[j] <= 0.0)
                .map(|&j| x[j] / (x[j] - z[j]))
                .fold(f64::INFINITY, f64::min);
            for j in 0..p {
                x[j] += alpha * (z[j] - x[j]);
            }
            for &j in &cols {
                if x[j] <= 0.0 || (z[j] <= 0.0 && x[j] <= 1e-15 * (1.0 + x[j].abs())) {
                    x[j] = 0.0;
                    passive[j] = false;
                }
            }
        }
    }
    // KKT: descent direction zero on the free variables, ≤ 0 on the bound ones
    let w = descent(&x);
    let kkt = (0..p)
        .map(|j| {
            if x[j] > 0.0 {
                w[j].abs()
            } else {
                w[j].max(0.0)
            }
        })
        .fold(0.0f64, f64::max);
    Ok(NnlsSolution {
        x,
        kkt_residual: kkt / scale,
        iterations,
    })
}

/// `w_0 = S_0`, `w_j = S_j − S_{j−1}`, nudged up by ulps where needed so that
/// the partial sums recomputed in floating point (as the operators' checks do)
/// stay at or above `bound`.
pub(super) fn weights_from_sums(sums: &[f64], bound: f64) -> Vec<f64> {
    let mut w = Vec::with_capacity(sums.len());
    let mut prev_exact = 0.0;
    let mut running = 0.0;
    for &s in sums {
        let s = s.max(bound);
        let mut wj = s - prev_exact;
        // a few ulps of `wj` usually do; when `running` is far larger than
        // `wj` they change nothing for a very long time (a fuzzed record with
        // inputs of 1e15 took 16 s here), so then the step grows from an ulp
        // of the larger operand, doubling: O(log) steps, a few ulps above
        // the smallest such weight
        let mut ulps = 0;
        while running + wj < bound && ulps < 64 {
            wj = wj.next_up();
            ulps += 1;
        }
        let mut step = running.abs().max(bound.abs()) * f64::EPSILON;
        while running + wj < bound {
            wj = wj.max(bound - running) + step;
            step = (2.0 * step).max(f64::MIN_POSITIVE);
        }
        running += wj;
        prev_exact = s;
        w.push(wj);
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_from_sums_keep_recomputed_sums_at_the_bound() {
        let sums = [0.3, 0.1 + 0.2, 1e-3, 0.7, 1e-3];
        let w = weights_from_sums(&sums, 1e-3);
        let mut s = 0.0;
        for wj in w {
            s += wj;
            assert!(s >= 1e-3);
        }
        let w = weights_from_sums(&[0.5, 0.0, 0.25, 0.0], 0.0);
        let mut s = 0.0;
        for wj in w {
            s += wj;
            assert!(s >= 0.0);
        }
    }

    /// Fuzzing finding (`fuzz/regressions/trace_csv/`): a running sum whose
    /// ulp is 10⁸ of the step's took ulp steps for seconds (16 s on the
    /// fuzzed record; more than 10⁷ steps on these sums, found by search).
    #[test]
    fn weights_from_sums_are_quick_when_the_sum_dwarfs_the_step() {
        let sums = [
            9.945799809269083e-15,
            3.092264566010291e-15,
            3.0922645657010645e-15,
        ];
        let bound = sums[2];
        let w = weights_from_sums(&sums, bound);
        let mut s = 0.0;
        for (wj, exact) in w.iter().zip(sums) {
            s += wj;
            assert!(s >= bound, "{s} below the bound {bound}");
            // a few ulps of the sum above the exact one, no more
            assert!(
                s - exact.max(bound) <= 8.0 * f64::EPSILON * 1e-14,
                "{s} vs {exact}"
            );
        }
    }
}
