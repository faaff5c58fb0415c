#!/usr/bin/env bash
# The C library on Windows x86-64 and Linux aarch64, used from C as on
# Linux x86-64 (capi/tests/c_example.rs, verification/conform.rs): built
# with each platform's C compiler against the cross-built library, then run
# under wine and qemu-user.
#   - examples/c/api_errors.c: malformed input, NULL and bad handles;
#   - examples/c/mfcbeam_run.c through `mfcbeam conform` as a model and a
#     compensator: in f64 linked statically, in f32 (at f32 tolerances)
#     against the shared library (the DLL with its import library);
#   - the independent C candidate (examples/conformance/c/candidate.c);
#   - examples/c/start_up.c: a compensator started from the memory
#     mfcbeam_estimate_state estimates.
#
#   verification/platforms/c_api.sh CLI WORK [CASES]
# WORK holds the wine prefix of verification/platforms/run.py.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
cli="$(realpath "$1")"
work="$(realpath "$2")"
cases="${3:-40}"
f32_scale=536870912 # eps32/eps64 = 2^29
export WINEPREFIX="$work/wine" WINEDEBUG=-all WINEDLLOVERRIDES="mscoree,mshtml="
export WINE="$(command -v wine64 || command -v wine || echo /usr/lib/wine/wine64)"
# wine's failed client starts, tried again by wine_client.sh
export WINE_CLIENT_LOG="$work/wine-client.log"
rm -f "$WINE_CLIENT_LOG"
flags=(-std=c99 -O2 -Wall -Wextra -Werror -I "$root/include")

conform() { # KIND EXEC [SCALE]
  local args=(conform --kind "$1" --exec "$2" --cases "$cases" --out "$work/c-api-conform")
  [ -n "${3:-}" ] && args+=(--tolerance-scale "$3")
  if ! "$cli" "${args[@]}" >"$work/c-api-conform.log" 2>&1; then
    cat "$work/c-api-conform.log" >&2
    echo "c_api.sh: $2 ($1) does not conform" >&2
    exit 1
  fi
  echo "$2 ($1${3:+, f32 tolerances}): $(tail -n 1 "$work/c-api-conform.log")"
}

for platform in x86_64-windows aarch64-linux; do
  out="$work/c-api/$platform"
  mkdir -p "$out"
  case "$platform" in
    x86_64-windows)
      lib="$root/target/x86_64-pc-windows-gnu/release"
      cc=x86_64-w64-mingw32-gcc
      static_libs=(-lws2_32 -luserenv -lntdll)
      exe=.exe
      run=("$root/verification/platforms/wine_client.sh")
      # the DLL beside the programs, where Windows looks first
      cp "$lib/mfcbeam.dll" "$out/"
      shared=("$lib/libmfcbeam.dll.a")
      ;;
    aarch64-linux)
      lib="$root/target/aarch64-unknown-linux-gnu/release"
      cc=aarch64-linux-gnu-gcc
      static_libs=(-lpthread -ldl -lm)
      exe=
      run=(qemu-aarch64 -L /usr/aarch64-linux-gnu -E "LD_LIBRARY_PATH=$lib")
      shared=(-L "$lib" -lmfcbeam -lm)
      ;;
  esac
  "$cc" "${flags[@]}" -D_POSIX_C_SOURCE=200809L -o "$out/mfcbeam_run$exe" \
    "$root/examples/c/mfcbeam_run.c" "$lib/libmfcbeam.a" "${static_libs[@]}"
  "$cc" "${flags[@]}" -D_POSIX_C_SOURCE=200809L -o "$out/mfcbeam_run_shared$exe" \
    "$root/examples/c/mfcbeam_run.c" "${shared[@]}"
  "$cc" "${flags[@]}" -D_POSIX_C_SOURCE=200809L -o "$out/api_errors$exe" \
    "$root/examples/c/api_errors.c" "$lib/libmfcbeam.a" "${static_libs[@]}"
  "$cc" -O2 -o "$out/candidate$exe" "$root/examples/conformance/c/candidate.c" -lm
  "$cc" "${flags[@]}" -o "$out/start_up$exe" "$root/examples/c/start_up.c" "$lib/libmfcbeam.a" \
    "${static_libs[@]}"

  report="$("${run[@]}" "$out/api_errors$exe" | tr -d '\r')"
  if ! grep -q "0 failed$" <<<"$report" || grep -q FAILED <<<"$report"; then
    echo "$report" >&2
    echo "c_api.sh: api_errors failed on $platform" >&2
    exit 1
  fi
  echo "$platform: api_errors: $(grep -c '^ok: ' <<<"$report") checks, $(tail -n 1 <<<"$report")"
  report="$("${run[@]}" "$out/start_up$exe" | tr -d '\r')"
  if [ "$(tail -n 1 <<<"$report")" != ok ]; then
    echo "$report" >&2
    echo "c_api.sh: start_up failed on $platform" >&2
    exit 1
  fi
  echo "$platform: start_up: $(head -n 1 <<<"$report")"
  for pair in model:simulate compensator:compensate; do
    kind="${pair%%:*}" command="${pair#*:}"
    conform "$kind" "${run[*]} $out/mfcbeam_run$exe $command"
    conform "$kind" "${run[*]} $out/mfcbeam_run_shared$exe $command --f32" "$f32_scale"
    conform "$kind" "${run[*]} $out/candidate$exe $command"
  done
done
if [ -s "$WINE_CLIENT_LOG" ]; then
  echo "wine failed to start a client $(wc -l <"$WINE_CLIENT_LOG") times; each was started again"
fi
