#!/usr/bin/python3
"""Writes media/cumulus.vdb: a cumulus cloud about 280 voxels across, with fractal detail on its
surface and a flat base, stored sparsely.

Run with Debian's Python, numpy and pyopenvdb
(`apt-get install python3-openvdb python3-numpy`):

    /usr/bin/python3 media/make_cumulus.py

Shape: a union of spheres piled as cumulus towers grow (wide at the base, smaller turrets on top),
its signed distance displaced by fractal (fBm) value noise of five octaves — the billows whose
edges catch the sun — and cut off below a flat condensation level. Density rises from 0 at the
surface to 1 a few voxels inside; deeper in it is exactly 1, which OpenVDB prunes into tiles, so
the file holds mostly the surface shell (about 1 % of the cloud's voxels are not constant
tiles). Voxels of 1/100 (the cloud is about 2.8 units wide). Deterministic (fixed seed).
"""
import os

import numpy as np
import pyopenvdb as vdb

HERE = os.path.dirname(os.path.abspath(__file__))
NX, NY, NZ = 352, 224, 264
SCALE = 1.1  # the sphere layout below, scaled
SEED = 11
EDGE = 4.0  # voxels over which density rises from 0 to 1 inside the surface


def upsample(lat, shape):
    """Trilinear upsampling of a small lattice to `shape` (separable linear interpolation)."""
    out = lat
    for axis, n in enumerate(shape):
        m = out.shape[axis]
        x = np.linspace(0.0, m - 1.0, n, dtype=np.float32)
        i = np.minimum(x.astype(np.int32), m - 2)
        f = (x - i).reshape([-1 if a == axis else 1 for a in range(3)])
        a = np.take(out, i, axis=axis)
        b = np.take(out, i + 1, axis=axis)
        out = a + (b - a) * f
    return out.astype(np.float32)


def fbm(shape, rng, base=6, octaves=5):
    """Fractal value noise in about [-1, 1]: octaves of lattice noise, each twice as fine and
    half as strong."""
    total = np.zeros(shape, np.float32)
    amp, norm = 1.0, 0.0
    for o in range(octaves):
        cells = [max(2, int(base * 2 ** o * s / max(shape))) + 2 for s in shape]
        lat = rng.uniform(-1.0, 1.0, size=cells).astype(np.float32)
        total += amp * upsample(lat, shape)
        norm += amp
        amp *= 0.5
    return total / norm


def main():
    rng = np.random.default_rng(SEED)
    x, y, z = np.meshgrid(
        np.arange(NX, dtype=np.float32),
        np.arange(NY, dtype=np.float32),
        np.arange(NZ, dtype=np.float32),
        indexing="ij",
    )
    # Spheres (centre x, y, z, radius) in voxels: a broad base, towers, turrets.
    spheres = [
        (110, 55, 120, 55), (170, 60, 110, 62), (225, 55, 125, 50), (150, 50, 160, 52),
        (140, 95, 115, 48), (190, 100, 125, 45), (165, 130, 120, 36), (120, 115, 135, 30),
        (205, 135, 105, 28), (175, 160, 125, 24), (80, 60, 105, 38), (250, 60, 100, 34),
    ]
    sdf = np.full((NX, NY, NZ), 1e9, np.float32)
    for cx, cy, cz, r in spheres:
        cx, cy, cz, r = (v * SCALE for v in (cx, cy, cz, r))
        d = np.sqrt((x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2) - r
        sdf = np.minimum(sdf, d)
    del x, z
    # Billows: displace the surface by fBm, strongest on the upper, sunlit parts.
    noise = fbm((NX, NY, NZ), rng)
    sdf -= 16.0 * noise * np.clip((y - 20.0) / 60.0, 0.3, 1.0)
    # A flat base at the condensation level.
    sdf = np.maximum(sdf, 20.0 - y)
    density = np.clip(-sdf / EDGE, 0.0, 1.0).astype(np.float32)
    density[:2] = density[-2:] = 0.0
    density[:, :2] = density[:, -2:] = 0.0
    density[:, :, :2] = density[:, :, -2:] = 0.0
    g = vdb.FloatGrid(0.0)
    g.name = "density"
    g.copyFromArray(density, ijk=(0, 0, 0), tolerance=1e-3)
    g.prune(tolerance=0.0)
    g.transform = vdb.createLinearTransform(voxelSize=0.01)
    path = os.path.join(HERE, "cumulus.vdb")
    vdb.write(path, grids=[g])
    print(f"wrote cumulus.vdb: {os.path.getsize(path)} bytes, {g.activeVoxelCount()} active "
          f"voxels, {g.leafCount()} leaves")


if __name__ == "__main__":
    main()
