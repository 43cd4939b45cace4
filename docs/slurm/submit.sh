#!/usr/bin/env bash
# Submits a frictionlab power run to Slurm: an array of $TASKS shards, then
# the merge as a job that waits for all of them (afterok). Prints the two
# job ids. Settings come from the environment:
#   PROTOCOL  protocol file (required)
#   OUT       output folder on storage every node sees (required)
#   SEED      plan seed (required)
#   TASKS     array tasks, i.e. shards (default 100)
#   SIZES     sample sizes (default 4,6,8,12,16,20)
#   STUDIES   studies per size (default 1000)
#   FRICTIONLAB     the binary (default: frictionlab on PATH)
#   POWER_OPTIONS   more `frictionlab power` options, e.g. "--alpha 0.01"
# Example:
#   PROTOCOL=protocols/paired-comparison.json OUT=$PWD/power-pc SEED=1 \
#     docs/slurm/submit.sh
set -euo pipefail
: "${PROTOCOL:?set PROTOCOL}" "${OUT:?set OUT}" "${SEED:?set SEED}"
here=$(cd "$(dirname "$0")" && pwd)
tasks=${TASKS:-100}
mkdir -p "$OUT"
array=$(sbatch --parsable --export=ALL --array="0-$((tasks - 1))" \
  --output="$OUT/slurm-%A_%a.out" "$here/power-array.sbatch")
array=${array%%;*}
merge=$(sbatch --parsable --export=ALL --dependency="afterok:$array" \
  --output="$OUT/slurm-merge-%j.out" "$here/power-merge.sbatch")
merge=${merge%%;*}
echo "array $array ($tasks tasks), merge $merge after it; results in $OUT/power.json"
