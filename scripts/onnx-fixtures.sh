#!/usr/bin/env bash
# The ONNX fixtures of tmo's tests (tests/fixtures/onnx/), from the start: trials on the
# simulator, their rows exported by tmo, models trained by scikit-learn and written as
# ONNX, and onnxruntime's outputs on test rows. CI does not run this (the fixtures are
# committed); run it again after a change to the features or the simulator's trials:
#
#   cargo build --release && OUT=tests/fixtures/onnx bash scripts/onnx-fixtures.sh
#
# Without OUT it writes to a new scratch directory (and says where), so a run made to look
# never overwrites the committed fixtures.
# It installs its Python packages (scripts/onnx-requirements.txt) into a venv of its own,
# $ONNX_VENV (default: a directory under $TMPDIR), and works in a temporary directory.
set -euo pipefail
cd "$(dirname "$0")/.."
tmo=${TMO:-target/release/tmo}
venv=${ONNX_VENV:-${TMPDIR:-/tmp}/tmo-onnx-venv}
out=${OUT:-$(mktemp -d "${TMPDIR:-/tmp}/tmo-onnx-fixtures.XXXXXX")}
[ -x "$venv/bin/python" ] || python3 -m venv "$venv"
"$venv/bin/pip" install -q -r scripts/onnx-requirements.txt
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$tmo" -q sim collect --trials 10 --seed 5 --out "$work/train"
"$tmo" -q sim collect --trials 5 --seed 7 --out "$work/test"
"$tmo" -q dataset export "$work/train" --n-slip 13 --downsample 1 --out "$work/train.csv"
"$tmo" -q dataset export "$work/test" --n-slip 13 --downsample 1 --out "$work/test.csv"
# a model file of tmo's own on the same trials and labels: its features, labels and
# sensors are the ONNX models' metadata
"$tmo" -q train "$work/train" --classifier threshold --n-slip 13 --out "$work/spec.json" 2>/dev/null
mkdir -p "$out"
"$venv/bin/python" scripts/onnx_fixtures.py "$work/spec.json" "$work/train.csv" "$work/test.csv" "$out"
echo "wrote $out"
