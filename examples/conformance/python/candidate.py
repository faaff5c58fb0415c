#!/usr/bin/env python3
"""An independent implementation of W and W^-1 that follows mfcbeam's file
contract, written for `mfcbeam conform` (Python standard library only).

    candidate.py simulate   --model M.json --input IN.csv --output OUT.csv
    candidate.py compensate --model M.json --input IN.csv --output OUT.csv --limits=LO,HI

`simulate` reads column `u` and appends `y = W[u]`; `compensate` reads column
`y_d` and appends `u = W^-1[y_d]` and `saturated` (0/1). The model file's
`state` is honoured as the contract says: the hysteresis state is x_init of
(8), the creep state is chi at the first sample; its `offset` is added to the
output (and subtracted from a compensator's target). An optional
`superposition` S acts on H + C: y = S[H + C] + offset, and W^-1 applies
S^-1 to the target first. A dead time `delay` of d samples delays the output,
y_k = S[H + C]_{max(k-d,0)} + offset (`delay_state`: the d values still to
come out; absent, the first sample's value fills the line), and `compensate`
previews the target by d samples: u_k = W^-1[y_d]_{k+d}, the last d samples
holding the last target.

`--fault NAME` injects a known fault, so that the conformance test can show
each one is caught: creep-vk, threshold, sign, no-flag, delay, ignore-state,
ignore-dead-time.
"""

import csv
import json
import math
import sys

FAULTS = ("creep-vk", "threshold", "sign", "no-flag", "delay", "ignore-state", "ignore-dead-time")


def play(v, r, x):
    return max(v - r, min(v + r, x))


class Hysteresis:
    """The PI operator (10) with the sampled play (20)."""

    def __init__(self, r, w, x):
        self.r, self.w, self.x = list(r), list(w), list(x)

    def step(self, v):
        y = 0.0
        for i, r in enumerate(self.r):
            self.x[i] = play(v, r, self.x[i])
            y += self.w[i] * self.x[i]
        return y

    def inverse(self):
        """The transformation rules (22), direct sums."""
        n = len(self.r)
        s = [sum(self.w[: j + 1]) for j in range(n)]
        r = [sum(self.w[i] * (self.r[j] - self.r[i]) for i in range(j + 1)) for j in range(n)]
        w = [1.0 / self.w[0]] + [-self.w[j] / (s[j] * s[j - 1]) for j in range(1, n)]
        x = [s[j] * self.x[j] + sum(self.w[i] * self.x[i] for i in range(j + 1, n)) for j in range(n)]
        return Hysteresis(r, w, x)


class Creep:
    """The PI creep operator (16) of log(t)-creep operators (15), exact ZOH (20)."""

    def __init__(self, r, w, a, ts, chi, fault):
        self.r, self.w = list(r), list(w)
        self.g = [-math.expm1(-aj * ts) for aj in a]
        self.chi = [list(row) for row in chi]
        self.fault = fault

    def output(self):
        m = len(self.g)
        return sum(self.w[i] * sum(self.chi[i]) / m for i in range(len(self.r)))

    def advance(self, v):
        for i, r in enumerate(self.r):
            for j, g in enumerate(self.g):
                self.chi[i][j] += g * play(v - self.chi[i][j], r, 0.0)

    def step(self, v):
        """C_k from chi_k (which depends on v_{k-1}), then advance with v_k."""
        if self.fault == "creep-vk":
            self.advance(v)
            return self.output()
        out = self.output()
        self.advance(v)
        return out


class Superposition:
    """S[z] = sum_i w_i d_i(z), one-sided dead zones around the zero threshold."""

    def __init__(self, r, w):
        self.r, self.w = list(r), list(w)

    def __call__(self, z):
        return sum(
            w * (max(z - r, 0.0) if r > 0 else min(z - r, 0.0) if r < 0 else z)
            for r, w in zip(self.r, self.w)
        )

    def inverse(self):
        """Thresholds S(r_i); weights 1/w_0 and -w_i / (slope outward * slope inward),
        the slopes as direct sums from the zero threshold."""
        zero = self.r.index(0.0)

        def slope(j):  # the slope just outside r_j (towards larger |r|)
            span = range(zero, j + 1) if j >= zero else range(j, zero + 1)
            return sum(self.w[i] for i in span)

        def inward(j):
            return slope(j - 1) if j > zero else slope(j + 1)

        w = [
            1.0 / self.w[zero] if j == zero else -self.w[j] / (slope(j) * inward(j))
            for j in range(len(self.r))
        ]
        return Superposition([self(r) for r in self.r], w)


