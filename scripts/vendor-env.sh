#!/usr/bin/env bash
# A Python environment with the vendors' own client libraries (ROBOTIS DynamixelSDK, SDU's
# ur_rtde, pyserial) for tests/vendor_clients.rs. Idempotent: does nothing when the
# environment already holds exactly scripts/vendor-requirements.txt. Prints the python path.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
venv="$root/target/vendor-venv"
req="$root/scripts/vendor-requirements.txt"
stamp="$venv/.requirements"
if [[ ! -x "$venv/bin/python" ]] || ! cmp -s "$req" "$stamp"; then
    rm -rf "$venv"
    python3 -m venv "$venv" >&2
    "$venv/bin/pip" install --quiet --disable-pip-version-check -r "$req" >&2
    cp "$req" "$stamp"
fi
echo "$venv/bin/python"
