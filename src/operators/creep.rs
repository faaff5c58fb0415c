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
use crate::operators::heap::Heap;
use crate::operators::play::dead_zone;
use crate::operators::traits::{Operator, Snapshot};
use crate::realtime::checks::{
    check_eigenvalues, check_finite, check_length, check_sample_time, check_threshold,
};
use crate::realtime::{Creep, Real, Storage};

pub use crate::realtime::creep::creep_gain;

/// `C` (16) in `f64` on the heap: what most programs use.
pub type CreepOperator = Creep<f64, Heap>;

/// (24): eigenvalues `a_j = 1 / (10^j T_s)`, `j = 1..m`.
pub fn log_spaced_eigenvalues(m: usize, sample_time: f64) -> Vec<f64> {
    (1..=m)
        .map(|j| 1.0 / (10f64.powi(j as i32) * sample_time))
        .collect()
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
        check_threshold("creep.threshold", threshold)?;
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
        check_threshold("creep.threshold", threshold)?;
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

crate::operators::traits::operator_in_any_precision!(Creep);

impl<T: Real, S: Storage> Snapshot for Creep<T, S> {
    /// One row of `m` values per threshold, as in the model file.
    type State = Vec<Vec<f64>>;

    fn state(&self) -> Vec<Vec<f64>> {
        let (n, m) = self.shape();
        let mut flat = vec![0.0; n * m];
        self.state_flat_into(&mut flat)
            .expect("the buffer has the shape's length");
        flat.chunks(m.max(1)).take(n).map(<[f64]>::to_vec).collect()
    }

    fn set_state(&mut self, state: &Vec<Vec<f64>>) -> Result<(), ModelError> {
        let (n, m) = self.shape();
        check_length("creep.state", n, state.len())?;
        for (i, row) in state.iter().enumerate() {
            let field = || format!("creep.state[{i}]");
            check_length("", m, row.len()).map_err(|e| e.named(&field()))?;
            check_finite("", row).map_err(|e| e.named(&field()))?;
        }
        let flat: Vec<f64> = state.iter().flatten().copied().collect();
        Ok(self.set_state_flat(&flat)?)
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
            e,
            ParameterError::PartialSumNegative { index: 1, .. }
        ));
        let e = CreepOperator::new(vec![0.0], vec![0.1], vec![-1.0], 1e-3).unwrap_err();
        assert!(matches!(e, ParameterError::NonPositiveEigenvalue { .. }));
        let e = CreepOperator::new(vec![0.0], vec![0.1], vec![1.0], 0.0).unwrap_err();
        assert!(matches!(e, ParameterError::NonPositiveSampleTime { .. }));
    }

    #[test]
    fn single_threshold_creep_operator_is_the_weighted_log_creep_operator() {
        let a = [500.0, 5.0, 0.05];
        let mut pi = CreepOperator::new(vec![0.0], vec![1.0], a, 2e-4).unwrap();
        let mut log = LogCreepOperator::new(0.0, &a, 2e-4).unwrap();
        for k in 0..1000 {
            let v = (k as f64 * 0.01).sin();
            let (p, l) = (pi.step(v), log.step(v));
            // Same terms summed in another order: rounding of m terms, |χ| ≤ 1.
            assert!((p - l).abs() <= 4.0 * a.len() as f64 * f64::EPSILON);
        }
    }
}
