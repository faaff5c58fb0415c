//! The derived rounding bounds of every operator ([`RoundingBounds`]).

use crate::realtime::creep::creep_gain;
use crate::realtime::dynamics::l1_gains;
use crate::realtime::parameters::{zero_index, ModelParameters};
use crate::realtime::superposition::inverse_parameters_into;

/// Rounding bounds of the operators, from first-order error analysis: how
/// far two correct implementations (or one and exact arithmetic) can differ.
/// The conformance checks use them as tolerances; firmware uses them to judge
/// its own `W[W⁻¹[y]] = y` on the target.
///
/// * A sum of `n` products `Σ w_i x_i` in floating point differs from the
///   exact one by at most `n ε Σ|w_i| max|x_i|` (Higham, Thm. 3.1, first
///   order); a play output is one of `x`, `v − r`, `v + r`, so
///   `|x_i| ≤ max|v| + r_n`. Two implementations that both round that way
///   differ by twice that; a constant 4 covers the clamps and a different
///   summation order.
/// * An inverse amplifies an error in its argument by its steepest slope
///   `1/s_min` (the partial sums `s_j` of (11) are the forward slopes).
/// * A creep update `χ ← χ + g d_r(v − χ)`, `g = 1 − e^{−aT_s}`, is
///   non-expansive and contracts by `1 − g` where it moves, and where it
///   does not move (`d_r = 0`) it adds no error (`creep_pass::update`): a
///   rounding error `δ` per moving sample accumulates to at most `δ/g`.
///   The literal form rounds by `δ ≤ ε|χ|/2` (its last addition; the
///   increment's own roundings are `g` times smaller), the fused form
///   `g c + (χ − g χ)` of `std` builds by `δ ≤ ε max(|χ|, |c|)` (two
///   roundings of values that large). That is what an implementation
///   rounding differently shows, and what `f32` shows when a slow
///   operator's increment drops below half an ulp of `χ` and it stalls:
///   the bound carries `Σ_j (1/g_j + 2)` per threshold, the fused form's
///   `δ/g` with `|χ|, |c| ≤ max|v| + r_n`. Over a run of `K` samples from
///   a common state the errors of at most `K` moving samples add:
///   `δ Σ_{k<K} (1 − g)^k = δ (1 − e^{−aKT_s})/g`, at most `K δ` and at
///   most `δ/g` ([`RoundingBounds::creep_sum_over`]); `1/g` is that sum's
///   limit, which a run reaches once `K ≫ 1/(aT_s)` (`10⁵` samples for
///   `a = 0.05 s⁻¹` at 5 kHz).
///
/// * The superposition operator `S` is a sum of `k` dead zones, rounded as
///   the hysteresis sum is; an error in its argument comes out scaled by its
///   steepest slope `σ_max`, and `S⁻¹` (slopes `1/σ`) amplifies by
///   `1/σ_min`. Its inverse parameters carry a relative rounding of order
///   `k ε` each.
///
/// * The dynamics `G` (all-pole, `y_k = g w_k − Σ c_j y_{k−j}`) carry an
///   error at their input to the output amplified by at most `‖g/A‖₁` (the
///   sum of `|h_k|` of its impulse response); a rounding made in one output
///   step, `(order + 2) ε (g|w| + Σ|c_j| |y|)`, is carried on by `‖1/A‖₁`.
///   The inverse step `(y + Σ c_j y_{k−j})/g` makes `|w| ≤ (1 + Σ|c_j|)|y|/g`
///   and rounds by `(order + 2) ε` of that.
///
/// Every bound is linear in `ε`: for another precision, pass its `ε`.
///
/// This holds the bounds of one model at precision `eps`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoundingBounds<'a> {
    pub parameters: ModelParameters<'a>,
    /// The largest `|x|` of any initial play or creep state (0 if virgin).
    pub state_max: f64,
    /// Unit roundoff times two: `f64::EPSILON` or `f32::EPSILON`.
    pub eps: f64,
}

fn abs_sum(w: &[f64]) -> f64 {
    w.iter().map(|x| x.abs()).sum()
}

