#!/usr/bin/env python3
"""Write the fuzz targets' seed corpus (fuzz/corpus/TARGET/) from golden/ and
the shapes the tests use. Deterministic: run it again after golden/ changes;
libFuzzer's own finds go to target/fuzz/, not here."""
import json
import pathlib
import struct

root = pathlib.Path(__file__).resolve().parent.parent
corpus = root / "fuzz" / "corpus"
golden = root / "golden"


def put(target, name, data):
    d = corpus / target
    d.mkdir(parents=True, exist_ok=True)
    (d / name).write_bytes(data if isinstance(data, bytes) else data.encode())


def doubles(*xs):
    return b"".join(struct.pack("<d", x) for x in xs)


nominal = json.loads((golden / "nominal_model.json").read_text())
models = {"nominal": nominal}
m = dict(nominal)
m.pop("creep", None)
models["hysteresis-only"] = m
m = dict(nominal)
m["superposition"] = {"thresholds": [-500, -200, 0, 150, 400], "weights": [0.25, -0.25, 1, -0.2, -0.15]}
models["superposition"] = m
m = dict(nominal)
m["delay"] = 2
m["delay_state"] = [12.5, 13.1]
m["offset"] = 0.25
models["delay-offset"] = m
m = dict(nominal)
m["dynamics"] = {"low_pass": {"frequency": 1500.0}, "resonance": {"frequency": 600.0, "damping": 0.05},
                 "delay_fraction": 0.3, "state": [1.0, 2.0, 3.0, 4.0, 5.0]}
models["dynamics"] = m
m = dict(nominal)
n = len(m["hysteresis"]["thresholds"])
m["hysteresis"] = dict(m["hysteresis"], state=[10.0 * i for i in range(n)])
models["state"] = m
hostile_numbers = doubles(0.0, 100.0, float("nan"), -250.0, float("inf"), 5e-324, 1e300, -0.0)
for name, model in models.items():
    text = json.dumps(model)
    put("model_json", name + ".json", text)
    put("model_json", name + "-inputs", text.encode() + b"\0" + hostile_numbers)
    put("capi", name, text.encode() + b"\0" + hostile_numbers)

# model_fields: shape bits, field index, kind of value, then its bytes
for shape in range(16):
    for field, kind in [(0, 0), (3, 1), (7, 4), (11, 8), (17, 12), (23, 7)]:
        put("model_fields", f"s{shape}-f{field}-k{kind}", bytes([shape, field, kind, 5]) + doubles(3.5))

beam = (golden / "nominal_beam.json").read_text()
put("beam_json", "nominal.json", beam)
put("beam_json", "nominal-inputs", beam.encode() + b"\0" + doubles(1.0, -1.0, float("nan"), 100.0))

for csv in sorted(golden.glob("*.csv")):
    lines = csv.read_text().splitlines()[:40]
    put("trace_csv", csv.stem + ".csv", "\n".join(lines) + "\n")
rows = ["t,u,y"] + [f"{k * 2e-4!r},{v!r},{0.9 * v + 3.0!r}" for k, v in enumerate([0, 100, 300, 100, -200, -50, 0, 250, 100, 0])]
put("trace_csv", "record.csv", "\n".join(rows) + "\n")
put("trace_csv", "record-no-time.csv", "\n".join(r.split(",", 1)[1] for r in rows) + "\n")

put("candidate_output", "model.csv", "t,u,y\n" + "".join(f"{k * 2e-4!r},{k}.0,{k * 0.5}\n" for k in range(8)))
put("candidate_output", "compensator.csv", "t,y_d,u,saturated\n" + "".join(f"{k * 2e-4!r},{k}.0,{2 * k}.0,0\n" for k in range(8)))
put("candidate_output", "short.csv", "t,u,y\n0,0,0\n")

# controller files (the controller FMU's): the PID's gains as designed, a
# small state feedback, and inputs with a NaN and huge values
pid = {"sample_time": 2e-4, "pid": {"kp": 179703.92370092354, "ki": 9830276.72724188,
                                    "kd": 3971.609828392829, "tf": 0.011050426019085353}}
sf = {"sample_time": 2e-4, "state_feedback": {
    "modes": 1, "a": [0.99, 2e-4, 0.0, -0.5, 0.99, 1e-3, 0.0, 0.0, 1.0], "b": [0.0, 1e-3, 0.0],
    "c": [1.0, 0.0, 0.0], "observer": [0.5, 10.0, 100.0], "feedback": [1e4, 10.0, 1.0],
    "residuals": [0.0, 0.0], "disturbance_increment": 0.1}}
inputs = doubles(1e-3, 0.0, 1e-3, 2e-3, float("nan"), 1e-3, 1e-3, 1e300, 1e-3, 1e-3)
for name, c in [("pid", pid), ("state-feedback", sf)]:
    put("controller_json", f"{name}.json", json.dumps(c))
    put("controller_json", f"{name}-inputs", json.dumps(c).encode() + b"\0" + inputs)

# shared libraries' headers (what an FMU's binary is checked for before it
# is loaded): an x86-64 ELF with one loaded segment, an aarch64 one whose
# segment runs past its end, a PE with one section, a Mach-O header
elf = bytearray(176)
elf[:4], elf[4], elf[5], elf[18] = b"\x7fELF", 2, 1, 0x3E
struct.pack_into("<Q", elf, 0x20, 64)  # e_phoff
struct.pack_into("<HH", elf, 0x36, 56, 1)  # e_phentsize, e_phnum
struct.pack_into("<I", elf, 64, 1)  # PT_LOAD
struct.pack_into("<Q", elf, 96, 176)  # p_filesz
put("library_header", "elf-x86_64", bytes(elf))
elf[18] = 0xB7
struct.pack_into("<Q", elf, 96, 4096)
put("library_header", "elf-aarch64-cut", bytes(elf))
pe = bytearray(512)
pe[:2], pe[0x3C], pe[0x80:0x84] = b"MZ", 0x80, b"PE\0\0"
struct.pack_into("<HH", pe, 0x84, 0x8664, 1)  # machine, one section
struct.pack_into("<II", pe, 0x80 + 24 + 16, 256, 256)  # its raw data
put("library_header", "pe-x86_64", bytes(pe))
put("library_header", "macho-arm64", struct.pack("<II", 0xFEEDFACF, 0x0100000C) + bytes(24))
