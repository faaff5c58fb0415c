//! Identification of the hysteresis and creep weights from a measurement,
//! equations (23)–(25), in stages: [`settings`] (what to fit), `regressor`
//! (stage 1), `solve` (stage 2) and [`report`] (stage 3), put together by
//! [`identify()`]; [`delay`] chooses a dead time, [`rate_gain`] the rate
//! dependence of the play thresholds, [`validation`] checks the result on
//! other records.
//!
//! Thresholds (23): `r_i = (i · r_max)/(n + 1)`, `r_max = max_k |v_k|`;
//! creep eigenvalues (24): `a_j = 1/(10^j T_s)`. With those fixed, `W` is linear
//! in the weights, `W[v] = Φ w`, where `Φ` has one column per play output and
//! one per log(t)-creep output (15), sampled on the measured input from the
//! virgin state. (25) becomes the convex QP
//!
//! ```text
//! min_w ½ ‖Φ w − ς‖²   s.t.  Σ_{i≤j} w_H,i ≥ ε_H  (j = 0..n_H),   Σ_{i≤j} w_C,i ≥ 0  (j = 0..n_C)
//! ```
//!
//! **Unknown initial state and offset.** A measurement starts from a history
//! the model does not know, and a sensor adds an offset. Once `|v|` has
//! reached `max|v|`, every play has been pushed to one side of its band, so
//! its state is fixed by the input alone (wiping out, Madelung (iii)): by
//! default only the samples from there on are fitted (the operators still run
//! from the first sample). The creep states are not wiped out that way; their
//! unknown initial part decays like `e^{−a t}`. An output offset is fitted as
//! one more, unconstrained, unknown.
//!
//! Solved as follows:
//!
//! 1. `Φ` is built in one pass over the input (the plays and creep operators
//!    are stepped once per sample); the fitted rows of `[1 | Φ | ς]` (offset
//!    column first) get one thin Householder QR (faer). Eliminating the
//!    offset leaves `‖Φ w − ς‖² = ‖R w − c‖² + ρ²` with a small triangular
//!    `R`: the rest no longer depends on the number of samples.
//! 2. The unknowns become the partial sums shifted by their bounds,
//!    `x_j = S_j − b_j ≥ 0` (`w = D S`, `D` the difference operator per
//!    group), a non-negative least-squares problem `min ‖M x − d‖`,
//!    `M = R D`, solved exactly by the Lawson–Hanson active-set method: it
//!    ends in finitely many steps at a point that meets the KKT conditions
//!    (`g = Mᵀ(M x − d)`: `g_j = 0` where `x_j > 0`, `g_j ≥ 0` where
//!    `x_j = 0`), which the report states as a relative residual.
//! 3. The numerical rank of `R` comes from its singular values: those below
//!    [`RANK_TOLERANCE`] times the largest span directions the input does not
//!    determine; the operators with weight in them are named. Every
//!    least-squares step takes the minimum-norm solution (in `x`), so the
//!    returned optimum is the minimum-norm one of its active set.
//! 4. The weights are rebuilt from the partial sums so that the recomputed
//!    partial sums satisfy the bounds in floating point: the identified model
//!    always satisfies (11) and (17), so its inverse (22) exists.
//!
//! With rate-dependent thresholds (`settings.rate_gain > 0`) the plays'
//! columns use the widened thresholds, and the hysteresis weights
//! themselves are bounded (`w_0 ≥ ε_H`, `w_i ≥ 0`: no `D` on their columns),
//! the class whose steps stay invertible (docs/MATHEMATICS.md §5.8).
//!
//! Operators whose threshold the input never exceeds (`r_i ≥ max|v|`) are
//! never excited: their columns are zero. They keep weight 0 (which leaves the
//! partial sums, and so (11), intact) and are named in the report.

// the state estimate needs `std` alone (the C library has it); the rest
// needs the `identification` feature (faer)
#[cfg(feature = "identification")]
pub mod delay;
#[cfg(feature = "identification")]
mod dynamics;
#[cfg(feature = "identification")]
mod identify;
pub mod initial_state;
#[cfg(feature = "identification")]
mod joint_state;
#[cfg(feature = "identification")]
mod plan;
#[cfg(feature = "identification")]
pub mod rate_gain;
#[cfg(feature = "identification")]
mod regressor;
#[cfg(feature = "identification")]
pub mod report;
pub mod settings;
#[cfg(feature = "identification")]
mod solve;
#[cfg(feature = "identification")]
pub mod thresholds;
#[cfg(feature = "identification")]
pub mod validation;

#[cfg(feature = "identification")]
pub use delay::{
    search_delay, search_delay_records, validation_rms, DelayRow, DelaySearch, DelaySetting,
    Record, SearchCriterion, DEFAULT_MAX_DELAY,
};
#[cfg(feature = "identification")]
pub use dynamics::{fit_dynamics, fit_dynamics_and_delay, DynamicsParts};
#[cfg(feature = "identification")]
pub use identify::{identify, identify_records, FitRecord, Identification};
pub use initial_state::{estimate_state, StateEstimate, StateSettings};
#[cfg(feature = "identification")]
pub use joint_state::{identify_with_initial_states, InitialStateFit, InitialStateSettings};
#[cfg(feature = "identification")]
pub use plan::EPSILON_S;
#[cfg(feature = "identification")]
pub use rate_gain::{search_rate_gain, RateGainRow, RateGainSearch, RateGainSetting};
#[cfg(feature = "identification")]
pub use report::{
    first_at_max, validate, ActiveConstraint, DynamicsReport, FitErrors, FitReport, RecordFit,
    UnexcitedOperator,
};
pub use settings::{
    holdout_samples, superposition_kinks, thresholds_23, CreepRegularisation, IdentificationError,
    IdentificationSettings,
};
#[cfg(feature = "identification")]
pub use solve::RANK_TOLERANCE;
#[cfg(feature = "identification")]
pub use validation::{
    check_record, dominant_rate, validate_record, validate_record_from_state,
    validate_record_zeroed, FitStart, ValidationRow, ValidationTable, ZeroSegment,
};
