#!/usr/bin/env bash
# Runs the Slurm deployment for real on this machine: brings up a one-node
# Slurm cluster (munged, slurmctld, slurmd), submits a 4-task render array and
# the dependent merge with deploy/slurm/submit.sh (real sbatch --array=0-3 and
# --dependency=afterok), waits, checks the merged image against one
# uninterrupted run of the same samples (`pathmix compare`, 1e-6 relative;
# with --variance, which lays out Sobol's samples in replicates as the parts do),
# checks that the comparison does catch a missing or duplicated shard, and
# tears the cluster down. Exit status 0 only when all of that passed.
#
#   bash deploy/slurm/local-test.sh [--fail-shard I]
#
# --fail-shard I makes array task I fail, to exercise the failure path: the
# merge must be cancelled and this script must exit 1 (and still clean up).
#
# Needs root on Debian/Ubuntu: installs slurmctld slurmd slurm-client munge
# (--no-install-recommends) when missing, with a policy-rc.d that keeps the
# packages from starting their services (created only if absent, removed
# after). Everything else lives in a scratch folder (config, state, spool,
# logs, munge key and socket), which is removed at the end; no config is
# written to /etc: every Slurm command reads $SLURM_CONF. Only the daemons it
# started are stopped, by PID, and any job step left behind (found by that
# SLURM_CONF in its environment) likewise; on failure too.
#
# Environment: PATHMIX, the binary (default: `cargo build --release`, then
# target/release/pathmix); KEEP=1 keeps the scratch folder.
set -euo pipefail

SHARDS=4
SPP=64
SIZE=32
WAIT_LIMIT=300 # seconds for the array and the merge together

repo=$(cd "$(dirname "$0")/../.." && pwd)
scene=$repo/scenes/cornell-boxes.toml
fail_shard=
case "${1:-}" in
    --fail-shard) fail_shard=${2:?--fail-shard needs a task index} ;;
    "") ;;
    *) echo "usage: local-test.sh [--fail-shard I]" >&2; exit 2 ;;
esac

say() { echo "local-test: $*"; }
fail() {
    echo "local-test: FAILED: $*" >&2
    exit 1
}
started=$SECONDS

if [ "$(id -u)" -ne 0 ]; then
    echo "local-test: needs root (it installs packages and runs slurmd)" >&2
    exit 2
fi

scratch=
created_policy=
pids=() # daemons started here, in start order: munged, slurmctld, slurmd
ctld_pid=
waiter= # submit.sh --wait, while it runs
conf=

# Processes of this cluster that are not ours by PID: job steps (slurmstepd)
# and what they run. They inherit SLURM_CONF=$conf, a path unique to this run.
cluster_leftovers() {
    [ -n "$conf" ] || return 0
    local marker="SLURM_CONF=$conf" pid
    for pid in $(ls /proc | grep -E '^[0-9]+$'); do
        [ "$pid" != $$ ] && [ "$pid" != "$BASHPID" ] || continue
        if { tr "\0" "\n" <"/proc/$pid/environ"; } 2>/dev/null | grep -qxF "$marker"; then
            echo "$pid"
        fi
    done
}

