"""The example script examples/identify_and_compensate.py runs as documented:
on its synthetic lab record, on a record from a CSV file, and with a bad
file."""

import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "examples" / "identify_and_compensate.py"
LINE = re.compile(
    r"staircase on (.+?): \d+ samples, tracking error rms (\S+) V, max (\S+) V "
    r"\(uncompensated, u = y_d - offset: max (\S+) V\); saturated samples (\d+), faults (\d+)"
)


def run(*args, cwd, env=None):
    return subprocess.run(
        [sys.executable, str(SCRIPT), *map(str, args)], capture_output=True, text=True, cwd=cwd, env=env
    )


def without_matplotlib(tmp_path):
    """An environment in which `import matplotlib` fails, as where it is not
    installed."""
    blocker = tmp_path / "no_matplotlib" / "matplotlib"
    blocker.mkdir(parents=True)
    (blocker / "__init__.py").write_text("raise ImportError('matplotlib is blocked by the test')\n")
    return {**os.environ, "PYTHONPATH": str(blocker.parent)}


def figures(stdout):
    m = LINE.search(stdout)
    assert m, stdout
    return m.group(1), float(m.group(2)), float(m.group(3)), float(m.group(4)), int(m.group(5)), int(m.group(6))


def has_matplotlib():
    return importlib.util.find_spec("matplotlib") is not None


@pytest.mark.parametrize("plotting", ["matplotlib", "without matplotlib"])
def test_synthetic_record(tmp_path, plotting):
    if plotting == "matplotlib" and not has_matplotlib():
        pytest.skip("matplotlib is not installed")
    env = without_matplotlib(tmp_path) if plotting == "without matplotlib" else None
    r = run("--output", tmp_path / "plots", cwd=tmp_path, env=env)
    assert r.returncode == 0, r.stderr
    plant, rms, worst, uncompensated, saturated, faults = figures(r.stdout)
    assert plant == "the true actuator (as measured)"
    assert saturated == 0 and faults == 0
    # the compensator removes the hysteresis and creep to the identification
    # error: more than an order of magnitude below the uncompensated error
    assert worst < uncompensated / 20
    assert "KKT residual" in r.stdout
    png = tmp_path / "plots" / "identify_and_compensate.png"
    if plotting == "matplotlib":
        assert png.stat().st_size > 10_000
    else:
        assert "matplotlib is not installed: no figure drawn" in r.stdout
        assert not png.exists()


def test_record_from_csv_plays_into_the_identified_model(tmp_path):
    # a record made by the script's own generator, written as a lab file
    spec = importlib.util.spec_from_file_location("example", SCRIPT)
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    record, _ = example.synthetic_record(7)
    csv = tmp_path / "rec.csv"
    np.savetxt(csv, np.column_stack([record["t"], record["u"], record["y"]]), delimiter=",",
               header="t,u,y", comments="", fmt="%.17g")
    r = run("--record", csv, "--output", tmp_path, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    plant, rms, worst, _, saturated, _ = figures(r.stdout)
    assert plant == "the identified model"
    # W[W⁻¹[y_d]] = y_d to rounding (test_compensator checks the derived
    # bound, ~1e-11 V at this size); 1e-9 V only tells the identity apart
    # from a model error, which would be of the order of the noise (volts)
    assert saturated == 0 and worst < 1e-9


def test_bad_record_is_one_line_and_exit_2(tmp_path):
    csv = tmp_path / "rec.csv"
    csv.write_text("t,u,y\n0,1,2\n0.0002,x,3\n")
    r = run("--record", csv, cwd=tmp_path)
    assert r.returncode == 2
    assert r.stderr.strip() == f"error: {csv}: row 3, column 'u': not a number: 'x'"
    csv.write_text("t,u\n0,1\n")
    r = run("--record", csv, cwd=tmp_path)
    assert r.returncode == 2 and "no column 'y'" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    # errors of the library come through as the same one line
    csv.write_text("t,u,y\n0,1,2\n0,2,3\n0.0004,3,4\n")
    r = run("--record", csv, cwd=tmp_path)
    assert r.returncode == 2 and r.stderr.startswith("error: t[1]") and len(r.stderr.strip().splitlines()) == 1
