"""Every bad argument or file raises ValueError naming the field, file or
sample, with the command line's message; nothing is left half done."""

import json

import numpy as np
import pytest

import mfcbeam


def nominal_with(**changes):
    m = json.loads(mfcbeam.Model.nominal().to_json())
    for path, value in changes.items():
        *parents, leaf = path.split("__")
        d = m
        for p in parents:
            d = d[p]
        d[leaf] = value
    return json.dumps(m)


BAD_MODELS = [
    # (changes, text the message must contain)
    ({"sample_time": 0.0}, "sample_time: must be a finite number > 0"),
    ({"hysteresis__weights": [1.0] + [-0.2] * 11}, "hysteresis.weights: partial sum"),
    ({"hysteresis__thresholds": [0.0, 75.0, 50.0] + [100.0 + i for i in range(9)]},
     "hysteresis.thresholds[2]: thresholds must increase strictly"),
    ({"hysteresis__thresholds": [1.0] + [100.0 + i for i in range(11)]},
     "hysteresis.thresholds[0]: the first threshold must be 0"),
    ({"hysteresis__weights": [0.5] * 3}, "hysteresis.weights: expected 12 values, found 3"),
    ({"hysteresis__state": [900.0] + [0.0] * 11}, "hysteresis.state[1]: inadmissible state"),
    ({"creep__eigenvalues": [-1.0, 10.0, 100.0, 1000.0, 10000.0]},
     "creep.eigenvalues[0]: a creep eigenvalue must be > 0"),
    ({"creep__weights": [-1.0] + [0.0] * 11}, "creep.weights: partial sum"),
]


@pytest.mark.parametrize("changes, message", BAD_MODELS)
def test_bad_models_name_the_field(changes, message, tmp_path):
    text = nominal_with(**changes)
    with pytest.raises(ValueError, match=None) as e:
        mfcbeam.Model.from_json(text)
    assert message in str(e.value)
    path = tmp_path / "bad.json"
    path.write_text(text)
    with pytest.raises(ValueError) as e:
        mfcbeam.Model.from_file(path)
    assert str(e.value).startswith(f"{path}: ") and message in str(e.value)


@pytest.mark.parametrize("changes, message", BAD_MODELS[:3])
def test_the_message_is_the_cli_s(cli, changes, message):
    path = cli.tmp / "bad.json"
    path.write_text(nominal_with(**changes))
    src = cli.write_csv("u.csv", {"u": [0.0, 1.0]})
    r = cli.run("simulate", "--model", path, "--input", src, "--output", cli.tmp / "o.csv", check=False)
    assert r.returncode == 2 and not (cli.tmp / "o.csv").exists()
    with pytest.raises(ValueError) as e:
        mfcbeam.Model.from_file(path)
    assert r.stderr.strip() == f"mfcbeam: error: {e.value}"


def test_files_and_json(tmp_path):
    with pytest.raises(ValueError, match="missing.json"):
        mfcbeam.Model.from_file(tmp_path / "missing.json")
    with pytest.raises(ValueError, match="malformed JSON"):
        mfcbeam.Model.from_json("{")
    with pytest.raises(ValueError, match="unknown field `weight`"):
        mfcbeam.Model.from_json('{"sample_time": 1e-3, "hysteresis": {"thresholds": [0], "weight": [1]}}')
    with pytest.raises(ValueError, match="malformed JSON"):
        mfcbeam.Beam.from_json("[]")
    beam = json.loads(mfcbeam.Beam.nominal().to_json())
    beam["length"] = -1.0
    with pytest.raises(ValueError, match="^length: "):
        mfcbeam.Beam.from_json(json.dumps(beam))
    with pytest.raises(ValueError, match=str(tmp_path / "missing.json")):
        mfcbeam.Beam.from_file(tmp_path / "missing.json")
    with pytest.raises(ValueError, match="no_such_dir"):
        mfcbeam.Model.nominal().to_file(tmp_path / "no_such_dir" / "m.json")
    assert not (tmp_path / "no_such_dir").exists()


@pytest.mark.parametrize("bad, message", [
    ([[1.0, 2.0], [3.0, 4.0]], "u: expected a one-dimensional array, found shape (2, 2)"),
    (["a", "b"], "u: could not convert string to float"),
    (5.0, "u: expected a one-dimensional array, found shape ()"),
    (None, "u: expected a one-dimensional array"),
])
def test_arrays(bad, message):
    with pytest.raises(ValueError) as e:
        mfcbeam.Model.nominal().simulate(bad)
    assert message in str(e.value)
    with pytest.raises(ValueError) as e:
        mfcbeam.Compensator(mfcbeam.Model.nominal()).compensate(bad)
    assert message.replace("u:", "y_d:") in str(e.value)