stop_pids() { # NAME PID...: SIGTERM, up to 10 s, then SIGKILL
    local name=$1 pid i alive
    shift
    kill -TERM "$@" 2>/dev/null || true
    for i in $(seq 100); do
        alive=()
        for pid in "$@"; do
            kill -0 "$pid" 2>/dev/null && alive+=("$pid")
        done
        [ ${#alive[@]} -eq 0 ] && return 0
        sleep 0.1
    done
    echo "local-test: $name (${alive[*]}) ignored SIGTERM; killing" >&2
    kill -KILL "${alive[@]}" 2>/dev/null || true
}

cleanup() {
    local status=$? i pid left
    set +e
    trap - EXIT INT TERM
    if [ -n "$created_policy" ]; then
        rm -f /usr/sbin/policy-rc.d
    fi
    if [ -n "$waiter" ]; then
        stop_pids submit.sh "$waiter"
    fi
    if [ -n "$ctld_pid" ] && kill -0 "$ctld_pid" 2>/dev/null; then
        # Cancel what is still queued or running while the controller is up.
        local jobs
        jobs=$(squeue -h -o %i 2>/dev/null)
        if [ -n "$jobs" ]; then
            say "cancelling jobs left: $(echo $jobs)"
            # shellcheck disable=SC2086
            scancel $jobs 2>/dev/null
            for i in $(seq 100); do
                [ -z "$(squeue -h -o %i 2>/dev/null)" ] && break
                sleep 0.2
            done
        fi
    fi
    if [ "$status" -ne 0 ] && [ -n "$scratch" ]; then
        for log in "$scratch"/slurm/*.log "$scratch"/slurm/*.out "$scratch"/munge/munged.log "$scratch"/run/*.log; do
            [ -s "$log" ] || continue
            echo "---- ${log#"$scratch"/} (last lines)" >&2
            tail -n 15 "$log" >&2
        done
    fi
    # Stop the daemons in reverse start order: slurmd, slurmctld, munged.
    for ((i = ${#pids[@]} - 1; i >= 0; i--)); do
        stop_pids daemon "${pids[i]}"
    done
    unset SLURM_CONF
    for i in 1 2 3; do
        left=$(cluster_leftovers)
        [ -n "$left" ] || break
        for pid in $left; do
            say "stopping left-over job process $pid: $({ tr '\0' ' ' <"/proc/$pid/cmdline"; } 2>/dev/null)"
        done
        # shellcheck disable=SC2086
        stop_pids "job processes" $left
    done
    left=$(cluster_leftovers)
    for pid in "${pids[@]}"; do
        kill -0 "$pid" 2>/dev/null && left="$left $pid"
    done
    if [ -n "${left// /}" ]; then
        echo "local-test: processes left running: $left" >&2
        [ "$status" -eq 0 ] && status=1
    fi
    if [ -n "$scratch" ]; then
        if [ "${KEEP:-}" = 1 ]; then
            say "kept $scratch"
        else
            rm -rf "$scratch"
        fi
    fi
    if [ "$status" -eq 0 ]; then
        say "passed in $((SECONDS - started)) s; the cluster is stopped"
    else
        echo "local-test: failed (exit $status) after $((SECONDS - started)) s; the cluster is stopped" >&2
    fi
    exit "$status"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

# ---- packages ---------------------------------------------------------------
missing=()
for package in slurmctld slurmd slurm-client munge; do
    dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q 'ok installed' \
        || missing+=("$package")
done
if [ ${#missing[@]} -gt 0 ]; then
    say "installing ${missing[*]}"
    if [ ! -e /usr/sbin/policy-rc.d ]; then
        created_policy=1
        printf '#!/bin/sh\n# local-test.sh: do not start services while installing\nexit 101\n' \
            >/usr/sbin/policy-rc.d
        chmod 755 /usr/sbin/policy-rc.d
    fi
    # Waits for the package lock when another install is running.
    apt-get update -qq -o DPkg::Lock::Timeout=300
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
        -o DPkg::Lock::Timeout=300 \
        "${missing[@]}" >/dev/null
    if [ -n "$created_policy" ]; then
        rm -f /usr/sbin/policy-rc.d
        created_policy=
    fi
fi

if [ -z "${PATHMIX:-}" ]; then
    (cd "$repo" && cargo build --release --quiet)
    PATHMIX=${CARGO_TARGET_DIR:-$repo/target}/release/pathmix
fi
PATHMIX=$(realpath "$PATHMIX")
[ -x "$PATHMIX" ] || fail "no pathmix binary at $PATHMIX"

# ---- scratch folder -----------------------------------------------------------
scratch=$(mktemp -d /tmp/pathmix-slurm.XXXXXX)
chmod 0755 "$scratch" # munged checks the folders above its socket
mkdir -p "$scratch"/munge/run "$scratch"/munge/key "$scratch"/slurm/state \
    "$scratch"/slurm/spool "$scratch"/run
chmod 0755 "$scratch"/munge "$scratch"/munge/run
chmod 0700 "$scratch"/munge/key
socket=$scratch/munge/run/munge.socket

# Two free TCP ports for slurmctld and slurmd (another cluster may be up).
port_free() { ! (exec 3<>"/dev/tcp/127.0.0.1/$1") 2>/dev/null; }
ports=()
for port in $(seq 6817 6899); do
    port_free "$port" && ports+=("$port")
    [ ${#ports[@]} -eq 2 ] && break
done
[ ${#ports[@]} -eq 2 ] || fail "no free ports in 6817-6899"

host=$(hostname -s)
conf=$scratch/slurm/slurm.conf
cat >"$conf" <<EOF
# Written by deploy/slurm/local-test.sh: a one-node cluster for a test.
ClusterName=pathmix-test
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=${ports[0]}
SlurmdPort=${ports[1]}
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$socket
StateSaveLocation=$scratch/slurm/state
SlurmdSpoolDir=$scratch/slurm/spool
SlurmctldPidFile=$scratch/slurm/slurmctld.pid
SlurmdPidFile=$scratch/slurm/slurmd.pid
SlurmctldLogFile=$scratch/slurm/slurmctld.log
SlurmdLogFile=$scratch/slurm/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/filetxt
JobCompLoc=$scratch/slurm/jobcomp.txt
SlurmdParameters=config_overrides
ReturnToService=2
MailProg=/bin/true
NodeName=$host NodeAddr=127.0.0.1 CPUs=$(nproc) State=UNKNOWN
PartitionName=test Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$conf

# ---- bring-up -----------------------------------------------------------------
bring_up=$SECONDS
mungekey --create --keyfile="$scratch/munge/key/munge.key"
chmod 0400 "$scratch/munge/key/munge.key"
munged --foreground --socket="$socket" --key-file="$scratch/munge/key/munge.key" \
    --pid-file="$scratch/munge/munged.pid" --log-file="$scratch/munge/munged.log" \
    --seed-file="$scratch/munge/munged.seed" </dev/null >>"$scratch/munge/munged.log" 2>&1 &
pids+=($!)
for _ in $(seq 50); do [ -S "$socket" ] && break; sleep 0.1; done
[ -S "$socket" ] || fail "munged did not start"

slurmctld -D -i </dev/null >"$scratch/slurm/slurmctld.out" 2>&1 &
ctld_pid=$!
pids+=("$ctld_pid")
slurmd -D -N "$host" </dev/null >"$scratch/slurm/slurmd.out" 2>&1 &
pids+=($!)
state=
for _ in $(seq 150); do
    for pid in "${pids[@]}"; do
        kill -0 "$pid" 2>/dev/null || fail "a daemon exited at start (pid $pid)"
    done
    state=$(sinfo -h -N -o %T 2>/dev/null || true)
    [ "$state" = idle ] && break
    sleep 0.2
done
[ "$state" = idle ] || fail "node not idle after 30 s: ${state:-no answer} $(sinfo -h -R 2>/dev/null)"
say "cluster up in $((SECONDS - bring_up)) s: node $host, ports ${ports[*]}, $(nproc) CPUs"

# ---- the array and the merge ----------------------------------------------------
run=$scratch/run
pathmix=$PATHMIX
if [ -n "$fail_shard" ]; then
    # A pathmix that fails for one shard.
    pathmix=$scratch/pathmix-failing
    printf '#!/bin/sh\ncase " $* " in *" --shard %s/"*) echo "injected failure" >&2; exit 3;; esac\nexec %s "$@"\n' \
        "$fail_shard" "$PATHMIX" >"$pathmix"
    chmod 755 "$pathmix"
fi
submitted=$SECONDS
status=0
(
    cd "$run"
    export PATHMIX=$pathmix PATHMIX_FLAGS="--width $SIZE --height $SIZE" \
        OUT=$run/parts IMAGE=$run/final.png EXR=$run/final.exr \
        SBATCH_FLAGS="--cpus-per-task=1"
    exec timeout "$WAIT_LIMIT" "$repo/deploy/slurm/submit.sh" --wait "$scene" "$SPP" "$SHARDS"
) &
waiter=$! # waited for in the background, so that a signal to this script is handled at once
wait "$waiter" || status=$?
waiter=
say "array and merge done in $((SECONDS - submitted)) s (submit.sh --wait: exit $status)"
# The per-task record (JobCompType=jobcomp/filetxt): name, task, state, exit code.
jobs=$(awk '{ split("", f)
        for (i = 1; i <= NF; i++) { k = $i; sub(/=.*/, "", k); v = $i; sub(/^[^=]*=/, "", v); f[k] = v }
        print f["Name"], (f["ArrayTaskId"] == "" ? "-" : f["ArrayTaskId"]), f["JobState"], f["ExitCode"] }' \
    "$scratch/slurm/jobcomp.txt" 2>/dev/null | sort -k1,1 -k2,2n || true)
