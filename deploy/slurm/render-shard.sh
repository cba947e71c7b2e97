#!/bin/sh
#SBATCH --job-name=pathmix-render
#SBATCH --array=0-3
#SBATCH --cpus-per-task=4
#SBATCH --requeue
#SBATCH --output=pathmix-render-%A_%a.log
# One array task = one shard; $SLURM_ARRAY_TASK_ID picks it. Submit with
# deploy/slurm/submit.sh, which also queues the merge. Slurm sends SIGTERM at
# preemption and at the time limit: the shard saves its checkpoint, and a
# requeued task resumes from it.
#
# Environment (exported by submit.sh): SCENE, SPP, OUT, PATHMIX, PATHMIX_FLAGS
# as in deploy/render-shard.sh; SHARDS (default: the array's task count);
# PATHMIX_DEPLOY, the deploy/ folder (default: $SLURM_SUBMIT_DIR/deploy, as
# Slurm runs a copy of this script).
set -eu
COUNT=${SHARDS:-${SLURM_ARRAY_TASK_COUNT:?submit as an array job: sbatch --array=0-3}}
exec sh "${PATHMIX_DEPLOY:-$SLURM_SUBMIT_DIR/deploy}/render-shard.sh" \
    "${SLURM_ARRAY_TASK_ID:?not a Slurm array task}" "$COUNT"
