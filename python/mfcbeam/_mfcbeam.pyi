"""Type stubs of the compiled module `mfcbeam._mfcbeam` (re-exported by
`mfcbeam`). The docstrings at run time (`help(mfcbeam.Model)`) come from the
Rust sources; these stubs give editors and type checkers the signatures."""

from os import PathLike
from typing import Any, Dict, List, Optional, Sequence, Tuple, TypedDict, Union

import numpy as np
import numpy.typing as npt

__version__: str

ArrayLike = npt.ArrayLike
FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
StrPath = Union[str, PathLike]

class ModelState(TypedDict):
    hysteresis: FloatArray
    """Play states, one per hysteresis threshold."""
    creep: Optional[FloatArray]
    """Creep states, shape (creep thresholds, eigenvalues); None without creep."""
    delay: Optional[FloatArray]
    """The values waiting in the dead time, oldest first; None without one or before the first sample."""
    dynamics: Optional[FloatArray]
    """The last outputs of the dynamics G, newest first; None without G or before the first sample."""

class Model:
    """The hysteresis and creep model W = S[H + C] + offset (S, the optional
    superposition operator of asymmetric loops): it maps the balanced patch
    voltage u (V) to the effective voltage y.

    Stateful: `simulate` continues from the current state; `reset()` returns
    to the virgin state."""

    @staticmethod
    def from_file(path: StrPath) -> Model:
        """Read a model file (JSON). Raises ValueError naming file and field."""
    @staticmethod
    def from_json(text: str) -> Model:
        """A model from the text of a model file. Raises ValueError naming the field."""
    @staticmethod
    def nominal() -> Model:
        """The paper's nominal model (12 plays, 12 creep operators, 5 eigenvalues, T_s = 0.2 ms)."""
    def simulate(self, u: ArrayLike) -> FloatArray:
        """y = W[u] from the current state; non-finite samples are held."""
    def reset(self) -> None:
        """Return to the virgin state."""
    @property
    def sample_time(self) -> float:
        """T_s (s)."""
    @property
    def offset(self) -> float:
        """Constant output offset."""
    @property
    def superposition(self) -> Optional[Tuple[List[float], List[float]]]:
        """The superposition operator S after H + C as (thresholds, weights), or None."""
    @property
    def delay(self) -> int:
        """The dead time d (samples): y_k = G[S[H + C]]_{max(k-d, 0)} + offset."""
    @property
    def dynamics(self) -> Optional[Dict[str, Any]]:
        """The dynamics G after S: {"low_pass": Hz or None, "resonance": (Hz, damping) or None}, or None."""
    @property
    def state(self) -> ModelState:
        """The current play and creep states."""
    def to_json(self) -> str:
        """The model file (JSON) with the current state."""
    def to_file(self, path: StrPath) -> None:
        """Write the model file with the current state (atomically)."""
    def copy(self) -> Model:
        """A copy with its own state."""
    def __copy__(self) -> Model: ...
    def __deepcopy__(self, memo: Any) -> Model: ...

class Compensator:
    """The compensator W⁻¹ (analytic inverse of H, creep predicted one
    sample ahead), clipped to `limits`; starts from the model's state."""

    def __init__(
        self, model: Model, limits: Optional[Tuple[float, float]] = (-1000.0, 1000.0)
    ) -> None:
        """`limits=None`: no saturation (the one way to say so; both bounds
        infinite is refused). Raises ValueError unless lower < upper."""
    def compensate(
        self, y_d: ArrayLike, *, preview: bool = False
    ) -> Tuple[FloatArray, BoolArray, BoolArray]:
        """(u, saturated, fault) for the targets y_d, from the current state.
        With a dead time d, y_d[k] is the target for sample k + d (a stream);
        `preview=True` shifts a whole planned y_d by d instead."""
    def reset(self) -> None:
        """Return to the virgin state."""
    @property
    def delay(self) -> int:
        """The model's dead time d (samples)."""
    @property
    def limits(self) -> Tuple[float, float]:
        """(lower, upper) in V; infinite without limits."""
    def copy(self) -> Compensator:
        """A copy with its own state."""
    def __copy__(self) -> Compensator: ...
    def __deepcopy__(self, memo: Any) -> Compensator: ...

class FitErrors(TypedDict):
    samples: int
    rms: float
    rms_percent: float
    max: float
    max_percent: float
    output_range: float

class ActiveConstraint(TypedDict):
    group: str
    index: int
    bound: float

class NamedOperator(TypedDict):
    group: str
    index: int
    threshold: float

class ValidationRow(TypedDict):
    name: str
    start: int
    rate: Optional[float]
    zero_offset: Optional[float]
    zeroed: Optional[FitErrors]
    samples: int
    rms: float
    rms_percent: float
    max: float
    max_percent: float
    output_range: float

class DelayRow(TypedDict):
    delay: int
    fit: FitErrors
    holdout: Optional[FitErrors]
    validations: List[FitErrors]
    score: float

class RateGainRow(TypedDict):
    rate_gain: float
    fit: FitErrors
    holdout: Optional[FitErrors]
    validations: List[FitErrors]
    score: float

class InitialStateReport(TypedDict):
    rms: List[float]
    rounds: int
    models: List[Model]
    unwiped: List[List[int]]

