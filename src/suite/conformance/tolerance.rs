//! Tolerances of the conformance properties: the rounding bounds of
//! [`crate::realtime::RoundingBounds`] (where the analysis is written out) for a
//! model file, at `f64`'s `ε`. A lower precision scales them through
//! [`super::ConformanceSettings::tolerance_scale`].

use crate::operators::model::ModelFile;
use crate::realtime::rounding::RoundingBounds;

fn bounds(file: &ModelFile) -> RoundingBounds<'_> {
    let h = file.hysteresis.state.iter().flatten();
    let c = file
        .creep
        .iter()
        .flat_map(|c| c.state.iter().flatten().flatten());
    RoundingBounds {
        parameters: file.parameters(),
        state_max: h.chain(c).fold(0.0f64, |m, v| m.max(v.abs())),
        eps: f64::EPSILON,
    }
}

/// Smallest partial sum `s_min` of the hysteresis weights (the smallest slope).
pub fn min_slope(file: &ModelFile) -> f64 {
    bounds(file).min_slope()
}

/// Rounding bound of the hysteresis sum for inputs up to `v_max`.
pub fn hysteresis_sum(file: &ModelFile, v_max: f64) -> f64 {
    bounds(file).hysteresis_sum(v_max)
}

/// Rounding bound of the creep sum and its updates for inputs up to `v_max`.
pub fn creep_sum(file: &ModelFile, v_max: f64) -> f64 {
    bounds(file).creep_sum(v_max)
}

/// Two implementations of `W` on inputs up to `v_max`.
pub fn model(file: &ModelFile, v_max: f64) -> f64 {
    bounds(file).model(v_max)
}

/// `H⁻¹∘H`, `H∘H⁻¹` or two implementations of `H⁻¹`.
pub fn inverse(file: &ModelFile, v_max: f64, y_max: f64) -> f64 {
    bounds(file).inverse(v_max, y_max)
}

/// The compensator against `W` (either order) or another compensator.
pub fn compensator(file: &ModelFile, v_max: f64, y_max: f64) -> f64 {
    bounds(file).compensator(v_max, y_max)
}
