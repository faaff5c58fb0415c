"""identify: bit-for-bit agreement with the command line on a noisy,
offset, jittered record; statistical accuracy on a record from a known
model; the report."""

import json
import re

import numpy as np
import pytest

import mfcbeam
from conftest import shrinking_loops

SIGMA = 0.5  # noise of the output (V)
OFFSET = 3.0  # sensor offset (V)


@pytest.fixture(scope="module")
def record():
    """A record of the nominal model: shrinking loops with plateaus (the
    plays and the creep excited), Gaussian noise, an offset and a logger
    clock with 0.3 % jitter."""
    rng = np.random.default_rng(20111)
    model = mfcbeam.Model.nominal()
    ts = model.sample_time
    u = shrinking_loops(900.0, 3, 3, ts)
    clean = model.simulate(u)
    y = clean + OFFSET + rng.normal(0.0, SIGMA, len(u))
    t = np.arange(len(u)) * ts + rng.uniform(-0.0015, 0.0015, len(u)) * ts
    return {"t": t, "u": u, "y": y, "clean": clean, "ts": ts}


def nominal_structure():
    """The nominal model's thresholds and eigenvalues: with them the model
    class contains the truth, and what remains is the noise."""
    m = json.loads(mfcbeam.Model.nominal().to_json())
    return {
        "hysteresis_thresholds": m["hysteresis"]["thresholds"],
        "creep_thresholds": m["creep"]["thresholds"],
        "eigenvalues": m["creep"]["eigenvalues"],
    }


def test_agrees_with_the_cli_bit_for_bit(cli, record):
    src = cli.write_csv("rec.csv", {k: record[k] for k in ("t", "u", "y")})
    out = cli.tmp / "m.json"
    r = cli.run("identify", "--input", src, "--output", out, "--holdout", "0.1")
    model, report = mfcbeam.identify(record["u"], record["y"], t=record["t"], holdout=0.1)
    ours = json.loads(model.to_json())
    # the CLI writes the virgin model without "state"; ours has zero states
    assert not np.any(ours["hysteresis"].pop("state")) and not np.any(ours["creep"].pop("state"))
    assert ours == json.loads(out.read_text())
    assert report["text"] in r.stderr
    m = re.search(r"sample time +(\S+) s \(mean step of t; jitter (\S+) of a step\)", r.stderr)
    assert float(m.group(1)) == report["sample_time"]
    assert float(m.group(2)) == float(f"{report['jitter']:.2e}")
    # the sample time is the mean step of t, as the CLI takes it
    t = record["t"]
    assert report["sample_time"] == (t[-1] - t[0]) / (len(t) - 1)


def test_recovers_a_known_model_to_the_noise_level(record):
    model, report = mfcbeam.identify(
        record["u"], record["y"], sample_time=record["ts"], **nominal_structure()
    )
    # unknowns: the weights, and the offset
    n, p = report["fitted"][1] - report["fitted"][0], report["unknowns"] + 1
    # residual rms of least squares: σ·sqrt(1 − p/n), relative spread 1/sqrt(2n)
    expected = SIGMA * np.sqrt(1 - p / n)
    assert abs(report["rms"] / expected - 1) < 6 / np.sqrt(2 * n), report["rms"]
    # the model error left by the noise: σ·sqrt(p/n) rms over the fitted
    # samples (the average variance of a least-squares prediction); allow 5x
    pred = model.simulate(record["u"]) - report["offset"]
    lo, hi = report["fitted"]
    err = np.sqrt(np.mean((pred[lo:hi] - record["clean"][lo:hi]) ** 2))
    assert err < 5 * SIGMA * np.sqrt(p / n), err
    assert abs(report["offset"] - OFFSET) < 0.05
    assert report["kkt_residual"] < 1e-12
    assert report["rank"] == report["unknowns"]


def test_report_fields(record):
    model, report = mfcbeam.identify(
        record["u"], record["y"], sample_time=record["ts"], hysteresis_operators=8,
        creep_operators=4, creep_eigenvalues=4, holdout=0.2,
        validate=(record["u"], record["clean"] + OFFSET),
    )
    assert report["samples"] == len(record["u"])
    lo, hi = report["fitted"]
    assert report["skipped"] == lo > 0 and "max|u|" in report["skip_reason"]
    assert hi == len(record["u"]) - int(0.2 * len(record["u"]))
    assert report["holdout"]["samples"] == len(record["u"]) - hi
    assert report["validation"]["samples"] > 0
    assert report["unknowns"] == 8 + 4  # the weights (the offset is eliminated first)
    assert report["jitter"] is None
    for key in ("rms", "max", "rms_percent", "max_percent", "condition_number", "epsilon_h"):
        assert np.isfinite(report[key]) and report[key] > 0, key
    for c in report["active_constraints"]:
        assert c["group"] in ("hysteresis", "creep") and c["index"] >= 0
    assert len(report["weights"]) == len(report["standard_errors"]) == 8 + 4
    assert all(se > 0 for se in report["standard_errors"])
    assert report["superposition"] is None
    assert json.loads(model.to_json())["creep"]["eigenvalues"] == [
        1 / (10.0 ** j * record["ts"]) for j in range(1, 5)
    ]
    assert model.state["creep"].shape == (4, 4)


