#!/usr/bin/env bash
# Build the independent C FMU: build.sh compensator|model OUT.fmu [FAULT]
# FAULT: creep-current, half-thresholds or no-saturation (a convention
# error on purpose). Needs cc and python3 (for the zip).
set -euo pipefail
kind=$1 out=$2 fault=${3:-}
here=$(cd "$(dirname "$0")" && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
id=nominal_$kind
guid="{6e6f6d69-6e61-6c2d-$(printf %s "$kind$fault" | md5sum | cut -c1-4)-$(printf %s "$kind$fault" | md5sum | cut -c5-16)}"
defines=(-DKIND_$(tr a-z A-Z <<<"$kind") "-DGUID=\"$guid\"")
case $fault in
  "") ;;
  creep-current) defines+=(-DFAULT_CREEP_CURRENT) ;;
  half-thresholds) defines+=(-DFAULT_HALF_THRESHOLDS) ;;
  no-saturation) defines+=(-DFAULT_NO_SATURATION) ;;
  *) echo "build.sh: unknown fault '$fault'" >&2; exit 2 ;;
esac
mkdir -p "$tmp/binaries/linux64"
cc -std=c99 -D_DEFAULT_SOURCE -shared -fPIC -O2 -Wall -Wextra -Werror -fvisibility=hidden \
  "${defines[@]}" -o "$tmp/binaries/linux64/$id.so" "$here/nominal_fmu.c" -lm
if [ "$kind" = compensator ]; then
  vars='
    <ScalarVariable name="target" valueReference="0" causality="input" variability="discrete"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="voltage" valueReference="1" causality="output" variability="discrete" initial="exact"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="clipped" valueReference="2" causality="output" variability="discrete" initial="exact"><Boolean start="false"/></ScalarVariable>
    <ScalarVariable name="bad_input" valueReference="3" causality="output" variability="discrete" initial="exact"><Boolean start="false"/></ScalarVariable>
    <ScalarVariable name="v_min" valueReference="4" causality="parameter" variability="fixed" initial="exact"><Real start="-1000"/></ScalarVariable>
    <ScalarVariable name="v_max" valueReference="5" causality="parameter" variability="fixed" initial="exact"><Real start="1000"/></ScalarVariable>'
  outputs='<Unknown index="2" dependencies=""/><Unknown index="3" dependencies=""/><Unknown index="4" dependencies=""/>'
else
  vars='
    <ScalarVariable name="voltage" valueReference="0" causality="input" variability="discrete"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="effective_voltage" valueReference="1" causality="output" variability="discrete" initial="exact"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="bad_input" valueReference="3" causality="output" variability="discrete" initial="exact"><Boolean start="false"/></ScalarVariable>'
  outputs='<Unknown index="2" dependencies=""/><Unknown index="3" dependencies=""/>'
fi
cat >"$tmp/modelDescription.xml" <<XML
<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="$id" guid="$guid" generationTool="hand-written C" variableNamingConvention="flat" numberOfEventIndicators="0">
  <CoSimulation modelIdentifier="$id" canHandleVariableCommunicationStepSize="true" canGetAndSetFMUstate="true"/>
  <DefaultExperiment startTime="0" stepSize="0.0002"/>
  <ModelVariables>$vars
  </ModelVariables>
  <ModelStructure><Outputs>$outputs</Outputs></ModelStructure>
</fmiModelDescription>
XML
python3 - "$tmp" "$out" <<'PY'
import os, sys, zipfile
src, out = sys.argv[1], os.path.abspath(sys.argv[2])
with zipfile.ZipFile(out + ".tmp", "w", zipfile.ZIP_DEFLATED) as z:
    for d, _, files in os.walk(src):
        for f in files:
            p = os.path.join(d, f)
            z.write(p, os.path.relpath(p, src))
os.replace(out + ".tmp", out)
PY
