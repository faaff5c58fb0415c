"""Beam and feedforward: bit-for-bit agreement with the command line, the
static gain, the tracking of the flat design, and the beam file round trip."""

import json

import numpy as np
import pytest

import mfcbeam


@pytest.fixture(scope="module")
def beam():
    return mfcbeam.Beam.nominal()


@pytest.mark.parametrize("beam_model", ["modal", "ritz"])
def test_modes_agree_with_the_cli(cli, beam, beam_model):
    path = cli.tmp / "beam.json"
    cli.run("nominal", "--beam", "--output", path)
    expected = json.loads(cli.run("beam", "modes", "--beam", path, "--beam-model", beam_model).stdout)
    for b in (beam, mfcbeam.Beam.from_file(path)):
        modes = b.modes(beam_model)
        np.testing.assert_array_equal(modes["frequencies_hz"], expected["frequencies_hz"])
        np.testing.assert_array_equal(modes["damping_ratios"], expected["damping_ratios"])
        assert modes["static_gain"] == expected["static_gain"]
        assert (modes["model"], modes["modes"]) == (expected["model"], expected["modes"])


def test_simulate_agrees_with_the_cli(cli, beam):
    path = cli.tmp / "beam.json"
    cli.run("nominal", "--beam", "--output", path)
    t = np.arange(0.0, 0.5, 2e-4)
    u = 300.0 * (t > 0.01) - 150.0 * (t > 0.3) + 20.0 * np.sin(2 * np.pi * 40 * t)
    src = cli.write_csv("u.csv", {"t": t, "u": u})
    for beam_model in ("modal", "ritz"):
        cli.run("beam", "simulate", "--beam", path, "--beam-model", beam_model,
                "--input", src, "--output", cli.tmp / "y.csv")
        expected = cli.read_csv(cli.tmp / "y.csv")["y"]
        np.testing.assert_array_equal(beam.simulate(u, 2e-4, beam_model=beam_model), expected)


def test_step_settles_at_the_static_gain(beam):
    """The slowest mode (about 12 Hz, damping 1.5 %) decays like
    exp(−ζωt): after 25 s its part is below 1e-10 of the step. Rounding: each
    step rounds the 2n modal states by a few ε (4 here), and the slowest mode
    sums them over 1/(1 − e^{−ζωT_s}) ≈ 1/(ζωT_s) steps."""
    modes = beam.modes()
    zeta, omega = modes["damping_ratios"][0], 2 * np.pi * modes["frequencies_hz"][0]
    t_end = 25.0
    decay = np.exp(-zeta * omega * t_end)
    assert decay < 1e-10
    ts = 1e-3
    u = np.concatenate([[0.0], np.full(int(t_end / ts), 100.0)])
    y = beam.simulate(u, ts)
    rounding = 4 * 2 * modes["modes"] * np.finfo(float).eps / (zeta * omega * ts)
    assert abs(y[-1] / (100.0 * modes["static_gain"]) - 1) <= decay + rounding


def test_feedforward_agrees_with_the_cli(cli, beam):
    """The paper's case, with the defaults of both."""
    b, m = cli.tmp / "beam.json", cli.tmp / "model.json"
    cli.run("nominal", "--beam", "--output", b)
    cli.run("nominal", "--output", m)
    # the defaults are the CLI's: the paper's move of 1 mm in 75 ms
    cli.run("feedforward", "--beam", b, "--model", m, "--output", cli.tmp / "ff.csv")
    expected = cli.read_csv(cli.tmp / "ff.csv")
    ff = mfcbeam.feedforward(beam, mfcbeam.Model.nominal())
    assert set(ff) == set(expected)
    for k in ("t", "y_d", "u_d", "u", "u_fs", "u_bs"):
        np.testing.assert_array_equal(ff[k], expected[k], err_msg=k)
    np.testing.assert_array_equal(ff["saturated"], expected["saturated"] == 1.0)


def test_feedforward_moves_the_beam_along_the_trajectory(beam):
    """u_d drives the modal beam along y_d; sampled and held, u_d lags by half
    a sample, so |y − y_d| ≤ (T_s/2)·max|ẏ_d| to first order in T_s."""
    ff = mfcbeam.feedforward(beam, start=0.1, duration=0.075, y_final=1e-3, end=1.0)
    ts = ff["t"][1] - ff["t"][0]
    assert set(ff) == {"t", "y_d", "u_d"}
    assert ff["y_d"][0] == 0.0 and abs(ff["y_d"][-1] - 1e-3) < 1e-15
    y = beam.simulate(ff["u_d"], ts)
    slope = np.max(np.abs(np.diff(ff["y_d"]))) / ts
    assert np.max(np.abs(y - ff["y_d"])) <= 1.05 * (ts / 2) * slope


def test_feedforward_sample_time_follows_the_model(beam):
    model = mfcbeam.Model.nominal()
    ff = mfcbeam.feedforward(beam, model, end=0.01)
    assert len(ff["t"]) == 51 and ff["t"][1] == model.sample_time
    ff = mfcbeam.feedforward(beam, end=0.01, sample_time=1e-3)
    assert len(ff["t"]) == 11


def test_beam_json_round_trip(beam, tmp_path):
    text = beam.to_json()
    again = mfcbeam.Beam.from_json(text)
    assert again.to_json() == text
    beam.to_file(tmp_path / "b.json")
    assert mfcbeam.Beam.from_file(tmp_path / "b.json").to_json() == text
    changed = json.loads(text)
    changed["basis_functions"] = 4
    assert mfcbeam.Beam.from_json(json.dumps(changed)).modes()["modes"] == 4
