#!/usr/bin/python3
"""Writes target/bench/sparse-1024.vdb: a float grid `density` whose active voxels span 1024³
but fill only about 3 % of that box — noisy blobs of smoke scattered through it, the shape of a
production explosion or cloud field — to measure haze's sparse layout (docs/performance.md,
"Grids"). Not committed (about 100 MB); made with Debian's Python, numpy and pyopenvdb:

    /usr/bin/python3 benches/make-sparse-grid.py [OUT.vdb]
"""
import os
import sys

import numpy as np
import pyopenvdb as vdb

N = 1024
BLOBS = 64
RADIUS = 52       # voxels; 64 blobs of radius 52 hold ~3 % of 1024³
SEED = 3


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(
        os.path.dirname(os.path.abspath(__file__)), "..", "target", "bench", "sparse-1024.vdb")
    rng = np.random.default_rng(SEED)
    g = vdb.FloatGrid(0.0)
    g.name = "density"
    g.transform = vdb.createLinearTransform(voxelSize=1.0 / 256.0)
    size = 2 * RADIUS + 1
    x = np.arange(size, dtype=np.float32) - RADIUS
    xx, yy, zz = np.meshgrid(x, x, x, indexing="ij")
    r = np.sqrt(xx * xx + yy * yy + zz * zz) / RADIUS
    for _ in range(BLOBS):
        corner = rng.integers(0, N - size, size=3)
        # A ball fading at its edge, with value noise at two scales.
        phase = rng.random(6) * 6.28
        noise = (np.sin(xx * 0.21 + phase[0]) * np.sin(yy * 0.17 + phase[1]) * np.sin(zz * 0.19 + phase[2])
                 + 0.5 * np.sin(xx * 0.53 + phase[3]) * np.sin(yy * 0.47 + phase[4]) * np.sin(zz * 0.61 + phase[5]))
        d = np.clip(1.0 - r + 0.25 * noise, 0.0, None).astype(np.float32)
        d[r > 1.0] = 0.0
        # Add to what is there (blobs may overlap).
        block = np.zeros_like(d)
        g.copyToArray(block, ijk=tuple(int(c) for c in corner))
        g.copyFromArray(np.maximum(block, d), ijk=tuple(int(c) for c in corner), tolerance=0.0)
    # The box's far corners, so that the active voxels span 1024³.
    acc = g.getAccessor()
    acc.setValueOn((0, 0, 0), 0.5)
    acc.setValueOn((N - 1, N - 1, N - 1), 0.5)
    os.makedirs(os.path.dirname(out), exist_ok=True)
    vdb.write(out, grids=[g])
    active = g.activeVoxelCount()
    print(f"wrote {out}: {os.path.getsize(out)} bytes, {active} active voxels "
          f"({100 * active / N**3:.2f} % of {N}³)")


if __name__ == "__main__":
    main()
