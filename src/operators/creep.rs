//! Creep operators, equations (13)–(18) with the time-discrete form (20).
//!
//! * Elementary creep operator `K_{r,a}` (13)–(14): `dχ/dt = a · d_r(v − χ)`,
//!   with the dead zone `d_r(z) = max(z − r, min(z + r, 0))`. For a
//!   zero-order-hold input it is solved exactly over one sample:
//!   `χ_k = χ_{k−1} + (1 − e^{−a T_s}) d_r(v_{k−1} − χ_{k−1})` (20). Within one
//!   sample `v − χ` keeps its sign side of the dead zone, so the linear ODE
//!   solution is exact. `1 − e^{−aT_s}` is computed as `−expm1(−aT_s)`: the
//!   literal form loses five digits at `a = 0.05 s⁻¹`.
//! * log(t)-creep operator (15): the unweighted mean of `m` elementary operators
//!   with one threshold and eigenvalues spread over decades (24); its step
//!   response grows linearly in `log t` between `1/a_1` and `1/a_m`.
//! * PI creep operator (16): `C[v]_k = Σ_i w_i ς_{i,k}` over log(t)-creep
//!   operators with thresholds `0 = r_0 < … < r_n` (18) and weights whose partial
//!   sums are non-negative (17).
//!
//! All three have a one-sample delay: the output at step `k` is computed from
//! the state `χ_k`, which depends on `v_{k−1}`; `step(v_k)` returns it and then
//! advances the state with `v_k`. The state stored (and saved to a model file)
//! is `χ` at the next sample.

use crate::error::ModelError;
use crate::operators::hysteresis::{check_finite, check_length, check_thresholds};
use crate::operators::play::dead_zone;
use crate::operators::traits::{Operator, Snapshot};
use crate::realtime;
use crate::realtime::parameters;

pub use crate::realtime::creep::creep_gain;

/// (24): eigenvalues `a_j = 1 / (10^j T_s)`, `j = 1..m`.
pub fn log_spaced_eigenvalues(m: usize, sample_time: f64) -> Vec<f64> {
    (1..=m)
        .map(|j| 1.0 / (10f64.powi(j as i32) * sample_time))
        .collect()
}

fn check_sample_time(ts: f64) -> Result<(), ModelError> {
    Ok(parameters::check_sample_time(ts)?)
}

fn check_eigenvalues(field: &str, a: &[f64]) -> Result<(), ModelError> {
    parameters::check_eigenvalues("", a).map_err(|e| e.named(field))
}

/// The elementary creep operator `K_{r,a}` (13)–(14).
#[derive(Debug, Clone, PartialEq)]
pub struct ElementaryCreepOperator {
    threshold: f64,
    eigenvalue: f64,
    gain: f64,
    chi: f64,
}

impl ElementaryCreepOperator {
    /// A creep operator with threshold `r ≥ 0`, eigenvalue `a > 0` and sample
    /// time `T_s > 0`, in the zero state.
    pub fn new(threshold: f64, eigenvalue: f64, sample_time: f64) -> Result<Self, ModelError> {
        parameters::check_threshold("creep.threshold", threshold)?;
        check_eigenvalues("creep.eigenvalue", &[eigenvalue])?;
        check_sample_time(sample_time)?;
        Ok(Self {
            threshold,
            eigenvalue,
            gain: creep_gain(eigenvalue, sample_time),
            chi: 0.0,
        })
    }

    /// The eigenvalue `a` (s⁻¹).
    pub fn eigenvalue(&self) -> f64 {
        self.eigenvalue
    }
}

impl Operator for ElementaryCreepOperator {
    #[inline]
    fn step(&mut self, v: f64) -> f64 {
        let out = self.chi;
        self.chi += self.gain * dead_zone(v - self.chi, self.threshold);
        out
    }

    fn reset(&mut self) {
        self.chi = 0.0;
    }
}

impl Snapshot for ElementaryCreepOperator {
    type State = f64;

    fn state(&self) -> f64 {
        self.chi
    }

    fn set_state(&mut self, state: &f64) -> Result<(), ModelError> {
        check_finite("creep.state", std::slice::from_ref(state))?;
        self.chi = *state;
        Ok(())
    }
}

/// The elementary log(t)-creep operator (15): the mean of `m` elementary creep
/// operators with one threshold.
#[derive(Debug, Clone, PartialEq)]
pub struct LogCreepOperator {
    threshold: f64,
    gains: Vec<f64>,
    chi: Vec<f64>,
}

impl LogCreepOperator {
    /// A log(t)-creep operator with threshold `r ≥ 0` and eigenvalues `a_j > 0`.
    pub fn new(threshold: f64, eigenvalues: &[f64], sample_time: f64) -> Result<Self, ModelError> {
        parameters::check_threshold("creep.threshold", threshold)?;
        check_eigenvalues("creep.eigenvalues", eigenvalues)?;
        check_sample_time(sample_time)?;
        Ok(Self {
            threshold,
            gains: eigenvalues
                .iter()
                .map(|&a| creep_gain(a, sample_time))
                .collect(),
            chi: vec![0.0; eigenvalues.len()],
        })
    }
}

