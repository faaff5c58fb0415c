"""Hostile arguments and files (docs/FILES.md, "Limits"): every count is
checked against its limit before anything is allocated from it, and every
refusal is a ValueError naming the field, never another exception, a crash
or a large allocation. The cases run in a child interpreter whose peak
memory is read from os.wait4; a seeded structure-aware sweep changes one
field of a valid model file at a time."""

import json
import os
import random
import subprocess
import sys
import textwrap

import pytest

import mfcbeam

MAX_RSS = 100 << 20

NOMINAL = json.loads(mfcbeam.Model.nominal().to_json())


def with_field(path, value, base=NOMINAL):
    m = json.loads(json.dumps(base))
    *parents, leaf = path
    d = m
    for p in parents:
        d = d[p]
    d[leaf] = value
    return json.dumps(m)


MODEL_COUNTS = [
    (("delay",), 10**12, "delay: 1000000000000 exceeds the limit"),
    (("delay",), 2**64 - 1, "delay: 18446744073709551615 exceeds the limit"),
    (("delay",), 100_000_001, "delay"),
    (("delay",), 2**70, "delay"),
    (("delay",), -1, "expected usize"),
    (("hysteresis", "thresholds"), list(range(1025)), "hysteresis.thresholds: 1025 exceeds"),
    (("creep", "eigenvalues"), [float(i + 1) for i in range(65)], "creep.eigenvalues: 65 exceeds"),
]


@pytest.mark.parametrize("path, value, message", MODEL_COUNTS)
def test_counts_in_a_model_file_raise_value_error(path, value, message):
    text = with_field(path, value)
    with pytest.raises(ValueError, match=message.replace("(", r"\(")):
        mfcbeam.Model.from_json(text)


def test_creep_elements_are_counted_as_a_product():
    m = json.loads(json.dumps(NOMINAL))
    m["creep"] = {"thresholds": [float(i) for i in range(1000)], "weights": [0.0] * 1000,
                  "eigenvalues": [float(i + 1) for i in range(17)]}
    with pytest.raises(ValueError, match="thresholds × eigenvalues"):
        mfcbeam.Model.from_json(json.dumps(m))


def test_counts_of_the_beam_raise_value_error():
    beam = json.loads(mfcbeam.Beam.nominal().to_json())
    beam["basis_functions"] = 10**12
    with pytest.raises(ValueError, match="basis_functions"):
        mfcbeam.Beam.from_json(json.dumps(beam))
    b = mfcbeam.Beam.nominal()
    for elements in (-1, 10**30, 501, 2**64, True, 2.5):
        with pytest.raises(ValueError, match="elements"):
            b.modes(elements=elements)
    with pytest.raises(ValueError, match="elements"):
        b.simulate([0.0, 1.0], 2e-4, elements=-5)
    with pytest.raises(ValueError, match="end"):
        mfcbeam.feedforward(b, end=1e12)
    with pytest.raises(ValueError, match="samples"):
        mfcbeam.feedforward(b, sample_time=1e-300)


def test_identification_counts_raise_value_error():
    u = [0.0, 300.0, -300.0, 150.0, -150.0, 0.0] * 20
    y = [0.9 * v for v in u]
    for kwargs, field in [
        ({"hysteresis_operators": -1}, "hysteresis_operators"),
        ({"hysteresis_operators": 10**30}, "hysteresis_operators"),
        ({"hysteresis_operators": 100_000}, "hysteresis_operators"),
        ({"creep_eigenvalues": 10**9}, "creep_eigenvalues"),
        ({"superposition": 10**12}, "superposition"),
        ({"delay": "auto", "max_delay": 10**9}, "max_delay"),
        ({"delay": 10**12}, "delay"),
        ({"fit_from": -3}, "fit_from"),
    ]:
        with pytest.raises(ValueError, match=field):
            mfcbeam.identify(u, y, sample_time=2e-4, **kwargs)


HOSTILE = [10**12, 2**64 - 1, -1, 0, 1e308, -1e308, 5e-324, [], "text", None,
           {"nested": [[1]]}, 0.5, 100_001, [1.0] * 5000]


def hostile_texts(seed, count):
    """Valid model files (with and without creep, S, dead time) with one
    field replaced by a hostile value, seeded."""
    rng = random.Random(seed)
    shapes = [NOMINAL]
    m = json.loads(json.dumps(NOMINAL))
    m["superposition"] = {"thresholds": [-500, -200, 0, 150, 400],
                          "weights": [0.25, -0.25, 1, -0.2, -0.15]}
    m["delay"] = 2
    shapes.append(m)
    m = json.loads(json.dumps(NOMINAL))
    del m["creep"]
    shapes.append(m)

    def leaves(v, at):
        yield at
        if isinstance(v, dict):
            for k, x in v.items():
                yield from leaves(x, at + (k,))
        elif isinstance(v, list):
            for i, x in enumerate(v):
                yield from leaves(x, at + (i,))

    for _ in range(count):
        base = rng.choice(shapes)
        paths = [p for p in leaves(base, ()) if p]
        yield with_field(rng.choice(paths), rng.choice(HOSTILE), base)


def test_one_field_changed_at_a_time_is_accepted_or_a_value_error():
    for text in hostile_texts(seed=32, count=600):
        try:
            model = mfcbeam.Model.from_json(text)
        except ValueError:
            continue
        model.simulate([0.0, 100.0, float("nan"), -50.0])
        try:
            comp = mfcbeam.Compensator(model)
        except ValueError:
            continue
        comp.compensate([0.0, 0.3, float("nan"), -0.2])


def peak_of(code):
    """The peak resident memory of a child interpreter running `code`, from
    its own VmHWM (a fork's copy of this process, which the rusage of a
    child would count, is not in it)."""
    code += textwrap.dedent(
        """
        for line in open("/proc/self/status"):
            if line.startswith("VmHWM:"):
                print(int(line.split()[1]) * 1024)
        """
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return int(out.stdout.split()[-1])


def test_hostile_cases_stay_within_100_mb():
    """The cases above in a child interpreter, imports (pytest's too)
    included, and the largest accepted calls in another: each stays under
    100 MB."""
    if not os.path.exists("/proc/self/status"):
        pytest.skip("needs /proc (Linux)")
    sweep = peak_of(textwrap.dedent(
        f"""
        import sys
        sys.path[:0] = {sys.path!r}
        import mfcbeam
        sys.path.insert(0, {os.path.dirname(__file__)!r})
        import test_hostile as t
        for path, value, _ in t.MODEL_COUNTS:
            try:
                mfcbeam.Model.from_json(t.with_field(path, value))
            except ValueError:
                pass
        t.test_counts_of_the_beam_raise_value_error()
        t.test_identification_counts_raise_value_error()
        t.test_one_field_changed_at_a_time_is_accepted_or_a_value_error()
        """
    ))
    assert sweep <= MAX_RSS, f"{sweep} bytes"
    # the finest beam, and a feedforward just under the generated-samples
    # limit through it and a model
    largest = peak_of(textwrap.dedent(
        f"""
        import sys
        sys.path[:0] = {sys.path!r}
        import mfcbeam
        b = mfcbeam.Beam.nominal()
        b.modes(elements=500)
        r = mfcbeam.feedforward(b, mfcbeam.Model.nominal(), end=199.0, elements=500)
        assert len(r["u"]) == 995001
        """
    ))
    assert largest <= MAX_RSS, f"{largest} bytes"
