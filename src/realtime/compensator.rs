//! The compensator `W⁻¹` (21) and its per-sample kernel.
//!
//! `v_k = H⁻¹[S⁻¹[ς_k − offset] − C_k]`: explicit, because `C_k` depends on
//! inputs up to `u_{k−1}` only (`S⁻¹` is the identity for the paper's
//! symmetric model). `v_k` is clipped to the supply limits; when it was
//! clipped, the plays of `H` the actuator holds are recovered from those of
//! `H⁻¹` before the sample (the state rule of (22) solved backwards), advanced
//! with the voltage actually applied, and the inverse plays re-seated from
//! them by (22), so the compensator leaves saturation on the branch the
//! actuator is on. Between saturations the plays of `H` are implied by those
//! of `H⁻¹` and are not stepped. A non-finite target holds the last voltage
//! and is flagged; creep keeps advancing with the voltage applied.
//!
//! Linear dynamics `G` after `S` are inverted first, exactly (their inverse
//! is an FIR filter on the target, [`Dynamics::input_for`]); the state of
//! `G` advances with the output the plant produces, which after a clipped or
//! held sample is the forward model's (`S[H(u) + C]` through `G`), so the
//! identity resumes on the branch the plant is on.
//!
//! With rate-dependent thresholds ([`RateGain`]) there are no inverse
//! plays: the compensator keeps the plant's plays and last input, and
//! inverts each step (the least input that reaches the target, bisected to
//! the resolution of `T`: docs/MATHEMATICS.md §4.3); a clipped sample needs
//! no re-seat, the plays simply step with the voltage applied.
//!
//! A model's dead time is not inverted here (no causal inverse exists): the
//! compensator inverts the memory part `S[H + C]`, and a caller whose model
//! has a delay `d` ([`Compensator::delay`]) gives it the target `d` samples
//! ahead ([`preview`]).

use crate::realtime::checks::{check_admissible, check_finite, check_length, check_limits};
use crate::realtime::creep::Creep;
#[cfg(doc)]
use crate::realtime::delay::preview;
use crate::realtime::dynamics::Dynamics;
use crate::realtime::error::ParameterError;
use crate::realtime::hysteresis::{self, Hysteresis};
use crate::realtime::inverse::{forward_state_in_place, inverse_state_into};
use crate::realtime::model::Model;
use crate::realtime::parameters::{Checked, ModelParameters};
use crate::realtime::rate::{self, RateGain};
use crate::realtime::real::Real;
use crate::realtime::simd::{self, Kernels};
use crate::realtime::storage::{Buffer, Storage};
use crate::realtime::superposition::Superposition;

/// One compensator output sample. `#[repr(C)]`: the value, then the two
/// flags as bytes, padded to twice the value's size — the records the
/// bank writes whole from vector registers.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[repr(C)]
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

/// After a clipped sample: the plays of `H` before it (from the inverse
/// plays the step saved in `scratch`), advanced with the applied `u`, and
/// `H⁻¹`'s plays from them (22), so that the compensator leaves saturation
/// on the branch the actuator is on.
#[cold]
#[inline(never)]
fn reseat<T: Real>(
    inv_state: &mut [T],
    scratch: &mut [T],
    thresholds: &[T],
    weights: &[T],
    sums: &[T],
    u: T,
) {
    forward_state_in_place(sums, scratch);
    hysteresis::advance_plays(scratch, thresholds, u);
    inverse_state_into(weights, sums, scratch, inv_state);
}

/// Output limits of a compensator (balanced voltage, V): every output lies
/// in `[lower_limit, upper_limit]` and a clipped sample is flagged. The one
/// way limits are stated, in every layer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompensatorSettings {
    /// Lowest output; `-inf` for none.
    pub lower_limit: f64,
    /// Highest output; `+inf` for none.
    pub upper_limit: f64,
}

impl Default for CompensatorSettings {
    /// The balanced supply range of (1): `[−1000, 1000]` V.
    fn default() -> Self {
        Self::with_limits(-1000.0, 1000.0)
    }
}

