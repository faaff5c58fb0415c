//! The branching rules of the PI operator that the paper's Fig. 8 shows in
//! measurements: Madelung rules (i)–(iii), the Masing rule, and the
//! intersection property (SPEC section 10).
//!
//! Histories are built from *nested* extrema `e_0, e_1, …`: each new extremum
//! lies strictly between the two before it, so each reversal opens a minor loop
//! inside the previous one. The input moves linearly between extrema, sampled
//! with a few intermediate points.

mod common;

use common::*;
use mfcbeam::prelude::*;
use proptest::prelude::*;

/// Nested extrema: `e_0 = a0 > 0`, `e_1 = −a1 < 0`, `e_{k+1} = e_k + f_k (e_{k−1} − e_k)`.
fn nested_extrema(a0: f64, a1: f64, fractions: &[f64]) -> Vec<f64> {
    let mut e = vec![a0, -a1];
    for &f in fractions {
        let n = e.len();
        e.push(e[n - 1] + f * (e[n - 2] - e[n - 1]));
    }
    e
}

/// Samples from `from` (exclusive) to `to` (inclusive, exactly) in `sub` steps.
fn segment(from: f64, to: f64, sub: usize) -> Vec<f64> {
    (1..=sub)
        .map(|j| {
            if j == sub {
                to
            } else {
                from + (to - from) * j as f64 / sub as f64
            }
        })
        .collect()
}

/// A path from 0 through the given points.
fn path(points: &[f64], sub: usize) -> Vec<f64> {
    let mut out = vec![0.0];
    let mut last = 0.0;
    for &p in points {
        out.extend(segment(last, p, sub));
        last = p;
    }
    out
}

fn history() -> impl Strategy<Value = (f64, f64, Vec<f64>)> {
    (
        2.0f64..6.0,
        2.0f64..6.0,
        prop::collection::vec(0.05f64..0.95, 1..7),
    )
}

proptest! {
    #![proptest_config(config(256, "proptest-regressions/madelung_masing.txt"))]

    /// Madelung (i): the curve leaving a turning point depends only on the
    /// turning point and the dominant memory, not on minor loops that were
    /// wiped out before it: inserting such a loop earlier changes nothing.
    #[test]
    fn madelung_i_curve_from_turning_point_is_determined_by_it(
        h in hysteresis_operator(12),
        (a0, a1, f) in history(),
        at in any::<prop::sample::Index>(),
        g in 0.05f64..0.95,
        sub in 1usize..6,
    ) {
        let e = nested_extrema(a0, a1, &f);
        let k = e.len() - 1;
        // A minor loop e_j -> inner -> e_j toward e_{j+1}, wiped out by the move to e_{j+1}.
        let j = 1 + at.index(k - 1);
        let mut with_loop = e[..=j].to_vec();
        let inner = e[j] + g * (e[j + 1] - e[j]);
        with_loop.extend([inner, e[j]]);
        with_loop.extend_from_slice(&e[j + 1..]);
        // Then leave the last turning point e_k toward e_{k-1}.
        let tail = segment(e[k], e[k - 1], 7);
        let mut a = h.clone();
        let mut b = h.clone();
        a.run(&path(&e, sub));
        b.run(&path(&with_loop, sub));
        prop_assert_eq!(a.state(), b.state());
        prop_assert_eq!(a.run(&tail), b.run(&tail));
    }

    /// Madelung (ii), return-point memory: from a turning point `p1`, a
    /// reversal at `p2` on the new branch gives a curve that leads back exactly
    /// to `p1`, closing a minor loop.
    #[test]
    fn madelung_ii_minor_loop_returns_to_its_turning_point(
        h in hysteresis_operator(12),
        (a0, a1, f) in history(),
        g in 0.05f64..0.95,
        sub in 1usize..6,
    ) {
        let e = nested_extrema(a0, a1, &f);
        let k = e.len() - 1;
        let p1 = e[k];
        let p2 = p1 + g * (e[k - 1] - p1);
        let mut op = h.clone();
        let y = op.run(&path(&e, sub));
        let y_p1 = *y.last().unwrap();
        let state_p1 = op.state();
        op.run(&segment(p1, p2, sub));
        let back = op.run(&segment(p2, p1, sub));
        prop_assert_eq!(back.last().unwrap().to_bits(), y_p1.to_bits());
        prop_assert_eq!(op.state(), state_p1);
    }

    /// Madelung (iii), wiping out: continued beyond `p1`, the curve coincides
    /// with the one that led to `p1`, as if the minor loop had never happened.
    #[test]
    fn madelung_iii_continuation_beyond_p1_wipes_out_the_minor_loop(
        h in hysteresis_operator(12),
        (a0, a1, f) in history(),
        g in 0.05f64..0.95,
        beyond in 0.1f64..3.0,
        sub in 1usize..6,
    ) {
        let e = nested_extrema(a0, a1, &f);
        let k = e.len() - 1;
        let p1 = e[k];
        let p2 = p1 + g * (e[k - 1] - p1);
        let dir = (p1 - e[k - 1]).signum();
        let q = p1 + dir * beyond;
        let onward = segment(p1, q, 9);
        let mut direct = h.clone();
        direct.run(&path(&e, sub));
        let y_direct = direct.run(&onward);
        let mut looped = h.clone();
        looped.run(&path(&e, sub));
        looped.run(&segment(p1, p2, sub));
        looped.run(&segment(p2, p1, sub));
        prop_assert_eq!(looped.run(&onward), y_direct);
    }

    /// Masing rule, first part: every branch leaving a turning point
    /// `(u_R, y_R)` is the initial loading curve `φ` scaled by two,
    /// `y(u) = y_R ± 2 φ(|u − u_R| / 2)`, until it meets the dominant memory.
    #[test]
    fn masing_branches_are_the_initial_loading_curve_scaled_by_two(
        h in hysteresis_operator(12),
        (a0, a1, f) in history(),
        sub in 1usize..6,
    ) {
        let e = nested_extrema(a0, a1, &f);
        let k = e.len() - 1;
        let mut op = h.clone();
        let y_r = *op.run(&path(&e, sub)).last().unwrap();
        let u_r = e[k];
        let dir = (e[k - 1] - u_r).signum();
        let branch = segment(u_r, e[k - 1], 23);
        let y = op.run(&branch);
        let tol = 4.0 * pi_rounding(&h, 8.0);
        for (&u, &yu) in branch.iter().zip(&y) {
            let masing = y_r + dir * 2.0 * h.initial_loading((u - u_r).abs() / 2.0);
            prop_assert!((yu - masing).abs() <= tol, "u = {u}: {yu} vs {masing}");
        }
    }

    /// Masing rule, second part: an input varying between the same two
    /// extrema after different histories gives congruent minor loops (they
    /// differ only by a vertical shift).
    #[test]
    fn masing_minor_loops_between_fixed_extrema_are_congruent(
        h in hysteresis_operator(12),
        ua in -1.5f64..0.0,
        width in 0.2f64..2.0,
        hist in prop::collection::vec((2.0f64..6.0, 2.0f64..6.0, 0.1f64..3.0), 2..=2),
        cycles in 1usize..4,
    ) {
        let ub = ua + width;
        let mut loops = Vec::new();
        for &(a, b, over) in &hist {
            // 0 -> +a -> -b (below ua) -> M (above ub) -> ua, then cycles.
            let top = (ub + over).min(a.max(ub + 0.01));
            let mut op = h.clone();
            op.run(&path(&[a.max(top), -(b.max(-ua + 0.5)), top, ua], 4));
            let mut y = Vec::new();
            for _ in 0..cycles {
                y.extend(op.run(&segment(ua, ub, 11)));
                y.extend(op.run(&segment(ub, ua, 11)));
            }
            loops.push(y);
        }
        let shift = loops[0][0] - loops[1][0];
        let tol = 4.0 * pi_rounding(&h, 8.0);
        for (a, b) in loops[0].iter().zip(&loops[1]) {
            prop_assert!((a - b - shift).abs() <= tol);
        }
    }
}

