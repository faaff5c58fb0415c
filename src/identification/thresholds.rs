//! Where the play thresholds go, and whether the data's minor loops are
//! what a Prandtl–Ishlinskii model can follow.
//!
//! (23) spaces the thresholds evenly over `[0, max|u|)`: a loop of
//! half-amplitude `a` is shaped only by the plays with `r < a`, so on a
//! record of small loops (a controller's jagged output, a tracking task)
//! most plays never move. [`reversal_thresholds`] follows the data: half of
//! the thresholds by (23), the other half at the quantiles of the
//! half-amplitudes of the input's reversals — two scales, the whole range
//! and the loops the record actually makes.
//!
//! A PI operator (and any Preisach operator) makes congruent minor loops:
//! by Masing's rule the branch from a turning point `u_a` is
//! `y(u_a) ± 2 F(|u − u_a|/2)`, the same curve of `s = |u − u_a|` from every
//! turning point until it meets the memory. [`branch_congruence`] measures
//! how far the data's branches are from one curve: if they differ by more
//! than the noise, no choice of thresholds makes a PI model follow them.

use super::report::range;
use super::settings::{thresholds_23, IdentificationError};

/// The turning points of `u` (indices), ignoring wiggles below `dead_band`.
pub fn reversals(u: &[f64], dead_band: f64) -> Vec<usize> {
    let mut out = Vec::new();
    if u.is_empty() {
        return out;
    }
    let (mut extreme, mut rising) = (0usize, None::<bool>);
    for (k, &v) in u.iter().enumerate().skip(1) {
        let e = u[extreme];
        match rising {
            None => {
                if (v - e).abs() > dead_band {
                    out.push(extreme);
                    rising = Some(v > e);
                    extreme = k;
                } else if (v - u[0]).abs() < (e - u[0]).abs() {
                    // still at the start
                } else {
                    extreme = k;
                }
            }
            Some(up) => {
                if (up && v > e) || (!up && v < e) {
                    extreme = k;
                } else if (v - e).abs() > dead_band {
                    out.push(extreme);
                    rising = Some(!up);
                    extreme = k;
                }
            }
        }
    }
    out.push(extreme);
    out
}

/// `count` thresholds (`r_0 = 0`, strictly increasing, below `max|u|`):
/// `⌈count/2⌉` by (23) and the rest at the quantiles of the reversals'
/// half-amplitudes of `u` (dead band 0.1 % of its range). Too few
/// reversals for the quantiles is an error.
pub fn reversal_thresholds(u: &[f64], count: usize) -> Result<Vec<f64>, IdentificationError> {
    let r_max = u.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let range_u = range(u);
    let turns = reversals(u, 1e-3 * range_u);
    let mut half: Vec<f64> = turns
        .windows(2)
        .map(|w| 0.5 * (u[w[1]] - u[w[0]]).abs())
        .filter(|a| *a > 0.0)
        .collect();
    let from_data = count / 2;
    if half.len() < 2 * from_data.max(1) {
        return Err(IdentificationError::InvalidSetting {
            field: "thresholds",
            reason: format!(
                "{} reversals are too few to place {from_data} thresholds by their amplitudes",
                half.len()
            ),
        });
    }
    half.sort_by(f64::total_cmp);
    let mut r = thresholds_23(count - from_data, r_max);
    // a quantile at or above max|u| would never move: it stays below
    let top = r_max * (1.0 - 1e-6);
    for i in 1..=from_data {
        let q = i as f64 / (from_data + 1) as f64;
        r.push(half[((q * half.len() as f64) as usize).min(half.len() - 1)].min(top));
    }
    r.sort_by(f64::total_cmp);
    // strictly increasing: a repeated value moves halfway to the next
    let mut out: Vec<f64> = Vec::with_capacity(r.len());
    for (i, &v) in r.iter().enumerate() {
        let v = match out.last() {
            Some(&p) if v <= p => {
                let next = r[i + 1..]
                    .iter()
                    .copied()
                    .find(|&x| x > p)
                    .unwrap_or(r_max.max(p));
                0.5 * (p + next)
            }
            _ => v,
        };
        out.push(v);
    }
    Ok(out)
}

