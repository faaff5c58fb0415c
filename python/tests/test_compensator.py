"""Compensator: bit-for-bit agreement with the Rust command line, the
identity W[W⁻¹[y]] = y within a rounding bound derived below, saturation
and faults, and agreement with the pure NumPy/Python compensator of the
speed comparison."""

import json
import sys
from pathlib import Path

import numpy as np
import pytest

import mfcbeam
from conftest import EPS, shrinking_loops

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from pure_python import PurePythonCompensator  # noqa: E402


def identity_bound(model_json, u, y_d):
    """A first-order bound on |W[W⁻¹[y_d]] − y_d| in double precision.

    The compensator's creep prediction c is computed exactly as the plant's
    (same operations on the same inputs), so only H∘H⁻¹ and the offset and
    creep additions round. A sum of n products w_i·x_i rounds by at most
    n·ε·Σ|w_i||x_i|; |x_i| ≤ max|u| for the plays of H, |x'_j| ≤ max|z| for
    those of H⁻¹ (22), z = y_d − offset − c. An error e in H⁻¹'s output moves
    H by at most max_j s_j·|e| (the Lipschitz constant of H, s_j the partial
    sums). Each of the four additions (z and y) rounds by ε of its size.
    The creep states move toward the input from their start, so
    |c| ≤ Σ|w_C|·max(|u|, |χ_0|).
    """
    h = model_json["hysteresis"]
    w = np.array(h["weights"])
    s = np.cumsum(w)
    w_inv = np.concatenate([[1.0 / w[0]], -w[1:] / (s[1:] * s[:-1])])
    n = len(w)
    offset = abs(model_json.get("offset") or 0.0)
    creep = model_json.get("creep")
    c_max = 0.0
    if creep is not None:
        chi0 = np.max(np.abs(creep.get("state") or [[0.0]]))
        c_max = np.sum(np.abs(creep["weights"])) * max(np.max(np.abs(u)), chi0)
    z_max = np.max(np.abs(y_d)) + offset + c_max
    e_inv = n * EPS * np.sum(np.abs(w_inv)) * z_max
    e_h = n * EPS * np.sum(np.abs(w)) * np.max(np.abs(u))
    return np.max(s) * e_inv + e_h + 4 * EPS * (z_max + offset + c_max)


def test_compensate_agrees_with_the_cli_bit_for_bit(cli, nominal):
    y_d = shrinking_loops(1100.0, 2, 4, nominal.sample_time)  # saturates at the top
    model_file = cli.tmp / "nominal.json"
    cli.run("nominal", "--output", model_file)
    src = cli.write_csv("in.csv", {"y_d": y_d})
    for limits, flag in (((-1000.0, 1000.0), []), ((-300.0, 700.0), ["--limits=-300,700"]),
                         (None, ["--no-limits"])):
        cli.run("compensate", "--model", model_file, "--input", src,
                "--output", cli.tmp / "out.csv", *flag)
        expected = cli.read_csv(cli.tmp / "out.csv")
        u, saturated, fault = mfcbeam.Compensator(nominal, limits=limits).compensate(y_d)
        np.testing.assert_array_equal(u, expected["u"])
        np.testing.assert_array_equal(saturated, expected["saturated"] == 1.0)
        assert not fault.any()
        if limits != (-300.0, 700.0):
            assert saturated.any() == (limits is not None)


def test_identity_within_the_rounding_bound(nominal, nominal_json):
    y_d = shrinking_loops(700.0, 3, 4, nominal.sample_time)
    comp = mfcbeam.Compensator(nominal)
    plant = nominal.copy()
    u, saturated, fault = comp.compensate(y_d)
    assert not saturated.any() and not fault.any()
    y = plant.simulate(u)
    bound = identity_bound(nominal_json, u, y_d)
    err = np.max(np.abs(y - y_d))
    assert err <= bound, (err, bound)
    assert bound < 1e-8  # the bound itself is tight enough to mean something


