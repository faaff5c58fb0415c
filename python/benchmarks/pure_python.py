"""The compensator W⁻¹ (21) written the way one would in Python with NumPy:
a loop over the samples, NumPy vectors over the operators. It is the peer
of `mfcbeam.Compensator` in `compensate_speed.py` and is checked against it
in `tests/test_compensator.py`.

Per sample k, with target y_d:
  c      = Σ_i w_C,i · mean_j χ_ij                 creep, from the last input
  z      = y_d − offset − c
  x'     = play(z, r', x')       v = w' · x'       H⁻¹ (22), a PI operator
  u      = clip(v, lower, upper)
  x      = play(u, r, x)                           the plant's H, matched
  x'     = s ∘ x + reverse-cumsum(w ∘ x) shifted   only after clipping (22)
  χ     += g ∘ d_r(u − χ)                          creep (20), g = 1 − e^{−a T_s}
"""

import json
import math

import numpy as np


def play(v, r, x):
    """The play operator: x kept within [v − r, v + r]."""
    return np.maximum(v - r, np.minimum(x, v + r))


class PurePythonCompensator:
    def __init__(self, model_json, limits=(-1000.0, 1000.0)):
        m = json.loads(model_json)
        h = m["hysteresis"]
        self.r = np.array(h["thresholds"], dtype=float)
        self.w = np.array(h["weights"], dtype=float)
        self.s = np.cumsum(self.w)
        n = len(self.r)
        # (22): r'_j = Σ_{i<j} w_i (r_j − r_i), w'_0 = 1/w_0, w'_j = −w_j/(s_j s_{j−1})
        self.r_inv = np.array([np.sum(self.w[:j] * (self.r[j] - self.r[:j])) for j in range(n)])
        self.w_inv = np.empty(n)
        self.w_inv[0] = 1.0 / self.w[0]
        self.w_inv[1:] = -self.w[1:] / (self.s[1:] * self.s[:-1])
        self.x = np.array(h.get("state") or np.zeros(n), dtype=float)
        self.x_inv = self._inverse_state()
        self.offset = m.get("offset") or 0.0
        c = m.get("creep")
        if c is None:
            self.creep = False
        else:
            self.creep = True
            self.r_c = np.array(c["thresholds"], dtype=float)[:, None]
            self.w_c = np.array(c["weights"], dtype=float)
            a = np.array(c["eigenvalues"], dtype=float)
            self.g = -np.expm1(-a * m["sample_time"])[None, :]
            shape = (len(c["thresholds"]), len(a))
            self.chi = np.array(c.get("state") or np.zeros(shape), dtype=float)
        self.lower, self.upper = limits if limits is not None else (-math.inf, math.inf)

    def _inverse_state(self):
        # x'_j = s_j x_j + Σ_{i>j} w_i x_i
        wx = self.w * self.x
        tail = np.concatenate([np.cumsum(wx[::-1])[::-1][1:], [0.0]])
        return self.s * self.x + tail

    def _creep_output(self):
        return float(self.w_c @ self.chi.mean(axis=1)) if self.creep else 0.0

    def _advance_creep(self, u):
        if self.creep:
            self.chi += self.g * play(u - self.chi, self.r_c, 0.0)

    def compensate(self, y_d):
        y_d = np.asarray(y_d, dtype=float)
        u = np.empty(len(y_d))
        saturated = np.zeros(len(y_d), dtype=bool)
        fault = np.zeros(len(y_d), dtype=bool)
        for k, target in enumerate(y_d):
            if not math.isfinite(target):
                # hold the last output; the plays see no change
                u[k] = self.x[0]
                fault[k] = True
                self._advance_creep(u[k])
                continue
            z = target - self.offset - self._creep_output()
            self.x_inv = play(z, self.r_inv, self.x_inv)
            v = float(self.w_inv @ self.x_inv)
            uk = min(max(v, self.lower), self.upper)
            saturated[k] = uk != v
            self.x = play(uk, self.r, self.x)
            if saturated[k]:
                self.x_inv = self._inverse_state()
            self._advance_creep(uk)
            u[k] = uk
        return u, saturated, fault