class FitReport(TypedDict):
    sample_time: float
    jitter: Optional[float]
    samples: int
    fitted: Tuple[int, int]
    skipped: int
    skip_reason: str
    rms: float
    rms_percent: float
    max: float
    max_percent: float
    output_range: float
    holdout: Optional[FitErrors]
    validation: Optional[FitErrors]
    validations: List[ValidationRow]
    offset: float
    condition_number: float
    rank: int
    unknowns: int
    epsilon_h: float
    kkt_residual: float
    iterations: int
    weights: List[float]
    standard_errors: List[float]
    superposition: Optional[Tuple[List[float], List[float]]]
    delay: int
    delays: Optional[List[DelayRow]]
    delay_criterion: Optional[str]
    rate_gain: float
    rate_gains: Optional[List[RateGainRow]]
    rate_gain_criterion: Optional[str]
    active_constraints: List[ActiveConstraint]
    unexcited: List[NamedOperator]
    undetermined: List[NamedOperator]
    records: List[Dict[str, Any]]
    dynamics: Optional[Dict[str, Any]]
    initial_state: Optional[InitialStateReport]
    creep_regularisation: Optional[Tuple[float, float]]
    text: str

def identify(
    u: ArrayLike,
    y: ArrayLike,
    *,
    sample_time: Optional[float] = None,
    t: Optional[ArrayLike] = None,
    hysteresis_operators: int = 12,
    creep_operators: int = 12,
    creep_eigenvalues: int = 5,
    hysteresis_thresholds: Optional[ArrayLike] = None,
    creep_thresholds: Optional[ArrayLike] = None,
    eigenvalues: Optional[ArrayLike] = None,
    epsilon_h: Optional[float] = None,
    fit_offset: bool = True,
    fit_from: Optional[int] = None,
    holdout: float = 0.0,
    validate: Union[None, Tuple[ArrayLike, ArrayLike], List[Tuple[ArrayLike, ArrayLike]]] = None,
    superposition: int = 0,
    superposition_kinks: Optional[ArrayLike] = None,
    validate_from: Optional[int] = None,
    delay: Union[None, int, str] = None,
    max_delay: int = 10,
    records: Optional[List[Tuple[ArrayLike, ArrayLike]]] = None,
    offset: str = "shared",
    dynamics: str = "none",
    validate_zero: Optional[Tuple[int, int]] = None,
    thresholds: str = "uniform",
    fit_initial_state: bool = False,
    creep_regularisation: Union[None, str, float] = None,
    rate_gain: Union[None, str, float] = None,
) -> Tuple[Model, FitReport]:
    """Identify W = G[S[H + C]] + offset from input u (V) and measured y, at
    `sample_time` (s) or timestamps `t` (`superposition=M`: M dead zones of S
    per side; 0, the paper's symmetric model; `delay=d` or "auto": a dead
    time; `records`: more records fitted together, `offset="per-record"`;
    `dynamics`: "low-pass", "resonance" or both, comma-separated;
    `validate_zero=(a, b)`: each validation record's offset estimated on its
    samples a..b; `fit_initial_state`: each record's memory fitted with the
    weights; `creep_regularisation`: "gcv" or λ, a penalty on the creep
    weights; `rate_gain`: β (s) of the rate-dependent thresholds
    r_i + β|Δu|/T_s, or "auto"); returns the model and the fit report."""

class StateReport(TypedDict):
    window: int
    rms: float
    prior_rms: float
    offset: float
    unwiped: List[int]
    iterations: int

def estimate_state(
    model: Model,
    u: ArrayLike,
    y: ArrayLike,
    *,
    until: Optional[int] = None,
    state_at: str = "start",
    fit_offset: bool = True,
    fit_creep: bool = True,
    fit_dynamics: bool = True,
) -> Tuple[Model, StateReport]:
    """Estimate the memory the record (u, y) starts in for `model` (play and
    creep states, the state of G, the offset) from its samples before
    `until`; returns the model in that state (`state_at="end"`: after the
    window) and the report."""

class Modes(TypedDict):
    frequencies_hz: FloatArray
    damping_ratios: FloatArray
    static_gain: float
    model: str
    modes: int

class Beam:
    """The MFC-driven cantilever (a beam file, SI units). `beam_model` is
    "modal" (finite elements reduced to modes) or "ritz" (the paper's)."""

    @staticmethod
    def from_file(path: StrPath) -> Beam:
        """Read a beam file (JSON). Raises ValueError naming file and field."""
    @staticmethod
    def from_json(text: str) -> Beam:
        """A beam from the text of a beam file."""
    @staticmethod
    def nominal() -> Beam:
        """The paper's beam (reconstructed)."""
    def to_json(self) -> str:
        """The beam file (JSON)."""
    def to_file(self, path: StrPath) -> None:
        """Write the beam file (atomically)."""
    def modes(self, beam_model: str = "modal", *, elements: int = 240) -> Modes:
        """Natural frequencies, damping ratios and static gain of the modes."""
    def simulate(
        self, u: ArrayLike, sample_time: float, *, beam_model: str = "modal", elements: int = 240
    ) -> FloatArray:
        """Tip deflection (m) for the effective voltage u (V), exact ZOH, from rest."""

class FeedforwardTrace(TypedDict, total=False):
    t: FloatArray
    y_d: FloatArray
    u_d: FloatArray
    u: FloatArray
    u_fs: FloatArray
    u_bs: FloatArray
    saturated: BoolArray

def feedforward(
    beam: Beam,
    model: Optional[Model] = None,
    *,
    start: float = 2.9,
    duration: float = 0.075,
    y_final: float = 1e-3,
    sigma: float = 1.1,
    end: float = 4.0,
    sample_time: Optional[float] = None,
    beam_model: str = "modal",
    elements: int = 240,
) -> FeedforwardTrace:
    """Flatness-based feedforward of a rest-to-rest tip move; with `model`
    also the compensated voltages u = W⁻¹[u_d], u_fs, u_bs, saturated."""