def test_identity_from_a_state_and_with_an_offset(nominal, nominal_json):
    """Matched states: a compensator built from a model that has run
    continues from the same state, and the offset is removed."""
    nominal.simulate(shrinking_loops(600.0, 1, 2, nominal.sample_time))
    shifted = json.loads(nominal.to_json())
    shifted["offset"] = -12.5
    model = mfcbeam.Model.from_json(json.dumps(shifted))
    y_d = 200.0 * np.sin(np.linspace(0.0, 20.0, 20000)) - 12.5
    u, _, _ = mfcbeam.Compensator(model, limits=None).compensate(y_d)
    y = model.simulate(u)
    bound = identity_bound(shifted, u, y_d)
    assert np.max(np.abs(y - y_d)) <= bound


def test_saturation_limits_and_recovery(nominal):
    y_d = np.concatenate([np.linspace(0, 2000, 4000), np.linspace(2000, 0, 4000)])
    u, saturated, fault = mfcbeam.Compensator(nominal, limits=(-200.0, 250.0)).compensate(y_d)
    assert u.max() == 250.0 and u.min() >= -200.0
    assert saturated.any() and not fault.any()
    assert np.all(u[saturated] == 250.0)
    # after the limit the compensator's plant copy is matched again: the
    # identity holds once the target is reachable
    y = nominal.simulate(u)
    free = ~saturated & (np.arange(len(u)) > np.flatnonzero(saturated).max())
    assert np.max(np.abs(y[free] - y_d[free])) < 1e-9


def test_non_finite_targets_hold_the_output_and_are_flagged(nominal, nominal_json):
    y_d = np.array([0.0, 100.0, np.nan, np.inf, 150.0, -np.inf, 120.0])
    comp = mfcbeam.Compensator(nominal)
    u, saturated, fault = comp.compensate(y_d)
    np.testing.assert_array_equal(fault, ~np.isfinite(y_d))
    assert not saturated.any()
    assert u[2] == u[3] == u[1] and u[5] == u[4]
    # the plant fed the held values stays matched
    y = nominal.simulate(u)
    ok = np.isfinite(y_d)
    assert np.max(np.abs(y[ok] - y_d[ok])) <= identity_bound(nominal_json, u, y_d[ok])


def test_reset_and_piecewise(nominal):
    y_d = shrinking_loops(800.0, 1, 3, nominal.sample_time)
    comp = mfcbeam.Compensator(nominal)
    whole, _, _ = comp.copy().compensate(y_d)
    parts = [comp.compensate(p)[0] for p in np.array_split(y_d, 5)]
    np.testing.assert_array_equal(np.concatenate(parts), whole)
    comp.reset()
    again, _, _ = comp.compensate(y_d)
    np.testing.assert_array_equal(again, whole)


@pytest.mark.parametrize("limits", [(-1000.0, 1000.0), (-150.0, 400.0)])
def test_the_pure_python_peer_is_the_same_compensator(nominal, limits):
    """The peer of the speed comparison computes the same u: the sums run
    in another order, so the outputs differ by rounding only (a few ulps of
    the 1000 V range here, ~1e-13 V; the identity bound above is ~1e-11 V)."""
    t = np.arange(0.0, 3.0, nominal.sample_time)
    y_d = 700.0 * np.sin(2 * np.pi * t) * np.exp(-t) + 400.0 * (t > 2.0)
    y_d[[7, 8000]] = [np.nan, np.inf]
    u, saturated, fault = mfcbeam.Compensator(nominal, limits=limits).compensate(y_d)
    u_py, saturated_py, fault_py = PurePythonCompensator(nominal.to_json(), limits).compensate(y_d)
    np.testing.assert_array_equal(fault, fault_py)
    np.testing.assert_array_equal(saturated, saturated_py)
    assert np.max(np.abs(u - u_py)) < 1e-9


