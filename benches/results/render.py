#!/usr/bin/env python3
"""The performance chapter's tables, from the data in benches/results/.

Each CPU has a folder (`<vendor>-<family>-<model>`) of dated files, written
by the benches (`MFCBEAM_RESULTS=1 cargo bench ...`, see
benches/common/results.rs) or, for measurements made before the benches
wrote data, transcribed from their printed output. One table per CPU:
every figure once, from the latest file that has it, with its date and
commit.

    python3 benches/results/render.py          # rewrite the chapter's tables
    python3 benches/results/render.py --check  # exit 1 if they differ (CI)
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
CHAPTER = HERE.parent.parent / "docs" / "guide" / "performance.md"
BEGIN = "<!-- results: begin (benches/results/render.py writes this part) -->"
END = "<!-- results: end -->"

# the figures in the order the tables show them, with what a row says
ROWS = [
    ("step_f64_run_over_strongest_c", "`f64` a run / the strongest C's loop"),
    ("step_f64_call_over_strongest_c", "`f64` one call / the strongest C's call"),
    ("step_f32_over_f64_run", "`f32` / `f64`, a run"),
    ("step_f32_over_f64_call", "`f32` / `f64`, one call"),
    ("strongest_c_f32_over_f64", "the strongest C's `f32` / `f64`"),
    ("capi_call_over_strongest_c", "C API one call / the strongest C's call"),
    ("step_f64_run_ns", "`f64` step, a run (ns)"),
    ("bank_f64_64_of_bound", "bank `f64`, 64 channels, of its bound"),
    ("bank_f64_1024_of_bound", "bank `f64`, 1024 channels, of its bound"),
    ("bank_f32_64_of_bound", "bank `f32`, 64 channels, of its bound"),
    ("bank_f32_1024_of_bound", "bank `f32`, 1024 channels, of its bound"),
    ("bank_f64_64_frames_of_bound", "bank `f64`, 64 channels, 64 frames a call, of its bound"),
    ("bank_f64_1024_frames_of_bound", "bank `f64`, 1024 channels, 64 frames a call, of its bound"),
    ("bank_f32_64_frames_of_bound", "bank `f32`, 64 channels, 64 frames a call, of its bound"),
    ("bank_f32_1024_frames_of_bound", "bank `f32`, 1024 channels, 64 frames a call, of its bound"),
    ("bank_f64_crossover_blocks", "bank `f64`: blocks from which `Par::rayon(2)` pays"),
    ("bank_f32_crossover_blocks", "bank `f32`: blocks from which `Par::rayon(2)` pays"),
    ("bank_f64_two_threads_over_one_256", "bank `f64`, 256 channels: `Par::rayon(2)` / one thread"),
    ("bank_f64_two_threads_over_one_1024", "bank `f64`, 1024 channels: `Par::rayon(2)` / one thread"),
    ("bank_f32_two_threads_over_one_256", "bank `f32`, 256 channels: `Par::rayon(2)` / one thread"),
    ("bank_f32_two_threads_over_one_1024", "bank `f32`, 1024 channels: `Par::rayon(2)` / one thread"),
    ("portable_bank_f64_64_over_loop", "portable bank `f64`, 64 channels / a loop of portable compensators"),
    ("portable_bank_f64_1024_over_loop", "portable bank `f64`, 1024 channels / a loop of portable compensators"),
    ("portable_bank_f32_64_over_loop", "portable bank `f32`, 64 channels / a loop of portable compensators"),
    ("portable_bank_f32_1024_over_loop", "portable bank `f32`, 1024 channels / a loop of portable compensators"),
    ("portable_bank_f64_64_over_dispatched", "portable bank `f64`, 64 channels / the dispatched bank"),
    ("portable_bank_f64_1024_over_dispatched", "portable bank `f64`, 1024 channels / the dispatched bank"),
    ("portable_bank_f32_64_over_dispatched", "portable bank `f32`, 64 channels / the dispatched bank"),
    ("portable_bank_f32_1024_over_dispatched", "portable bank `f32`, 1024 channels / the dispatched bank"),
    ("latency_f64_median_ns", "one `f64` step, adversarial targets: median (ns)"),
    ("latency_f64_p999_ns", "the same, 99.9th percentile (ns)"),
    ("bench_reference_median_ns", "`mfcbeam bench`, the reference (heap `f64`) step, adversarial targets: median (ns)"),
    ("bench_reference_p999_ns", "the same, 99.9th percentile (ns)"),
]
LABELS = dict(ROWS)


def cell(values: list[float], unit: str, runs: int | None = None) -> str:
    if unit == "fraction":
        values = [100.0 * v for v in values]
        suffix = " %"
        digits = 0
    elif unit == "ratio":
        suffix, digits = "", 3
    elif unit == "ns":
        suffix, digits = "", 1
    else:
        suffix, digits = "", 0
    lo, hi = min(values), max(values)
    text = f"{lo:.{digits}f}" if lo == hi else f"{lo:.{digits}f}–{hi:.{digits}f}"
    runs = runs or len(values)
    return text + suffix + (f" ({runs})" if runs > 1 else "")


def cpu_table(folder: Path) -> str:
    files = sorted(folder.glob("*.json"))
    latest: dict[str, tuple] = {}
    cpu_name, title = folder.name, None
    for f in files:
        data = json.loads(f.read_text())
        cpu = data.get("cpu", {})
        # a title given by hand (the guest's own name can be vague) stays
        title = cpu.get("title") or title
        cpu_name = title or cpu.get("name") or cpu_name
        family, model = cpu.get("family", "?"), cpu.get("model", "?")
        for bench, entry in data.get("benches", {}).items():
            for fig in entry.get("figures", []):
                latest[fig["name"]] = (
                    data["date"],
                    entry.get("commit", "?"),
                    entry.get("kernels", "?"),
                    fig["values"],
                    fig["unit"],
                    fig.get("runs"),
                )
    lines = [f"### {cpu_name} (family {family}, model {model})", ""]
    lines.append("| figure | value (runs) | measured |")
    lines.append("|---|---|---|")
    names = [n for n, _ in ROWS if n in latest] + sorted(n for n in latest if n not in LABELS)
    for name in names:
        date, commit, kernels, values, unit, runs = latest[name]
        label = LABELS.get(name, name)
        lines.append(f"| {label} | {cell(values, unit, runs)} | {date}, `{commit}`, {kernels} |")
    return "\n".join(lines)


def render() -> str:
    folders = sorted(p for p in HERE.iterdir() if p.is_dir() and any(p.glob("*.json")))
    return "\n\n".join(cpu_table(f) for f in folders)


def main() -> int:
    text = CHAPTER.read_text()
    if BEGIN not in text or END not in text:
        print(f"{CHAPTER}: the markers are missing", file=sys.stderr)
        return 1
    head, rest = text.split(BEGIN, 1)
    _, tail = rest.split(END, 1)
    new = head + BEGIN + "\n\n" + render() + "\n\n" + END + tail
    if "--check" in sys.argv:
        if new != text:
            print(f"{CHAPTER}: its tables differ from benches/results/ "
                  "(python3 benches/results/render.py)", file=sys.stderr)
            return 1
        print("the performance chapter's tables match benches/results/")
        return 0
    CHAPTER.write_text(new)
    return 0


if __name__ == "__main__":
    sys.exit(main())