impl CompensatorSettings {
    /// No saturation at all: the one way to say so in Rust (the command
    /// line's is `--no-limits`, Python's `limits=None`, C's ±INFINITY).
    pub fn unlimited() -> Self {
        Self::with_limits(f64::NEG_INFINITY, f64::INFINITY)
    }

    /// Limits `[lower, upper]`; one of them may be infinite (a one-sided
    /// limit; none at all is [`CompensatorSettings::unlimited`]).
    pub fn with_limits(lower_limit: f64, upper_limit: f64) -> Self {
        Self {
            lower_limit,
            upper_limit,
        }
    }

    /// `lower < upper`, neither NaN (either may be infinite).
    pub fn validate(&self) -> Result<(), ParameterError> {
        check_limits(self.lower_limit, self.upper_limit)
    }
}

/// The compensator `W⁻¹` (21) in `T`, kept in storage `S`: `H⁻¹` by the
/// rules (22), a copy of the plant's creep operator and the model's offset.
/// No allocation per sample (with [`Inline`](crate::realtime::Inline)
/// storage none at all, construction included).
#[derive(Debug, Clone, PartialEq)]
pub struct Compensator<T: Real, S: Storage> {
    pub(crate) inverse: Hysteresis<T, S>,
    /// Thresholds, weights and partial sums of the plant's `H`.
    pub(crate) thresholds: S::Plays<T>,
    pub(crate) weights: S::Plays<T>,
    pub(crate) sums: S::Plays<T>,
    /// The plays of the plant's `H`: after a saturated sample (the
    /// re-seat's room), or with rate-dependent thresholds always.
    scratch: S::Plays<T>,
    /// Rate-dependent thresholds, if any: their gain and the plant's last
    /// input (the inverse plays are then unused).
    rate: Option<RateGain<T>>,
    /// The voltage of the last sample (held for a non-finite target).
    last_u: T,
    pub(crate) creep: Option<Creep<T, S>>,
    /// `S⁻¹` by its inverse rules, if the model has `S`.
    inverse_superposition: Option<Superposition<T, S>>,
    /// `S` itself (with dynamics only: the plant's output after a clipped
    /// sample goes through it).
    superposition: Option<Superposition<T, S>>,
    /// `G` advanced by its lag ([`Dynamics::ahead`]), whose inverse runs
    /// first.
    pub(crate) dynamics: Option<Dynamics<T>>,
    /// `H[u]` of the last sample (with dynamics: a held sample repeats it).
    last_h: T,
    offset: T,
    lower: T,
    upper: T,
    /// The model's dead time (samples), which the caller's preview covers.
    delay: usize,
    /// Whether the model has the paper's layout (12 plays, creep 12 × 5):
    /// the step then runs code compiled for it.
    paper: bool,
}

/// Rate-dependent thresholds: `None` without them; with them, the class
/// whose steps are invertible (non-negative weights, `w_0 > 0`:
/// docs/MATHEMATICS.md §4.3) is checked.
fn rate_of<T: Real>(
    parameters: &ModelParameters<'_>,
) -> Result<Option<RateGain<T>>, ParameterError> {
    if parameters.rate_gain == 0.0 {
        return Ok(None);
    }
    let field = "hysteresis.weights";
    let w = parameters.hysteresis.weights;
    if let Some((index, &value)) = w.iter().enumerate().find(|(_, &w)| w < 0.0) {
        return Err(ParameterError::NegativeWeight {
            field,
            index,
            value,
        });
    }
    if w.first().is_some_and(|&w0| w0 <= 0.0) {
        return Err(ParameterError::PartialSumNotPositive {
            field,
            index: 0,
            sum: w[0],
        });
    }
    Ok(Some(RateGain::new(
        parameters.rate_gain,
        parameters.sample_time,
    )))
}

