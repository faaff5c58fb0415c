//! Tolerances of the conformance properties, from rounding analysis.
//!
//! A sum of `n` products `Σ w_i x_i` evaluated in floating point differs from
//! the exact one by at most `n ε Σ|w_i| max|x_i|` (Higham, Thm. 3.1, first
//! order); each play output is one of `x`, `v − r`, `v + r`, so
//! `|x_i| ≤ max|v| + r_n`. Two implementations that both round that way
//! differ by twice that; a constant 4 covers the clamps and a different
//! summation order. An inverse amplifies an error in its argument by its
//! steepest slope `1/s_min` (the partial sums `s_j` of (11) are the forward
//! slopes).

use crate::operators::model::ModelFile;

const EPS: f64 = f64::EPSILON;

fn abs_sum(w: &[f64]) -> f64 {
    w.iter().map(|x| x.abs()).sum()
}

fn last(r: &[f64]) -> f64 {
    r.last().copied().unwrap_or(0.0)
}

/// Smallest partial sum `s_min` of the hysteresis weights (the smallest slope).
pub fn min_slope(file: &ModelFile) -> f64 {
    let mut s = 0.0;
    let mut min = f64::INFINITY;
    for w in &file.hysteresis.weights {
        s += w;
        min = min.min(s);
    }
    min
}

/// Largest `|x|` any play or creep state of the model can hold for inputs
/// up to `v_max`: the input plus the largest threshold, or a larger initial state.
fn state_bound(file: &ModelFile, v_max: f64) -> f64 {
    let h = &file.hysteresis;
    let mut x = v_max + last(&h.thresholds);
    if let Some(s) = &h.state {
        x = x.max(s.iter().fold(0.0f64, |m, v| m.max(v.abs())));
    }
    if let Some(c) = &file.creep {
        x = x.max(v_max + last(&c.thresholds));
        if let Some(s) = &c.state {
            x = x.max(s.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs())));
        }
    }
    x
}

/// Rounding bound of the hysteresis sum `Σ w_i x_i` for inputs up to `v_max`.
pub fn hysteresis_sum(file: &ModelFile, v_max: f64) -> f64 {
    let n = file.hysteresis.weights.len() as f64 + 1.0;
    4.0 * n * EPS * abs_sum(&file.hysteresis.weights) * state_bound(file, v_max)
}

/// Rounding bound of the creep sum `Σ_i w_i (1/m) Σ_j χ_ij` and of its
/// `χ` updates (each a contraction: errors do not grow from sample to sample).
pub fn creep_sum(file: &ModelFile, v_max: f64) -> f64 {
    match &file.creep {
        None => 0.0,
        Some(c) => {
            let n = (c.weights.len() * c.eigenvalues.len()) as f64 + 1.0;
            8.0 * n * EPS * abs_sum(&c.weights) * state_bound(file, v_max)
        }
    }
}

/// Two implementations of `W` on inputs up to `v_max`.
pub fn model(file: &ModelFile, v_max: f64) -> f64 {
    2.0 * (hysteresis_sum(file, v_max) + creep_sum(file, v_max) + offset(file))
}

/// Rounding of adding (or subtracting) the output offset.
fn offset(file: &ModelFile) -> f64 {
    2.0 * EPS * file.offset.unwrap_or(0.0).abs()
}

/// Parameters of `H⁻¹` as the direct sums of (22) give them: `(r', w', x')`.
fn inverse_scale(file: &ModelFile) -> (f64, f64) {
    let h = &file.hysteresis;
    let (mut s, mut r_inv) = (0.0, 0.0f64);
    let mut w_inv = 0.0;
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

/// `H⁻¹∘H`, `H∘H⁻¹` or two implementations of `H⁻¹`, for inputs of `H` up
/// to `v_max` and of `H⁻¹` up to `y_max`: the forward sum's rounding amplified
/// by `1/s_min`, plus the inverse sum's own, plus the rounding of the
/// transformed parameters (relative `n ε` each, amplified the same way).
pub fn inverse(file: &ModelFile, v_max: f64, y_max: f64) -> f64 {
    let n = file.hysteresis.weights.len() as f64 + 1.0;
    let s_min = min_slope(file);
    let forward = hysteresis_sum(file, v_max);
    let (r_inv, w_inv) = inverse_scale(file);
    let x_inv = y_max + r_inv + abs_sum(&file.hysteresis.weights) * state_bound(file, v_max);
    let inverse_sum = 4.0 * n * EPS * w_inv * x_inv;
    let parameters = 4.0 * n * n * EPS * (v_max + r_inv + x_inv / s_min);
    2.0 * (forward / s_min + inverse_sum + forward + parameters)
}

/// The compensator `W⁻¹` against `W` (either order) or against another
/// compensator: the inverse bound with the creep sum's rounding carried
/// through `1/s_min`, twice (the creep states follow slightly different
/// inputs, a contraction, so once more at most).
pub fn compensator(file: &ModelFile, v_max: f64, y_max: f64) -> f64 {
    let creep = creep_sum(file, v_max);
    let creep_out = file
        .creep
        .as_ref()
        .map_or(0.0, |c| abs_sum(&c.weights) * state_bound(file, v_max));
    let off = offset(file);
    2.0 * (inverse(
        file,
        v_max,
        y_max + creep_out + file.offset.unwrap_or(0.0).abs(),
    ) + 2.0 * (creep + off) / min_slope(file)
        + creep
        + off)
}