/// Input value reached on an ascending branch from `m` after coming down from `top`.
fn ascending_after(h: &HysteresisOperator, top: f64, m: f64, u: f64) -> (f64, HysteresisOperator) {
    let mut op = h.clone();
    op.run(&path(&[top, m], 5));
    let y = *op.run(&segment(m, u, 5)).last().unwrap();
    (y, op)
}

/// Intersection property (Fig. 8b): several branches, all with the input
/// increasing, pass through one point of the input–output plane with
/// different slopes. The point is the virgin curve at `u*`; the other
/// branches leave the descending branches from `+1000 V` and `+900 V` at
/// reversal points found by bisection.
#[test]
fn intersection_property_several_branches_through_one_point() {
    let h = nominal_model().hysteresis().clone();
    let u_star = 200.0;
    let y_star = h.initial_loading(u_star);
    let mut slopes = vec![{
        let mut op = h.clone();
        op.run(&segment(0.0, u_star, 5));
        let y1 = op.step(u_star + 1.0);
        y1 - y_star
    }];
    for top in [1000.0, 900.0] {
        // f(m) = y(u*) − y* is negative for m = −top (outer branch) and
        // positive for m → u* (inner branch); bisect for the crossing.
        let (mut lo, mut hi) = (-top, u_star - 1e-9);
        assert!(ascending_after(&h, top, lo, u_star).0 < y_star);
        assert!(ascending_after(&h, top, hi, u_star).0 > y_star);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if ascending_after(&h, top, mid, u_star).0 < y_star {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let (y, mut op) = ascending_after(&h, top, hi, u_star);
        // The branch reaches the same point, to the rounding of the bisection.
        assert!((y - y_star).abs() <= 1e-9 * y_star.abs(), "{y} vs {y_star}");
        slopes.push(op.step(u_star + 1.0) - y);
    }
    // Distinct slopes: the branches cross rather than merge.
    for i in 0..slopes.len() {
        for j in 0..i {
            assert!(
                (slopes[i] - slopes[j]).abs() > 1e-3,
                "slopes {slopes:?} should differ"
            );
        }
    }
}
