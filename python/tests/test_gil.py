"""The long calls release the GIL: another Python thread runs while they
compute.

With the switch interval set far beyond the test, a thread holding the GIL
is never asked to give it up. The main thread starts the call in a worker
and then needs the GIL to look at the worker's `done` flag: if the call
keeps the GIL, the main thread gets it only after the call has returned and
sees `done` set; if the call releases it, the main thread runs during the
call and sees `done` clear. The main thread then waits in `join`, which
releases the GIL, so the worker can always finish. The control case
(`sorted`, a C call that keeps the GIL) shows that the test tells the two
apart."""

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


def ran_during(call):
    """Whether this thread ran Python code while `call` ran in another."""
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
    during = not done.is_set()
    t.join()
    return during


def test_control_a_call_that_keeps_the_gil_blocks_other_threads():
    values = [random.random() for _ in range(300_000)]
    assert not ran_during(lambda: sorted(values))


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
    assert ran_during(calls[what])