impl Operator for LogCreepOperator {
    #[inline]
    fn step(&mut self, v: f64) -> f64 {
        let m = self.chi.len() as f64;
        let mut sum = 0.0;
        for (chi, &g) in self.chi.iter_mut().zip(&self.gains) {
            sum += *chi;
            *chi += g * dead_zone(v - *chi, self.threshold);
        }
        sum / m
    }

    fn reset(&mut self) {
        self.chi.fill(0.0);
    }
}

impl Snapshot for LogCreepOperator {
    type State = Vec<f64>;

    fn state(&self) -> Vec<f64> {
        self.chi.clone()
    }

    fn set_state(&mut self, state: &Vec<f64>) -> Result<(), ModelError> {
        check_length("creep.state", self.chi.len(), state.len())?;
        check_finite("creep.state", state)?;
        self.chi.copy_from_slice(state);
        Ok(())
    }
}

/// The Prandtl–Ishlinskii creep operator `C` (16).
///
/// Output `C_k = Σ_i (w_i / m) Σ_j χ_{i,j,k}`, with `χ` stored
/// eigenvalue-major (`j` outer, `i` inner); the per-sample update is the
/// real-time core's blocked pass ([`crate::realtime::creep::advance`]).
#[derive(Debug, Clone, PartialEq)]
pub struct CreepOperator {
    thresholds: Vec<f64>,
    weights: Vec<f64>,
    eigenvalues: Vec<f64>,
    sample_time: f64,
    /// `χ[j * n + i]`: eigenvalue `j`, threshold `i`.
    chi: Vec<f64>,
    /// `1 − e^{−a_j T_s}` per eigenvalue and `w_i / m` per threshold.
    gains: Vec<f64>,
    scaled_weights: Vec<f64>,
    /// The output the current state produces, kept so `output()` is O(1).
    output: f64,
    /// The last finite input, held in place of a non-finite one.
    last_input: f64,
}

impl CreepOperator {
    /// A PI creep operator in the zero state. Checks (18) for the thresholds,
    /// (17) for the weights, positive eigenvalues and sample time.
    pub fn new(
        thresholds: Vec<f64>,
        weights: Vec<f64>,
        eigenvalues: Vec<f64>,
        sample_time: f64,
    ) -> Result<Self, ModelError> {
        check_thresholds("creep.thresholds", &thresholds)?;
        check_finite("creep.weights", &weights)?;
        check_length("creep.weights", thresholds.len(), weights.len())?;
        parameters::check_partial_sums("creep.weights", &weights, false)?;
        check_eigenvalues("creep.eigenvalues", &eigenvalues)?;
        check_sample_time(sample_time)?;
        let n = thresholds.len();
        let m = eigenvalues.len();
        Ok(Self {
            gains: eigenvalues
                .iter()
                .map(|&a| creep_gain(a, sample_time))
                .collect(),
            scaled_weights: weights.iter().map(|&w| w / m as f64).collect(),
            thresholds,
            weights,
            eigenvalues,
            sample_time,
            chi: vec![0.0; n * m],
            output: 0.0,
            last_input: 0.0,
        })
    }

    /// Thresholds `r_{C,i}`.
    pub fn thresholds(&self) -> &[f64] {
        &self.thresholds
    }

    /// Weights `w_{C,i}`.
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// Eigenvalues `a_j` (s⁻¹).
    pub fn eigenvalues(&self) -> &[f64] {
        &self.eigenvalues
    }

    /// Sample time `T_s` (s).
    pub fn sample_time(&self) -> f64 {
        self.sample_time
    }

    /// The output `C_k` of the current state (before the next input acts).
    #[inline]
    pub fn output(&self) -> f64 {
        self.output
    }

    /// The outputs `ς_{C,i} = (1/m) Σ_j χ_{i,j}` of the log(t)-creep operators
    /// (15), one per threshold, for the current state: the creep columns of
    /// the identification regressor (25).
    #[inline]
    pub fn log_creep_outputs_into(&self, out: &mut [f64]) {
        let n = self.thresholds.len();
        let m = self.eigenvalues.len() as f64;
        out[..n].copy_from_slice(&self.chi[..n]);
        for row in self.chi.chunks_exact(n).skip(1) {
            for (o, &c) in out.iter_mut().zip(row) {
                *o += c;
            }
        }
        for o in &mut out[..n] {
            *o /= m;
        }
    }

    /// Advance the state with input `v_k` (`χ_k → χ_{k+1}`) and return the
    /// next output `C_{k+1}`. Allocation-free. A non-finite input is taken as
    /// the last finite one held: it never enters the state.
    #[inline]
    pub fn advance(&mut self, v: f64) -> f64 {
        realtime::simd::dispatch(|| self.advance_with::<true>(v))
    }

