"""Identify a hysteresis and creep compensator from a record, compensate a
staircase with it, and look at the result.

    python examples/identify_and_compensate.py                  # a synthetic lab record
    python examples/identify_and_compensate.py --record rec.csv # your own (columns t,u,y or u,y)
    python examples/identify_and_compensate.py --output plots/  # where the PNG goes

Without --record, the record is made the way a lab makes one: the nominal
actuator (the paper's model) driven through shrinking loops with plateaus,
its output measured with Gaussian noise, a sensor offset and a logger clock
with jitter. The staircase is then compensated with the identified model
and played into that same actuator, so the tracking error shown is the one
the lab would see. With --record the true actuator is not known: the
staircase is played into the identified model, which checks the inverse
(W[W⁻¹[y_d]] = y_d) and shows the voltages a real run would apply.

The figure needs matplotlib; without it the script prints its figures and
says that it drew nothing.
"""

import argparse
import csv
import sys
from pathlib import Path

import numpy as np

import mfcbeam


def shrinking_loops(amplitude, periods, steps, ts, plateau=0.4, rise=0.05):
    """0 → +A → −A → 0 in `steps` levels per quarter, the amplitude shrinking
    each period, every level held for a plateau: every play is excited, and
    the creep is seen on the plateaus."""
    levels = []
    for p in range(periods):
        a = amplitude * (periods - p) / periods
        up = [a * (i + 1) / steps for i in range(steps)]
        levels += up + up[-2::-1] + [-x for x in up] + [-x for x in up[-2::-1]] + [0.0]
    return staircase(levels, ts, plateau, rise)


def staircase(levels, ts, plateau=0.4, rise=0.05):
    """Levels joined by raised-cosine transitions of `rise` s, each held for
    `plateau` s, starting from 0."""
    n_rise, n_plateau = int(round(rise / ts)), int(round(plateau / ts))
    out, last = [], 0.0
    for level in levels:
        s = 0.5 - 0.5 * np.cos(np.pi * np.arange(1, n_rise + 1) / n_rise)
        out.append(last + (level - last) * s)
        out.append(np.full(n_plateau, float(level)))
        last = level
    return np.concatenate(out)


def synthetic_record(seed, noise=2.0, offset=37.5, jitter=0.003):
    """A lab record of the nominal actuator, and the actuator as the sensor
    sees it (its output plus the offset, without the noise)."""
    rng = np.random.default_rng(seed)
    actuator = mfcbeam.Model.nominal()
    ts = actuator.sample_time
    u = shrinking_loops(900.0, 3, 4, ts)
    y = actuator.copy().simulate(u) + offset + rng.normal(0.0, noise, len(u))
    t = np.arange(len(u)) * ts + rng.uniform(-jitter / 2, jitter / 2, len(u)) * ts

    def measured(u_in):
        return actuator.copy().simulate(u_in) + offset

    return {"t": t, "u": u, "y": y}, measured


def read_record(path):
    """Columns t (s, optional), u (V), y (V) of a CSV file with a header."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if not rows:
        raise ValueError(f"{path}: empty file")
    header = [h.strip() for h in rows[0]]
    for need in ("u", "y"):
        if need not in header:
            raise ValueError(f"{path}: no column '{need}' (the header is {','.join(header)})")
    columns = {name: [] for name in header}
    for line, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            raise ValueError(f"{path}: row {line} has {len(row)} fields, the header {len(header)}")
        for name, field in zip(header, row):
            try:
                columns[name].append(float(field))
            except ValueError:
                raise ValueError(f"{path}: row {line}, column '{name}': not a number: {field!r}") from None
    return {k: np.array(v) for k, v in columns.items() if k in ("t", "u", "y")}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--record", type=Path, help="CSV with columns t,u,y (or u,y with --sample-time)")
    ap.add_argument("--sample-time", type=float, help="sample time (s) when the record has no t")
    ap.add_argument("--output", type=Path, default=Path("."), help="directory for the figure")
    ap.add_argument("--seed", type=int, default=2011, help="seed of the synthetic record")
    args = ap.parse_args(argv)

    if args.record is None:
        record, plant = synthetic_record(args.seed)
        plant_name = "the true actuator (as measured)"
    else:
        record, plant = read_record(args.record), None
        if "t" not in record and args.sample_time is None:
            ap.error("the record has no column t: give --sample-time")

    # 1. identify, holding the last 10 % out to see the fit on unseen data
    model, report = mfcbeam.identify(
        record["u"],
        record["y"],
        t=record.get("t"),
        sample_time=None if "t" in record else args.sample_time,
        holdout=0.1,
    )
    print(report["text"])
    if plant is None:
        plant = lambda u_in: model.copy().simulate(u_in)  # noqa: E731
        plant_name = "the identified model"

    # 2. compensate a staircase in the identified range
    ts = report["sample_time"]
    span = 0.8 * min(abs(record["y"].max() - model.offset), abs(record["y"].min() - model.offset))
    y_d = model.offset + staircase([0.5 * span, span, 0.25 * span, -0.5 * span, -span, 0.0], ts)
    compensator = mfcbeam.Compensator(model, limits=(-1000.0, 1000.0))
    u, saturated, fault = compensator.compensate(y_d)
    y = plant(u)
    error = y - y_d
    print(
        f"staircase on {plant_name}: {len(y_d)} samples, "
        f"tracking error rms {np.sqrt(np.mean(error**2)):.3g} V, max {np.max(np.abs(error)):.3g} V "
        f"(uncompensated, u = y_d - offset: max {np.max(np.abs(plant(y_d - model.offset) - y_d)):.3g} V); "
        f"saturated samples {int(saturated.sum())}, faults {int(fault.sum())}"
    )

    # 3. plot, if matplotlib is there
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed: no figure drawn")
        return 0

    fitted = model.copy().simulate(record["u"])
    t_rec = record["t"] if "t" in record else np.arange(len(record["u"])) * ts
    t = np.arange(len(y_d)) * ts
    fig, ax = plt.subplots(2, 2, figsize=(11, 7), constrained_layout=True)
    ax[0, 0].plot(t_rec, record["y"], lw=0.5, color="0.6", label="measured y")
    ax[0, 0].plot(t_rec, fitted, lw=0.8, label="identified model")
    ax[0, 0].set(xlabel="t (s)", ylabel="y (V)", title="record and fit")
    ax[0, 1].plot(record["u"], record["y"], lw=0.3, color="0.6", label="measured")
    ax[0, 1].plot(record["u"], fitted, lw=0.6, label="identified model")
    ax[0, 1].set(xlabel="u (V)", ylabel="y (V)", title="hysteresis")
    ax[1, 0].plot(t, y_d, "k--", lw=0.8, label="desired $y_d$")
    ax[1, 0].plot(t, y, lw=0.8, label=f"y of {plant_name}")
    ax[1, 0].plot(t, u, lw=0.6, label="compensated input u")
    ax[1, 0].set(xlabel="t (s)", ylabel="V", title="compensated staircase")
    ax[1, 1].plot(t, error, lw=0.8)
    ax[1, 1].set(xlabel="t (s)", ylabel="$y - y_d$ (V)", title="tracking error")
    for a in ax.flat:
        a.grid(alpha=0.3)
        if a.get_legend_handles_labels()[0]:
            a.legend(fontsize=8)
    args.output.mkdir(parents=True, exist_ok=True)
    png = args.output / "identify_and_compensate.png"
    fig.savefig(png, dpi=120)
    print(f"wrote {png}")
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        sys.exit(2)
