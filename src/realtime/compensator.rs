//! The compensator (21) in fixed-capacity storage, and the per-sample kernel
//! the `std` compensator shares.
//!
//! `v_k = H⁻¹[ς_k − offset − C_k]`: explicit, because `C_k` depends on inputs
//! up to `u_{k−1}` only. `v_k` is clipped to the supply limits; when it was
//! clipped, the plays of `H` the actuator holds are recovered from those of
//! `H⁻¹` before the sample (the state rule of (22) solved backwards), advanced
//! with the voltage actually applied, and the inverse plays re-seated from
//! them by (22), so the compensator leaves saturation on the branch the
//! actuator is on. Between saturations the plays of `H` are implied by those
//! of `H⁻¹` and are not stepped. A non-finite target holds the last voltage
//! and is flagged; creep keeps advancing with the voltage applied.

use crate::realtime::creep::FixedCreep;
use crate::realtime::error::ParameterError;
use crate::realtime::hysteresis::{self, FixedHysteresis};
use crate::realtime::inverse::{
    forward_state_in_place, inverse_parameters_into, inverse_state_into,
};
use crate::realtime::parameters::{
    check_admissible, check_capacity, check_finite, check_length, check_limits, ModelParameters,
};
use crate::realtime::real::Real;
use crate::realtime::simd::dispatch;

/// One compensator output sample.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Compensated<T = f64> {
    /// The (clipped) balanced voltage `u_k`.
    pub u: T,
    /// Whether `u_k` was clipped to a limit.
    pub saturated: bool,
    /// Whether the target was not a finite number: the previous output is
    /// held (and the state advances as the plant's does when it receives
    /// it), so the identity resumes with the next finite target.
    pub fault: bool,
}

/// The hysteresis half of (21): `H⁻¹` with its plays, the thresholds, weights
/// and partial sums `s_j` of `H`, and room for one set of play states.
pub(crate) struct HysteresisPair<'a, T> {
    pub inv_thresholds: &'a [T],
    pub inv_weights: &'a [T],
    pub inv_state: &'a mut [T],
    pub thresholds: &'a [T],
    pub weights: &'a [T],
    pub sums: &'a [T],
    pub scratch: &'a mut [T],
}

/// `u = sat(H⁻¹[y])`, and on saturation the inverse plays re-seated on the
/// branch of `u` (22). Returns `(u, saturated)`.
#[inline(always)]
pub(crate) fn invert_saturating<T: Real, const SIMD: bool>(
    p: HysteresisPair<'_, T>,
    y: T,
    lower: T,
    upper: T,
) -> (T, bool) {
    p.scratch.copy_from_slice(p.inv_state);
    let v = hysteresis::step_fast::<T, SIMD>(p.inv_state, p.inv_thresholds, p.inv_weights, y);
    let (u, saturated) = if v < lower {
        (lower, true)
    } else if v > upper {
        (upper, true)
    } else {
        (v, false)
    };
    if saturated {
        reseat(p, u);
    }
    (u, saturated)
}

/// After a clipped sample: the plays of `H` before it (from the saved inverse
/// plays), advanced with the applied `u`, and `H⁻¹`'s plays from them (22).
#[cold]
#[inline(never)]
fn reseat<T: Real>(p: HysteresisPair<'_, T>, u: T) {
    forward_state_in_place(p.sums, p.scratch);
    hysteresis::advance_plays::<T, false>(p.scratch, p.thresholds, u);
    inverse_state_into(p.weights, p.sums, p.scratch, p.inv_state);
}

/// The compensator `W⁻¹` (21) with at most `N` plays and `K` elementary creep
/// operators, in `T`. No allocation anywhere, construction included.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FixedCompensator<T: Real, const N: usize, const K: usize> {
    inverse: FixedHysteresis<T, N>,
    thresholds: [T; N],
    weights: [T; N],
    sums: [T; N],
    /// Room for the plays of `H`, used after a saturated sample.
    scratch: [T; N],
    /// The voltage of the last sample (held for a non-finite target).
    last_u: T,
    creep: Option<FixedCreep<T, K>>,
    offset: T,
    lower: T,
    upper: T,
}

