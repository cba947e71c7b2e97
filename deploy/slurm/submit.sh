#!/bin/sh
# Queues SHARDS render tasks as a job array and the merge after them.
#
#   deploy/slurm/submit.sh [--wait] SCENE SPP SHARDS
#
# Runs from any folder: the jobs start there (their logs, and parts/,
# final.png and final.exr by default, land there). It submits
#
#   sbatch --array=0-(SHARDS-1) deploy/slurm/render-shard.sh
#   sbatch --dependency=afterok:ARRAY_JOB --kill-on-invalid-dep=yes deploy/slurm/merge.sh
#
# so the merge starts once every task has succeeded, and is cancelled if any
# fails (re-run the failed shards, which resume from their checkpoints, then
# sbatch merge.sh alone). With --wait it waits for the merge and exits 0 only
# when the merge completed (1 when a task failed, so the merge was cancelled,
# or the merge failed).
#
# Environment: OUT, IMAGE, EXR, PATHMIX, PATHMIX_FLAGS and CHECKPOINT_EVERY
# pass through to the jobs (see deploy/render-shard.sh); SBATCH_FLAGS adds
# sbatch options to both submissions, e.g. "--partition=gpu --time=4:00:00"
# or "--cpus-per-task=2" (they override the scripts' #SBATCH lines);
# PATHMIX_DEPLOY is the deploy/ folder (default: the one holding this script).
set -eu
wait=
if [ "${1:-}" = --wait ]; then
    wait=--wait
    shift
fi
export SCENE="${1:?usage: submit.sh [--wait] SCENE SPP SHARDS}"
export SPP="${2:?usage: submit.sh [--wait] SCENE SPP SHARDS}"
export SHARDS="${3:?usage: submit.sh [--wait] SCENE SPP SHARDS}"
export OUT="${OUT:-$PWD/parts}"
export PATHMIX_DEPLOY="${PATHMIX_DEPLOY:-$(cd "$(dirname "$0")/.." && pwd)}"
# shellcheck disable=SC2086 # SBATCH_FLAGS is a list of options
job=$(sbatch --parsable --export=ALL ${SBATCH_FLAGS:-} --array="0-$((SHARDS - 1))" \
    "$PATHMIX_DEPLOY/slurm/render-shard.sh")
job=${job%%;*}
echo "render array job $job: tasks 0-$((SHARDS - 1))"
# shellcheck disable=SC2086
merge=$(sbatch --parsable --export=ALL ${SBATCH_FLAGS:-} --dependency="afterok:$job" \
    --kill-on-invalid-dep=yes "$PATHMIX_DEPLOY/slurm/merge.sh")
merge=${merge%%;*}
echo "merge job $merge: runs when every task has succeeded"
[ -n "$wait" ] || exit 0

# Wait for the merge's end (sbatch --wait would not do: it returns 0 for a job
# cancelled because its dependency failed). Every 2 s for a minute, then 30 s.
polls=0
while :; do
    info=$(scontrol -o show job "$merge" 2>/dev/null || true)
    state=$(echo "$info" | sed -n 's/.* JobState=\([A-Z_]*\) .*/\1/p')
    case "$state" in
        COMPLETED)
            echo "merge job $merge: COMPLETED"
            exit 0
            ;;
        BOOT_FAIL | CANCELLED | DEADLINE | FAILED | NODE_FAIL | OUT_OF_MEMORY | PREEMPTED | TIMEOUT)
            reason=$(echo "$info" | sed -n 's/.* Reason=\([^ ]*\) .*/\1/p')
            echo "merge job $merge: $state (reason: ${reason:-none}); render tasks:" >&2
            scontrol -o show job "$job" 2>/dev/null \
                | sed -n 's/^.* ArrayTaskId=\([^ ]*\) .* JobState=\([A-Z_]*\) .* ExitCode=\([^ ]*\) .*/  task \1: \2, exit \3/p' >&2
            exit 1
            ;;
        "")
            echo "merge job $merge: no longer known to Slurm" >&2
            exit 1
            ;;
    esac
    polls=$((polls + 1))
    if [ "$polls" -lt 30 ]; then sleep 2; else sleep 30; fi
done
