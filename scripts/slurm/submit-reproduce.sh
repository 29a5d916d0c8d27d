#!/usr/bin/env bash
# Spreads a `tmo reproduce` over a Slurm cluster: an array of SHARDS jobs (reproduce.sbatch,
# one part of the replicate x variant plan each), then a merge job that runs once all of
# them succeeded and writes OUT, with its findings report, as a single run would.
#
#   SHARDS=8 OUT=results/paper REPRODUCE_ARGS="--preset paper --replicates 5" \
#   scripts/slurm/submit-reproduce.sh
#
# It prints the two job ids (the merge's last) on its final line.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
: "${SHARDS:=8}" "${TMO:=target/release/tmo}" "${OUT:=results/paper}"
: "${REPRODUCE_ARGS:=--preset paper}"
export SHARDS TMO OUT REPRODUCE_ARGS
mkdir -p "$OUT.parts"
array=$(sbatch --parsable --array="1-$SHARDS" "$here/reproduce.sbatch")
parts=()
for k in $(seq 1 "$SHARDS"); do parts+=("$OUT.parts/shard-$k-of-$SHARDS"); done
merge=$(sbatch --parsable --dependency="afterok:$array" --job-name=tmo-reproduce-merge \
    --output=tmo-reproduce-merge-%j.log --wrap="$TMO reproduce merge ${parts[*]} --out $OUT")
echo "queued the shards as job $array (array 1-$SHARDS) and the merge as job $merge; it writes $OUT"
echo "$array $merge"
