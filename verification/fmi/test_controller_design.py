"""The LQ + observer design inside the controller FMU, checked against
solvers written independently of this project: SciPy's Riccati solver
(Schur vectors) and the plain Riccati recursion iterated to its fixed point.
docs/MATHEMATICS.md §11.2 states the design."""

import json
import zipfile

import numpy as np
import pytest
import scipy.linalg as sl

from conftest import run
from test_fmpy import read_csv


def recursion(a, b, q, r, steps=400_000):
    """X ← aᵀXa − aᵀXb (r + bᵀXb)⁻¹ bᵀXa + q from X = 0, to its fixed point."""
    x = np.zeros_like(q)
    for _ in range(steps):
        g = a.T @ x @ b
        nxt = a.T @ x @ a - np.outer(g, g) / (r + b @ x @ b) + q
        if np.array_equal(nxt, x):
            break
        x = nxt
    return x


@pytest.mark.parametrize("version", ["3"])
def test_lq_and_observer_gains_against_scipy_and_the_recursion(cli, fmus, tmp_path, version):
    with zipfile.ZipFile(fmus[("controller-lq", version)]) as z:
        design = json.loads(z.read("resources/controller.json"))["state_feedback"]
    b = np.array(design["b"])
    big = len(b)
    n = big - 1  # the modal states; the last is the input disturbance
    a = np.array(design["a"]).reshape(big, big)
    c = np.array(design["c"])
    phi, gamma, cm = a[:n, :n], b[:n], c[:n]
    # Bryson's rule: y_max the stroke of the reference, u_max 1000 V
    out = tmp_path / "loop"
    run(cli, "benchmark-control", "--controller", "open", "--scenario", "nominal", "--output-dir", out)
    y_max = np.abs(read_csv(out / "nominal-open.csv")["reference"]).max()
    q, r = np.outer(cm, cm) / y_max**2, 1.0 / 1000.0**2
    k_ours = np.array(design["feedback"][:n])
    assert design["feedback"][n] == 1.0  # the disturbance estimate is cancelled
    x = sl.solve_discrete_are(phi, gamma[:, None], q, np.array([[r]]))
    k_scipy = (gamma @ x @ phi) / (r + gamma @ x @ gamma)
    # both solutions have residuals near 1e-14 of |X|; X's condition number
    # (3e7: poles 2e-4 from the unit circle) leaves the gains within 1e-9
    assert np.max(np.abs(k_scipy - k_ours) / np.abs(k_ours)) < 1e-9
    x = recursion(phi, gamma, q, r)
    k_rec = (gamma @ x @ phi) / (r + gamma @ x @ gamma)
    assert np.max(np.abs(k_rec - k_ours) / np.abs(k_ours)) < 1e-9

    # the observer: the dual equation on (x, d) with σ_v = 1 µm, σ_d as stored
    w = np.zeros((big, big))
    w[n, n] = design["disturbance_increment"] ** 2
    v = 1e-6**2
    l_ours = np.array(design["observer"])
    p = recursion(a.T, c, w, v)
    l_rec = p @ c / (c @ p @ c + v)
    assert np.max(np.abs(l_rec - l_ours) / np.abs(l_ours)) < 1e-10
    # SciPy's Schur solution is the least accurate of the three here (its
    # residual is 6e-13 of |P| against 1e-15 for the recursion): 1e-6
    p = sl.solve_discrete_are(a.T, c[:, None], w, np.array([[v]]))
    l_scipy = p @ c / (c @ p @ c + v)
    assert np.max(np.abs(l_scipy - l_ours) / np.abs(l_ours)) < 1e-6
