"""The numba peer of the compensator step: the same loops as compensator.c
(play (20), creep (20), compensator (21), inverse state rule (22)), compiled
with numba's @njit. Prints the per-step median over batches in ns.

    python3 numba_compensator.py time | trace

The timed function runs a whole batch of steps inside numba, so no Python
call is counted per step.
"""

import sys
import time

import numpy as np
from numba import njit

NP, NC, M, TS, LEN = 12, 12, 5, 2e-4, 4096
HW = np.array([0.45, 0.0963, 0.0773, 0.062, 0.0498, 0.0399,
               0.0321, 0.0257, 0.0206, 0.0166, 0.0133, -0.01])
CW = np.array([0.08, 0.006, 0.005, 0.004, 0.003, 0.002,
               0.002, 0.001, 0.001, 0.001, 0.001, 0.001])
EIG = np.array([500.0, 50.0, 5.0, 0.5, 0.05])


@njit(cache=False)
def creep_advance(chi, rc, wc, g, v):
    out = 0.0
    for j in range(M):
        for i in range(NC):
            z = v - chi[j, i]
            d = max(z - rc[i], min(z + rc[i], 0.0))
            chi[j, i] += g[j] * d
            out += wc[i] * chi[j, i]
    return out


@njit(cache=False)
def compensate(p, st, chi, target):
    """p: parameters (r, w, s, ri, wi, rc, wc, g, limits) as rows of a 2-D
    array; st: states (x, xi) rows and scalars (creep_out, last_u)."""
    r, w, s, ri, wi, rc, wc = p[0], p[1], p[2], p[3], p[4], p[5], p[6]
    g = p[7, :M]
    lower, upper = p[8, 0], p[8, 1]
    x, xi = st[0], st[1]
    if not np.isfinite(target):
        u = st[2, 1]
        st[2, 0] = creep_advance(chi, rc, wc, g, u)
        return u
    y = target - st[2, 0]
    v = 0.0
    for i in range(NP):
        xi[i] = max(y - ri[i], min(y + ri[i], xi[i]))
        v += wi[i] * xi[i]
    u = min(max(v, lower), upper)
    for i in range(NP):
        x[i] = max(u - r[i], min(u + r[i], x[i]))
    if u != v:
        tail = 0.0
        for j in range(NP - 1, -1, -1):
            xi[j] = s[j] * x[j] + tail
            tail += w[j] * x[j]
    st[2, 1] = u
    st[2, 0] = creep_advance(chi, rc, wc, g, u)
    return u


@njit(cache=False)
def run_batch(p, st, chi, targets, k, steps):
    sink = 0.0
    for _ in range(steps):
        k = (k + 1) & (LEN - 1)
        sink += compensate(p, st, chi, targets[k])
    return k, sink


def parameters():
    p = np.zeros((9, NP))
    r = np.arange(NP) * 1000.0 / 12.0
    s = np.cumsum(HW)
    ri = np.zeros(NP)
    wi = np.zeros(NP)
    wi[0] = 1.0 / HW[0]
    for j in range(1, NP):
        ri[j] = ri[j - 1] + s[j - 1] * (r[j] - r[j - 1])
        wi[j] = -HW[j] / (s[j] * s[j - 1])
    p[0], p[1], p[2], p[3], p[4] = r, HW, s, ri, wi
    p[5], p[6] = r, CW / M
    p[7, :M] = -np.expm1(-EIG * TS)
    p[8, :2] = (-1000.0, 1000.0)
    return p


def test_input():
    state, v, out = 0x9E3779B97F4A7C15, 0.0, np.empty(LEN)
    mask = (1 << 64) - 1
    for k in range(LEN):
        state ^= (state << 13) & mask
        state ^= state >> 7
        state ^= (state << 17) & mask
        step = ((state >> 11) / float(1 << 53) - 0.5) * 40.0
        v = min(max(v + step, -600.0), 600.0)
        out[k] = v
    return out


def targets_of(u, p):
    """W of u by the forward loops (the plant model)."""
    x, chi, creep_out, y = np.zeros(NP), np.zeros((M, NC)), 0.0, np.empty(len(u))
    for k, uk in enumerate(u):
        x = np.maximum(uk - p[0], np.minimum(uk + p[0], x))
        y[k] = HW @ x + creep_out
        creep_out = creep_advance(chi, p[5], p[6], p[7, :M], uk)
    return y


def main():
    mode = sys.argv[1] if len(sys.argv) > 1 else "time"
    p = parameters()
    targets = targets_of(test_input(), p)
    st, chi = np.zeros((3, NP)), np.zeros((M, NC))
    if mode == "trace":
        print("y_d,u_peer")
        for t in targets:
            u = compensate(p, st, chi, t)
            print(f"{float(t)!r},{float(u)!r}")
        return
    if mode != "time":
        sys.exit(f"usage: {sys.argv[0]} time|trace")
    steps, batches = 200_000, 41
    k, _ = run_batch(p, st, chi, targets, 0, steps)  # compiles, warms up
    per_step = []
    for _ in range(batches):
        t0 = time.perf_counter()
        k, _ = run_batch(p, st, chi, targets, k, steps)
        per_step.append((time.perf_counter() - t0) / steps * 1e9)
    print(f"{sorted(per_step)[batches // 2]:.2f}")


if __name__ == "__main__":
    main()
