#!/usr/bin/env bash
# Renders every bundled scene with the haze of git revision BASE and with the working tree, at a
# fixed seed, iteration count and reduced resolution, and compares the pixels of the two EXR files
# bit for bit. Used to show that a restructuring changes no image.
#
#   tests/compare-renders.sh BASE [SCENE.toml ...]
#
# Environment: ITERATIONS (default 3), PHOTONS (default 20000), SEED (default 7), THREADS (default
# 2), WIDTH (default 96; the height keeps each scene's aspect ratio), EXTRA (more render flags for
# both, e.g. "--integrator path" or "--volume-estimate point"). The pixels are compared by the
# new build's `haze diff`.
# OLD_BIN: a haze binary already built from BASE, used instead of building BASE in a worktree.
# Exit status 0 if every image is identical, 1 otherwise.
set -euo pipefail
cd "$(dirname "$0")/.."
base=${1:?usage: tests/compare-renders.sh BASE [SCENE.toml ...]}
shift
scenes=("$@")
if [ ${#scenes[@]} -eq 0 ]; then scenes=(scenes/*.toml); fi
iterations=${ITERATIONS:-3}
photons=${PHOTONS:-20000}
seed=${SEED:-7}
threads=${THREADS:-2}
width=${WIDTH:-96}

work=$(mktemp -d)
trap 'git worktree remove --force "$work/base" >/dev/null 2>&1 || true; rm -rf "$work"' EXIT
if [ -n "${OLD_BIN:-}" ]; then
    old=$OLD_BIN
else
    git worktree add --detach "$work/base" "$base" >/dev/null
    echo "building $base (release)"
    (cd "$work/base" && cargo build --release --quiet)
    old="$work/base/target/release/haze"
fi
cargo build --release --quiet
new=target/release/haze

status=0
for scene in "${scenes[@]}"; do
    name=$(basename "$scene" .toml)
    # The scene's resolution, scaled to the chosen width.
    read -r w h < <(sed -n 's/^resolution *= *\[ *\([0-9]*\) *, *\([0-9]*\) *\].*/\1 \2/p' "$scene" | head -1)
    height=$(( (width * h + w / 2) / w ))
    # shellcheck disable=SC2206
    args=(-n "$iterations" -p "$photons" -s "$seed" -j "$threads" --resolution "${width}x${height}" -q ${EXTRA:-})
    "$old" render "$scene" "${args[@]}" -o "$work/$name-old.exr" 2>/dev/null
    "$new" render "$scene" "${args[@]}" -o "$work/$name-new.exr" 2>/dev/null
    if out=$("$new" diff "$work/$name-old.exr" "$work/$name-new.exr"); then
        echo "$name: $out"
    else
        echo "DIFFERENT $name: $out"
        status=1
    fi
done
exit $status
