"""Model: bit-for-bit agreement with the Rust command line, state handling,
and the JSON round trip."""

import copy
import json

import numpy as np
import pytest

import mfcbeam
from conftest import shrinking_loops


def test_done_when_example():
    y = mfcbeam.Model.nominal().simulate([0.0, 100.0])
    assert y.dtype == np.float64 and y.shape == (2,)
    # W[0] = 0 from the virgin state; creep has a one-sample delay, so
    # y[1] = H[100] alone: every play with r_i < 100 moves by 100 − r_i.
    m = json.loads(mfcbeam.Model.nominal().to_json())["hysteresis"]
    r, w = np.array(m["thresholds"]), np.array(m["weights"])
    expected = np.sum(w * np.maximum(100.0 - r, 0.0))
    assert y[0] == 0.0
    assert abs(y[1] - expected) <= 4 * np.finfo(float).eps * np.sum(np.abs(w)) * 100.0


def test_simulate_agrees_with_the_cli_bit_for_bit(cli, nominal):
    u = shrinking_loops(900.0, 2, 3, nominal.sample_time)
    model_file = cli.tmp / "nominal.json"
    cli.run("nominal", "--output", model_file)
    src = cli.write_csv("in.csv", {"u": u})
    cli.run("simulate", "--model", model_file, "--input", src, "--output", cli.tmp / "out.csv")
    expected = cli.read_csv(cli.tmp / "out.csv")["y"]
    # the CLI's nominal file and Model.nominal() are the same model
    for model in (nominal, mfcbeam.Model.from_file(model_file)):
        y = model.simulate(u)
        np.testing.assert_array_equal(y, expected)


def test_simulate_in_pieces_equals_whole(nominal):
    u = shrinking_loops(700.0, 1, 4, nominal.sample_time)
    whole = nominal.copy().simulate(u)
    pieces = [nominal.simulate(part) for part in np.array_split(u, 7)]
    np.testing.assert_array_equal(np.concatenate(pieces), whole)


def test_json_round_trip_keeps_the_state_bit_for_bit(nominal, tmp_path):
    u = shrinking_loops(800.0, 1, 3, nominal.sample_time)
    half = len(u) // 2
    nominal.simulate(u[:half])
    text = nominal.to_json()
    again = mfcbeam.Model.from_json(text)
    assert again.to_json() == text
    nominal.to_file(tmp_path / "m.json")
    from_file = mfcbeam.Model.from_file(tmp_path / "m.json")
    for k in ("hysteresis", "creep"):
        np.testing.assert_array_equal(again.state[k], nominal.state[k])
    rest = nominal.simulate(u[half:])
    np.testing.assert_array_equal(again.simulate(u[half:]), rest)
    np.testing.assert_array_equal(from_file.simulate(u[half:]), rest)


def test_state_reset_and_copies(nominal):
    s = nominal.state
    assert s["hysteresis"].shape == (12,) and s["creep"].shape == (12, 5)
    assert not s["hysteresis"].any() and not s["creep"].any()
    before = nominal.copy()
    nominal.simulate(np.linspace(0.0, 500.0, 1000))
    assert nominal.state["hysteresis"][0] == 500.0  # the play with r_0 = 0 follows u
    assert not before.state["hysteresis"].any()  # a copy has its own state
    for c in (copy.copy(nominal), copy.deepcopy(nominal)):
        np.testing.assert_array_equal(c.state["creep"], nominal.state["creep"])
    nominal.reset()
    assert not nominal.state["hysteresis"].any() and not nominal.state["creep"].any()


def test_inputs_of_any_dtype_and_empty(nominal):
    a = nominal.copy().simulate(np.arange(5, dtype=np.int32) * 10)
    b = nominal.copy().simulate([0, 10, 20, 30, 40])
    c = nominal.copy().simulate(np.arange(0.0, 50.0, 10.0)[::1])
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(a, c)
    # a strided view is read correctly
    d = nominal.copy().simulate(np.arange(0.0, 100.0, 10.0)[::2])
    np.testing.assert_array_equal(d, nominal.copy().simulate([0.0, 20.0, 40.0, 60.0, 80.0]))
    assert nominal.simulate([]).shape == (0,)


def test_non_finite_input_is_held(nominal):
    u = np.array([0.0, 100.0, np.nan, np.inf, -np.inf, 100.0, 50.0])
    y = nominal.copy().simulate(u)
    held = nominal.copy().simulate([0.0, 100.0, 100.0, 100.0, 100.0, 100.0, 50.0])
    np.testing.assert_array_equal(y, held)
    assert np.isfinite(nominal.state["creep"]).all()


def test_properties_and_repr(nominal):
    assert nominal.sample_time == 2e-4
    assert nominal.offset == 0.0
    assert "12 plays" in repr(nominal)
    shifted = json.loads(nominal.to_json())
    shifted["offset"] = 1.5
    m = mfcbeam.Model.from_json(json.dumps(shifted))
    assert m.offset == 1.5
    np.testing.assert_array_equal(m.simulate([0.0, 30.0]), nominal.simulate([0.0, 30.0]) + 1.5)


def test_without_creep(nominal_json):
    del nominal_json["creep"]
    m = mfcbeam.Model.from_json(json.dumps(nominal_json))
    assert m.state["creep"] is None
    y = m.simulate([0.0, 100.0, 0.0])
    assert y[2] < y[1]


@pytest.mark.parametrize("limits", [(-1000.0, 1000.0), None])
def test_help_and_docstrings(limits):
    for obj in (mfcbeam.Model, mfcbeam.Model.simulate, mfcbeam.Compensator.compensate,
                mfcbeam.identify, mfcbeam.Beam.modes, mfcbeam.feedforward):
        assert obj.__doc__ and len(obj.__doc__) > 40, obj
    assert mfcbeam.Compensator(mfcbeam.Model.nominal(), limits=limits).limits == (
        limits or (-np.inf, np.inf))
