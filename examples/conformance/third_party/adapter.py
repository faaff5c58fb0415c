#!/usr/bin/env python3
"""The adapter between `mfcbeam conform` and `pi_library.py`: it translates
conventions only, never the mathematics.

    adapter.py hysteresis --model M.json --input IN.csv --output OUT.csv   (column u -> y)
    adapter.py inverse    --model M.json --input IN.csv --output OUT.csv   (column y -> u)

mfcbeam's model file gives each play a threshold r (half the band) and a
state x_init that the first input passes through (its equation (8)); the
library takes band widths 2 r and initial outputs x_init. `--wrong NAME`
injects a known adapter mistake, to show that `conform` catches it:
half-width (the threshold taken as the band width) or skip-first (the first
sample reported without passing the play, another common first-sample
convention). A model with a part the library does not have (creep, the
superposition operator, a dead time, an offset) is declined with exit code
3, so that `conform --kind model` skips those cases instead of failing them.
"""

import csv
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from pi_library import PIOperator  # noqa: E402

WRONG = ("half-width", "skip-first")

# `mfcbeam conform` skips a case whose model has a part the candidate does
# not implement when the candidate exits with this code.
UNSUPPORTED = 3


def fail(message):
    print(f"adapter.py: {message}", file=sys.stderr)
    sys.exit(2)


def operator(path, wrong):
    with open(path) as f:
        m = json.load(f)
    # the library has H alone: decline the other parts, never approximate them
    missing = [k for k in ("creep", "superposition") if k in m]
    missing += [k for k in ("delay", "offset") if m.get(k)]
    if missing:
        print(f"adapter.py: the library implements H alone, not {', '.join(missing)}", file=sys.stderr)
        sys.exit(UNSUPPORTED)
    h = m["hysteresis"]
    r = h["thresholds"]
    # the convention: band width = 2 r (the mistake: width = r)
    widths = [x if wrong == "half-width" else 2.0 * x for x in r]
    return PIOperator(widths, h["weights"], h.get("state"))


def main(argv):
    if not argv or argv[0] not in ("hysteresis", "inverse"):
        fail("usage: adapter.py hysteresis|inverse --model M --input IN --output OUT [--wrong NAME]")
    kind, opts, k = argv[0], {}, 1
    while k < len(argv):
        if argv[k].startswith("--") and "=" in argv[k]:
            key, val = argv[k][2:].split("=", 1)
            k += 1
        elif argv[k].startswith("--") and k + 1 < len(argv):
            key, val = argv[k][2:], argv[k + 1]
            k += 2
        else:
            fail(f"unexpected argument {argv[k]}")
        opts[key] = val
    wrong = opts.get("wrong")
    if wrong is not None and wrong not in WRONG:
        fail(f"unknown --wrong {wrong} (one of {', '.join(WRONG)})")
    pi = operator(opts["model"], wrong)
    if kind == "inverse":
        pi = pi.inverse()
    column, new = ("u", "y") if kind == "hysteresis" else ("y", "u")
    with open(opts["input"], newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    if column not in header:
        fail(f"{opts['input']}: missing column {column}")
    c = header.index(column)
    out = []
    for i, row in enumerate(body):
        x = float(row[c])
        if wrong == "skip-first" and i == 0:
            y = sum(w * p.y for w, p in zip(pi.weights, pi.plays))
        else:
            y = pi.update(x)
        out.append(row + [repr(y)])
    with open(opts["output"], "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(header + [new])
        w.writerows(out)


if __name__ == "__main__":
    main(sys.argv[1:])
