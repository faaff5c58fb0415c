#!/usr/bin/env bash
# The release artifacts, from a clean clone, into DIR (default target/dist):
#
#   mfcbeam-capi-VERSION-x86_64-linux.tar.gz    include/mfcbeam.h, lib/libmfcbeam.so, lib/libmfcbeam.a
#   mfcbeam-capi-VERSION-aarch64-linux.tar.gz   the same for 64-bit ARM Linux
#   mfcbeam-capi-VERSION-x86_64-windows.zip     include/mfcbeam.h, bin/mfcbeam.dll,
#                                               lib/libmfcbeam.dll.a (import library), lib/libmfcbeam.a
#   mfcbeam-KIND-fmi2.fmu, mfcbeam-KIND-fmi3.fmu the compensator, model and plant of the
#                                               nominal models and the PID and LQ controllers,
#                                               each with the three platforms' libraries
#   mfcbeam-VERSION-*.whl                       the Python package for this machine
#   SHA256SUMS                                  sha256sum -c SHA256SUMS checks them
#
# Every archive holds the licences. The toolchains: rustup's targets
# x86_64-pc-windows-gnu and aarch64-unknown-linux-gnu, Debian's
# gcc-mingw-w64-x86-64 and gcc-aarch64-linux-gnu (docs/guide/deploy.md);
# a missing one is named before anything is built.
#
#   scripts/release.sh [DIR]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
dist="$(realpath -m "${1:-target/dist}")"
version="$(sed -n 's/^version = "\(.*\)"/\1/p' Cargo.toml | head -n 1)"
cross=(x86_64-pc-windows-gnu aarch64-unknown-linux-gnu)

missing=()
for t in "${cross[@]}"; do
  rustup target list --installed 2>/dev/null | grep -qx "$t" || missing+=("rustup target add $t")
done
command -v x86_64-w64-mingw32-gcc >/dev/null || missing+=("apt-get install gcc-mingw-w64-x86-64")
command -v aarch64-linux-gnu-gcc >/dev/null || missing+=("apt-get install gcc-aarch64-linux-gnu")
if [ ${#missing[@]} -gt 0 ]; then
  echo "release.sh: missing toolchains; install them with: $(IFS=';'; echo "${missing[*]}")" >&2
  exit 2
fi

# the program, and the C and FMU libraries of each platform
cargo build --release -p mfcbeam -p mfcbeam-capi -p mfcbeam-fmu
cargo build --release -p mfcbeam-capi -p mfcbeam-fmu "${cross[@]/#/--target=}"

rm -rf "$dist"
mkdir -p "$dist"
stage="$(mktemp -d)"
trap 'rm -rf "$stage"' EXIT

# the C library: header, libraries, licences
capi() { # PLATFORM RELEASE-FOLDER FILES...
  local platform=$1 from=$2
  shift 2
  local name="mfcbeam-capi-$version-$platform" dir
  dir="$stage/$name"
  mkdir -p "$dir/include" "$dir/lib"
  cp include/mfcbeam.h "$dir/include/"
  cp LICENSE-MIT LICENSE-APACHE "$dir/"
  for f in "$@"; do
    case "$f" in
      *.dll) mkdir -p "$dir/bin" && cp "$from/$f" "$dir/bin/" ;;
      *) cp "$from/$f" "$dir/lib/" ;;
    esac
  done
  if [ "$platform" = x86_64-windows ]; then
    (cd "$stage" && python3 -m zipfile -c "$dist/$name.zip" "$name")
  else
    tar -C "$stage" --sort=name --owner=0 --group=0 --numeric-owner -czf "$dist/$name.tar.gz" "$name"
  fi
}
capi x86_64-linux target/release libmfcbeam.so libmfcbeam.a
capi aarch64-linux target/aarch64-unknown-linux-gnu/release libmfcbeam.so libmfcbeam.a
capi x86_64-windows target/x86_64-pc-windows-gnu/release mfcbeam.dll libmfcbeam.dll.a libmfcbeam.a

# the FMUs, each with the three platforms' libraries
all=x86_64-linux,x86_64-windows,aarch64-linux
fmu() { # NAME ARGS...
  local name=$1
  shift
  for v in 2 3; do
    target/release/mfcbeam fmu "$@" --fmi "$v" --platforms "$all" --output "$dist/mfcbeam-$name-fmi$v.fmu"
  done
}
fmu compensator --kind compensator --model golden/nominal_model.json
fmu model --kind model --model golden/nominal_model.json
fmu plant --kind plant --model golden/nominal_model.json --beam golden/nominal_beam.json
fmu pid --kind controller --controller pid
fmu lq --kind controller --controller lq

# the Python package (maturin builds it in this target folder)
python3 -m pip wheel ./python --no-deps --quiet --disable-pip-version-check -w "$dist"

(cd "$dist" && sha256sum -- * >SHA256SUMS)
echo "release.sh: $(find "$dist" -type f | wc -l) files in $dist"
cat "$dist/SHA256SUMS"
