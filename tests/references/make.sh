#!/bin/sh
# Regenerates the small per-scene references of tests/suite/references.rs: every bundled scene
# at 1/16 of its resolution, path traced long.
#
#   cargo build --release && tests/references/make.sh          # about 40 minutes on 2 cores
#
# Path tracer, 8,192 samples per pixel, seed 1000, for every scene it can render; the two caustic
# scenes and dense-fog by the hybrid (below; see tests/suite/references.rs). Keep the lists and
# settings here and there in step.
set -eu
cd "$(dirname "$0")/../.."
HAZE=${HAZE:-target/release/haze}
size() {
    # The scene's resolution / 16, rounded, at least 8.
    sed -n 's/^resolution *= *\[ *\([0-9]*\) *, *\([0-9]*\) *\].*/\1 \2/p' "scenes/$1.toml" | head -1 |
        awk '{w = int($1 / 16 + 0.5); h = int($2 / 16 + 0.5); if (w < 8) w = 8; if (h < 8) h = 8; print w "x" h}'
}
for s in campfire coloured-smoke cornell-box cornell-cloud-homogeneous cornell-cloud cornell-fog cumulus \
    cumulus-sky fire fog-backward fog-forward smoke-plume spotlight-fog sunset-fog thin-fog vdb-cloud \
    vdb-edges; do
    "$HAZE" render "scenes/$s.toml" --integrator path -n 8192 --seed 1000 \
        --resolution "$(size "$s")" -q -o "tests/references/$s.exr"
    rm -f "tests/references/$s.png"
done
# The two caustic scenes, which the path tracer cannot render: the hybrid, 8,000 iterations of
# 50,000 light paths (their bias layers enter the test's allowance).
for s in glass-caustic volumetric-caustic; do
    "$HAZE" render "scenes/$s.toml" --reference -n 8000 -p 50000 --seed 1000 --integrator hybrid \
        --resolution "$(size "$s")" -q -o "tests/references/$s.exr"
    rm -f "tests/references/$s.png"
done
# dense-fog, whose path-traced pixels are dominated by rare paths: the hybrid at a fixed volume
# radius 10x the scene's (the test's renders use the same radii), 8,192 iterations of the
# scene's 2,000 light paths (about 25 minutes on 2 cores).
"$HAZE" render scenes/dense-fog.toml --reference -n 8192 --seed 1000 --alpha 0.9999 --integrator hybrid \
    --volume-alpha 0.9999 --volume-radius-fraction 0.1 --resolution "$(size dense-fog)" -q \
    -o tests/references/dense-fog.exr
rm -f tests/references/dense-fog.png
ls -l tests/references/*.exr
