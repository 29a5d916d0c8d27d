#!/usr/bin/env bash
# The outside-the-paper row "James, Pestell & Lepora (2018)" (docs/outside.toml): the slip
# rail run again at 100 fps, the frame rate of the larger TacTip that caught the rail
# object after 16 mm in that study, with everything else this simulator's T-MO fingertip.
# For each replicate of a finished paper-preset reproduction it takes the replicate's own
# rail protocols (seeds, counts), adds `[sim] "tactip.frame_rate_hz" = 100`, collects,
# trains an SVM with the replicate's 60 fps model's settings (the same slip window in
# seconds, its down-sampling, C and gamma: not searched again) and runs the rail catch.
#
#   scripts/outside-rail-100fps.sh REPRODUCTION_DIR OUT_DIR [TMO]
#
# Writes OUT_DIR/replicate-NN/{train,test,model.json,online} and OUT_DIR/summary.txt
# (mean catch distance per strategy over the replicates' caught trials).
set -euo pipefail
repro=${1:?reproduction directory}
out=${2:?output directory}
tmo=${3:-tmo}
mkdir -p "$out"
for rep in "$repro"/replicate-*; do
  name=$(basename "$rep")
  dir="$out/$name"
  mkdir -p "$dir"
  for part in train test; do
    { cat "$rep/01_rail_collect/$part/protocol.toml"; printf '\n[sim]\n"tactip.frame_rate_hz" = 100.0\n'; } \
      > "$dir/collect-$part.toml"
    "$tmo" -q run "$dir/collect-$part.toml" --out "$dir/$part"
  done
  read -r ds c gamma n_slip rate < <(python3 - "$rep/03_rail_model/rail.json" <<'PY'
import json, sys
m = json.load(open(sys.argv[1]))
h = m["hyperparameters"]
print(m["downsample"], h["c"], h["gamma"], m["labels"]["n_slip"], m["features"]["frame_rate_hz"])
PY
)
  window_s=$(python3 -c "print($n_slip / $rate)")
  "$tmo" -q train "$dir/train" --classifier svm-rbf --n-slip-s "$window_s" \
    --downsample "$ds" --C "$c" --gamma "$gamma" --out "$dir/model.json"
  sed -e 's#^models = .*#models = ["model.json"]#' "$rep/04_rail_online/protocol.toml" > "$dir/online.toml"
  printf '\n[sim]\n"tactip.frame_rate_hz" = 100.0\n' >> "$dir/online.toml"
  "$tmo" -q run "$dir/online.toml" --out "$dir/online"
done
python3 - "$out" <<'PY' | tee "$out/summary.txt"
import csv, glob, math, statistics, sys
rows = []
for f in sorted(glob.glob(f"{sys.argv[1]}/replicate-*/online/outcomes.csv")):
    rows += list(csv.DictReader(open(f)))
for strategy in sorted({r["strategy"] for r in rows}):
    d = [float(r["slip_distance_mm"]) for r in rows
         if r["strategy"] == strategy and r["verdict"] == "true_positive" and r["slip_distance_mm"]]
    n = len([r for r in rows if r["strategy"] == strategy])
    m = statistics.mean(d)
    half = 1.96 * statistics.stdev(d) / math.sqrt(len(d))
    print(f"{strategy}: catch distance {m:.1f} mm [{m - half:.1f}, {m + half:.1f}] over {len(d)} caught of {n} trials")
PY