/// How congruent the branches between turning points are.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Congruence {
    /// Branches compared (each at least `span` long).
    pub branches: usize,
    /// The common span `s` compared (input units).
    pub span: f64,
    /// The rms over branches and points of `y(u_a ± s) − y(u_a)` from its
    /// median over the branches, in % of the output range.
    pub spread_percent: f64,
}

/// The median length `|u_b − u_a|` of the branches between turning points
/// (dead band 0.1 % of the range), or `None` without two branches.
pub fn median_branch(u: &[f64]) -> Option<f64> {
    let range_u = range(u);
    let turns = reversals(u, 1e-3 * range_u);
    let mut lengths: Vec<f64> = turns
        .windows(2)
        .map(|w| (u[w[1]] - u[w[0]]).abs())
        .collect();
    if lengths.len() < 2 {
        return None;
    }
    lengths.sort_by(f64::total_cmp);
    Some(lengths[lengths.len() / 2])
}

/// [`Congruence`] of the branches of `(u, y)` from sample `from` on that
/// reach at least `span` from their turning point (rising and falling
/// branches each against their own median; 8 points per branch).
pub fn branch_congruence(u: &[f64], y: &[f64], from: usize, span: f64) -> Option<Congruence> {
    let u = &u[from.min(u.len())..];
    let y = &y[from.min(y.len())..];
    let range_u = range(u);
    let range_y = range(y);
    let turns = reversals(u, 1e-3 * range_u);
    const POINTS: usize = 8;
    // per direction, each branch's displacement at s = span · j / POINTS
    let mut curves: [Vec<[f64; POINTS]>; 2] = [Vec::new(), Vec::new()];
    for w in turns.windows(2) {
        let (a, b) = (w[0], w[1]);
        let up = u[b] > u[a];
        if (u[b] - u[a]).abs() < span {
            continue;
        }
        let mut curve = [0.0; POINTS];
        let mut k = a;
        for (j, c) in curve.iter_mut().enumerate() {
            let s = span * (j + 1) as f64 / POINTS as f64;
            while k < b && (u[k + 1] - u[a]).abs() < s {
                k += 1;
            }
            // interpolate between k and k + 1
            let (s0, s1) = ((u[k] - u[a]).abs(), (u[(k + 1).min(b)] - u[a]).abs());
            let t = if s1 > s0 { (s - s0) / (s1 - s0) } else { 0.0 };
            let yk = y[k] + t.clamp(0.0, 1.0) * (y[(k + 1).min(b)] - y[k]);
            *c = yk - y[a];
        }
        curves[usize::from(up)].push(curve);
    }
    let (mut sq, mut n) = (0.0, 0usize);
    for set in &curves {
        if set.len() < 2 {
            continue;
        }
        for j in 0..POINTS {
            let mut column: Vec<f64> = set.iter().map(|c| c[j]).collect();
            column.sort_by(f64::total_cmp);
            let median = column[column.len() / 2];
            for c in set {
                sq += (c[j] - median) * (c[j] - median);
                n += 1;
            }
        }
    }
    (n > 0).then(|| Congruence {
        branches: curves[0].len() + curves[1].len(),
        span,
        spread_percent: 100.0 * (sq / n as f64).sqrt() / range_y.max(f64::MIN_POSITIVE),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reversals_of_a_zigzag_are_its_corners() {
        let u = [0.0, 1.0, 2.0, 1.0, 0.0, 3.0, 2.5, 2.0];
        assert_eq!(reversals(&u, 0.1), vec![0, 2, 4, 5, 7]);
    }

    #[test]
    fn thresholds_follow_small_loops() {
        // loops of half-amplitudes 2 to 10 around 0 inside a ±100 range
        let mut u = vec![-100.0, 100.0];
        for k in 0..100 {
            let a = 2.0 + (k % 9) as f64;
            u.push(if k % 2 == 0 { a } else { -a });
        }
        let r = reversal_thresholds(&u, 12).unwrap();
        assert_eq!(r.len(), 12);
        assert_eq!(r[0], 0.0);
        assert!(r.windows(2).all(|w| w[0] < w[1]), "{r:?}");
        // (23) alone puts one threshold below 10 (100/6 apart); the rule
        // puts the six quantiles of the small loops there too
        assert!(r.iter().filter(|&&x| x < 10.0).count() >= 6, "{r:?}");
    }
}
