#!/usr/bin/env bash
# The bank's portable step in an aarch64 build is NEON code: in BINARY (an
# aarch64 executable holding the bank's step, such as the bank's tests),
# every instance of the portable block work (`run_blocks::portable`, one
# per type and step form) does its floating-point arithmetic on vectors —
# `.2d` lanes for f64, `.4s` for f32 — for at least 90 % of its
# floating-point instructions, and both arrangements occur. Prints the
# counts; exit 1 otherwise.
#
#   verification/platforms/neon_bank.sh BINARY
set -euo pipefail
binary="$1"
objdump="$(command -v aarch64-linux-gnu-objdump || echo objdump)"
"$objdump" -d --no-show-raw-insn -C "$binary" | awk '
/^[0-9a-f]+ <.*>:$/ { inside = ($0 ~ /run_blocks::portable>:$/); if (inside) n++; next }
inside && $2 ~ /^f(add|sub|mul|mla|mls|min|max|minnm|maxnm|cmgt|cmge|cmeq|cmlt|abs|neg|div|sqrt)$/ {
  if ($3 ~ /^v[0-9]+\.2d/) { d[n]++ } else if ($3 ~ /^v[0-9]+\.4s/) { s[n]++ } else if ($3 ~ /^[ds][0-9]+/) { scalar[n]++ }
}
END {
  if (n == 0) { print "no run_blocks::portable in the binary" > "/dev/stderr"; exit 1 }
  bad = 0
  for (i = 1; i <= n; i++) {
    vec = d[i] + s[i]; all = vec + scalar[i]
    printf "bank step %d: %d vector floating-point instructions (%d on .2d, %d on .4s), %d scalar\n", i, vec, d[i], s[i], scalar[i]
    if (all == 0 || vec < 0.9 * all) bad = 1
    if (d[i] > s[i]) f64++; else f32++
  }
  if (!f64 || !f32) { print "not both an f64 (.2d) and an f32 (.4s) step" > "/dev/stderr"; bad = 1 }
  if (bad) { print "the bank'\''s portable step is not NEON code" > "/dev/stderr"; exit 1 }
}'
