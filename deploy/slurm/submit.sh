#!/bin/sh
# Queues SHARDS render tasks as a job array and the merge after them.
#
#   deploy/slurm/submit.sh SCENE SPP SHARDS
#
# Run from the repository root (or set PATHMIX_DEPLOY); OUT, IMAGE, EXR,
# PATHMIX and PATHMIX_FLAGS pass through to the jobs.
set -eu
export SCENE="${1:?usage: submit.sh SCENE SPP SHARDS}"
export SPP="${2:?usage: submit.sh SCENE SPP SHARDS}"
export SHARDS="${3:?usage: submit.sh SCENE SPP SHARDS}"
export OUT="${OUT:-$PWD/parts}"
export PATHMIX_DEPLOY="${PATHMIX_DEPLOY:-$PWD/deploy}"
job=$(sbatch --parsable --export=ALL --array="0-$((SHARDS - 1))" deploy/slurm/render-shard.sh)
job=${job%%;*}
sbatch --export=ALL --dependency="afterok:$job" deploy/slurm/merge.sh
echo "render array job $job; the merge runs when all its tasks are done"
