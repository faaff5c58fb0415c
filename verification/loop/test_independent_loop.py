"""The loop `mfcbeam benchmark-control` runs, simulated again from its
definition (docs/MATHEMATICS.md §11.1) with NumPy and SciPy, independently
of this project's code: the beam's modal model from `mfcbeam beam modes`,
discretized by SciPy's matrix exponential (zero-order hold, both inputs);
the PID of §11.2 written again here; `W∘W⁻¹` the identity (the true `W` is
the compensator's, no sample is clipped). The controller in the benchmark
is `examples/control/pid_controller.py` through the per-sample protocol."""

import csv
import json

import numpy as np
import pytest
import scipy.linalg as sl

from conftest import ROOT, run

TS = 2e-4


def read_csv(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}


def discretize(modes):
    omega = np.array(modes["omega"])
    n = len(omega)
    d = np.array(modes["modal_damping"]).reshape(n, n)
    b, c = np.array(modes["modal_input"]), np.array(modes["modal_output"])
    a = np.zeros((2 * n, 2 * n))
    a[:n, n:] = np.eye(n)
    a[n:, :n] = -np.diag(omega**2)
    a[n:, n:] = -d
    inputs = np.zeros((2 * n, 2))
    inputs[n:, 0], inputs[n:, 1] = b, c  # effective voltage, tip force
    m = np.zeros((2 * n + 2, 2 * n + 2))
    m[: 2 * n, : 2 * n] = a * TS
    m[: 2 * n, 2 * n :] = inputs * TS
    e = sl.expm(m)
    out = np.concatenate([c, np.zeros(n)])
    return e[: 2 * n, : 2 * n], e[: 2 * n, 2 * n :], out, d[0, 0] / (2 * omega[0])


def pid_gains(modes):
    """§11.2: poles of the first mode at (s + ω₁)(s² + 1.4ω₁s + ω₁²), T_f = T_d/2."""
    w1 = modes["omega"][0]
    z1 = modes["modal_damping"][0] / (2 * w1)
    k1 = modes["modal_input"][0] * modes["modal_output"][0] / w1**2
    zc, scale = 0.7, k1 * w1**2
    kp = ((1 + 2 * zc) * w1**2 - w1**2) / scale
    ki = w1**3 / scale
    kd = ((1 + 2 * zc) * w1 - 2 * z1 * w1) / scale
    return kp, ki, kd, kd / kp / 2.0


@pytest.mark.parametrize("scenario", ["impulse", "step-load", "noise"])
def test_the_loop_is_the_independent_simulation(cli, tmp_path, scenario):
    modes = json.loads(run(cli, "beam", "modes", "--beam", ROOT / "golden" / "nominal_beam.json"))
    run(cli, "benchmark-control", "--exec", "python3 examples/control/pid_controller.py",
        "--scenario", scenario, "--output-dir", tmp_path)
    tr = read_csv(tmp_path / f"{scenario}-program.csv")
    assert not tr["saturated"].any() and not tr["held"].any()
    phi, gamma, c, zeta1 = discretize(modes)
    kp, ki, kd, tf = pid_gains(modes)
    x = np.zeros(len(c))
    integral = derivative = 0.0
    last = None
    tip = []
    for k in range(len(tr["t"])):
        y = c @ x
        e = y + tr["noise"][k] - tr["reference"][k]
        last = e if last is None else last
        integral += TS * e
        derivative = (tf * derivative + kd * (e - last)) / (tf + TS)
        last = e
        delta = -(kp * e + ki * integral + derivative)
        x = phi @ x + gamma @ np.array([tr["feedforward"][k] + delta, tr["force"][k]])
        tip.append(y)
    tip = np.array(tip)
    # the two discretizations agree to 1e-9 relative (the complex
    # eigendecomposition's accuracy, verification/beam.rs), amplified up to
    # 1/(2ζ₁) near the first resonance; the gains from the closed form agree
    # to rounding
    scale = np.abs(tip).max()
    tol = 1e-9 / (2 * zeta1) * scale
    worst = np.abs(tip - tr["tip"]).max()
    print(f"{scenario}: the loops differ by {worst:.2e} m (tolerance {tol:.2e})")
    assert worst < tol
    # the measurement the controller saw is the tip plus the noise, and
    # the loop applied exactly what the PID answers to those measurements
    assert np.array_equal(tr["measurement"], tr["tip"] + tr["noise"])
    integral = derivative = 0.0
    last = None
    for k in range(len(tr["t"])):
        e = tr["measurement"][k] - tr["reference"][k]
        last = e if last is None else last
        integral += TS * e
        derivative = (tf * derivative + kd * (e - last)) / (tf + TS)
        last = e
        assert -(kp * e + ki * integral + derivative) == tr["correction"][k], k
