"""Fixtures of the Python tests: the command-line program (the Rust
results to agree with bit for bit), test signals and a noisy record.

The CLI is found as $MFCBEAM_CLI, else target/{debug,release}/mfcbeam of
this repository (`cargo build`). Tests that need it are skipped without it,
unless MFCBEAM_CLI is set (as CI does): then a missing program fails.
"""

import csv
import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

import mfcbeam

REPO = Path(__file__).resolve().parents[2]
EPS = np.finfo(float).eps


def find_cli():
    env = os.environ.get("MFCBEAM_CLI")
    if env:
        if not Path(env).is_file():
            raise FileNotFoundError(f"MFCBEAM_CLI={env} does not exist")
        return env
    for profile in ("debug", "release"):
        p = REPO / "target" / profile / "mfcbeam"
        if p.is_file():
            return str(p)
    return None


class Cli:
    """The `mfcbeam` program, run on files in a temporary directory."""

    def __init__(self, path, tmp):
        self.path = path
        self.tmp = Path(tmp)

    def run(self, *args, check=True):
        r = subprocess.run([self.path, *map(str, args)], capture_output=True, text=True)
        if check and r.returncode != 0:
            raise AssertionError(f"mfcbeam {' '.join(map(str, args))}: {r.stderr}")
        return r

    def write_csv(self, name, columns):
        path = self.tmp / name
        keys = list(columns)
        with open(path, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(keys)
            for row in zip(*(columns[k] for k in keys)):
                # repr is the shortest round-trip form: the CLI reads the same bits
                w.writerow([repr(float(v)) for v in row])
        return path

    def read_csv(self, path):
        with open(path, newline="") as f:
            rows = list(csv.reader(f))
        return {name: np.array([float(r[i]) for r in rows[1:]]) for i, name in enumerate(rows[0])}

    def write_text(self, name, text):
        path = self.tmp / name
        path.write_text(text)
        return path


@pytest.fixture
def cli(tmp_path):
    path = find_cli()
    if path is None:
        pytest.skip("the mfcbeam program is not built (cargo build), and MFCBEAM_CLI is not set")
    return Cli(path, tmp_path)


def staircase(levels, ts, plateau=0.5, rise=0.05):
    """Levels joined by smooth (raised-cosine) transitions of `rise` s, each
    held for `plateau` s, starting from 0."""
    n_rise, n_plateau = int(round(rise / ts)), int(round(plateau / ts))
    out, last = [], 0.0
    for level in levels:
        s = 0.5 - 0.5 * np.cos(np.pi * np.arange(1, n_rise + 1) / n_rise)
        out.append(last + (level - last) * s)
        out.append(np.full(n_plateau, float(level)))
        last = level
    return np.concatenate(out)


def shrinking_loops(amplitude, periods, steps, ts, plateau=0.5, rise=0.05):
    """0 → +A → −A → 0 in `steps` steps per quarter, the amplitude shrinking
    each period: every play is excited, with reversals at many levels."""
    levels = []
    for p in range(periods):
        a = amplitude * (periods - p) / periods
        up = [a * (i + 1) / steps for i in range(steps)]
        levels += up + up[-2::-1] + [-x for x in up] + [-x for x in up[-2::-1]] + [0.0]
    return staircase(levels, ts, plateau, rise)


@pytest.fixture
def nominal():
    return mfcbeam.Model.nominal()


@pytest.fixture
def nominal_json(nominal):
    return json.loads(nominal.to_json())