impl<T: Real, S: Storage> Compensator<T, S> {
    /// The compensator of the model `parameters` (virgin state) with
    /// output limits `settings`. The inverse parameters (22) and creep
    /// gains are computed in `f64`, then rounded; the limits are rounded
    /// inward, so every `u` lies within them.
    pub fn new(
        parameters: &Checked<ModelParameters<'_>>,
        settings: CompensatorSettings,
    ) -> Result<Self, ParameterError> {
        let parameters = parameters.get();
        let (ts, superposition) = (parameters.sample_time, parameters.superposition.as_ref());
        settings.validate()?;
        let rate = rate_of(parameters)?;
        let h = &parameters.hysteresis;
        let n = h.thresholds.len();
        let field = "hysteresis.thresholds";
        let zeros = || S::Plays::<T>::zeroed(field, n);
        let mut c = Self {
            inverse: Hysteresis::inverse_built(h, None)?,
            thresholds: zeros()?,
            weights: zeros()?,
            sums: zeros()?,
            scratch: zeros()?,
            rate,
            last_u: T::ZERO,
            creep: parameters
                .creep
                .as_ref()
                .map(|c| Creep::build(c, ts))
                .transpose()?,
            inverse_superposition: superposition
                .map(Superposition::inverse_built)
                .transpose()?,
            superposition: match parameters.dynamics {
                Some(_) => superposition.map(Superposition::build).transpose()?,
                None => None,
            },
            dynamics: parameters.dynamics.as_ref().map(|g| Dynamics::build(g, ts)),
            last_h: T::ZERO,
            offset: T::from_f64(parameters.offset),
            // rounded inward: an f32 limit rounded to nearest can lie outside
            lower: T::from_f64_up(settings.lower_limit),
            upper: T::from_f64_down(settings.upper_limit),
            delay: parameters.delay + parameters.dynamics.as_ref().map_or(0, |g| g.lag()),
            paper: n == simd::PAPER_PLAYS
                && parameters.creep.as_ref().is_some_and(|c| {
                    (c.thresholds.len(), c.eigenvalues.len()) == simd::PAPER_CREEP
                }),
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

    /// The compensator of `model`, matched to the model's current state
    /// (so that `W[W⁻¹[y]] = y` from the next sample on).
    pub fn of<S2: Storage>(
        model: &Model<f64, S2>,
        settings: CompensatorSettings,
    ) -> Result<Self, ParameterError> {
        let mut c = Self::new(&model.parameters(), settings)?;
        c.set_model_state(model.hysteresis().play_states(), None)?;
        if let (Some(mine), Some(theirs)) = (&mut c.rate, model.rate_gain()) {
            mine.set_last_input(theirs.last_input().map(|v| T::from_f64(v.to_f64())));
            if let Some(v) = mine.last_input() {
                c.last_u = v;
            }
        }
        if let (Some(mine), Some(theirs)) = (&mut c.creep, model.creep()) {
            mine.copy_state_from(theirs)?;
        }
        if let (Some(mine), Some(theirs)) = (&mut c.dynamics, model.dynamics()) {
            let mut state =
                [0.0; crate::realtime::dynamics::MAX_ORDER + crate::realtime::dynamics::INPUTS];
            let state = &mut state[..theirs.state_len()];
            match theirs.state_into(state) {
                Some(()) => c_set_ahead(mine, Some(state))?,
                None => mine.reset(),
            }
        }
        Ok(c)
    }

    /// Match the compensator to a model whose hysteresis plays hold
    /// `hysteresis` and whose creep operators hold `creep` (flattened as
    /// [`Creep::set_state_flat`] takes it; `None`: zero): the inverse plays
    /// follow by (22). Checked before anything changes.
    pub fn set_model_state(
        &mut self,
        hysteresis: &[f64],
        creep: Option<&[f64]>,
    ) -> Result<(), ParameterError> {
        let n = self.inverse.len();
        check_length("hysteresis.state", n, hysteresis.len())?;
        check_finite("hysteresis.state", hysteresis)?;
        let field = "hysteresis.state";
        let mut r = S::Plays::<f64>::zeroed(field, n)?;
        let mut w = S::Plays::<f64>::zeroed(field, n)?;
        let mut s = S::Plays::<f64>::zeroed(field, n)?;
        for i in 0..n {
            r[i] = self.thresholds[i].to_f64();
            w[i] = self.weights[i].to_f64();
            s[i] = self.sums[i].to_f64();
        }
        check_admissible(field, &r, hysteresis, T::EPSILON.to_f64())?;
        let mut creep_trial = self.creep.clone();
        match (&mut creep_trial, creep) {
            (Some(c), Some(state)) => c.set_state_flat(state)?,
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
        let mut inv = S::Plays::<f64>::zeroed(field, n)?;
        inverse_state_into(&w, &s, hysteresis, &mut inv);
        for (x, &v) in self.inverse.state_mut().iter_mut().zip(inv.iter()) {
            *x = T::from_f64(v);
        }
        for (x, &v) in self.scratch.iter_mut().zip(hysteresis) {
            *x = T::from_f64(v);
        }
        self.last_u = T::from_f64(hysteresis[0]);
        self.last_h = T::from_f64(w.iter().zip(hysteresis).map(|(w, x)| w * x).sum());
        self.creep = creep_trial;
        Ok(())
    }

    /// The limits in force (as rounded to `T`).
    pub fn settings(&self) -> CompensatorSettings {
        CompensatorSettings::with_limits(self.lower.to_f64(), self.upper.to_f64())
    }

    /// The preview (samples): the model's dead time `d` and the lag `ρ` of
    /// its dynamics; the compensator inverts the rest, so the target for
    /// sample `k` is the one wanted at `k + d + ρ` ([`preview`]).
    pub fn delay(&self) -> usize {
        self.delay
    }

    /// The linear dynamics `G` as the compensator tracks them (its state:
    /// the plant's last outputs before the offset).
    pub fn dynamics(&self) -> Option<&Dynamics<T>> {
        self.dynamics.as_ref()
    }

    /// Set the state of `G` to match a plant's whose `G` holds `values`
    /// (its state as [`Dynamics::state_into`] gives it; `None`: not
    /// started): the compensator tracks `G` advanced by its lag.
    pub fn set_dynamics_state(&mut self, values: Option<&[f64]>) -> Result<(), ParameterError> {
        match &mut self.dynamics {
            Some(g) => c_set_ahead(g, values),
            None if values.is_none() => Ok(()),
            None => Err(ParameterError::LengthMismatch {
                field: "dynamics.state",
                expected: 0,
                found: values.map_or(0, <[f64]>::len),
            }),
        }
    }

    /// `S⁻¹` as its inverse rules give it, if the model has `S`.
    pub fn inverse_superposition(&self) -> Option<&Superposition<T, S>> {
        self.inverse_superposition.as_ref()
    }

    /// `H⁻¹` as the rules (22) give it, in its current state.
    pub fn inverse_hysteresis(&self) -> &Hysteresis<T, S> {
        &self.inverse
    }

    /// The plays of the plant's `H` that match the inverse plays (22):
    /// `x` gets one value per play.
    pub fn forward_state_into(&self, x: &mut [T]) -> Result<(), ParameterError> {
        check_length("hysteresis.state", self.inverse.len(), x.len())?;
        if self.rate.is_some() {
            x.copy_from_slice(&self.scratch);
            return Ok(());
        }
        x.copy_from_slice(self.inverse.play_states());
        forward_state_in_place(&self.sums, x);
        Ok(())
    }

    /// The voltage for the target `target`; allocation-free, O(n + n_C m).
    #[inline]
    pub fn compensate(&mut self, target: T) -> Compensated<T> {
        self.compensate_with(Kernels::detect_single_step::<T>(), target)
    }

    /// [`Compensator::compensate`] on the portable kernels (the same bits;
    /// for tests).
    #[cfg(feature = "internals")]
    #[inline(always)]
    pub fn compensate_portable(&mut self, target: T) -> Compensated<T> {
        self.compensate_with(Kernels::Portable, target)
    }

    /// [`Compensator::compensate`] on the kernels `k` (any of
    /// [`Kernels::all`]: the same bits on each; for tests and benches).
    #[cfg(feature = "internals")]
    #[inline]
    pub fn compensate_using(&mut self, k: Kernels, target: T) -> Compensated<T> {
        self.compensate_with(k, target)
    }

    /// A whole signal into caller buffers, every flag kept; one
    /// instruction-set dispatch for the lot, and one loop compiled with the
    /// kernels' features, in which the creep's output goes from one sample
    /// to the next in a register: faster than one
    /// [`Compensator::compensate`] per sample, with the same bits. Like
    /// [`Compensator::compensate`] it inverts the memory part: with a dead
    /// time `d`, `targets` must be the ones wanted `d` samples later (a
    /// stream continues across calls; [`preview`] shifts a whole planned
    /// signal). Returns how many samples were saturated and how many were
    /// faults.
    pub fn compensate_into(
        &mut self,
        targets: &[T],
        u: &mut [T],
        saturated: &mut [bool],
        fault: &mut [bool],
    ) -> Result<(usize, usize), ParameterError> {
        self.compensate_into_on(
            Kernels::detect_single_step::<T>(),
            targets,
            u,
            saturated,
            fault,
        )
    }

    /// [`Compensator::compensate_into`] on the kernels `k` (any of
    /// [`Kernels::all`]: the same bits on each, and the same as one
    /// [`Compensator::compensate_using`] per sample; for tests and benches).
    /// The samples run in one loop compiled with `k`'s features.
    #[cfg(feature = "internals")]
    pub fn compensate_into_using(
        &mut self,
        k: Kernels,
        targets: &[T],
        u: &mut [T],
        saturated: &mut [bool],
        fault: &mut [bool],
    ) -> Result<(usize, usize), ParameterError> {
        self.compensate_into_on(k, targets, u, saturated, fault)
    }

    /// [`Compensator::compensate_into`] on the kernels `k`.
    fn compensate_into_on(
        &mut self,
        k: Kernels,
        targets: &[T],
        u: &mut [T],
        saturated: &mut [bool],
        fault: &mut [bool],
    ) -> Result<(usize, usize), ParameterError> {
        check_length("u", targets.len(), u.len())?;
        check_length("saturated", targets.len(), saturated.len())?;
        check_length("fault", targets.len(), fault.len())?;
        let out = simd::RunOutputs {
            u,
            saturated,
            fault,
        };
        Ok(simd::compensator_run(k, self, targets, out))
    }

    /// One step on the kernels `k`. The common case (no `G`, no `S`, a
    /// finite target) here: `H⁻¹`, the clip and the creep pass in one
    /// kernel call ([`simd::compensator_step`]) and the re-seat after a
    /// clipped sample; anything else in [`Compensator::compensate_general`].
    #[inline(always)]
    fn compensate_with(&mut self, k: Kernels, target: T) -> Compensated<T> {
        use simd::RunSource;
        // the common case, no `G` and no `S`: the general path's operations
        // on it, with nothing else in the function (the rest out of line:
        // fewer instructions and registers per step); a run's loop takes
        // the same three pieces. The creep's output is read inside the
        // kernels' function, by the broadcast of the step's first kernel
        // (`simd::compensator_step`)
        let Some(y) = self.common_target(target) else {
            return self.compensate_general(k, target);
        };
        let (u, saturated) = simd::compensator_step(k, self, y, self.lower, self.upper);
        self.after_step(u, saturated);
        Compensated {
            u,
            saturated,
            fault: false,
        }
    }

    /// The plays of `H⁻¹` re-seated after the clipped sample `u`.
    #[cold]
    #[inline(never)]
    fn reseat_clipped(&mut self, u: T) {
        let (_, _, inv_state) = self.inverse.parts_mut();
        reseat(
            inv_state,
            &mut self.scratch,
            &self.thresholds,
            &self.weights,
            &self.sums,
            u,
        );
    }

    /// [`Compensator::compensate_with`] with `G` or `S`, or a non-finite
    /// target (held): `G⁻¹` and `S⁻¹` of the target, then the kernel call,
    /// the re-seat after a clipped sample and `G`'s state.
    #[inline(never)]
    fn compensate_general(&mut self, k: Kernels, target: T) -> Compensated<T> {
        if !target.is_finite() {
            return self.hold();
        }
        let c = match &self.creep {
            Some(op) => op.output(),
            None => T::ZERO,
        };
        let t = target - self.offset;
        let v = match &self.dynamics {
            Some(g) => {
                let v = g.input_for(t);
                // a finite target G⁻¹ cannot reach in T (it overflows): a
                // fault, held, so that no infinity enters G's state
                if !v.is_finite() {
                    return self.hold();
                }
                v
            }
            None => t,
        };
        let y = match &self.inverse_superposition {
            Some(s) => s.apply(v),
            None => v,
        };
        let (u, saturated) = match self.rate.is_some() {
            true => self.rate_step(y, c),
            false => {
                let (u, saturated) = simd::compensator_step(k, self, y, self.lower, self.upper);
                if saturated {
                    self.reseat_clipped(u);
                }
                (u, saturated)
            }
        };
        if self.dynamics.is_some() {
            let h = if saturated {
                self.clipped_output()
            } else {
                y - c
            };
            self.advance_dynamics(t, v, h, c, saturated);
        }
        self.last_u = u;
        Compensated {
            u,
            saturated,
            fault: false,
        }
    }

    /// A non-finite target: emit the previous output again. The plays see
    /// the same input (no change); the creep advances with it, as the
    /// plant's does.
    #[cold]
    fn hold(&mut self) -> Compensated<T> {
        let u = self.last_u;
        if let Some(r) = &mut self.rate {
            // the plant's plays see the same input again, with no rate
            hysteresis::advance_plays_widened(&mut self.scratch, &self.thresholds, u, r.widen(u));
            self.last_h = hysteresis::weighted_sum(&self.weights, &self.scratch);
        }
        if self.dynamics.is_some() {
            let c = self.creep.as_ref().map_or(T::ZERO, |op| op.output());
            self.advance_dynamics(T::ZERO, T::ZERO, self.last_h, c, true);
        }
        if let Some(op) = &mut self.creep {
            op.advance(u);
        }
        Compensated {
            u,
            saturated: false,
            fault: true,
        }
    }

    /// Advance `G` with the plant's output: the target `t` (from the input
    /// `v` asked for) when the voltage was applied as computed, else
    /// (`off_target`: clipped or held) `G` of `S[h + c]`, `h` the plays'
    /// output.
    #[inline(always)]
    fn advance_dynamics(&mut self, t: T, v: T, h: T, c: T, off_target: bool) {
        self.last_h = h;
        if let Some(g) = &mut self.dynamics {
            if off_target {
                let w = match &self.superposition {
                    Some(s) => s.apply(h + c),
                    None => h + c,
                };
                g.push_input(w);
            } else {
                g.push_exact(t, v);
            }
        }
    }

    /// `H[u]` after a clipped sample: the forward plays re-seated with the
    /// applied voltage are in `scratch`.
    #[cold]
    fn clipped_output(&self) -> T {
        let mut sum = T::ZERO;
        for (w, x) in self.weights.iter().zip(self.scratch.iter()) {
            sum += *w * *x;
        }
        sum
    }

    /// Back to the virgin state (the model's, not the one set last).
    pub fn reset(&mut self) {
        self.last_u = T::ZERO;
        self.last_h = T::ZERO;
        if let Some(g) = &mut self.dynamics {
            g.reset();
        }
        self.inverse.reset();
        self.scratch.fill(T::ZERO);
        if let Some(r) = &mut self.rate {
            r.reset();
        }
        if let Some(c) = &mut self.creep {
            c.reset();
        }
    }

    /// One step of `H⁻¹ + C` with rate-dependent thresholds: the input that
    /// reaches `y − c` ([`rate::invert_step`]), clipped, the plant's plays
    /// and the creep advanced with it. Returns it and whether it was
    /// clipped.
    #[inline(never)]
    fn rate_step(&mut self, y: T, c: T) -> (T, bool) {
        let Some(r) = &mut self.rate else {
            unreachable!("called with rate-dependent thresholds only")
        };
        let wanted = rate::invert_step(&self.scratch, &self.thresholds, &self.weights, r, y - c);
        let (u, saturated) = if wanted < self.lower {
            (self.lower, true)
        } else if wanted > self.upper {
            (self.upper, true)
        } else if wanted.is_finite() {
            (wanted, false)
        } else {
            // NaN: none of the limits; cannot happen for a finite target
            (self.last_u, true)
        };
        hysteresis::advance_plays_widened(&mut self.scratch, &self.thresholds, u, r.widen(u));
        if let Some(op) = &mut self.creep {
            op.advance(u);
        }
        (u, saturated)
    }

    /// The rate dependence of the thresholds, if any (the plant's last
    /// input in it).
    pub fn rate_gain(&self) -> Option<&RateGain<T>> {
        self.rate.as_ref()
    }

    /// Set the plant's last input, which rate-dependent thresholds need
    /// (`None`: not started); without them only `None` is taken.
    pub fn set_last_input(&mut self, last: Option<f64>) -> Result<(), ParameterError> {
        let field = "hysteresis.last_input";
        match (&mut self.rate, last) {
            (Some(r), None) => {
                r.set_last_input(None);
                Ok(())
            }
            (None, None) => Ok(()),
            (None, Some(_)) => Err(ParameterError::Unsupported {
                field,
                reason: "only a model with a rate gain keeps its last input",
            }),
            (Some(r), Some(v)) => {
                check_finite(field, core::slice::from_ref(&v))?;
                r.set_last_input(Some(T::from_f64(v)));
                self.last_u = T::from_f64(v);
                Ok(())
            }
        }
    }
}

/// `g` set to a plant's state `values` advanced by its lag (`None`: not
/// started).
fn c_set_ahead<T: Real>(g: &mut Dynamics<T>, values: Option<&[f64]>) -> Result<(), ParameterError> {
    g.set_state(values)?;
    *g = g.ahead();
    Ok(())
}

/// A run of samples ([`Compensator::compensate_into`]): the common case as
/// [`Compensator::compensate_with`] has it, the rest through
/// [`Compensator::compensate_general`].
impl<T: Real, S: Storage> simd::RunSource<T> for Compensator<T, S> {
    #[inline(always)]
    fn limits(&self) -> (T, T) {
        (self.lower, self.upper)
    }

    #[inline(always)]
    fn common_target(&self, target: T) -> Option<T> {
        if self.dynamics.is_some()
            || self.inverse_superposition.is_some()
            || self.rate.is_some()
            || !target.is_finite()
        {
            return None;
        }
        Some(target - self.offset)
    }

    #[inline(always)]
    fn creep_output(&self) -> T {
        match &self.creep {
            Some(op) => op.output(),
            None => T::ZERO,
        }
    }

    #[inline(always)]
    fn after_step(&mut self, u: T, saturated: bool) {
        if saturated {
            self.reseat_clipped(u);
        }
        self.last_u = u;
    }

    fn general_step(&mut self, k: Kernels, target: T) -> (T, bool, bool) {
        let out = self.compensate_general(k, target);
        (out.u, out.saturated, out.fault)
    }
}

impl<T: Real, S: Storage> simd::StepSource<T> for Compensator<T, S> {
    #[inline(always)]
    fn step_parts(&mut self) -> simd::StepParts<'_, T> {
        let (inv_thresholds, inv_weights, inv_state) = self.inverse.parts_mut();
        simd::StepParts {
            inv_state,
            saved: &mut self.scratch,
            inv_thresholds,
            inv_weights,
            creep: self.creep.as_mut().map(Creep::step_parts),
        }
    }

    #[inline(always)]
    fn paper_parts(&mut self) -> simd::StepParts<'_, T> {
        const N: usize = simd::PAPER_PLAYS;
        let (inv_thresholds, inv_weights, inv_state) = self.inverse.prefix_parts_mut::<N>();
        simd::StepParts {
            inv_state,
            saved: self.scratch.prefix_mut::<N>(),
            inv_thresholds,
            inv_weights,
            creep: self.creep.as_mut().map(Creep::paper_step_parts),
        }
    }

    #[inline(always)]
    fn paper_layout(&self) -> bool {
        self.paper
    }
}

#[cfg(test)]
mod tests;
