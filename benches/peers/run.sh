#!/usr/bin/env bash
# The compensator step against its peers, in one run on this machine: the
# hand-written C (compensator.c, -O3 -march=native -ffast-math; built with
# -DBRANCH_FREE: no target test, no forward plays, no re-seat; and built
# with -DSTRONG, the strongest: AVX2 intrinsics with FMA, a running creep
# sum, the dependency chain cut to its minimum; the same with -DNO_FMA; the
# same in single precision with -DSTRONG_F32; the same called once per
# sample, not inlined into the timing loop, with -DONE_CALL; and with -DSAME_ORDER,
# mfcbeam's own order of operations in intrinsics), the
# hand-written C bank (bank.c, AVX-512F: checked here, timed by bank_limit
# with MFCBEAM_C_BANK), mfcbeam's own C library (capi/, timed as C calls
# it: a heap handle, and storage the caller owns in f64 and f32), numba
# (numba_compensator.py, if numba is installed) and this crate's criterion
# benches (step/compensator_step: the heap compensator, and the fixed f64
# and f32 cores), and on a CPU with AVX-512F the step's chain alone
# (chain.c). Checks first that the peers compute what mfcbeam does.
#
#   benches/peers/run.sh            # three processes of interleaved rounds,
#                                   # then criterion (--measurement-time 3)
#   benches/peers/run.sh --check    # only the agreement checks (CI)
#   PEER_MARCH=znver3 benches/peers/run.sh
#                                   # the C built for another instruction
#                                   # set than this CPU's (default: native)
#
# The agreement checks run the peers' own traces (4096 steps from the
# virgin state) through `mfcbeam compensate`: the voltages must agree to
# 1e-9 V (measured: about 6e-13 V; -ffast-math only reassociates sums),
# and mfcbeam's order in C exactly.
set -euo pipefail
cd "$(dirname "$0")/../.."
out=target/peers
mkdir -p "$out"
march=${PEER_MARCH:-native}

cc -O3 -march="$march" -ffast-math -Wall -Wextra -Werror -o "$out/compensator" \
  benches/peers/compensator.c -lm
cc -O3 -march="$march" -ffast-math -Wall -Wextra -Werror -DBRANCH_FREE \
  -o "$out/compensator_branch_free" benches/peers/compensator.c -lm
# the strongest: its trees as written (no -ffast-math, no contraction)
strong_flags=(-O3 -march="$march" -ffp-contract=off -Wall -Wextra -Werror -DSTRONG)
# and the same without FMA, in f32, and mfcbeam's order of operations in
# intrinsics
no_fma_flags=("${strong_flags[@]}" -DNO_FMA)
f32_flags=(-O3 -march="$march" -ffp-contract=off -Wall -Wextra -Werror -DSTRONG_F32)
same_flags=(-O3 -march="$march" -ffp-contract=off -Wall -Wextra -Werror -DSAME_ORDER)
# the C bank includes compensator.c for its model and leaves its steps unused
bank_flags=(-O3 -march="$march" -ffp-contract=off -Wall -Wextra -Werror -Wno-unused-function)
strong=no
if grep -qw avx2 /proc/cpuinfo && grep -qw fma /proc/cpuinfo &&
  cc "${strong_flags[@]}" -o "$out/compensator_strong" benches/peers/compensator.c -lm; then
  cc "${no_fma_flags[@]}" -o "$out/compensator_strong_no_fma" benches/peers/compensator.c -lm
  cc "${f32_flags[@]}" -o "$out/compensator_strong_f32" benches/peers/compensator.c -lm
  cc "${same_flags[@]}" -o "$out/compensator_same_order" benches/peers/compensator.c -lm
  strong=yes
else
  echo "this CPU has no AVX2 + FMA: the strongest C peer is skipped"
