#!/usr/bin/env bash
# No masked stores in the bank's AVX2 kernels of BINARY (the kernel-choice
# bench, which steps a bank on every kernel set). AMD's cores run
# `vmaskmovpd`/`vmaskmovps` to memory as microcode, which held the AVX2
# bank up by 3-9 % on a Zen 4; the compiler makes one of a select of a
# row's own lanes stored back to the row, which `store_except` hides from
# it. Masked loads (a bank's partial last block) are native and allowed.
# Exit 1, listing them, if any store is found; 2 if no AVX2 bank kernel is.
set -euo pipefail
binary=$1
kernels=$(objdump -d --no-show-raw-insn -C "$binary" |
  awk '/^[0-9a-f]+ <.*run_blocks::avx2.*>:$/ { inside = 1; print; next }
       /^$/ { inside = 0 }
       inside')
count=$(grep -c '^[0-9a-f]* <' <<<"$kernels" || true)
if [ "$count" -eq 0 ]; then
  echo "no AVX2 bank kernel (run_blocks::avx2) in $binary" >&2
  exit 2
fi
# AT&T order: a store is `vmaskmovpd %ymm(data),%ymm(mask),(address)`
stores=$(grep -E 'vmaskmovp[sd] +%ymm[0-9]+,%ymm[0-9]+,[^%]*\(' <<<"$kernels" || true)
loads=$(grep -cE 'vmaskmovp[sd] +[^%]*\(' <<<"$kernels" || true)
if [ -n "$stores" ]; then
  echo "masked stores in the bank's AVX2 kernels of $binary:" >&2
  echo "$stores" >&2
  exit 1
fi
echo "the bank's AVX2 kernels ($count functions): no masked store ($loads masked loads)"
