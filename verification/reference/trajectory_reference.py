#!/usr/bin/env python3
"""Independent high-precision reference for the Gevrey trajectory (28).

Computes d^k z/dt^k, k = 0..30, of

    z(t) = z0 + (zT - z0) / (1 + exp(-2 w)),   w = 2 (2 tau - 1) / (4 tau (1 - tau))^sigma,   tau = t / T

with mpmath's high-precision differentiation (mpmath.diffs: finite differences
evaluated at a working precision raised for the order), at 150 significant
digits, cross-checked against the same at 100 digits (agreement to 1e-30
relative shows the digits are converged). Writes
trajectory_derivatives.csv (one row per point: tau, then the 31 derivatives)
and trajectory_scales.csv (max |d^k z/dt^k| over a grid of 199 points).

Run once:  python3 verification/reference/trajectory_reference.py
(needs mpmath; the outputs are committed, the tests do not run this).
"""
import os
import mpmath as mp

mp.mp.dps = 150
T = mp.mpf("0.075")
SIGMA = mp.mpf("1.1")
Z0, ZT = mp.mpf(0), mp.mpf(1)
ORDER = 30


def z(t):
    tau = t / T
    w = 2 * (2 * tau - 1) / (4 * tau * (1 - tau)) ** SIGMA
    return Z0 + (ZT - Z0) / (1 + mp.exp(-2 * w))


def derivatives(tau):
    t = mp.mpf(tau) * T
    return list(mp.diffs(z, t, ORDER))


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    points = ["0.004", "0.005", "0.008", "0.01", "0.03", "0.07", "0.12", "0.2", "0.3", "0.4",
              "0.47", "0.5", "0.53", "0.6", "0.7", "0.8", "0.88", "0.93", "0.97", "0.99",
              "0.992", "0.995", "0.996"]
    with open(os.path.join(here, "trajectory_derivatives.csv"), "w") as f:
        f.write("tau," + ",".join(f"d{k}" for k in range(ORDER + 1)) + "\n")
        for p in points:
            d = derivatives(p)
            with mp.workdps(100):
                check = derivatives(p)
            for k in range(ORDER + 1):
                # relative to the size of this order and its neighbours (a
                # derivative may vanish, e.g. the even ones at tau = 1/2)
                size = max([abs(d[k])] + [abs(d[j]) * T ** (j - k) for j in (k - 1, k + 1) if 0 <= j <= ORDER])
                assert abs(check[k] - d[k]) <= mp.mpf(10) ** -30 * size, (p, k)
            f.write(p + "," + ",".join(mp.nstr(x, 25) for x in d) + "\n")
    scales = [mp.mpf(0)] * (ORDER + 1)
    for i in range(1, 200):
        d = derivatives(mp.mpf(i) / 400)
        scales = [max(s, abs(x)) for s, x in zip(scales, d)]
    # the table points too (the maximum may fall between grid points)
    for row in open(os.path.join(here, "trajectory_derivatives.csv")).read().splitlines()[1:]:
        d = [mp.mpf(x) for x in row.split(",")[1:]]
        scales = [max(s, abs(x)) for s, x in zip(scales, d)]
    with open(os.path.join(here, "trajectory_scales.csv"), "w") as f:
        f.write("order,max_abs\n")
        for k, s in enumerate(scales):
            f.write(f"{k},{mp.nstr(s, 25)}\n")


if __name__ == "__main__":
    main()