echo "local-test: jobs (name, array task, state, exit code):"
echo "$jobs" | sed 's/^/    /'
if [ -n "$fail_shard" ]; then
    [ "$status" -ne 0 ] || fail "task $fail_shard failed, yet submit.sh --wait returned 0"
    [ ! -e "$run/final.exr" ] || fail "task $fail_shard failed, yet the merge ran"
    say "as expected, task $fail_shard failed and the merge did not run"
    exit 1
fi
[ "$status" -eq 0 ] || fail "the array or the merge failed (exit $status)"
[ -s "$run/final.exr" ] || fail "no merged image $run/final.exr"
expected=$(echo "pathmix-merge - COMPLETED 0:0"
    for ((i = 0; i < SHARDS; i++)); do echo "pathmix-render $i COMPLETED 0:0"; done)
[ "$jobs" = "$expected" ] || fail "expected every task and the merge COMPLETED with exit 0"

# ---- the check ------------------------------------------------------------------
"$PATHMIX" render "$scene" --spp "$SPP" --width "$SIZE" --height "$SIZE" \
    -o "$run/one.png" --exr "$run/one.exr" --variance "$run/one-se.exr" --quiet >"$run/one.log" 2>&1 \
    || fail "the single run failed: $(cat "$run/one.log")"
out=$("$PATHMIX" compare "$run/final.exr" "$run/one.exr" --tolerance 1e-6 2>&1) \
    || fail "the merged image differs from one run: $out"
