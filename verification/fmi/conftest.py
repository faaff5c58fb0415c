"""Fixtures of the FMU checks: the mfcbeam program, the FMUs it builds and
a scratch folder. MFCBEAM_CLI names the program (default: the debug build
of this checkout); the FMUs are built once per session."""

import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def cli():
    path = os.environ.get("MFCBEAM_CLI", str(ROOT / "target" / "debug" / "mfcbeam"))
    assert os.access(path, os.X_OK), f"{path}: build it first (cargo build --workspace)"
    return path


def run(*args, check=True, **kw):
    out = subprocess.run([str(a) for a in args], capture_output=True, text=True, **kw)
    if check and out.returncode != 0:
        raise AssertionError(f"{args}: exit {out.returncode}\n{out.stdout}\n{out.stderr}")
    return out


@pytest.fixture(scope="session")
def fmus(cli, tmp_path_factory):
    """Every kind in both FMI versions: {(kind, version): path}."""
    d = tmp_path_factory.mktemp("fmus")
    model, beam = ROOT / "golden" / "nominal_model.json", ROOT / "golden" / "nominal_beam.json"
    built = {}
    for version in ("2", "3"):
        for kind in ("compensator", "model", "plant"):
            out = d / f"{kind}{version}.fmu"
            extra = ["--beam", beam] if kind == "plant" else []
            run(cli, "fmu", "--kind", kind, "--model", model, *extra, "--fmi", version, "--output", out)
            built[(kind, version)] = out
        for design in ("pid", "lq"):
            out = d / f"controller-{design}{version}.fmu"
            run(cli, "fmu", "--kind", "controller", "--controller", design, "--fmi", version, "--output", out)
            built[(f"controller-{design}", version)] = out
    return built