def test_compensator_of_the_identified_model(record):
    """The identified compensator in front of the true plant tracks the
    target to within the identification error."""
    model, report = mfcbeam.identify(
        record["u"], record["y"], sample_time=record["ts"], fit_offset=True, **nominal_structure()
    )
    offset_free = json.loads(model.to_json())
    offset_free["offset"] = 0.0
    comp = mfcbeam.Compensator(mfcbeam.Model.from_json(json.dumps(offset_free)))
    y_d = shrinking_loops(500.0, 1, 5, record["ts"])
    u, saturated, _ = comp.compensate(y_d)
    assert not saturated.any()
    y = mfcbeam.Model.nominal().simulate(u)
    # y − y_d = W[u] − W_identified[u]: the model error, as above
    n, p = report["fitted"][1] - report["fitted"][0], report["unknowns"] + 1
    err = np.sqrt(np.mean((y - y_d) ** 2))
    assert err < 5 * SIGMA * np.sqrt(p / n), err


def asymmetric_nominal():
    """The nominal model followed by an asymmetric superposition operator."""
    m = json.loads(mfcbeam.Model.nominal().to_json())
    m["superposition"] = {
        "thresholds": [-500.0, -200.0, 0.0, 150.0, 400.0],
        "weights": [0.25, -0.25, 1.0, -0.2, -0.15],
    }
    m["offset"] = OFFSET
    return mfcbeam.Model.from_json(json.dumps(m))


def test_superposition_agrees_with_the_cli_and_fits_an_asymmetric_loop(cli, record):
    truth = asymmetric_nominal()
    assert truth.superposition[0] == [-500.0, -200.0, 0.0, 150.0, 400.0]
    u = record["u"]
    rng = np.random.default_rng(2211)
    y = truth.simulate(u) + rng.normal(0.0, SIGMA, len(u))
    src = cli.write_csv("asym.csv", {"t": record["t"], "u": u, "y": y})
    out = cli.tmp / "asym.json"
    r = cli.run("identify", "--input", src, "--output", out, "--superposition", "3")
    model, report = mfcbeam.identify(u, y, t=record["t"], superposition=3)
    ours = json.loads(model.to_json())
    assert not np.any(ours["hysteresis"].pop("state")) and not np.any(ours["creep"].pop("state"))
    assert ours == json.loads(out.read_text())
    assert report["text"] in r.stderr
    thresholds, weights = report["superposition"]
    assert model.superposition == (thresholds, weights)
    assert len(thresholds) == 7 and 0.0 in thresholds
    # the symmetric model cannot follow the asymmetric loop
    _, symmetric = mfcbeam.identify(u, y, t=record["t"])
    assert symmetric["superposition"] is None
    assert report["rms"] < 0.5 * symmetric["rms"]


def test_several_validation_records_give_one_row_each_with_the_input_rate(record):
    ts = record["ts"]
    model = mfcbeam.Model.nominal()

    def triangles(rate):
        k = np.arange(int(1.0 / ts))
        phase = (k * ts * rate) % 1.0
        u = 800.0 * np.where(phase < 0.5, 4 * phase - 1, 3 - 4 * phase)
        return u, model.copy().simulate(u)

    records = [triangles(20.0), triangles(50.0)]
    fitted, report = mfcbeam.identify(
        record["u"], record["y"], sample_time=ts, validate=records, validate_from=250
    )
    rows = report["validations"]
    assert [r["name"] for r in rows] == ["validate[0]", "validate[1]"]
    assert all(r["start"] == 250 and r["samples"] == len(records[0][0]) - 250 for r in rows)
    for r, rate in zip(rows, (20.0, 50.0)):
        assert abs(r["rate"] - rate) <= 0.01 * rate
    assert report["validation"] == {k: v for k, v in rows[0].items()
                                    if k not in ("name", "start", "rate", "zero_offset", "zeroed")}
    # a single tuple still works and is the first row
    _, single = mfcbeam.identify(
        record["u"], record["y"], sample_time=ts, validate=records[0], validate_from=250
    )
    assert single["validation"] == report["validation"]
    with pytest.raises(ValueError, match=r"validate\[1\]: must be a pair"):
        mfcbeam.identify(record["u"], record["y"], sample_time=ts, validate=[records[0], 3])


