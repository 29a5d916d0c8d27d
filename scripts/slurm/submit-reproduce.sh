#!/usr/bin/env bash
# Spreads a `tmo reproduce` over a Slurm cluster in two stages and a merge:
#   1. an array of SWEEP_SHARDS tasks, each a part of every replicate's rail sweep (the
#      sweep is some 90 % of a paper replicate; its chains are dealt out by cost);
#   2. once they all succeeded, an array of SHARDS tasks, each some replicates' steps with
#      their sweeps joined from the parts;
#   3. once those succeeded, the merge, which writes OUT with its findings report, as a
#      single run would.
#
#   SHARDS=8 OUT=results/paper REPRODUCE_ARGS="--preset paper --replicates 5" \
#   scripts/slurm/submit-reproduce.sh
#
# SWEEP_SHARDS defaults to SHARDS; SWEEP_SHARDS=0 skips the first stage (each shard then
# sweeps its own replicates). It prints the job ids (the merge's last) on its final line.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
: "${SHARDS:=8}" "${TMO:=target/release/tmo}" "${OUT:=results/paper}"
: "${REPRODUCE_ARGS:=--preset paper}"
: "${SWEEP_SHARDS:=$SHARDS}"
export SHARDS TMO OUT REPRODUCE_ARGS SWEEP_SHARDS
mkdir -p "$OUT.parts"
ids=()
after=()
if [ "$SWEEP_SHARDS" -gt 0 ]; then
    sweep=$(STAGE=sweep SHARDS="$SWEEP_SHARDS" sbatch --parsable --array="1-$SWEEP_SHARDS" \
        --job-name=tmo-reproduce-sweep "$here/reproduce.sbatch")
    ids+=("$sweep")
    after=(--dependency="afterok:$sweep")
    echo "queued the sweep parts as job $sweep (array 1-$SWEEP_SHARDS)"
fi
array=$(STAGE=steps sbatch --parsable --array="1-$SHARDS" "${after[@]}" "$here/reproduce.sbatch")
ids+=("$array")
parts=()
for k in $(seq 1 "$SHARDS"); do parts+=("$OUT.parts/shard-$k-of-$SHARDS"); done
merge=$(sbatch --parsable --dependency="afterok:$array" --job-name=tmo-reproduce-merge \
    --output=tmo-reproduce-merge-%j.log --wrap="$TMO reproduce merge ${parts[*]} --out $OUT")
ids+=("$merge")
echo "queued the shards as job $array (array 1-$SHARDS) and the merge as job $merge; it writes $OUT"
echo "${ids[*]}"
