#!/usr/bin/env bash
# wine on one program, for the checks that start hundreds of wine clients
# (c_api.sh's conformance runs). On a loaded host wine now and then fails
# to start a client: exit status 1 and nothing on stderr, which neither
# mfcbeam_run nor the C candidate ever gives (their errors are exit 2 and
# one line). Such a start is tried again, at most twice, and logged to
# $WINE_CLIENT_LOG, which c_api.sh reports; any other outcome, the same
# failure a third time included, is the program's and is passed on.
#
#   WINE=… WINE_CLIENT_LOG=… verification/platforms/wine_client.sh PROGRAM ARGS…
set -u
err="$(mktemp)"
trap 'rm -f "$err"' EXIT
for attempt in 1 2 3; do
  "$WINE" "$@" 2>"$err"
  status=$?
  if [ "$status" -ne 1 ] || [ -s "$err" ] || [ "$attempt" -eq 3 ]; then
    break
  fi
  echo "attempt $attempt of $1: exit status 1, no message" >>"$WINE_CLIENT_LOG"
done
cat "$err" >&2
exit "$status"