def triangles(truth, rate, seconds, seed):
    """Triangles of ±900 V at `rate` for `seconds` through `truth`, with
    0.5 V of noise."""
    ts = truth.sample_time
    k = np.arange(int(seconds / ts))
    phase = (k * ts * rate) % 1.0
    u = 900.0 * np.where(phase < 0.5, 4 * phase - 1, 3 - 4 * phase)
    rng = np.random.default_rng(seed)
    return u, truth.copy().simulate(u) + rng.normal(0.0, 0.5, len(u))


def test_a_dead_time_is_found_on_a_faster_record_and_agrees_with_the_cli(cli):
    """delay="auto": every d in 0..=max_delay is fitted and the 100 Hz
    validation record chooses the true 2 samples; the report lists each
    candidate; the command line gives the same model."""
    m = json.loads(asymmetric_nominal().to_json())
    del m["creep"]
    m["delay"] = 2
    truth = mfcbeam.Model.from_json(json.dumps(m))
    ts = truth.sample_time
    (u, y), (u2, y2) = triangles(truth, 20.0, 1.0, 1), triangles(truth, 100.0, 0.5, 2)
    model, report = mfcbeam.identify(u, y, sample_time=ts, creep_operators=0, superposition=2,
                                     delay="auto", max_delay=4, validate=(u2, y2))
    assert report["delay"] == 2 and model.delay == 2
    assert report["delay_criterion"] == "validation"
    rows = report["delays"]
    assert [r["delay"] for r in rows] == [0, 1, 2, 3, 4]
    best = min(rows, key=lambda r: r["score"])
    assert best["delay"] == 2 and len(best["validations"]) == 1
    assert "dead time chosen     2 samples" in report["text"]
    src = cli.write_csv("d.csv", {"t": np.arange(len(u)) * ts, "u": u, "y": y})
    val = cli.write_csv("v.csv", {"t": np.arange(len(u2)) * ts, "u": u2, "y": y2})
    out = cli.tmp / "d.json"
    cli.run("identify", "--input", src, "--output", out, "--creep-operators", "0",
            "--superposition", "2", "--delay", "auto", "--max-delay", "4", "--validate", val)
    assert json.loads(out.read_text())["delay"] == 2
    # fixed, and bad values
    _, fixed = mfcbeam.identify(u, y, sample_time=ts, creep_operators=0, delay=1)
    assert fixed["delay"] == 1 and fixed["delays"] is None
    for bad in ("soon", -1, 1.5):
        with pytest.raises(ValueError, match="delay"):
            mfcbeam.identify(u, y, sample_time=ts, delay=bad)


def test_a_rate_gain_is_found_on_a_faster_record_and_agrees_with_the_cli(cli):
    """The nominal loops, asymmetric, with rate-dependent thresholds (β = 0.3
    T_s): fitted on 20 Hz triangles with the truth's thresholds and
    rate_gain="auto", validated at 100 Hz, β comes back near the truth; the
    command line gives the same model."""
    m = json.loads(asymmetric_nominal().to_json())
    del m["creep"]
    ts = m["sample_time"]
    m["hysteresis"]["rate_gain"] = 0.3 * ts
    truth = mfcbeam.Model.from_json(json.dumps(m))
    (u, y), (u2, y2) = triangles(truth, 20.0, 1.0, 1), triangles(truth, 100.0, 0.5, 2)
    r = m["hysteresis"]["thresholds"]
    model, report = mfcbeam.identify(u, y, sample_time=ts, creep_operators=0, superposition=2,
                                     hysteresis_thresholds=r, rate_gain="auto",
                                     validate=(u2, y2))
    assert report["rate_gain_criterion"] == "validation"
    beta = report["rate_gain"]
    assert 0.75 <= beta / (0.3 * ts) <= 1.25, beta
    rows = report["rate_gains"]
    assert [row["rate_gain"] for row in rows] == sorted(row["rate_gain"] for row in rows)
    assert min(rows, key=lambda row: row["score"])["rate_gain"] == beta
    assert "rate gain chosen" in report["text"]
    src = cli.write_csv("r.csv", {"t": np.arange(len(u)) * ts, "u": u, "y": y})
    val = cli.write_csv("rv.csv", {"t": np.arange(len(u2)) * ts, "u": u2, "y": y2})
    out = cli.tmp / "r.json"
    cli.run("identify", "--input", src, "--output", out, "--creep-operators", "0",
            "--superposition", "2", "--hysteresis-thresholds", ",".join(map(str, r)),
            "--rate-gain", "auto", "--validate", val)
    ours = json.loads(model.to_json())
    assert not np.any(ours["hysteresis"].pop("state"))
    assert ours == json.loads(out.read_text())
    # fixed, and bad values
    _, fixed = mfcbeam.identify(u, y, sample_time=ts, creep_operators=0, rate_gain=0.5 * ts)
    assert fixed["rate_gain"] == 0.5 * ts and fixed["rate_gains"] is None
    for bad in ("fast", -1e-6, ts, float("nan")):
        with pytest.raises(ValueError, match="rate_gain"):
            mfcbeam.identify(u, y, sample_time=ts, rate_gain=bad)


