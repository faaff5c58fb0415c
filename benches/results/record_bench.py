#!/usr/bin/env python3
"""Record what `mfcbeam bench --json` measured, as the benches record theirs.

    mfcbeam bench --cpu 1 --json run1.json     # three processes, say
    python3 benches/results/record_bench.py run1.json run2.json run3.json

The reference's median and 99.9th percentile (ns) go into today's file
of this CPU's folder (benches/results/<vendor>-<family>-<model>/) as the
bench `mfcbeam_bench`, one value per file given, beside the commit and the
kernel set the files name: `bench_reference_median_ns` and
`bench_reference_p999_ns`, which the performance chapter shows beside the
`latency` bench's. The files must come from one machine, one kind and one
target; other candidates are a user's, not recorded.
"""

from __future__ import annotations

import datetime
import json
import re
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def cpu_field(info: str, names: list[str]) -> str:
    for name in names:
        for line in info.splitlines():
            key, _, value = line.partition(":")
            if key.strip() == name:
                return value.strip()
    return "?"


def main(paths: list[str]) -> int:
    if not paths:
        print(__doc__, file=sys.stderr)
        return 2
    runs = [json.loads(Path(p).read_text()) for p in paths]
    first = runs[0]
    for p, r in zip(paths, runs):
        for key in ("kind", "target", "cpu", "kernels"):
            if r.get(key) != first.get(key):
                print(f"record_bench: {p}: another {key} than {paths[0]}", file=sys.stderr)
                return 2
    info = Path("/proc/cpuinfo").read_text() if Path("/proc/cpuinfo").exists() else ""
    vendor = cpu_field(info, ["vendor_id", "CPU implementer"])
    family = cpu_field(info, ["cpu family", "CPU architecture"])
    model = cpu_field(info, ["model", "CPU part"])
    folder = HERE / re.sub(r"[^a-z0-9]", "-", f"{vendor}-{family}-{model}".lower())
    today = datetime.datetime.now(datetime.timezone.utc).date().isoformat()
    path = folder / f"{today}.json"
    data = json.loads(path.read_text()) if path.exists() else {}
    data["cpu"] = {
        "vendor": vendor,
        "family": family,
        "model": model,
        "name": cpu_field(info, ["model name"]),
        "description": first["cpu"],
    }
    data["date"] = today
    def git(*args: str) -> str:
        return subprocess.run(["git", *args], capture_output=True, text=True, cwd=HERE).stdout.strip()

    # the commit measured, with -dirty if the tree has changes (as the benches mark it)
    commit = git("rev-parse", "--short=7", "HEAD") or "?"
    if git("status", "--porcelain", "--untracked-files=no"):
        commit += "-dirty"
    figures: dict[str, list[float]] = {}
    for r in runs:
        for c in r["candidates"]:
            if c["name"].startswith("reference"):
                figures.setdefault("bench_reference_median_ns", []).append(c["ns"]["median"])
                figures.setdefault("bench_reference_p999_ns", []).append(c["ns"]["p999"])
    data.setdefault("benches", {})["mfcbeam_bench"] = {
        "commit": commit,
        "kernels": first["kernels"],
        "figures": [{"name": n, "unit": "ns", "values": v} for n, v in figures.items()],
    }
    folder.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=2) + "\n")
    print(f"results: {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
