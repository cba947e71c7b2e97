#!/bin/sh
# Merges the COUNT partial results of deploy/render-shard.sh into one image.
#
#   deploy/merge.sh COUNT
#
# Environment:
#   OUT      folder with part-0.exr .. part-(COUNT-1).exr (default: parts)
#   IMAGE    the merged PNG (default: final.png)
#   EXR      the merged linear EXR (default: final.exr)
#   PATHMIX  the pathmix binary (default: pathmix on PATH)
#
# A missing part is an error (its shard failed); parts that overlap or come
# from another scene, seed or size are refused by `pathmix merge`.
set -eu
COUNT=${1:?usage: merge.sh COUNT}
OUT=${OUT:-parts}
set --
i=0
while [ "$i" -lt "$COUNT" ]; do
    set -- "$@" "$OUT/part-$i.exr"
    i=$((i + 1))
done
exec "${PATHMIX:-pathmix}" merge "$@" -o "${IMAGE:-final.png}" --exr "${EXR:-final.exr}"