fi
# the step's dependency chain alone, in assembly (chain.c), and the
# latencies it is made of (latencies.c): built here so that they keep
# compiling; the chain runs after the rounds where the CPU has AVX-512F
cc -O2 -march="$march" -Wall -Wextra -Werror -o "$out/chain" benches/peers/chain.c
cc -O2 -march="$march" -Wall -Wextra -Werror -o "$out/latencies" benches/peers/latencies.c
# MFCBEAM_CLI: a built program to check against (CI passes the debug one)
if [[ -z "${MFCBEAM_CLI:-}" ]]; then
  cargo build --quiet --release --bin mfcbeam
  MFCBEAM_CLI=./target/release/mfcbeam
fi
"$MFCBEAM_CLI" nominal --output "$out/nominal.json"

# The C peer's targets through mfcbeam: the same voltages up to rounding
# (both are W⁻¹ of the same model; -ffast-math reassociates the sums).
"$out/compensator" trace >"$out/c_trace.csv"
"$MFCBEAM_CLI" compensate --model "$out/nominal.json" \
  --input "$out/c_trace.csv" --output "$out/c_vs_mfcbeam.csv"
# agree FILE NAME [exact|f32]: within 1e-9 V, or (exact) the same numbers,
# or (f32, a peer computing in single precision) within 1e-9 V scaled by
# the ratio of the two unit roundoffs, 2^29, as `mfcbeam conform
# --tolerance-scale` scales its tolerances for f32 candidates: 0.54 V. The
# derived first-order bound for these 4096 samples (the f32 and f64
# `RoundingBounds::compensator_over`, |u| <= 600 V, |y_d| <= 429 V) is
# 3.07 V: the scaled tolerance is the stricter of the two.
agree() {
  python3 - "$1" "$2" "${3:-close}" <<'EOF'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
worst = max(abs(float(r["u_peer"]) - float(r["u"])) for r in rows)
print(f"{sys.argv[2]}: max |u_peer - u_mfcbeam| = {worst:.2e} V over {len(rows)} samples")
if sys.argv[3] == "exact":
    sys.exit(0 if worst == 0.0 else 1)
sys.exit(0 if worst < (1e-9 * 2**29 if sys.argv[3] == "f32" else 1e-9) else 1)
EOF
}
agree "$out/c_vs_mfcbeam.csv" "C peer"
"$out/compensator_branch_free" trace >"$out/cbf_trace.csv"
"$MFCBEAM_CLI" compensate --model "$out/nominal.json" \
  --input "$out/cbf_trace.csv" --output "$out/cbf_vs_mfcbeam.csv"
agree "$out/cbf_vs_mfcbeam.csv" "branch-free C peer"
if [[ $strong == yes ]]; then
  "$out/compensator_strong" trace >"$out/cs_trace.csv"
  "$MFCBEAM_CLI" compensate --model "$out/nominal.json" \
    --input "$out/cs_trace.csv" --output "$out/cs_vs_mfcbeam.csv"
  agree "$out/cs_vs_mfcbeam.csv" "strongest C peer"
  "$out/compensator_strong_no_fma" trace >"$out/csn_trace.csv"
  "$MFCBEAM_CLI" compensate --model "$out/nominal.json" \
    --input "$out/csn_trace.csv" --output "$out/csn_vs_mfcbeam.csv"
  agree "$out/csn_vs_mfcbeam.csv" "strongest C peer without FMA"
  "$out/compensator_strong_f32" trace >"$out/cs32_trace.csv"
  "$MFCBEAM_CLI" compensate --model "$out/nominal.json" \
    --input "$out/cs32_trace.csv" --output "$out/cs32_vs_mfcbeam.csv"
  agree "$out/cs32_vs_mfcbeam.csv" "strongest C peer in f32" f32
  # mfcbeam's order in C: not close but equal, every sample
  "$out/compensator_same_order" trace >"$out/cso_trace.csv"
  "$MFCBEAM_CLI" compensate --model "$out/nominal.json" \
    --input "$out/cso_trace.csv" --output "$out/cso_vs_mfcbeam.csv"
  agree "$out/cso_vs_mfcbeam.csv" "mfcbeam's order in C" exact
