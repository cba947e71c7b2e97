#!/bin/sh
# Renders shard INDEX of COUNT of one image: the step every launcher runs
# (a Slurm array task, a Kubernetes Indexed Job pod, a shell loop).
#
#   deploy/render-shard.sh INDEX COUNT
#
# The sample range comes from `pathmix render --shard INDEX/COUNT` (shard I of N
# renders sample indices SPP*I/N .. SPP*(I+1)/N), the one rule for every launcher.
#
# Environment:
#   SCENE             scene file (required)
#   SPP               samples per pixel over all shards (default: the scene's spp)
#   OUT               folder for part-INDEX.exr and part-INDEX.ckpt (default: parts)
#   PATHMIX           the pathmix binary (default: pathmix on PATH)
#   PATHMIX_FLAGS     more render flags, e.g. "--width 300 --height 300"
#   CHECKPOINT_EVERY  how often a shard saves its state (default: 60s)
#
# A shard stopped by SIGTERM (preemption, time limit) saves its checkpoint and
# exits 143; run again, it resumes from the checkpoint.
set -eu
INDEX=${1:?usage: render-shard.sh INDEX COUNT}
COUNT=${2:?usage: render-shard.sh INDEX COUNT}
: "${SCENE:?set SCENE to the scene file}"
PATHMIX=${PATHMIX:-pathmix}
OUT=${OUT:-parts}
mkdir -p "$OUT"
CKPT="$OUT/part-$INDEX.ckpt"
if [ -f "$CKPT" ]; then
    exec "$PATHMIX" render --resume "$CKPT" --quiet
fi
# shellcheck disable=SC2086 # PATHMIX_FLAGS is a list of flags
exec "$PATHMIX" render "$SCENE" ${SPP:+--spp "$SPP"} --shard "$INDEX/$COUNT" \
    --partial "$OUT/part-$INDEX.exr" \
    --checkpoint "$CKPT" --checkpoint-every "${CHECKPOINT_EVERY:-60s}" \
    --quiet ${PATHMIX_FLAGS:-}