say "$out"

# The comparison must be able to fail: a merge lacking one shard differs from
# one run, and a duplicated shard (two tasks rendering the same samples) makes
# the merge step fail.
parts=$run/parts
"$PATHMIX" merge "$parts/part-0.exr" "$parts/part-1.exr" "$parts/part-2.exr" \
    -o "$run/three.png" --exr "$run/three.exr" >/dev/null 2>&1 \
    || fail "self-check: merging three of four parts failed"
if out=$("$PATHMIX" compare "$run/three.exr" "$run/one.exr" --tolerance 1e-6 2>&1); then
    fail "self-check: a merge without shard 3 passed the comparison: $out"
fi
say "self-check, shard 3 missing: ${out#pathmix: error: }"
mkdir "$run/dup"
cp "$parts/part-0.exr" "$parts/part-1.exr" "$parts/part-2.exr" "$run/dup/"
cp "$parts/part-2.exr" "$run/dup/part-3.exr"
if out=$(OUT=$run/dup IMAGE=$run/dup.png EXR=$run/dup.exr PATHMIX=$PATHMIX \
    sh "$repo/deploy/merge.sh" "$SHARDS" 2>&1); then
    fail "self-check: the merge step accepted shard 2 twice: $out"
fi
say "self-check, shard 2 twice: ${out#pathmix: error: }"
