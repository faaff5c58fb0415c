"""Speed of `mfcbeam.Compensator.compensate` on a 1-million-sample array
against the same compensator written in Python with NumPy
(`pure_python.py`), on the paper's nominal model (12 plays, 60 creep
operators).

    python python/benchmarks/compensate_speed.py [--samples N] [--repeat R]

Prints the CPU, the median time of R runs of mfcbeam (fresh compensator
each run), one run of the Python loop (it takes tens of seconds), both per
sample, their ratio, and the largest difference of the two outputs.
"""

import argparse
import os
import platform
import statistics
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from pure_python import PurePythonCompensator  # noqa: E402

import mfcbeam  # noqa: E402


def cpu_name():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def targets(n, ts):
    """A decaying sine with a step: the plays and the creep all move, and
    the step saturates for a while."""
    t = np.arange(n) * ts
    return 600.0 * np.sin(2 * np.pi * 0.5 * t) * np.exp(-t / 60.0) + 500.0 * (t % 40.0 > 30.0)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--samples", type=int, default=1_000_000)
    p.add_argument("--repeat", type=int, default=7)
    a = p.parse_args()
    model = mfcbeam.Model.nominal()
    y_d = targets(a.samples, model.sample_time)

    times = []
    for _ in range(a.repeat):
        comp = mfcbeam.Compensator(model)
        t0 = time.perf_counter()
        u, saturated, _ = comp.compensate(y_d)
        times.append(time.perf_counter() - t0)
    rust = statistics.median(times)

    peer = PurePythonCompensator(model.to_json())
    t0 = time.perf_counter()
    u_py, saturated_py, _ = peer.compensate(y_d)
    python = time.perf_counter() - t0

    print(f"CPU: {cpu_name()}; Python {platform.python_version()}, NumPy {np.__version__}")
    print(f"{a.samples} samples, nominal model, {saturated.sum()} saturated")
    print(f"mfcbeam.Compensator.compensate  {rust:9.4f} s  {1e9 * rust / a.samples:8.1f} ns/sample (median of {a.repeat})")
    print(f"pure NumPy/Python loop          {python:9.4f} s  {1e9 * python / a.samples:8.1f} ns/sample (one run)")
    print(f"ratio                           {python / rust:9.0f}x")
    print(f"max |u - u_py|                  {np.max(np.abs(u - u_py)):9.2e} V, saturation flags differ in {np.sum(saturated != saturated_py)} samples")


if __name__ == "__main__":
    main()
