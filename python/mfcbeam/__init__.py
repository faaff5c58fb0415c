"""Prandtl-Ishlinskii hysteresis and creep compensation of piezoelectric
actuators, at Rust speed on NumPy arrays.

The operators follow Schröck, Meurer and Kugi, Smart Mater. Struct. 20 (2011)
015016: the hysteresis and creep model W = H + C (`Model`), its analytic
inverse, the real-time compensator (`Compensator`), identification of the
weights from a measured record (`identify`), the memory a record starts in
(`estimate_state`), the MFC-patch-driven cantilever
(`Beam`) and flatness-based feedforward (`feedforward`).

Arrays go in as anything `numpy.asarray` takes and come out as float64 (or
bool) NumPy arrays; the per-sample loops run in Rust with the GIL released.
Bad arguments and files raise ValueError naming the field, file or sample.
"""

from ._mfcbeam import (
    Beam,
    Compensator,
    Model,
    __version__,
    estimate_state,
    feedforward,
    identify,
)

__all__ = [
    "Beam",
    "Compensator",
    "Model",
    "__version__",
    "estimate_state",
    "feedforward",
    "identify",
]