fi
# The hand-written C bank (bank.c, AVX-512F): lane 3 of a bank of eight
# channels against mfcbeam, equal every sample.
bank=no
# grep reads all of cc's output: with -q it would stop at the match and, under
# pipefail, cc's SIGPIPE would fail the test at random
if grep -qw avx512f /proc/cpuinfo &&
  cc -march="$march" -dM -E - </dev/null | grep -w __AVX512F__ >/dev/null; then
  cc "${bank_flags[@]}" -o "$out/bank" benches/peers/bank.c -lm
  bank=yes
  "$out/bank" trace >"$out/bank_trace.csv"
  "$MFCBEAM_CLI" compensate --model "$out/nominal.json" \
    --input "$out/bank_trace.csv" --output "$out/bank_vs_mfcbeam.csv"
  agree "$out/bank_vs_mfcbeam.csv" "C bank, lane 3 of 8" exact
else
  echo "this CPU (or -march=$march) has no AVX-512F: the C bank is skipped"
fi
numba=no
if python3 -c "import numba" 2>/dev/null; then
  numba=yes
  python3 benches/peers/numba_compensator.py trace >"$out/numba_trace.csv"
  "$MFCBEAM_CLI" compensate --model "$out/nominal.json" \
    --input "$out/numba_trace.csv" --output "$out/numba_vs_mfcbeam.csv"
  agree "$out/numba_vs_mfcbeam.csv" "numba peer"
else
  echo "numba not installed: its peer is skipped (pip install numba)"
fi
[[ "${1:-}" == "--check" ]] && exit 0

# Interleaved batches of the C libraries and mfcbeam in one process (the
# ratios), three processes; then numba, then criterion's medians.
[[ $strong == yes ]] || { echo "the interleaved comparison needs the strongest peer"; exit 1; }
cc -O3 -march="$march" -ffast-math -Wall -Wextra -Werror -DPEER_LIB -shared -fPIC \
  -o "$out/libpeer.so" benches/peers/compensator.c -lm
cc -O3 -march="$march" -ffast-math -Wall -Wextra -Werror -DPEER_LIB -DBRANCH_FREE -shared -fPIC \
  -o "$out/libpeer_branch_free.so" benches/peers/compensator.c -lm
cc "${strong_flags[@]}" -DPEER_LIB -shared -fPIC \
  -o "$out/libpeer_strong.so" benches/peers/compensator.c -lm
cc "${no_fma_flags[@]}" -DPEER_LIB -shared -fPIC \
  -o "$out/libpeer_strong_no_fma.so" benches/peers/compensator.c -lm
cc "${same_flags[@]}" -DPEER_LIB -shared -fPIC \
  -o "$out/libpeer_same_order.so" benches/peers/compensator.c -lm
cc "${f32_flags[@]}" -DPEER_LIB -shared -fPIC \
  -o "$out/libpeer_strong_f32.so" benches/peers/compensator.c -lm
cc "${strong_flags[@]}" -DONE_CALL -DPEER_LIB -shared -fPIC \
  -o "$out/libpeer_strong_call.so" benches/peers/compensator.c -lm
# for bank_limit: MFCBEAM_C_BANK=$PWD/target/peers/libbank.so cargo bench --features internals --bench bank_limit
if [[ $bank == yes ]]; then
  cc "${bank_flags[@]}" -DPEER_LIB -shared -fPIC \
    -o "$out/libbank.so" benches/peers/bank.c -lm
fi
echo "the C peers built with -march=$march"
# mfcbeam's own C library, timed as a C program calls it
cargo build --quiet --release -p mfcbeam-capi
for run in 1 2 3; do
  echo "== process $run of 3"
  MFCBEAM_C_PEER="$PWD/$out/libpeer.so" MFCBEAM_C_PEER_BRANCH_FREE="$PWD/$out/libpeer_branch_free.so" \
    MFCBEAM_C_PEER_STRONG="$PWD/$out/libpeer_strong.so" \
    MFCBEAM_C_PEER_STRONG_NO_FMA="$PWD/$out/libpeer_strong_no_fma.so" \
    MFCBEAM_C_PEER_SAME_ORDER="$PWD/$out/libpeer_same_order.so" \
    MFCBEAM_C_PEER_STRONG_F32="$PWD/$out/libpeer_strong_f32.so" \
    MFCBEAM_C_PEER_STRONG_CALL="$PWD/$out/libpeer_strong_call.so" \
    MFCBEAM_C_API="$PWD/target/release/libmfcbeam.so" \
    cargo bench --quiet --features internals --bench peers | tee "$out/peers_$run.txt"
