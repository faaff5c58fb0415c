#!/usr/bin/env bash
# Coverage-guided fuzzing on the stable toolchain, offline: the targets are
# built with LLVM's sanitizer-coverage passes (stable `-C passes` and
# `-C llvm-args` flags, what cargo-fuzz passes minus its nightly-only
# sanitizers) and linked with libFuzzer (the libfuzzer-sys crate builds it
# from source with the C++ compiler). Each target first replays its seed
# corpus (fuzz/corpus/TARGET) and its past findings (fuzz/regressions/TARGET),
# then mutates for SECONDS, as many targets at once as there are cores.
# A single allocation over 100 MB, a resident set over 300 MB, an input
# that takes over 10 s, a panic or an abort is a finding: written to
# target/fuzz/artifacts/ and the run fails.
#
#   fuzz/run.sh [SECONDS [TARGET ...]]     (default: 60 s, every target)
set -euo pipefail
cd "$(dirname "$0")"
seconds=${1:-60}
shift || true
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  targets=(model_json model_fields beam_json trace_csv candidate_output capi controller_json library_header)
fi
host=$(rustc -vV | sed -n 's/^host: //p')
export CARGO_TARGET_DIR="$PWD/../target"
# This package's own code (the harness and the targets) is linted as it is
# built, by clippy's driver (what `cargo clippy` runs it through, here in a
# build rather than a check), and -D warnings makes a lint or a warning of
# it or of mfcbeam's a failed build: no second, uninstrumented compile of
# every dependency just to lint.
clippy_driver="$(rustc --print sysroot)/bin/clippy-driver"
if [ -x "$clippy_driver" ]; then
  export RUSTC_WORKSPACE_WRAPPER="$clippy_driver"
else
  echo "clippy-driver not found: the fuzz targets are built without clippy's lints" >&2
fi
# --target: the flags then apply to the targets, not to build scripts
RUSTFLAGS="-Cpasses=sancov-module -Cllvm-args=-sanitizer-coverage-level=4 \
-Cllvm-args=-sanitizer-coverage-inline-8bit-counters \
-Cllvm-args=-sanitizer-coverage-pc-table \
-Cllvm-args=-sanitizer-coverage-trace-compares --cfg fuzzing -Dwarnings" \
  cargo build --release --locked --target "$host"
work="$CARGO_TARGET_DIR/fuzz"
mkdir -p "$work/artifacts"
# one fuzzer per core at a time (each is single-threaded); the statuses
# and summaries are read in the targets' order once all have finished
fuzz_one() {
  local t=$1 status=0
  "$CARGO_TARGET_DIR/$host/release/$t" \
    -max_total_time="$seconds" -timeout=10 -malloc_limit_mb=100 -rss_limit_mb=300 \
    -max_len=65536 -print_final_stats=1 \
    -artifact_prefix="$work/artifacts/$t-" \
    "$work/corpus/$t" "corpus/$t" "regressions/$t" >"$work/$t.log" 2>&1 || status=$?
  echo "$status" >"$work/$t.status"
}
cores=$(nproc 2>/dev/null || echo 1)
for t in "${targets[@]}"; do
  mkdir -p "$work/corpus/$t" "regressions/$t"
  rm -f "$work/$t.status"
  while [ "$(jobs -rp | wc -l)" -ge "$cores" ]; do
    wait -n || true
  done
  echo "fuzz $t: $seconds s"
  fuzz_one "$t" &
done
wait
failed=0
for t in "${targets[@]}"; do
  echo "fuzz $t:"
  grep -E '^(Done|INFO: seed corpus|stat::number_of_executed_units|stat::peak_rss_mb|==[0-9]+==|SUMMARY)|panicked|out-of-memory|Test unit written' "$work/$t.log" || true
  status=$(cat "$work/$t.status" 2>/dev/null || echo "none")
  if [ "$status" != 0 ]; then
    echo "fuzz $t: finding (exit $status), see $work/artifacts/ and $work/$t.log" >&2
    failed=1
  fi
done
exit "$failed"