fn last(r: &[f64]) -> f64 {
    r.last().copied().unwrap_or(0.0)
}

/// How far one creep update's rounding is carried over `samples` samples,
/// in units of it: `Σ_{k<K} (1 − g)^k = (1 − e^{−aKT_s})/g` with
/// `1 − g = e^{−aT_s}`, written as `creep_gain(a, K T_s) / creep_gain(a,
/// T_s)` (no cancellation): 1 for `K = 1`, and exactly `1/g` for `K = ∞`
/// (`−expm1(−∞) = 1`).
fn carried(eigenvalue: f64, sample_time: f64, samples: f64) -> f64 {
    creep_gain(eigenvalue, sample_time * samples.max(1.0)) / creep_gain(eigenvalue, sample_time)
}

impl RoundingBounds<'_> {
    /// Smallest partial sum `s_min` of the hysteresis weights.
    pub fn min_slope(&self) -> f64 {
        let mut s = 0.0;
        let mut min = f64::INFINITY;
        for w in self.parameters.hysteresis.weights {
            s += w;
            min = min.min(s);
        }
        min
    }

    /// Largest `|x|` any play or creep state can hold for inputs up to `v_max`.
    fn state_bound(&self, v_max: f64) -> f64 {
        let p = &self.parameters;
        let mut x = (v_max + last(p.hysteresis.thresholds)).max(self.state_max);
        if let Some(c) = &p.creep {
            x = x.max(v_max + last(c.thresholds));
        }
        x
    }

    /// The hysteresis sum `Σ w_i x_i` for inputs up to `v_max`.
    pub fn hysteresis_sum(&self, v_max: f64) -> f64 {
        let h = &self.parameters.hysteresis;
        let n = h.weights.len() as f64 + 1.0;
        4.0 * n * self.eps * abs_sum(h.weights) * self.state_bound(v_max)
    }

    /// The creep sum `Σ_i w_i (1/m) Σ_j χ_ij` and its updates, on a run of
    /// any length.
    pub fn creep_sum(&self, v_max: f64) -> f64 {
        self.creep_sum_within(v_max, f64::INFINITY)
    }

    /// [`RoundingBounds::creep_sum`] on a run of `samples` samples from a
    /// state both sides share (virgin, or one state set on both): the
    /// updates' roundings carried on by `(1 − e^{−a_j K T_s})/g_j` instead
    /// of `1/g_j`, which is smaller while `K` is short of the slowest
    /// operator's time constant `1/(a_j T_s)` samples (`K = 0` counts as
    /// one sample).
    pub fn creep_sum_over(&self, v_max: f64, samples: u64) -> f64 {
        self.creep_sum_within(v_max, samples as f64)
    }

    /// The creep sum's bound for runs of `samples` samples (`∞`: any).
    fn creep_sum_within(&self, v_max: f64, samples: f64) -> f64 {
        match &self.parameters.creep {
            None => 0.0,
            Some(c) => {
                let n = (c.weights.len() * c.eigenvalues.len()) as f64 + 1.0;
                let m = c.eigenvalues.len() as f64;
                let ts = self.parameters.sample_time;
                let drift = c
                    .eigenvalues
                    .iter()
                    .map(|&a| carried(a, ts, samples) + 2.0)
                    .sum::<f64>()
                    / m;
                self.eps * abs_sum(c.weights) * self.state_bound(v_max) * (8.0 * n + drift)
            }
        }
    }

    /// Adding (or subtracting) the output offset.
    fn offset(&self) -> f64 {
        2.0 * self.eps * self.parameters.offset.abs()
    }

    /// The smallest and the largest slope of `S` (`(1, 1)` without `S`).
    pub fn superposition_slopes(&self) -> (f64, f64) {
        let Some(s) = &self.parameters.superposition else {
            return (1.0, 1.0);
        };
        let zero = zero_index(s.thresholds).unwrap_or(0);
        let w = s.weights;
        let (mut lo, mut hi) = (w[zero], w[zero]);
        for side in [
            &mut (zero + 1..w.len()) as &mut dyn Iterator<Item = usize>,
            &mut (0..zero).rev(),
        ] {
            let mut slope = w[zero];
            for j in side {
                slope += w[j];
                (lo, hi) = (lo.min(slope), hi.max(slope));
            }
        }
        (lo, hi)
    }

    /// `|H + C|` for inputs up to `v_max`: the argument of `S`.
    fn inner_max(&self, v_max: f64) -> f64 {
        let p = &self.parameters;
        let creep = p.creep.as_ref().map_or(0.0, |c| abs_sum(c.weights));
        (abs_sum(p.hysteresis.weights) + creep) * self.state_bound(v_max)
    }

    /// Evaluating `S` for arguments up to `z_max` (0 without `S`).
    pub fn superposition_sum(&self, z_max: f64) -> f64 {
        let Some(s) = &self.parameters.superposition else {
            return 0.0;
        };
        let k = s.weights.len() as f64 + 1.0;
        let r_max = s.thresholds.iter().fold(0.0f64, |m, r| m.max(r.abs()));
        4.0 * k * self.eps * abs_sum(s.weights) * (z_max + r_max)
    }

    /// Evaluating `S⁻¹` (from the inverse rules) for arguments up to
    /// `y_max`: its own sum, and its parameters' rounding (relative `4 k ε`
    /// each, the thresholds' through the slope `1/σ_min`). 0 without `S`.
    pub fn inverse_superposition_sum(&self, y_max: f64) -> f64 {
        let Some(s) = &self.parameters.superposition else {
            return 0.0;
        };
        let zero = zero_index(s.thresholds).unwrap_or(0);
        let (mut w_inv, mut r_inv) = (0.0, 0.0f64);
        inverse_parameters_into(s.thresholds, s.weights, zero, |_, r, w| {
            w_inv += w.abs();
            r_inv = r_inv.max(r.abs());
        });
        let k = s.weights.len() as f64 + 1.0;
        let (s_min, _) = self.superposition_slopes();
        let x = y_max + r_inv;
        4.0 * k * self.eps * w_inv * x + 4.0 * k * k * self.eps * x / s_min
    }

    /// Two implementations of `W` on inputs up to `v_max`: the inner sums
    /// through `S`'s steepest slope, and `S`'s own rounding.
    pub fn model(&self, v_max: f64) -> f64 {
        let (_, s_max) = self.superposition_slopes();
        let inner = self.hysteresis_sum(v_max) + self.creep_sum(v_max);
        let outer = self.superposition_sum(self.inner_max(v_max));
        let g1 = self.dynamics().0;
        let w_max = s_max * self.inner_max(v_max) + self.superposition_offset();
        2.0 * (g1 * (s_max * inner + outer) + self.dynamics_sum(w_max) + self.offset())
    }

    /// `|S(0)|`-scale: the largest `|r|` of `S` times its steepest slope
    /// (what `S` may add beyond `σ_max |z|`).
    fn superposition_offset(&self) -> f64 {
        self.parameters.superposition.as_ref().map_or(0.0, |s| {
            let r_max = s.thresholds.iter().fold(0.0f64, |m, r| m.max(r.abs()));
            r_max * abs_sum(s.weights)
        })
    }

    /// The dynamics' `(‖G‖₁, ‖1/A‖₁, Σ|c_j|, g, order, ‖1/N‖₁)`;
    /// `(1, 1, 0, 1, 0, 1)` without dynamics. `N = b₀ + b₁z⁻¹` with
    /// `|b₁| < |b₀|`: `‖1/N‖₁ = 1/(|b₀| − |b₁|)`.
    fn dynamics(&self) -> (f64, f64, f64, f64, f64, f64) {
        let ts = self.parameters.sample_time;
        match &self.parameters.dynamics {
            None => (1.0, 1.0, 0.0, 1.0, 0.0, 1.0),
            Some(d) => {
                let (g1, a1) = l1_gains(d, ts);
                let k = d.coefficients(ts);
                let n_inv = 1.0 / (k.b[0].abs() - k.b[1].abs());
                (
                    g1,
                    a1,
                    abs_sum(&k.c[..k.order]),
                    k.gain,
                    k.order as f64,
                    n_inv,
                )
            }
        }
    }

    /// The rounding `G` adds to its output for inputs up to `w_max`, the
    /// state of two implementations (or one and exact arithmetic) carried
    /// on by `‖1/A‖₁`, and its coefficients' rounding (relative `ε` each,
    /// carried the same way). 0 without dynamics.
    pub fn dynamics_sum(&self, w_max: f64) -> f64 {
        if self.parameters.dynamics.is_none() {
            return 0.0;
        }
        let (g1, a1, c_abs, g, order, _) = self.dynamics();
        // |b₀| + |b₁| ≤ 2 on the input's side
        4.0 * (order + 5.0) * self.eps * (2.0 * g + c_abs * g1) * w_max * a1
    }

    /// `|G⁻¹[y − offset]|` and `|S⁻¹[·]|` of it for `|y| ≤ y_max`, and the
    /// rounding of forming it (`y_max + |offset|` without `G` and `S`).
    fn inner_target(&self, y_max: f64) -> (f64, f64) {
        self.inner_target_reachable(y_max, f64::INFINITY)
    }

    /// [`Self::inner_target`] for targets a voltage reaches, whose value
    /// before `G` is at most `w_reach` in magnitude: `G⁻¹` of an arbitrary
    /// signal can be `(1 + Σ|c_j|)/g · ‖1/N‖₁` times larger, but its
    /// rounding is that of the terms summed, whatever their sum:
    /// `(order + 3) ε (1 + Σ|c_j|) |y| / g`, carried through `1/N`.
    fn inner_target_reachable(&self, y_max: f64, w_reach: f64) -> (f64, f64) {
        let y = y_max + self.parameters.offset.abs();
        let (_, _, c_abs, g, order, n_inv) = self.dynamics();
        let (v, v_error) = match &self.parameters.dynamics {
            None => (y, 0.0),
            Some(_) => {
                let terms = (1.0 + c_abs) * y / g * n_inv;
                (terms.min(w_reach), (order + 3.0) * self.eps * terms * n_inv)
            }
        };
        match &self.parameters.superposition {
            None => (v, v_error),
            Some(_) => {
                let s_min = self.superposition_slopes().0;
                (
                    v / s_min,
                    self.inverse_superposition_sum(v) + v_error / s_min,
                )
            }
        }
    }

    /// `Σ_j |r'_j|`-scale and `Σ|w'_j|` of `H⁻¹` as (22) gives them.
    fn inverse_scale(&self) -> (f64, f64) {
        let h = &self.parameters.hysteresis;
        let (mut s, mut r_inv, mut w_inv) = (0.0, 0.0f64, 0.0);
        for (j, &w) in h.weights.iter().enumerate() {
            let prev = s;
            s += w;
            if j == 0 {
                w_inv += 1.0 / w.abs();
            } else {
                r_inv += prev * (h.thresholds[j] - h.thresholds[j - 1]);
                w_inv += (w / (s * prev)).abs();
            }
        }
        (r_inv, w_inv)
    }

    /// `H⁻¹∘H`, `H∘H⁻¹` or two implementations of `H⁻¹`, for inputs of `H`
    /// up to `v_max` and of `H⁻¹` up to `y_max`: the forward sum's rounding
    /// amplified by `1/s_min`, the inverse sum's own, and the rounding of the
    /// transformed parameters (relative `n ε` each, amplified the same way).
    pub fn inverse(&self, v_max: f64, y_max: f64) -> f64 {
        let h = &self.parameters.hysteresis;
        let n = h.weights.len() as f64 + 1.0;
        let s_min = self.min_slope();
        let forward = self.hysteresis_sum(v_max);
        let (r_inv, w_inv) = self.inverse_scale();
        let x_inv = y_max + r_inv + abs_sum(h.weights) * self.state_bound(v_max);
        let inverse_sum = 4.0 * n * self.eps * w_inv * x_inv;
        let parameters = 4.0 * n * n * self.eps * (v_max + r_inv + x_inv / s_min);
        2.0 * (forward / s_min + inverse_sum + forward + parameters)
    }

    /// `W[W⁻¹[y]] − y` when the plant's creep runs the compensator's own
    /// arithmetic (this crate's `Model` after its `Compensator`, in
    /// one precision): both creep outputs agree bit for bit, which leaves
    /// `H[H⁻¹[z]] − z` for `z = y − offset − C` and the roundings of forming
    /// `z` and `H + C + offset` (an error in `z` comes back through `H∘H⁻¹`
    /// with slope 1).
    ///
    /// With `S`, the error in `H + C` comes back through `S` (slope at most
    /// `σ_max`), with the roundings of `S⁻¹` and of `S` itself.
    pub fn identity(&self, v_max: f64, y_max: f64) -> f64 {
        let p = &self.parameters;
        let creep_out = p
            .creep
            .as_ref()
            .map_or(0.0, |c| abs_sum(c.weights) * self.state_bound(v_max));
        let (_, s_max) = self.superposition_slopes();
        // the targets are reached: before G they are the plant's S[H + C]
        let w_reach = s_max * self.inner_max(v_max) + self.superposition_offset();
        let (target, target_error) = self.inner_target_reachable(y_max, w_reach);
        let z = target + creep_out;
        let inner = self.inverse(v_max, z) + 4.0 * self.eps * z + target_error;
        let z_max = self.inner_max(v_max).max(z);
        let g1 = self.dynamics().0;
        let w_max = s_max * z_max + self.superposition_offset();
        g1 * (s_max * inner + self.superposition_sum(z_max))
            + self.dynamics_tracking(w_max, y_max + p.offset.abs())
    }

    /// The plant's `G` against the compensator's copy of it, which holds
    /// the targets: the plant's rounding per step,
    /// `(order + 3) ε (|b₀| + |b₁|) g |w| + (order + 3) ε Σ|c_j| |y|` with
    /// `|y|` the outputs (the targets), carried on by `‖1/A‖₁`.
    fn dynamics_tracking(&self, w_max: f64, y_max: f64) -> f64 {
        if self.parameters.dynamics.is_none() {
            return 0.0;
        }
        let (_, a1, c_abs, g, order, _) = self.dynamics();
        (order + 3.0) * self.eps * (2.0 * g * w_max + c_abs * y_max) * a1
    }

    /// The compensator `W⁻¹` against `W` (either order) or against another
    /// compensator: the inverse bound with the creep sum's rounding carried
    /// through `1/s_min`, twice (the creep states follow slightly different
    /// inputs, a contraction, so once more at most).
    ///
    /// With `S`, the argument of `H⁻¹` is `S⁻¹[y − offset] − C` and carries
    /// `S⁻¹`'s rounding; compared in the output domain, everything comes
    /// back through `S` (slope at most `σ_max`) with `S`'s own rounding.
    pub fn compensator(&self, v_max: f64, y_max: f64) -> f64 {
        self.compensator_within(v_max, y_max, f64::INFINITY)
    }

    /// [`RoundingBounds::compensator`] on a run of `samples` samples from a
    /// common state ([`RoundingBounds::creep_sum_over`]).
    pub fn compensator_over(&self, v_max: f64, y_max: f64, samples: u64) -> f64 {
        self.compensator_within(v_max, y_max, samples as f64)
    }

    fn compensator_within(&self, v_max: f64, y_max: f64, samples: f64) -> f64 {
        let p = &self.parameters;
        let creep = self.creep_sum_within(v_max, samples);
        let creep_out = p
            .creep
            .as_ref()
            .map_or(0.0, |c| abs_sum(c.weights) * self.state_bound(v_max));
        let off = self.offset();
        let (target, target_error) = self.inner_target(y_max);
        let errors = creep + off + target_error;
        let inner = 2.0
            * (self.inverse(v_max, target + creep_out) + 2.0 * errors / self.min_slope() + errors);
        let (_, s_max) = self.superposition_slopes();
        let z_max = self.inner_max(v_max).max(target + creep_out);
        let outer = self.superposition_sum(z_max);
        let g1 = self.dynamics().0;
        let w_max = s_max * z_max + self.superposition_offset();
        g1.max(1.0) * (s_max.max(1.0) * inner + 2.0 * outer) + 2.0 * self.dynamics_sum(w_max)
    }
}
