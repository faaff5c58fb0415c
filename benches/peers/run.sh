#!/usr/bin/env bash
# The compensator step against its peers, in one run on this machine: the
# hand-written C (compensator.c, -O3 -march=native -ffast-math; and built
# with -DBRANCH_FREE, the strongest peer: no target test, no forward plays,
# no re-seat), numba
# (numba_compensator.py, if numba is installed) and this crate's criterion
# benches (step/compensator_step: the heap compensator, and the fixed f64
# and f32 cores). Checks first that the peers compute what mfcbeam does.
#
#   benches/peers/run.sh            # criterion: --warm-up-time 1 --measurement-time 3
#   benches/peers/run.sh --check    # only the agreement checks (CI)
#
# The agreement checks run the peers' own traces (4096 steps from the
# virgin state) through `mfcbeam compensate`: the voltages must agree to
# 1e-9 V (measured: about 6e-13 V; -ffast-math only reassociates sums).
set -euo pipefail
cd "$(dirname "$0")/../.."
out=target/peers
mkdir -p "$out"

cc -O3 -march=native -ffast-math -Wall -Wextra -Werror -o "$out/compensator" \
  benches/peers/compensator.c -lm
cc -O3 -march=native -ffast-math -Wall -Wextra -Werror -DBRANCH_FREE \
  -o "$out/compensator_branch_free" benches/peers/compensator.c -lm
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
agree() {
  python3 - "$1" "$2" <<'EOF'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
worst = max(abs(float(r["u_peer"]) - float(r["u"])) for r in rows)
print(f"{sys.argv[2]}: max |u_peer - u_mfcbeam| = {worst:.2e} V over {len(rows)} samples")
sys.exit(0 if worst < 1e-9 else 1)
EOF
}
agree "$out/c_vs_mfcbeam.csv" "C peer"
"$out/compensator_branch_free" trace >"$out/cbf_trace.csv"
"$MFCBEAM_CLI" compensate --model "$out/nominal.json" \
  --input "$out/cbf_trace.csv" --output "$out/cbf_vs_mfcbeam.csv"
agree "$out/cbf_vs_mfcbeam.csv" "branch-free C peer"
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

# Interleaved batches of the C library and mfcbeam in one process (the
# ratios), then numba, then criterion's medians.
cc -O3 -march=native -ffast-math -Wall -Wextra -Werror -DPEER_LIB -shared -fPIC \
  -o "$out/libpeer.so" benches/peers/compensator.c -lm
cc -O3 -march=native -ffast-math -Wall -Wextra -Werror -DPEER_LIB -DBRANCH_FREE -shared -fPIC \
  -o "$out/libpeer_branch_free.so" benches/peers/compensator.c -lm
MFCBEAM_C_PEER="$PWD/$out/libpeer.so" MFCBEAM_C_PEER_BRANCH_FREE="$PWD/$out/libpeer_branch_free.so" \
  cargo bench --quiet --bench peers
c_ns=$("$out/compensator" time)
nb_ns=$([[ $numba == yes ]] && python3 benches/peers/numba_compensator.py time || echo nan)
cargo bench --quiet --bench operators -- 'step/compensator_step$' \
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
