"""estimate_state: the memory a record starts in, recovered on a record of
the nominal model with a known past; the same file as the command line's;
the compensator started from it inverts the model to rounding; bad
arguments raise ValueError."""

import json

import numpy as np
import pytest

import mfcbeam
from conftest import EPS

WINDOW = 4500  # the hold and the sine's first period


@pytest.fixture(scope="module")
def record():
    """The nominal model after a past (up to 900 V and back to 0): 0.4 s
    held at 0 V, then two periods of a 2 Hz sine of 300 V; noise-free."""
    actuator = mfcbeam.Model.nominal()
    ts = actuator.sample_time
    actuator.simulate(900.0 * (1.0 - np.abs(np.arange(4001) - 2000.0) / 2000.0))
    t = np.arange(7000) * ts - 0.4
    u = np.where(t < 0.0, 0.0, 300.0 * np.sin(2.0 * np.pi * 2.0 * t))
    y = actuator.simulate(u)
    return {"u": u, "y": y, "t": np.arange(7000) * ts}


def test_the_estimate_predicts_the_record_after_its_window(record):
    u, y = record["u"], record["y"]
    model, report = mfcbeam.estimate_state(mfcbeam.Model.nominal(), u, y, until=WINDOW)
    assert report["window"] == WINDOW
    assert report["rms"] < 1e-3 * report["prior_rms"]
    predicted = model.copy().simulate(u)
    virgin = mfcbeam.Model.nominal().simulate(u)
    after = slice(WINDOW, None)
    assert np.max(np.abs(virgin[after] - y[after])) > 10.0
    assert np.max(np.abs(predicted[after] - y[after])) < 0.05
    # the plays the sine does not reach keep the prior
    assert report["unwiped"] == [8, 9, 10, 11]


def test_the_state_after_the_window_continues_the_estimate(record):
    u, y = record["u"], record["y"]
    start, _ = mfcbeam.estimate_state(mfcbeam.Model.nominal(), u, y, until=WINDOW)
    end, _ = mfcbeam.estimate_state(
        mfcbeam.Model.nominal(), u, y, until=WINDOW, state_at="end"
    )
    # the model from the start, run through the window, is the model at the end
    start.simulate(u[:WINDOW])
    assert json.loads(start.to_json())["hysteresis"]["state"] == json.loads(
        end.to_json()
    )["hysteresis"]["state"]
    np.testing.assert_array_equal(start.simulate(u[WINDOW:]), end.simulate(u[WINDOW:]))


def test_the_compensator_from_the_estimate_inverts_the_model(record):
    u, y = record["u"], record["y"]
    end, _ = mfcbeam.estimate_state(
        mfcbeam.Model.nominal(), u, y, until=WINDOW, state_at="end"
    )
    targets = end.copy().simulate(u[WINDOW:])
    compensator = mfcbeam.Compensator(end, limits=(-1000.0, 1000.0))
    voltages, _, _ = compensator.compensate(targets)
    # H⁻¹ and C of the same state: rounding, a few hundred operations of the
    # voltages' size
    np.testing.assert_allclose(voltages, u[WINDOW:], rtol=0, atol=1e3 * EPS * 1000.0)


def test_the_same_file_as_the_command_line(record, cli):
    u, y = record["u"], record["y"]
    path = cli.write_csv("record.csv", {"t": record["t"], "u": u, "y": y})
    nominal = cli.tmp / "nominal.json"
    mfcbeam.Model.nominal().to_file(nominal)
    out = cli.tmp / "start.json"
    cli.run("estimate-state", "--model", nominal, "--input", path,
            "--until", WINDOW, "--output", out)
    model, _ = mfcbeam.estimate_state(mfcbeam.Model.nominal(), u, y, until=WINDOW)
    assert json.loads(out.read_text()) == json.loads(model.to_json())


def test_bad_arguments_raise_value_error(record):
    u, y = record["u"], record["y"]
    nominal = mfcbeam.Model.nominal()
    with pytest.raises(ValueError, match="until"):
        mfcbeam.estimate_state(nominal, u, y, until=1)
    with pytest.raises(ValueError, match="until"):
        mfcbeam.estimate_state(nominal, u, y, until=len(u) + 1)
    with pytest.raises(ValueError, match="state_at"):
        mfcbeam.estimate_state(nominal, u, y, state_at="middle")
    with pytest.raises(ValueError, match="differ in length"):
        mfcbeam.estimate_state(nominal, u, y[:-1])
    bad = u.copy()
    bad[3] = np.nan
    with pytest.raises(ValueError, match=r"u\[3\]"):
        mfcbeam.estimate_state(nominal, bad, y)


def test_identify_fits_the_initial_state_with_the_weights(record):
    u, y = record["u"], record["y"]
    model, report = mfcbeam.identify(
        u, y, sample_time=mfcbeam.Model.nominal().sample_time, fit_initial_state=True
    )
    rms = report["initial_state"]["rms"]
    # the ordinary fit, then every round kept: each lowers the error
    assert 2 <= len(rms) <= report["initial_state"]["rounds"] + 1
    assert all(b < a for a, b in zip(rms, rms[1:]))
    # every sample fitted; the record's model in its fitted state
    assert report["fitted"] == (0, len(u))
    (started,) = report["initial_state"]["models"]
    assert np.sqrt(np.mean((started.copy().simulate(u) - y) ** 2)) == pytest.approx(
        rms[-1], rel=1e-9
    )
    # the model itself stays virgin, as a compensator starts
    assert not any(json.loads(model.to_json())["hysteresis"].get("state", []))
    _, plain = mfcbeam.identify(u, y, sample_time=mfcbeam.Model.nominal().sample_time)
    assert plain["initial_state"] is None
