#!/bin/sh
#SBATCH --job-name=pathmix-merge
#SBATCH --cpus-per-task=2
#SBATCH --output=pathmix-merge-%j.log
# Merges the shards once the array job is done (submit.sh queues it with
# --dependency=afterok). Environment: SHARDS, OUT, IMAGE, EXR, PATHMIX,
# PATHMIX_DEPLOY as in deploy/merge.sh and render-shard.sh.
set -eu
exec sh "${PATHMIX_DEPLOY:-$SLURM_SUBMIT_DIR/deploy}/merge.sh" "${SHARDS:?set SHARDS}"
