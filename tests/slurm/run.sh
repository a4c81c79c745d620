#!/usr/bin/env bash
# A real Slurm on this machine: a single-node cluster on localhost (munged, slurmctld, slurmd)
# runs docs/slurm/render-array.sbatch as a 4-task job array and docs/slurm/merge.sbatch as a job
# that depends on it (afterok); the merged image must be bit-identical to one process rendering
# every iteration. Prints the wall time of the array (submission to merged image) beside that of
# the single process. Every daemon is stopped at the end, also on failure.
#
# Needs root and Debian's slurmctld, slurmd, slurm-client and munge (.ci/run installs them).
# Usage: tests/slurm/run.sh PATH/TO/haze
set -euo pipefail
HAZE=$(readlink -f "${1:?usage: tests/slurm/run.sh PATH/TO/haze}")
ROOT=$(cd "$(dirname "$0")/../.." && pwd)

fail() { echo "!!! SLURM TEST FAILED: $*" >&2; exit 1; }
for tool in munged slurmctld slurmd sbatch squeue sinfo scancel; do
    command -v "$tool" >/dev/null || fail "$tool is not installed (apt-get install slurmctld slurmd slurm-client munge)"
done
[ "$(id -u)" -eq 0 ] || fail "the single-node cluster needs root"

WORK=$(mktemp -d /tmp/haze-slurm.XXXXXX)
chmod 755 "$WORK"
export SLURM_CONF=$WORK/slurm.conf
MUNGE_PID=""

cleanup() {
    set +e
    scancel --quiet --user=root 2>/dev/null
    for pidfile in "$WORK/slurmd.pid" "$WORK/slurmctld.pid"; do
        [ -f "$pidfile" ] && kill "$(cat "$pidfile")" 2>/dev/null
    done
    [ -n "$MUNGE_PID" ] && kill "$MUNGE_PID" 2>/dev/null
    sleep 1
    for pidfile in "$WORK/slurmd.pid" "$WORK/slurmctld.pid"; do
        [ -f "$pidfile" ] && kill -9 "$(cat "$pidfile")" 2>/dev/null
    done
    if [ "${KEEP:-0}" != 1 ]; then rm -rf "$WORK"; fi
}
trap cleanup EXIT

# munge: a key and a socket directory of its own user (no systemd here).
install -d -o munge -g munge -m 0700 /etc/munge /var/lib/munge /var/log/munge
install -d -o munge -g munge -m 0755 /run/munge
if [ ! -s /etc/munge/munge.key ]; then
    dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 status=none
fi
chown munge:munge /etc/munge/munge.key
chmod 0400 /etc/munge/munge.key
if ! munge -n 2>/dev/null | unmunge >/dev/null 2>&1; then
    runuser -u munge -- /usr/sbin/munged --force
    MUNGE_PID=$(cat /run/munge/munged.pid 2>/dev/null || true)
fi
munge -n | unmunge >/dev/null || fail "munge does not work"

mkdir -p "$WORK/state" "$WORK/spool"
CPUS=$(nproc)
cat >"$SLURM_CONF" <<EOF
ClusterName=hazeci
SlurmctldHost=localhost
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
StateSaveLocation=$WORK/state
SlurmdSpoolDir=$WORK/spool
SlurmctldPidFile=$WORK/slurmctld.pid
SlurmdPidFile=$WORK/slurmd.pid
SlurmctldLogFile=$WORK/slurmctld.log
SlurmdLogFile=$WORK/slurmd.log
ReturnToService=2
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$CPUS State=UNKNOWN
PartitionName=ci Nodes=localhost Default=YES MaxTime=INFINITE State=UP
EOF
slurmctld -i || fail "slurmctld did not start ($(tail -n 5 "$WORK/slurmctld.log" 2>/dev/null))"
slurmd -N localhost || fail "slurmd did not start ($(tail -n 5 "$WORK/slurmd.log" 2>/dev/null))"
for _ in $(seq 120); do
    state=$(sinfo -h -n localhost -o %T 2>/dev/null || true)
    [ "$state" = idle ] && break
    sleep 0.5
done
[ "$state" = idle ] || fail "the node is not idle but '$state' ($(tail -n 5 "$WORK/slurmd.log"))"
echo "slurm $(sinfo -V | cut -d' ' -f2): node localhost with $CPUS CPUs is idle"

# The render: small enough for CI, large enough to time.
export HAZE SCENE="$ROOT/scenes/spotlight-fog.toml" ITERATIONS=64 PARTS="$WORK/parts" OUT="$WORK/merged.exr"
export HAZE_ARGS="--resolution 256x192 -p 100000"
mkdir -p "$PARTS"
cd "$WORK"
t0=$(date +%s.%N)
array=$(sbatch --parsable --array=0-3 --export=ALL "$ROOT/docs/slurm/render-array.sbatch")
merge=$(sbatch --parsable --dependency=afterok:"$array" --export=ALL "$ROOT/docs/slurm/merge.sbatch")
echo "submitted array job $array (4 tasks) and merge job $merge (afterok:$array)"
for _ in $(seq 1200); do
    left=$(squeue -h -j "$array,$merge" -o '%i %T %r' 2>/dev/null || true)
    [ -z "$left" ] && break
    if grep -q DependencyNeverSatisfied <<<"$left"; then
        cat "$WORK"/haze-render-*.log >&2 || true
        fail "a render task failed: $left"
    fi
    sleep 0.5
done
[ -z "$left" ] || fail "jobs still queued after 10 minutes: $left"
t1=$(date +%s.%N)
[ -f "$OUT" ] || { cat "$WORK"/haze-*.log >&2 || true; fail "the merge job wrote no image"; }
cat "$WORK"/haze-merge-*.log

# One process, every iteration, with both cores.
# shellcheck disable=SC2086
"$HAZE" render "$SCENE" -n "$ITERATIONS" -o "$WORK/single.exr" -q $HAZE_ARGS
t2=$(date +%s.%N)
"$HAZE" diff "$OUT" "$WORK/single.exr" || fail "the merged image differs from the single render"
awk -v a="$t0" -v b="$t1" -v c="$t2" -v n="$CPUS" 'BEGIN {
    printf "wall time: 4-task array + merge %.1f s; one process %.1f s (%d cores)\n", b - a, c - b, n }'
echo "SLURM TEST PASSED"
