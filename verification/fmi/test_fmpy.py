"""The project's FMUs through FMPy, an importer written independently of
this project: `fmpy validate` (schema and rules), and `simulate_fmu` on a
recorded input equal to the command line bit for bit after the documented
shift (the zero-order-hold outputs one communication step later; the
beam's tip deflection and modal state at the end of each step, so
unshifted)."""

import csv
import json
import math

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.validation import validate_fmu

from conftest import ROOT, run

TS = 2e-4


def read_csv(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}


def signal(cli, tmp, column, amplitude=900.0):
    path = tmp / f"{column}.csv"
    run(cli, "signal", "--output", path, "--column", column, "--amplitude", amplitude,
        "--steps", 2, "--rise", 0.004, "--plateau", 0.006)
    return path


def fmpy_input(trace, column):
    n = len(trace[column])
    arr = np.zeros(n, dtype=[("time", np.float64), (column, np.float64)])
    arr["time"] = np.arange(n) * TS
    arr[column] = trace[column]
    return arr


def simulate(fmu, arr, outputs):
    n = len(arr)
    return simulate_fmu(str(fmu), start_time=0.0, stop_time=n * TS, output_interval=TS,
                        input=arr, output=outputs, validate=True)


def same_bits(a, b):
    """Equal as numbers, every sample (-0.0 equals 0.0)."""
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape, (a.shape, b.shape)
    bad = np.flatnonzero(a != b)
    assert bad.size == 0, f"{bad.size} samples differ, first {bad[0]}: {a[bad[0]]!r} vs {b[bad[0]]!r}"


@pytest.mark.parametrize("kind", ["compensator", "model", "plant", "controller-pid", "controller-lq"])
@pytest.mark.parametrize("version", ["2", "3"])
def test_validate(fmus, kind, version):
    problems = validate_fmu(str(fmus[(kind, version)]))
    assert problems == [], problems


@pytest.mark.parametrize("version", ["2", "3"])
def test_model_equals_cli(cli, fmus, tmp_path, version):
    u = signal(cli, tmp_path, "u")
    out = tmp_path / "y.csv"
    run(cli, "simulate", "--model", ROOT / "golden" / "nominal_model.json", "--input", u, "--output", out)
    trace = read_csv(out)
    res = simulate(fmus[("model", version)], fmpy_input(trace, "u"), ["y", "fault"])
    n = len(trace["y"])
    assert len(res) == n + 1
    assert res["y"][0] == 0.0
    same_bits(res["y"][1:], trace["y"])
    assert not res["fault"].any()


@pytest.mark.parametrize("version", ["2", "3"])
def test_compensator_equals_cli(cli, fmus, tmp_path, version):
    # beyond the default limits at the peaks: saturation shows too
    y_d = signal(cli, tmp_path, "y_d", amplitude=1150.0)
    out = tmp_path / "u.csv"
    run(cli, "compensate", "--model", ROOT / "golden" / "nominal_model.json", "--input", y_d, "--output", out)
    trace = read_csv(out)
    assert trace["saturated"].any() and not trace["saturated"].all()
    res = simulate(fmus[("compensator", version)], fmpy_input(trace, "y_d"), ["u", "saturated", "fault"])
    same_bits(res["u"][1:], trace["u"])
    same_bits(res["saturated"][1:].astype(float), trace["saturated"])
    assert not res["fault"].any()


@pytest.mark.parametrize("design", ["pid", "lq"])
@pytest.mark.parametrize("version", ["2", "3"])
def test_controller_equals_the_loop(cli, fmus, tmp_path, design, version):
    # the loop's recorded reference and measurement into the controller FMU
    # under FMPy: its corrections, one communication step later, are the
    # loop's bit for bit (the measurement carries sensor noise)
    out = tmp_path / "loop"
    run(cli, "benchmark-control", "--controller", design, "--scenario", "noise", "--output-dir", out)
    trace = read_csv(out / f"noise-{design}.csv")
    n = 16_000  # through the transition at 2.9 s
    arr = np.zeros(n, dtype=[("time", np.float64), ("reference", np.float64), ("measurement", np.float64)])
    arr["time"] = np.arange(n) * TS
    arr["reference"] = trace["reference"][:n]
    arr["measurement"] = trace["measurement"][:n]
    res = simulate(fmus[(f"controller-{design}", version)], arr, ["correction", "held"])
    assert res["correction"][0] == 0.0
    same_bits(res["correction"][1:], trace["correction"][:n])
    assert np.abs(trace["correction"][:n]).max() > 1.0
    assert not res["held"].any()


@pytest.mark.parametrize("version", ["2", "3"])
def test_plant_equals_cli(cli, fmus, tmp_path, version):
    u = signal(cli, tmp_path, "u")
    v_path, y_path = tmp_path / "v.csv", tmp_path / "tip.csv"
    run(cli, "simulate", "--model", ROOT / "golden" / "nominal_model.json", "--input", u, "--output", v_path)
    v = read_csv(v_path)
    # the beam's input is the effective voltage: column u of the beam command
    with open(tmp_path / "beam_in.csv", "w") as f:
        f.write("t,u\n")
        for k, y in enumerate(v["y"]):
            f.write(f"{float(v['t'][k])!r},{float(y)!r}\n")
    run(cli, "beam", "simulate", "--beam", ROOT / "golden" / "nominal_beam.json",
        "--input", tmp_path / "beam_in.csv", "--output", y_path)
    tip = read_csv(y_path)
    res = simulate(fmus[("plant", version)], fmpy_input(v, "u"), ["y", "v", "z_re_1", "z_im_1"])
    n = len(v["u"])
    # the beam starts at rest (u_0 = 0): its state is that of the command's run
    same_bits(res["y"][:n], tip["y"])
    same_bits(res["v"][1:], v["y"])
    assert np.abs(res["z_re_1"]).max() > 0.0


