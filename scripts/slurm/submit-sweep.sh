#!/usr/bin/env bash
# Spreads a `tmo sweep` grid over a Slurm cluster: an array of SHARDS jobs (sweep.sbatch,
# one shard each), then a merge job that runs once all of them succeeded and writes OUT
# as a single run would. It prints the two job ids (the merge's last) on its final line.
#
#   SHARDS=8 TRIALS=trials/train TEST=trials/test OUT=results/sweep.csv \
#   SWEEP_ARGS="--search bayes --iters 12" scripts/slurm/submit-sweep.sh
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
: "${SHARDS:=8}" "${TMO:=target/release/tmo}" "${OUT:=results/sweep.csv}"
export SHARDS TMO OUT TRIALS TEST SWEEP_ARGS
mkdir -p "$(dirname "$OUT")"
array=$(sbatch --parsable --array="1-$SHARDS" "$here/sweep.sbatch")
dir="$(dirname "$OUT")"
parts=()
for k in $(seq 1 "$SHARDS"); do parts+=("$dir/shard-$k-of-$SHARDS.csv"); done
merge=$(sbatch --parsable --dependency="afterok:$array" --job-name=tmo-sweep-merge \
    --output=tmo-sweep-merge-%j.log --wrap="$TMO sweep merge ${parts[*]} --out $OUT")
echo "queued shards as job $array (array 1-$SHARDS) and the merge as job $merge; it writes $OUT"
echo "$array $merge"