impl<T: Real, const N: usize, const K: usize> FixedCompensator<T, N, K> {
    /// The compensator of the model `parameters` (virgin state) with output
    /// limits `lower < upper` (either may be infinite). The inverse
    /// parameters (22) and creep gains are computed in `f64`, then rounded;
    /// the limits are rounded inward, so every `u` lies within them.
    pub fn new(
        parameters: &ModelParameters<'_>,
        lower: f64,
        upper: f64,
    ) -> Result<Self, ParameterError> {
        parameters.validate()?;
        check_limits(lower, upper)?;
        let h = &parameters.hysteresis;
        let n = h.thresholds.len();
        check_capacity("hysteresis.thresholds", N, n)?;
        let mut inv_r = [0.0f64; N];
        let mut inv_w = [0.0f64; N];
        inverse_parameters_into(h.thresholds, h.weights, &mut inv_r[..n], &mut inv_w[..n]);
        let mut c = Self {
            inverse: FixedHysteresis::from_trusted(&inv_r[..n], &inv_w[..n], None),
            thresholds: [T::ZERO; N],
            weights: [T::ZERO; N],
            sums: [T::ZERO; N],
            scratch: [T::ZERO; N],
            last_u: T::ZERO,
            creep: match &parameters.creep {
                Some(cp) => Some(FixedCreep::new(cp, parameters.sample_time)?),
                None => None,
            },
            offset: T::from_f64(parameters.offset),
            // Rounded inward: an f32 limit rounded to nearest can lie outside.
            lower: T::from_f64_up(lower),
            upper: T::from_f64_down(upper),
        };
        let mut s = 0.0;
        for i in 0..n {
            s += h.weights[i];
            c.thresholds[i] = T::from_f64(h.thresholds[i]);
            c.weights[i] = T::from_f64(h.weights[i]);
            c.sums[i] = T::from_f64(s);
        }
        Ok(c)
    }

    /// Match the compensator to a model whose hysteresis plays hold
    /// `hysteresis` and whose creep operators hold `creep` (flattened as
    /// [`FixedCreep::set_state`] takes it): the inverse plays follow by (22).
    /// Checked before anything changes.
    pub fn set_model_state(
        &mut self,
        hysteresis: &[f64],
        creep: Option<&[f64]>,
    ) -> Result<(), ParameterError> {
        let n = self.inverse.len();
        check_length("hysteresis.state", n, hysteresis.len())?;
        check_finite("hysteresis.state", hysteresis)?;
        let mut r = [0.0f64; N];
        let mut w = [0.0f64; N];
        let mut s = [0.0f64; N];
        for i in 0..n {
            r[i] = self.thresholds[i].to_f64();
            w[i] = self.weights[i].to_f64();
            s[i] = self.sums[i].to_f64();
        }
        check_admissible("hysteresis.state", &r[..n], hysteresis, T::EPSILON.to_f64())?;
        let mut creep_trial = self.creep;
        match (&mut creep_trial, creep) {
            (Some(c), Some(state)) => c.set_state(state)?,
            (None, None) => {}
            (Some(c), None) => c.reset(),
            (None, Some(state)) => {
                return Err(ParameterError::LengthMismatch {
                    field: "creep.state",
                    expected: 0,
                    found: state.len(),
                })
            }
        }
        let mut inv = [0.0f64; N];
        inverse_state_into(&w[..n], &s[..n], hysteresis, &mut inv[..n]);
        for (x, &v) in self.inverse.state_mut().iter_mut().zip(&inv[..n]) {
            *x = T::from_f64(v);
        }
        self.last_u = T::from_f64(hysteresis[0]);
        self.creep = creep_trial;
        Ok(())
    }

    /// `H⁻¹` as the rules (22) give it.
    pub fn inverse_hysteresis(&self) -> &FixedHysteresis<T, N> {
        &self.inverse
    }

    /// The voltage for the target `target`; allocation-free, O(n + n_C m).
    #[inline]
    pub fn compensate(&mut self, target: T) -> Compensated<T> {
        dispatch(|| self.compensate_with::<true>(target))
    }

    /// [`FixedCompensator::compensate`] compiled for the caller's instruction
    /// set, without run-time dispatch (the same bits; for tests and for
    /// callers that dispatch a whole loop themselves).
    #[inline(always)]
    pub fn compensate_portable(&mut self, target: T) -> Compensated<T> {
        self.compensate_with::<false>(target)
    }

    #[inline(always)]
    fn compensate_with<const SIMD: bool>(&mut self, target: T) -> Compensated<T> {
        if !target.is_finite() {
            return self.hold();
        }
        let c = match &self.creep {
            Some(op) => op.output(),
            None => T::ZERO,
        };
        let n = self.inverse.len();
        let (inv_r, inv_w, inv_x) = self.inverse.parts_mut();
        let (u, saturated) = invert_saturating::<T, SIMD>(
            HysteresisPair {
                inv_thresholds: inv_r,
                inv_weights: inv_w,
                inv_state: inv_x,
                thresholds: &self.thresholds[..n],
                weights: &self.weights[..n],
                sums: &self.sums[..n],
                scratch: &mut self.scratch[..n],
            },
            target - self.offset - c,
            self.lower,
            self.upper,
        );
        self.last_u = u;
        if let Some(op) = &mut self.creep {
            op.advance_with::<SIMD>(u);
        }
        Compensated {
            u,
            saturated,
            fault: false,
        }
    }

    #[cold]
    fn hold(&mut self) -> Compensated<T> {
        let u = self.last_u;
        if let Some(op) = &mut self.creep {
            op.advance(u);
        }
        Compensated {
            u,
            saturated: false,
            fault: true,
        }
    }

    /// Back to the virgin state (the model's, not the one set last).
    pub fn reset(&mut self) {
        self.last_u = T::ZERO;
        self.inverse.reset();
        if let Some(c) = &mut self.creep {
            c.reset();
        }
    }
}
