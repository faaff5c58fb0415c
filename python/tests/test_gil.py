"""The long calls release the GIL: another Python thread runs while they
compute.

With the switch interval set far beyond the test, a thread holding the GIL
is never asked to give it up: the counting thread then cannot run a single
bytecode until the call has returned, and counts 0. It counts more only if
the call releases the GIL itself. The control case (`sorted`, a C call that
keeps the GIL) shows that the test tells the two apart."""

import random
import sys
import threading

import numpy as np
import pytest

import mfcbeam


@pytest.fixture(autouse=True)
def no_forced_switches():
    before = sys.getswitchinterval()
    sys.setswitchinterval(1000.0)
    yield
    sys.setswitchinterval(before)


def count_while(call):
    """How often this thread advances a counter while `call` runs in another."""
    started, done = threading.Event(), threading.Event()

    def worker():
        started.set()
        try:
            call()
        finally:
            done.set()

    t = threading.Thread(target=worker)
    t.start()
    started.wait()
    count = 0
    while not done.is_set():
        count += 1
    t.join()
    return count


def test_control_a_call_that_keeps_the_gil_counts_zero():
    values = [random.random() for _ in range(300_000)]
    assert count_while(lambda: sorted(values)) == 0


@pytest.mark.parametrize("what", ["simulate", "compensate", "identify", "beam", "feedforward"])
def test_long_calls_let_other_threads_run(what):
    model = mfcbeam.Model.nominal()
    beam = mfcbeam.Beam.nominal()
    y = np.sin(np.linspace(0.0, 1000.0, 1_000_000)) * 600.0
    calls = {
        "simulate": lambda: model.simulate(y),
        "compensate": lambda: mfcbeam.Compensator(model).compensate(y),
        "identify": lambda: mfcbeam.identify(y, y, sample_time=2e-4, creep_operators=0),
        "beam": lambda: beam.simulate(y, 2e-4),
        "feedforward": lambda: mfcbeam.feedforward(beam, model),
    }
    assert count_while(calls[what]) > 0
