#!/usr/bin/env bash
# Thread scaling on a machine with many cores, in one short run (docs/performance.md, "Thread
# scaling"): whole `haze render` runs of cornell-fog, vdb-cloud and cumulus with every integrator
# on 2, 8 and N threads (the issue's table: speed-up over 2 threads, shortest of two runs), then
# `haze bench --scaling -j N` on each (1 thread against N, each run a process of its own, phase
# by phase, with the processor clock's busy / waiting / more-work split).
#
#   benches/scaling.sh [HAZE [N [OUT]]]
#
# HAZE: a release binary (default target/release/haze); N: the most threads (default: every
# core); OUT: a directory for the tables (default scaling-out). Paths are taken from the current
# directory; the scenes and media from the repository this script sits in. Estimated from the
# 2-core times (not measured: no such machine has run it yet), about 6 minutes on 16 cores.
# A failed run stops the script with its error.
set -euo pipefail
haze=$(realpath "${1:-target/release/haze}")
n=${2:-$(nproc)}
out=$(realpath -m "${3:-scaling-out}")
[[ -x $haze ]] || { echo "not an executable: $haze" >&2; exit 2; }
cd "$(dirname "$0")/.."
mkdir -p "$out"
: >"$out/phases.md"
: >"$out/phases.log"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# The issue's iteration counts: cornell-fog 12, vdb-cloud 16, cumulus 4; the path tracer 24 spp.
iterations() {
    case "$1:$2" in
        *:path) echo 24 ;;
        cornell-fog:*) echo 12 ;;
        vdb-cloud:*) echo 16 ;;
        cumulus:*) echo 4 ;;
    esac
}

seconds() { # the wall-clock seconds of one run of "$@"; a failed run ends the script
    local t0 t1
    t0=$(date +%s.%N)
    "$@" >/dev/null || { echo "failed: $*" >&2; exit 1; }
    t1=$(date +%s.%N)
    awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.4f", b - a }'
}

{
    echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
    echo
    echo "| scene | integrator | iterations | 2 threads (s) | 8 threads | $n threads | efficiency at 8 | at $n |"
    echo "|---|---|---|---|---|---|---|---|"
    for scene in cornell-fog vdb-cloud cumulus; do
        for integrator in combined hybrid photons path; do
            it=$(iterations "$scene" "$integrator")
            declare -A best=()
            for threads in 2 8 "$n"; do
                for round in 1 2; do
                    t=$(seconds "$haze" render "scenes/$scene.toml" --integrator "$integrator" \
                        --iterations "$it" -j "$threads" -q -o "$tmp/out.exr")
                    best[$threads]=$(awk -v t="$t" -v b="${best[$threads]:-inf}" \
                        'BEGIN { print (b == "inf" || t < b) ? t : b }')
                done
            done
            awk -v s="$scene" -v i="$integrator" -v it="$it" -v n="$n" -v t2="${best[2]}" \
                -v t8="${best[8]}" -v tn="${best[$n]}" 'BEGIN {
                printf "| %s | %s | %s | %.2f | %.2fx | %.2fx | %.0f %% | %.0f %% |\n",
                    s, i, it, t2, t2 / t8, t2 / tn, 100 * 2 * t2 / (8 * t8), 100 * 2 * t2 / (n * tn)
            }'
            unset best
        done
    done
} | tee "$out/whole-runs.md"

for scene in cornell-fog vdb-cloud cumulus; do
    for integrator in combined hybrid photons path; do
        it=$(iterations "$scene" "$integrator")
        echo "== $scene $integrator $it" | tee -a "$out/phases.md"
        "$haze" bench "scenes/$scene.toml" --scaling --rounds 1 -j "$n" --integrator "$integrator" \
            --iterations "$it" 2>>"$out/phases.log" | tee -a "$out/phases.md"
    done
done
