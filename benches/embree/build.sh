#!/usr/bin/env bash
# Builds the Embree harness of `haze bench rays` (benches/embree/rays.c) as target/embree-rays.
# Needs Debian's libembree-dev (Embree 3): apt-get install -y libembree-dev. A benchmark tool
# only: haze itself never links Embree.
set -euo pipefail
cd "$(dirname "$0")/../.."
if [ ! -f /usr/include/embree3/rtcore.h ]; then
    echo "needs Embree 3's headers: apt-get install -y libembree-dev" >&2
    exit 2
fi
mkdir -p target
cc -O2 -Wall -o target/embree-rays benches/embree/rays.c -lembree3 -lpthread -lm
echo "built target/embree-rays"