done
python3 - "$out"/peers_{1,2,3}.txt <<'EOF'
import sys
names = ["C peer", "branch-free C peer", "strongest C peer", "strongest C peer without FMA",
         "mfcbeam's order in C", "strongest C peer in f32", "strongest C, one call per step",
         "Compensator (heap, f64)", "Compensator<f64, nominal::Capacity>",
         "Compensator<f32, nominal::Capacity>", "the same f64, a run", "the same f32, a run",
         "C API f64, one call per sample", "C API f64, a run",
         "caller-owned f64, one call per sample", "caller-owned f64, a run",
         "caller-owned f32, one call per sample", "caller-owned f32, a run"]
ratios = ["call/c_call", "run_f32/f64", "f32/f64", "c_f32/f64", "api_call/c_call", "api_run/c_loop",
          "owned_call/c_call", "owned_run/c_loop", "owned_run_f32/c_f32_loop"]
runs = []
for path in sys.argv[1:]:
    line = next(l for l in open(path) if l.startswith("summary:"))
    fields = line.split()[1:]
    rows = [tuple(map(float, f.split("/"))) for f in fields[:-len(ratios)]]
    named = dict(f.split("=") for f in fields[-len(ratios):])
    assert len(rows) == len(names) and list(named) == ratios, line
    runs.append((rows, [float(named[r]) for r in ratios]))
print("over three processes (each process's median; spread = (max - min) / min):")
print(f"{'implementation':<40} {'ns':>24} {'/ strongest':>24} {'spread':>7}")
for i, name in enumerate(names):
    ns = [r[0][i][0] for r in runs]
    ratio = [r[0][i][1] for r in runs]
    spread = (max(ratio) - min(ratio)) / min(ratio)
    print(f"{name:<40} {' '.join(f'{x:7.2f}' for x in ns):>24} "
          f"{' '.join(f'{x:7.3f}' for x in ratio):>24} {100 * spread:6.1f}%")
for i, name in enumerate(["one call per sample, mfcbeam f64 / the strongest C's",
                          "a run, mfcbeam f32 / f64", "one call per sample, mfcbeam f32 / f64",
                          "the strongest C's loop, f32 / f64",
                          "the C API, one call per sample / the strongest C's",
                          "the C API, a run / the strongest C's loop",
                          "caller-owned storage, one call per sample / the strongest C's",
                          "caller-owned storage, a run / the strongest C's loop",
                          "caller-owned storage, a run in f32 / the strongest C's f32 loop"]):
    print(f"{name}: {' '.join(f'{r[1][i]:.3f}' for r in runs)}")
EOF
if grep -qw avx512f /proc/cpuinfo; then
  echo "the step's chain alone (benches/peers/chain.c):"
  "$out/chain"
fi
c_ns=$("$out/compensator" time)
nb_ns=$([[ $numba == yes ]] && python3 benches/peers/numba_compensator.py time || echo nan)
cargo bench --quiet --features internals --bench operators -- 'step/compensator_step$' \
  --warm-up-time 1 --measurement-time 3 >/dev/null
median() {
  python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['median']['point_estimate'])" \
    "target/criterion/$1/new/estimates.json"
}
python3 - "$c_ns" "$nb_ns" "$(median step/compensator_step)" <<'EOF'
import sys
c, nb, heap = map(float, sys.argv[1:])
cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), "?")
print(f"CPU: {cpu}")
print("separate processes, one after another (the machine may change between them):")
print(f"  C peer alone (median of batches)            {c:8.1f} ns")
print(f"  numba @njit (median of batches)             {nb:8.1f} ns   numba / mfcbeam = {nb / heap:.2f}")
print(f"  criterion step/compensator_step (median)    {heap:8.1f} ns   / C = {heap / c:.2f}")
EOF