def test_an_asymmetric_model_compensates_like_the_cli(cli, nominal_json):
    """A model with a superposition operator S: the compensator applies S⁻¹
    first, bit for bit as the command line does, and W[W⁻¹[y]] = y."""
    m = json.loads(json.dumps(nominal_json))
    m["superposition"] = {
        "thresholds": [-500.0, -200.0, 0.0, 150.0, 400.0],
        "weights": [0.25, -0.25, 1.0, -0.2, -0.15],
    }
    m["offset"] = 3.0
    model_file = cli.tmp / "asym.json"
    model_file.write_text(json.dumps(m))
    model = mfcbeam.Model.from_file(model_file)
    y_d = 400.0 * np.sin(np.arange(20000) * 1e-3)
    src = cli.write_csv("in.csv", {"y_d": y_d})
    cli.run("compensate", "--model", model_file, "--input", src, "--output", cli.tmp / "o.csv",
            "--no-limits")
    u, saturated, fault = mfcbeam.Compensator(model, limits=None).compensate(y_d)
    np.testing.assert_array_equal(u, cli.read_csv(cli.tmp / "o.csv")["u"])
    assert not saturated.any() and not fault.any()
    # the requirement of the asymmetric-hysteresis work: to 1e-9 of the range
    error = np.max(np.abs(model.copy().simulate(u) - y_d))
    assert error <= 1e-9 * np.ptp(y_d), error


def test_a_model_with_a_dead_time_compensates_like_the_cli(cli, nominal_json):
    """A dead time of 3 samples: the compensator inverts the memory part, a
    whole planned target is previewed by 3 samples (preview=True, as the
    command line's compensate), and a stream given the target 3 samples
    ahead in chunks is the same; W[W⁻¹[y]] = y from sample 3 on."""
    m = json.loads(json.dumps(nominal_json))
    m["delay"] = 3
    m["offset"] = 3.0
    model_file = cli.tmp / "delayed.json"
    model_file.write_text(json.dumps(m))
    model = mfcbeam.Model.from_file(model_file)
    assert model.delay == 3 and model.state["delay"] is None
    y_d = 400.0 * np.sin(np.arange(20000) * 1e-3)
    src = cli.write_csv("in.csv", {"y_d": y_d})
    cli.run("compensate", "--model", model_file, "--input", src, "--output", cli.tmp / "o.csv",
            "--no-limits")
    comp = mfcbeam.Compensator(model, limits=None)
    assert comp.delay == 3
    u, saturated, fault = comp.copy().compensate(y_d, preview=True)
    np.testing.assert_array_equal(u, cli.read_csv(cli.tmp / "o.csv")["u"])
    assert not saturated.any() and not fault.any()
    error = np.max(np.abs(model.copy().simulate(u)[3:] - y_d[3:]))
    assert error <= 1e-9 * np.ptp(y_d), error
    # a stream: the target 3 samples ahead, in two chunks
    ahead = np.concatenate([y_d[3:], np.full(3, y_d[-1])])
    stream = comp.copy()
    u1, _, _ = stream.compensate(ahead[:7000])
    u2, _, _ = stream.compensate(ahead[7000:])
    np.testing.assert_array_equal(np.concatenate([u1, u2]), u)
    # the line's state is saved and resumed
    first = model.copy()
    first.simulate(u[:500])
    assert len(first.state["delay"]) == 3
    resumed = mfcbeam.Model.from_json(first.to_json())
    np.testing.assert_array_equal(resumed.simulate(u[500:]), model.copy().simulate(u)[500:])


def test_identity_with_rate_dependent_thresholds():
    """A model whose play thresholds grow with the rate (β = T_s/4, the
    weights non-negative): the compensator inverts each step, so the plant
    driven by it gives the target back, to the rounding of one input's step
    (the inverse is the least input that reaches it) and of the terms."""
    m = json.loads(mfcbeam.Model.nominal().to_json())
    w = m["hysteresis"]["weights"]
    m["hysteresis"]["weights"] = [max(x, 0.0) for x in w]
    m["hysteresis"]["rate_gain"] = 0.25 * m["sample_time"]
    model = mfcbeam.Model.from_json(json.dumps(m))
    y_d = 300.0 * np.sin(np.linspace(0.0, 60.0, 6000)) * np.linspace(0.2, 1.0, 6000)
    u, saturated, fault = mfcbeam.Compensator(model, limits=None).compensate(y_d)
    assert not saturated.any() and not fault.any()
    y = model.copy().simulate(u)
    slope = 2.0 * sum(m["hysteresis"]["weights"]) + sum(abs(x) for x in m["creep"]["weights"])
    bound = 64.0 * (len(w) + 8) * EPS * slope * (np.max(np.abs(u)) + 1000.0)
    assert np.max(np.abs(y - y_d)) <= bound