def write_csv(path, columns):
    keys = list(columns)
    with open(path, "w") as f:
        f.write(",".join(keys) + "\n")
        for row in zip(*(columns[k] for k in keys)):
            f.write(",".join(repr(float(v)) for v in row) + "\n")


@pytest.mark.parametrize("version", ["2", "3"])
def test_a_compensator_fmu_starts_in_an_estimated_memory(cli, tmp_path, version):
    # the nominal model after a past (up to 900 V and back), then a record:
    # 0.4 s held at 0 V and a 2 Hz sine of 300 V
    past = 900.0 * (1.0 - np.abs(np.arange(4001) - 2000.0) / 2000.0)
    t = np.arange(7000) * TS - 0.4
    record = np.where(t < 0.0, 0.0, 300.0 * np.sin(2.0 * np.pi * 2.0 * t))
    u = np.concatenate([past, record])
    write_csv(tmp_path / "u.csv", {"t": np.arange(len(u)) * TS, "u": u})
    model = ROOT / "golden" / "nominal_model.json"
    run(cli, "simulate", "--model", model, "--input", tmp_path / "u.csv", "--output", tmp_path / "y.csv")
    y = read_csv(tmp_path / "y.csv")["y"][len(past):]
    write_csv(tmp_path / "record.csv", {"t": np.arange(len(record)) * TS, "u": record, "y": y})
    # the memory after the hold and the sine's first period, estimated
    window = 4500
    run(cli, "estimate-state", "--model", model, "--input", tmp_path / "record.csv",
        "--until", window, "--state-at", "end", "--output", tmp_path / "end.json")
    # targets: the model in that state on the rest of the record; the
    # compensator FMU built from the same file gives the voltages back
    rest = record[window:]
    write_csv(tmp_path / "rest.csv", {"t": np.arange(len(rest)) * TS, "u": rest})
    run(cli, "simulate", "--model", tmp_path / "end.json", "--input", tmp_path / "rest.csv",
        "--output", tmp_path / "targets.csv")
    targets = read_csv(tmp_path / "targets.csv")
    fmu = tmp_path / f"compensator{version}.fmu"
    run(cli, "fmu", "--kind", "compensator", "--model", tmp_path / "end.json", "--fmi", version,
        "--output", fmu)
    res = simulate(fmu, fmpy_input({"y_d": targets["y"]}, "y_d"), ["u", "saturated", "fault"])
    # W⁻¹∘W = id to rounding: a thousand roundings of the voltages' size
    assert np.abs(res["u"][1:] - rest).max() <= 1e3 * np.finfo(float).eps * 900.0
    assert not res["saturated"].any() and not res["fault"].any()
    # and the estimate was worth making: the record's own output after the
    # window is the model's from there
    assert np.abs(targets["y"] - y[window:]).max() < 0.05


def test_delay_is_a_calculated_parameter(cli, tmp_path):
    """With a dead time the compensator FMU reports d, inverts the memory
    part, and the target previewed by d gives the command line's output."""
    model = json.loads((ROOT / "golden" / "nominal_model.json").read_text())
    model["delay"] = 3
    mpath = tmp_path / "delayed.json"
    mpath.write_text(json.dumps(model))
    fmu = tmp_path / "delayed.fmu"
    run(cli, "fmu", "--kind", "compensator", "--model", mpath, "--fmi", "3", "--output", fmu)
    from fmpy import read_model_description, instantiate_fmu, extract
    md = read_model_description(str(fmu))
    delay = next(v for v in md.modelVariables if v.name == "delay")
    assert delay.causality == "calculatedParameter"
    y_d = signal(cli, tmp_path, "y_d", amplitude=500.0)
    out = tmp_path / "u.csv"
    run(cli, "compensate", "--model", mpath, "--input", y_d, "--output", out)
    trace = read_csv(out)
    # the importer's preview: y_d(t + d Ts), the last d samples held
    z = np.concatenate([trace["y_d"][3:], np.repeat(trace["y_d"][-1], 3)])
    arr = fmpy_input({"y_d": z}, "y_d")
    res = simulate(fmu, arr, ["u", "delay"])
    same_bits(res["u"][1:], trace["u"])
    assert (res["delay"] == 3).all()


def test_the_readme_fmpy_example_runs(fmus, tmp_path, monkeypatch):
    """The guide's FMPy lines, as written, on the FMU its command builds."""
    import shutil
    import textwrap

    text = (ROOT / "docs" / "guide" / "deploy.md").read_text()
    start = text.index("* **FMPy**")
    block = text[text.index("```python", start) + len("```python"):]
    block = textwrap.dedent(block[:block.index("```")])
    shutil.copy(fmus[("compensator", "3")], tmp_path / "compensator.fmu")
    monkeypatch.chdir(tmp_path)
    scope = {}
    exec(compile(block, "deploy.md", "exec"), scope)
    res = scope["res"]
    assert len(res) == 5001 and np.isfinite(res["u"]).all()
    assert not res["saturated"].any()


@pytest.mark.parametrize("kind", ["compensator", "model"])
@pytest.mark.parametrize("version", ["2", "3"])
def test_the_projects_fmus_pass_conform_fmu(cli, fmus, tmp_path, kind, version):
    out = run(cli, "conform", "--kind", kind, "--fmu", fmus[(kind, version)],
              "--model", ROOT / "golden" / "nominal_model.json", "--cases", 60, "--out", tmp_path / "c")
    assert "FAILS" not in out.stdout
    assert "split_and_resume" in out.stdout and "cannot run on a fixed model" in out.stdout
