"""The closed loop checked from outside: the command line is the one under
test (MFCBEAM_CLI, default target/release/mfcbeam)."""

import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def cli():
    path = os.environ.get("MFCBEAM_CLI", str(ROOT / "target" / "release" / "mfcbeam"))
    assert pathlib.Path(path).exists(), f"{path}: build it (cargo build --release)"
    return path


def run(*args):
    out = subprocess.run([str(a) for a in args], capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 0, out.stderr
    return out.stdout