@pytest.mark.parametrize("limits, message", [
    ((1000.0, -1000.0), "limits: the lower limit 1000 must be below the upper limit -1000"),
    ((5.0, 5.0), "limits: the lower limit 5 must be below"),
    ((float("nan"), 1.0), "limits: the lower limit NaN"),
    ((-float("inf"), float("inf")), "limits: no limits at all is limits=None"),
])
def test_compensator_limits(limits, message):
    with pytest.raises(ValueError) as e:
        mfcbeam.Compensator(mfcbeam.Model.nominal(), limits=limits)
    assert message in str(e.value)


U = np.sin(np.linspace(0, 20, 3000)) * 500
Y = U * 0.8


@pytest.mark.parametrize("kwargs, message", [
    ({}, "sample_time: give the sample time (s) or the timestamps t"),
    ({"sample_time": -1.0}, "sample_time: must be a finite number > 0, found -1"),
    ({"sample_time": float("nan")}, "sample_time: must be a finite number > 0, found NaN"),
    ({"t": np.arange(2999) * 1e-3}, "t: expected 3000 samples (as u), found 2999"),
    ({"t": np.r_[0.0, 1e-3, 1e-3, np.arange(3, 3000) * 1e-3]}, "t[2]: time does not increase"),
    ({"t": np.r_[np.arange(1500) * 1e-3, np.arange(1500) * 1e-3 + 1.5003]}, "t[1500]: time step"),
    ({"t": np.r_[np.nan, np.arange(1, 3000) * 1e-3]}, "t[0]: NaN is not a finite number"),
    ({"t": np.arange(3000) * 1e-3, "sample_time": 2e-3}, "t: the mean time step 0.001 s differs"),
    ({"sample_time": 1e-3, "holdout": 1.0}, "holdout: must be a fraction in [0, 1), found 1"),
    ({"sample_time": 1e-3, "hysteresis_operators": 0}, "hysteresis_operators: must be at least 1"),
    ({"sample_time": 1e-3, "creep_eigenvalues": 0}, "creep_eigenvalues: must be at least 1"),
    ({"sample_time": 1e-3, "epsilon_h": -1.0}, "epsilon_h: must be a finite number > 0"),
    ({"sample_time": 1e-3, "eigenvalues": [1.0, -2.0]}, "eigenvalues: must be finite numbers > 0"),
    ({"sample_time": 1e-3, "hysteresis_thresholds": [0.0, 2.0, 1.0]},
     "hysteresis_thresholds[2]: thresholds must increase strictly"),
    ({"sample_time": 1e-3, "creep_thresholds": [[0.0, 1.0]]}, "creep_thresholds: expected a one-dimensional"),
    ({"sample_time": 1e-3, "validate": (U, Y[:10])}, "validate: u and y differ in length"),
    ({"sample_time": 1e-3, "validate": (U, "x")}, "validate[1]: could not convert"),
])
def test_identify_arguments(kwargs, message):
    with pytest.raises(ValueError) as e:
        mfcbeam.identify(U, Y, **kwargs)
    assert message in str(e.value)


@pytest.mark.parametrize("u, y, message", [
    (U, Y[:-1], "u and y differ in length: 3000 and 2999 samples"),
    (U, np.r_[Y[:5], np.nan, Y[6:]], "y[5]: NaN is not a finite number"),
    (np.r_[U[:7], np.inf, U[8:]], Y, "u[7]: inf is not a finite number"),
    (np.zeros(3000), Y, "the input is constant (0)"),
    (U[:5], Y[:5], "too few samples"),
])
def test_identify_data(u, y, message):
    with pytest.raises(ValueError) as e:
        mfcbeam.identify(u, y, sample_time=1e-3)
    assert message in str(e.value)


@pytest.mark.parametrize("call, message", [
    (lambda b: b.modes("fem"), "beam_model: expected 'modal' or 'ritz', found 'fem'"),
    (lambda b: b.modes(elements=0), "elements"),
    (lambda b: b.simulate([0.0, 1.0], 0.0), "sample_time: must be a finite number > 0, found 0"),
    (lambda b: b.simulate([0.0, 1.0], 1e-3, beam_model="x"), "beam_model: expected"),
    (lambda b: b.simulate([[0.0]], 1e-3), "u: expected a one-dimensional array"),
    (lambda b: mfcbeam.feedforward(b, duration=-1.0), "duration"),
    (lambda b: mfcbeam.feedforward(b, sigma=0.0), "sigma"),
    (lambda b: mfcbeam.feedforward(b, end=float("inf")), "end: must be a finite number >= 0"),
    (lambda b: mfcbeam.feedforward(b, sample_time=-2e-4), "sample_time: must be a finite number > 0"),
    (lambda b: mfcbeam.feedforward(b, y_final=float("nan")), "y_final: must be finite"),
    (lambda b: mfcbeam.feedforward(b, mfcbeam.Model.nominal(), sample_time=1e-3),
     "sample_time: 0.001 s differs from the model's sample time 0.0002 s"),
    (lambda b: mfcbeam.feedforward(b, beam_model="x"), "beam_model: expected"),
])
def test_beam_and_feedforward_arguments(call, message):
    with pytest.raises(ValueError) as e:
        call(mfcbeam.Beam.nominal())
    assert message in str(e.value)