    /// [`CreepOperator::advance`] compiled for the caller's instruction set;
    /// with `SIMD`, the explicit AVX blocks where the CPU has them.
    #[inline(always)]
    pub(crate) fn advance_with<const SIMD: bool>(&mut self, v: f64) -> f64 {
        self.output = realtime::creep::advance_fast::<f64, SIMD>(
            &mut self.chi,
            &self.thresholds,
            &self.gains,
            &self.scaled_weights,
            v,
            &mut self.last_input,
        );
        self.output
    }

    /// Advance the state with `v_k` like [`CreepOperator::advance`], without
    /// computing the output (for callers that read the log(t) outputs).
    #[cfg(feature = "identification")]
    #[inline]
    pub(crate) fn advance_state(&mut self, v: f64) {
        self.advance(v);
    }

    fn refresh_output(&mut self) {
        self.output = realtime::creep::output(&self.chi, &self.scaled_weights);
    }
}

impl Operator for CreepOperator {
    #[inline]
    fn step(&mut self, v: f64) -> f64 {
        let out = self.output;
        self.advance(v);
        out
    }

    fn reset(&mut self) {
        self.chi.fill(0.0);
        self.last_input = 0.0;
        self.refresh_output();
    }
}

impl Snapshot for CreepOperator {
    /// One row of `m` values per threshold, as in the model file.
    type State = Vec<Vec<f64>>;

    fn state(&self) -> Vec<Vec<f64>> {
        let n = self.thresholds.len();
        let m = self.eigenvalues.len();
        (0..n)
            .map(|i| (0..m).map(|j| self.chi[j * n + i]).collect())
            .collect()
    }

    fn set_state(&mut self, state: &Vec<Vec<f64>>) -> Result<(), ModelError> {
        let n = self.thresholds.len();
        let m = self.eigenvalues.len();
        check_length("creep.state", n, state.len())?;
        for (i, row) in state.iter().enumerate() {
            check_length(&format!("creep.state[{i}]"), m, row.len())?;
            check_finite(&format!("creep.state[{i}]"), row)?;
        }
        for (i, row) in state.iter().enumerate() {
            for (j, &c) in row.iter().enumerate() {
                self.chi[j * n + i] = c;
            }
        }
        self.refresh_output();
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::realtime::ParameterError;

    #[test]
    fn expm1_gain_keeps_digits_for_slow_eigenvalues() {
        let g = creep_gain(0.05, 2e-4);
        // 1 − e^{−x} = x − x²/2 + x³/6 for x = 1e-5, to 1e-21.
        let x: f64 = 1e-5;
        let series = x - x * x / 2.0 + x * x * x / 6.0;
        assert!((g - series).abs() <= 4.0 * f64::EPSILON * series);
    }

    #[test]
    fn eigenvalues_of_24_at_paper_sample_time() {
        let a = log_spaced_eigenvalues(5, 2e-4);
        let expected = [500.0, 50.0, 5.0, 0.5, 0.05];
        for (a, e) in a.iter().zip(expected) {
            assert!((a - e).abs() <= 4.0 * f64::EPSILON * e);
        }
    }

    #[test]
    fn output_has_one_sample_delay() {
        let mut c = ElementaryCreepOperator::new(0.0, 500.0, 2e-4).unwrap();
        assert_eq!(c.step(1.0), 0.0);
        assert!(c.step(1.0) > 0.0);
    }

    #[test]
    fn creep_weights_may_not_have_negative_partial_sums() {
        let e = CreepOperator::new(vec![0.0, 1.0], vec![0.1, -0.2], vec![1.0], 1e-3).unwrap_err();
        assert!(matches!(
            e.parameter(),
            Some(ParameterError::PartialSumNegative { index: 1, .. })
        ));
        let e = CreepOperator::new(vec![0.0], vec![0.1], vec![-1.0], 1e-3).unwrap_err();
        assert!(matches!(
            e.parameter(),
            Some(ParameterError::NonPositiveEigenvalue { .. })
        ));
        let e = CreepOperator::new(vec![0.0], vec![0.1], vec![1.0], 0.0).unwrap_err();
        assert!(matches!(
            e.parameter(),
            Some(ParameterError::NonPositiveSampleTime { .. })
        ));
    }

    #[test]
    fn single_threshold_creep_operator_is_the_weighted_log_creep_operator() {
        let a = [500.0, 5.0, 0.05];
        let mut pi = CreepOperator::new(vec![0.0], vec![1.0], a.to_vec(), 2e-4).unwrap();
        let mut log = LogCreepOperator::new(0.0, &a, 2e-4).unwrap();
        for k in 0..1000 {
            let v = (k as f64 * 0.01).sin();
            let (p, l) = (pi.step(v), log.step(v));
            // Same terms summed in another order: rounding of m terms, |χ| ≤ 1.
            assert!((p - l).abs() <= 4.0 * a.len() as f64 * f64::EPSILON);
        }
    }
}
