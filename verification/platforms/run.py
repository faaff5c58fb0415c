#!/usr/bin/env python3
"""Every FMU kind, in both FMI versions, on every platform, bit for bit.

For each kind (compensator, model, plant, controller) and FMI version,
`mfcbeam fmu` packs one archive with the Linux x86-64, Windows x86-64 and
Linux aarch64 libraries. The C host (`fmu_host.c`, built for each platform)
steps it through a scenario trace of `golden/`, with boundary samples
appended (saturation, a non-finite input), saves the FMU state half way,
and replays the second half from it. The host runs natively on Linux
x86-64, under wine on Windows and under qemu-user on aarch64.

Checked: every output of every sample on every platform has the bits of
the Linux x86-64 run, and the replay after restoring the state has the
bits of the first pass. Exit 1 on a difference (the first one is printed),
2 when a host cannot run.

    verification/platforms/run.py --cli target/release/mfcbeam \\
        --host x86_64-linux=H --host x86_64-windows=H.exe \\
        --host aarch64-linux=H-arm --work target/platforms \\
        --wine-dll bcryptprimitives.dll
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import shutil
import struct
import subprocess
import sys
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
REFERENCE = "x86_64-linux"


def bits(x: float) -> str:
    return struct.pack(">d", x).hex()


def column(name: str, *cols: str) -> list[list[float]]:
    with open(ROOT / "golden" / name, newline="") as f:
        return [[float(r[c]) for c in cols] for r in csv.DictReader(f)]


def inputs(kind: str) -> list[list[float]]:
    """A scenario's trace for the kind's inputs, with boundary samples: the
    limits exceeded, a NaN and an infinity (held, with `fault`), and back."""
    if kind == "compensator":
        rows = column("compensated.csv", "y_d")
    elif kind == "model":
        rows = column("minor-loops.csv", "u")
    elif kind == "plant":
        rows = column("compensated.csv", "u")
    else:  # the controller: the reference and a measurement of the loop
        rows = column("loop-step-load.csv", "y_d", "tip_pid")
    width = len(rows[0])
    scale = max(abs(v) for r in rows for v in r) or 1.0
    for v in [2.5 * scale, math.nan, -math.inf, -2.5 * scale, 0.0, 0.5 * scale]:
        rows.append([v] * width)
    return rows


def variables(xml: str) -> tuple[list[str], list[str]]:
    """The value references of the Float64 inputs and of the outputs, each
    output with its type (r or b), from the model description."""
    root = ET.fromstring(xml)
    ins, outs = [], []
    if root.get("fmiVersion", "").startswith("2"):
        for sv in root.iter("ScalarVariable"):
            vr, causality = sv.get("valueReference"), sv.get("causality")
            typ = "r" if sv.find("Real") is not None else "b" if sv.find("Boolean") is not None else None
            if causality == "input" and typ == "r":
                ins.append(vr)
            elif causality == "output" and typ:
                outs.append(vr + typ)
    else:
        for sv in root.find("ModelVariables"):
            vr, causality = sv.get("valueReference"), sv.get("causality")
            typ = {"Float64": "r", "Boolean": "b"}.get(sv.tag)
            if causality == "input" and typ == "r":
                ins.append(vr)
            elif causality == "output" and typ:
                outs.append(vr + typ)
    return ins, outs


def wine() -> str:
    return shutil.which("wine64") or shutil.which("wine") or "/usr/lib/wine/wine64"


def wine_env(work: Path) -> dict:
    env = dict(os.environ)
    env.update(WINEPREFIX=str(work / "wine"), WINEDEBUG="-all", WINEDLLOVERRIDES="mscoree,mshtml=")
    return env


def wine_prefix(work: Path, dlls: list[Path]) -> None:
    """A wine prefix of its own, with the stand-in DLLs in its system32."""
    system32 = work / "wine" / "drive_c" / "windows" / "system32"
    if not system32.is_dir():
        subprocess.run([wine(), "wineboot", "--init"], env=wine_env(work), check=True,
                       capture_output=True, timeout=600)
    for dll in dlls:
        shutil.copy(dll, system32 / dll.name)


def command(platform: str, host: Path, work: Path) -> tuple[list[str], callable, dict]:
    """How to run a host of `platform` here, how it names a path, and its
    environment."""
    env = dict(os.environ)
    if platform == "x86_64-windows":
        # wine maps the Unix root to drive Z:
        return [wine(), str(host)], lambda p: "Z:" + str(p).replace("/", "\\"), wine_env(work)
    if platform == "aarch64-linux":
        return ["qemu-aarch64", "-L", "/usr/aarch64-linux-gnu", str(host)], str, env
    return [str(host)], str, env


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cli", required=True, type=Path)
    ap.add_argument("--host", action="append", required=True, metavar="PLATFORM=PATH")
    ap.add_argument("--work", required=True, type=Path)
    ap.add_argument("--kinds", default="compensator,model,plant,controller")
    ap.add_argument("--wine-dll", action="append", default=[], type=Path,
                    help="a DLL to put in the wine prefix's system32 (bcryptprimitives.dll for wine 8)")
    args = ap.parse_args()
    hosts = dict(h.split("=", 1) for h in args.host)
    if REFERENCE not in hosts:
        print(f"run.py: --host {REFERENCE}=PATH is the reference", file=sys.stderr)
        return 2
    platforms = [REFERENCE] + sorted(p for p in hosts if p != REFERENCE)
    work = args.work.resolve()
    work.mkdir(parents=True, exist_ok=True)
    if "x86_64-windows" in hosts:
        wine_prefix(work, args.wine_dll)
    shutil.rmtree(work / "fmus", ignore_errors=True)
    (work / "fmus").mkdir(parents=True)
    failed = False
    print(f"| kind | FMI | samples | outputs | {' | '.join(platforms)} |")
    print(f"|---|---|---|---|{'---|' * len(platforms)}")
    for kind in args.kinds.split(","):
        for version in ["2", "3"]:
            name = f"{kind}-fmi{version}"
            fmu = work / "fmus" / f"{name}.fmu"
            extra = ["--controller", "pid"] if kind == "controller" else [
                "--model", str(ROOT / "golden" / "nominal_model.json")]
            if kind == "plant":
                extra += ["--beam", str(ROOT / "golden" / "nominal_beam.json")]
            subprocess.run(
                [str(args.cli), "fmu", "--kind", kind, *extra, "--fmi", version,
                 "--platforms", ",".join(platforms), "--output", str(fmu)],
                check=True)
            unpacked = work / "fmus" / name
            with zipfile.ZipFile(fmu) as z:
                z.extractall(unpacked)
            ins, outs = variables((unpacked / "modelDescription.xml").read_text())
            rows = inputs(kind)
            if len(ins) != len(rows[0]):
                print(f"run.py: {name}: {len(ins)} inputs, the trace has {len(rows[0])}", file=sys.stderr)
                return 2
            trace = unpacked / "rows.txt"
            trace.write_text("\n".join(" ".join(bits(v) for v in r) for r in rows) + "\n")
            save_at = len(rows) // 2
            results = {}
            for platform in platforms:
                cmd, path, env = command(platform, Path(hosts[platform]).resolve(), work)
                run = subprocess.run(
                    cmd + [path(unpacked), ",".join(ins), ",".join(outs), str(save_at), path(trace)],
                    capture_output=True, text=True, env=env, timeout=900)
                if run.returncode != 0:
                    print(f"run.py: {name} on {platform}: exit {run.returncode}: {run.stderr.strip()}",
                          file=sys.stderr)
                    return 2
                lines = run.stdout.splitlines()
                if "restored" not in lines:
                    print(f"run.py: {name} on {platform}: no replay", file=sys.stderr)
                    return 2
                cut = lines.index("restored")
                first, replay = lines[:cut], lines[cut + 1:]
                if len(first) != len(rows) or replay != first[save_at:]:
                    k = next((i for i, (a, b) in enumerate(zip(replay, first[save_at:])) if a != b), None)
                    print(f"{name} on {platform}: the replay from the saved state differs"
                          f" at sample {save_at + (k or 0)}", file=sys.stderr)
                    failed = True
                results[platform] = first
            cells = []
            for platform in platforms:
                same = results[platform] == results[REFERENCE]
                if not same:
                    failed = True
                    k = next(i for i, (a, b) in enumerate(zip(results[platform], results[REFERENCE]))
                             if a != b)
                    print(f"{name} on {platform}: sample {k}: {results[platform][k]}"
                          f" against {results[REFERENCE][k]} on {REFERENCE}", file=sys.stderr)
                cells.append("same bits, replay same" if same else "DIFFERS")
            print(f"| {kind} | {version}.0 | {len(rows)} | {len(outs)} | {' | '.join(cells)} |")
            sys.stdout.flush()
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
