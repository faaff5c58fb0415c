#!/usr/bin/env bash
# The programs of the platform check, built for each platform into DIR:
# the FMU host (fmu_host, fmu_host.exe, fmu_host-aarch64) against the FMI
# headers that FMPy ships (the standard's own, not mfcbeam's), and a wine
# prefix of its own in DIR/wine with the stand-in bcryptprimitives.dll that
# wine 8.0 lacks.
#
#   verification/platforms/build.sh DIR
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
out="$1"
mkdir -p "$out"
headers="$(python3 -c 'import fmpy, os; print(os.path.join(os.path.dirname(fmpy.__file__), "c-code"))')"
flags=(-std=c99 -O2 -Wall -Wextra -Werror -I "$headers")
gcc "${flags[@]}" -o "$out/fmu_host" "$here/fmu_host.c" -ldl
aarch64-linux-gnu-gcc "${flags[@]}" -o "$out/fmu_host-aarch64" "$here/fmu_host.c" -ldl
x86_64-w64-mingw32-gcc "${flags[@]}" -o "$out/fmu_host.exe" "$here/fmu_host.c"
x86_64-w64-mingw32-gcc -O2 -Wall -Wextra -Werror -shared -o "$out/bcryptprimitives.dll" \
  "$here/bcryptprimitives.c" -ladvapi32
export WINEPREFIX="$(realpath "$out")/wine" WINEDEBUG=-all WINEDLLOVERRIDES="mscoree,mshtml="
wine="$(command -v wine64 || command -v wine || echo /usr/lib/wine/wine64)"
if [ ! -d "$WINEPREFIX/drive_c/windows/system32" ]; then
  "$wine" wineboot --init >"$out/wineboot.log" 2>&1
  # until its server has written the new prefix out and exited: a server
  # killed now leaves a prefix that hangs the next client
  "$(command -v wineserver || echo /usr/lib/wine/wineserver)" -w
fi
cp "$out/bcryptprimitives.dll" "$WINEPREFIX/drive_c/windows/system32/"