def load(path, fault):
    with open(path) as f:
        m = json.load(f)
    ts = m["sample_time"]
    h = m["hysteresis"]
    r, w = list(h["thresholds"]), list(h["weights"])
    if fault == "threshold":
        r[-1] *= 1.0 + 1e-6
    if fault == "sign":
        # flip the largest weight whose flip keeps every partial sum positive
        def keeps(j):
            s = 0.0
            for i, wi in enumerate(w):
                s += -wi if i == j else wi
                if s <= 0.0:
                    return False
            return True

        flips = [j for j in range(1, len(w)) if keeps(j)]
        if flips:
            j = max(flips, key=lambda k: abs(w[k]))
            w[j] = -w[j]
    use_state = fault != "ignore-state"
    x = h.get("state") if use_state else None
    hyst = Hysteresis(r, w, x if x is not None else [0.0] * len(r))
    creep = None
    c = m.get("creep")
    if c is not None:
        chi = c.get("state") if use_state else None
        if chi is None:
            chi = [[0.0] * len(c["eigenvalues"]) for _ in c["thresholds"]]
        creep = Creep(c["thresholds"], c["weights"], c["eigenvalues"], ts, chi, fault)
    sup = m.get("superposition")
    sup = Superposition(sup["thresholds"], sup["weights"]) if sup is not None else None
    d = 0 if fault == "ignore-dead-time" else m.get("delay", 0)
    pending = list(m.get("delay_state") or []) if d else []
    return hyst, creep, sup, m.get("offset", 0.0), (d, pending)


def simulate(hyst, creep, sup, offset, dead, u, fault):
    d, pending = dead
    y, last = [], 0.0
    for v in u:
        z = hyst.step(v) + (creep.step(v) if creep else 0.0)
        z = sup(z) if sup else z
        if d:
            if not pending:
                pending = [z] * d
            pending.append(z)
            z = pending.pop(0)
        out = z + offset
        if fault == "delay":
            out, last = last, out
        y.append(out)
    return y


def compensate(hyst, creep, sup, offset, dead, targets, lo, hi, fault):
    inverse = hyst.inverse()
    sup_inv = sup.inverse() if sup else None
    d = dead[0]
    us, flags, last = [], [], 0.0
    for k in range(len(targets)):
        t = targets[min(k + d, len(targets) - 1)]
        c = creep.output() if creep else 0.0
        y = sup_inv(t - offset) if sup_inv else t - offset
        v = inverse.step(y - c)
        u = min(max(v, lo), hi)
        saturated = u != v
        hyst.step(u)
        if saturated:
            inverse.x = hyst.inverse().x
        if creep:
            creep.advance(u)
        if fault == "delay":
            u, last = last, u
        us.append(u)
        flags.append(saturated and fault != "no-flag")
    return us, flags


def fail(message):
    print(f"candidate.py: {message}", file=sys.stderr)
    sys.exit(2)


def main(argv):
    if not argv or argv[0] not in ("simulate", "compensate"):
        fail("usage: candidate.py simulate|compensate --model M --input IN --output OUT [--limits=LO,HI] [--fault NAME]")
    kind, opts, k = argv[0], {}, 1
    while k < len(argv):
        a = argv[k]
        if a.startswith("--") and "=" in a:
            key, val = a[2:].split("=", 1)
            k += 1
        elif a.startswith("--") and k + 1 < len(argv):
            key, val = a[2:], argv[k + 1]
            k += 2
        else:
            fail(f"unexpected argument {a}")
        opts[key] = val
    fault = opts.get("fault")
    if fault is not None and fault not in FAULTS:
        fail(f"unknown fault {fault} (one of {', '.join(FAULTS)})")
    hyst, creep, sup, offset, dead = load(opts["model"], fault)
    with open(opts["input"], newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    column = "u" if kind == "simulate" else "y_d"
    if column not in header:
        fail(f"{opts['input']}: missing column {column}")
    values = [float(row[header.index(column)]) for row in body]
    if kind == "simulate":
        extra = ["y"]
        cols = [[repr(y)] for y in simulate(hyst, creep, sup, offset, dead, values, fault)]
    else:
        lo, hi = (float(x) for x in opts.get("limits", "-inf,inf").split(","))
        us, flags = compensate(hyst, creep, sup, offset, dead, values, lo, hi, fault)
        extra = ["u", "saturated"]
        cols = [[repr(u), "1" if s else "0"] for u, s in zip(us, flags)]
    with open(opts["output"], "w", newline="") as f:
        out = csv.writer(f, lineterminator="\n")
        out.writerow(header + extra)
        for row, add in zip(body, cols):
            out.writerow(row + add)


if __name__ == "__main__":
    main(sys.argv[1:])