def test_several_records_with_their_offsets_and_dynamics_agree_with_the_cli(cli):
    """records=[...] fits one model to several rates, offset="per-record"
    gives each its own offset, dynamics="resonance" fits the stage's ringing
    with the weights; without noise the resonance comes back to the
    solver's precision, and the command line gives the same model."""
    m = json.loads(mfcbeam.Model.nominal().to_json())
    del m["creep"]
    m["sample_time"] = 1e-4
    m["dynamics"] = {"resonance": {"frequency": 740.0, "damping": 0.02}}
    truth = mfcbeam.Model.from_json(json.dumps(m))
    ts = truth.sample_time

    def cycles(rate, offset):
        k = np.arange(int(20 / rate / ts))
        u = -600.0 * np.cos(2 * np.pi * rate * k * ts) * (0.4 + 0.6 * k / len(k))
        return u, truth.copy().simulate(u) + offset

    (u1, y1), (u2, y2), (u3, y3) = cycles(20.0, 0.5), cycles(40.0, -1.0), cycles(100.0, 2.0)
    structure = {"hysteresis_thresholds": m["hysteresis"]["thresholds"], "creep_operators": 0}
    model, report = mfcbeam.identify(u1, y1, sample_time=ts, records=[(u2, y2)], fit_from=0,
                                     offset="per-record", dynamics="resonance",
                                     validate=(u3, y3), validate_zero=(0, 50), **structure)
    f, zeta = model.dynamics["resonance"]
    assert abs(f / 740.0 - 1) < 1e-6 and abs(zeta / 0.02 - 1) < 1e-6
    offsets = [r["offset"] for r in report["records"]]
    assert abs(offsets[0] - 0.5) < 1e-6 and abs(offsets[1] + 1.0) < 1e-6
    row = report["validations"][0]
    assert abs(row["zero_offset"] - 1.5) < 1e-4 and row["zeroed"]["rms_percent"] < 1e-3
    csv = [cli.write_csv(f"r{i}.csv", {"t": np.arange(len(u)) * ts, "u": u, "y": y})
           for i, (u, y) in enumerate([(u1, y1), (u2, y2)])]
    out = cli.tmp / "records.json"
    cli.run("identify", "--input", csv[0], "--input", csv[1], "--output", out,
            "--fit-from", "0", "--offset", "per-record", "--dynamics", "resonance",
            "--hysteresis-thresholds", ",".join(map(str, m["hysteresis"]["thresholds"])),
            "--creep-operators", "0", "--sample-time", repr(ts))
    ours = json.loads(model.to_json())
    ours["hysteresis"].pop("state")
    assert ours == json.loads(out.read_text())
    # the reversal rule agrees with the command line's
    model2, rev = mfcbeam.identify(u1, y1, sample_time=ts, creep_operators=0, fit_from=0,
                                   thresholds="reversals")
    out2 = cli.tmp / "reversals.json"
    cli.run("identify", "--input", csv[0], "--output", out2, "--creep-operators", "0",
            "--fit-from", "0", "--thresholds", "reversals", "--sample-time", repr(ts))
    assert len(rev["weights"]) == 12
    ours2 = json.loads(model2.to_json())
    ours2["hysteresis"].pop("state")
    assert ours2 == json.loads(out2.read_text())
    for bad in ({"offset": "each"}, {"dynamics": "spring"}, {"validate_zero": (5, 5)},
                {"records": [(u2, y2)], "holdout": 0.1}, {"thresholds": "even"},
                {"thresholds": "reversals", "hysteresis_thresholds": [0.0, 1.0]}):
        with pytest.raises(ValueError):
            mfcbeam.identify(u1, y1, sample_time=ts, **bad)


def test_the_creep_penalty_is_chosen_and_reported(record):
    u, y, ts = record["u"], record["y"], record["ts"]
    model, report = mfcbeam.identify(u, y, sample_time=ts, creep_regularisation="gcv")
    lam, df = report["creep_regularisation"]
    assert lam >= 0.0 and 0.0 < df <= report["unknowns"]
    assert "creep penalty" in report["text"]
    _, fixed = mfcbeam.identify(u, y, sample_time=ts, creep_regularisation=1e-3)
    assert fixed["creep_regularisation"][0] == 1e-3
    _, plain = mfcbeam.identify(u, y, sample_time=ts)
    assert plain["creep_regularisation"] is None
    for bad in ("ridge", -1.0, float("nan"), [1.0]):
        with pytest.raises(ValueError, match="creep_regularisation"):
            mfcbeam.identify(u, y, sample_time=ts, creep_regularisation=bad)
