#!/bin/sh
# Writes media/sunset-sky.exr, the environment map of scenes/sunset-fog.toml: haze's daylight
# model (Preetham et al. 1999; `haze sky --help`) with the sun 4 degrees above the horizon at
# azimuth 250 (towards -x, a little -z), turbidity 2.5, the sun folded into its texel, scaled by
# 0.05 to a comfortable exposure. 512 x 256 texels, about 0.7 MB.
set -eu
cd "$(dirname "$0")/.."
cargo run --release --quiet -- sky --elevation 4 --azimuth 250 --turbidity 2.5 \
    --ground-albedo 0.25 --resolution 512 --scale 0.05 -o media/sunset-sky.exr
