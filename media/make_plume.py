#!/usr/bin/python3
"""Writes media/smoke-plume.vdb: a rising smoke plume with turbulent detail, density and
temperature grids, by curl-noise advection.

Run with Debian's Python, numpy and pyopenvdb
(`apt-get install python3-openvdb python3-numpy`):

    /usr/bin/python3 media/make_plume.py      # about six minutes

No fluid solve: the velocity is a prescribed plume plus divergence-free turbulence, the curl of a
noise potential (Bridson, Hourihan and Nordenstam, "Curl-noise for procedural fluid flow",
SIGGRAPH 2007), and smoke and heat are carried by it with semi-Lagrangian advection
(media/make_fire.py's trilinear `sample`). The plume: an upward jet of Gaussian profile whose
width grows linearly with height while its speed falls (a buoyant plume's self-similar spread),
with the outward drift that spread implies. The turbulence: the curl of three tileable Perlin
potentials (media/make_cumulus_noise.py's textures) at two scales, scrolled upwards with the flow
and drifting in time, its strength growing with height — eddies that roll the plume's edges and
make it meander. The source, a flattened ball on the ground, puffs: its strength follows a slow
random pulse, so the column is a train of billows. Smoke fades slowly, heat faster; both are
let out through the top. Deterministic (fixed seed).

Grids: `density` (soot, 0 to about 1) and `temperature` (kelvin above ambient, 0 to 600), voxels
of 1/48, only voxels above small thresholds active, in half floats. Also writes the `vdb` fuzz
target's seed tests/fuzz-corpus/vdb/smoke-plume-piece.vdb, a 20^3 piece of both grids.
"""
import os
import sys
import time

import numpy as np
import pyopenvdb as vdb

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from make_cumulus_noise import TILE, lookup, perlin_tile, preview  # noqa: E402
from make_fire import sample  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
NX, NY, NZ = 112, 256, 112
VOXEL = 1.0 / 48.0
STEPS = 320
SPEED = 1.6  # the jet's speed at the source, cells per step
R0 = 9.0  # the jet's radius at the source, cells
SPREAD = 0.08  # radius growth per cell of height
TURB = 1.1  # turbulence, cells per step at the top
SOURCE_T = 600.0
COOLING = 0.012  # per step
FADE = 0.0008  # soot lost per step
SPONGE = 16  # cells at the top over which smoke leaves
SEED = 29


def velocity(psi, step, rng_offsets):
    """The plume's velocity (u, v, w) in cells per step at every cell, computed on every second
    cell and upsampled."""
    hx, hy, hz = NX // 2 + 1, NY // 2 + 1, NZ // 2 + 1
    x, y, z = np.meshgrid(np.arange(hx, dtype=np.float32) * 2, np.arange(hy, dtype=np.float32) * 2,
                          np.arange(hz, dtype=np.float32) * 2, indexing="ij")
    cx, cz = NX / 2.0, NZ / 2.0
    radius = R0 + SPREAD * y
    r2 = ((x - cx) ** 2 + (z - cz) ** 2) / radius ** 2
    up = SPEED * np.sqrt(R0 / radius) * np.exp(-r2)
    # The outward drift of a spreading plume: r/R grows by SPREAD per cell of rise.
    drift = up * SPREAD / radius
    u, v, w = drift * (x - cx), up, drift * (z - cz)
    # Turbulence: curl of a potential scrolled upwards with the flow, at two scales.
    grow = TURB * (0.25 + 0.75 * y / NY)
    for scale, amp in ((96.0, 1.0), (40.0, 0.45)):
        k = TILE / scale
        rise = step * SPEED * 0.6
        comps = []
        for c in range(3):
            ox, oy, oz = rng_offsets[c]
            comps.append(lookup(psi[c], (x + ox) * k, (y - rise + oy + 0.2 * step) * k,
                                (z + oz) * k))
        # curl (a, b, c) = (dc/dy - db/dz, da/dz - dc/dx, db/dx - da/dy), per cell of 2.
        a, b, c = comps
        da, db, dc = np.gradient(a, 2.0), np.gradient(b, 2.0), np.gradient(c, 2.0)
        s = grow * amp * scale / (2 * np.pi)
        u = u + s * (dc[1] - db[2])
        v = v + s * (da[2] - dc[0])
        w = w + s * (db[0] - da[1])
    gx, gy, gz = np.meshgrid(np.arange(NX, dtype=np.float32) / 2, np.arange(NY, dtype=np.float32) / 2,
                             np.arange(NZ, dtype=np.float32) / 2, indexing="ij")
    return [sample(f.astype(np.float32), gx, gy, gz) for f in (u, v, w)]


def write(path, d, t):
    """Writes density `d` and temperature `t` as sparse half-float grids, atomically."""
    grids = []
    for name, a, tol in (("density", d, 1e-3), ("temperature", t, 1.0)):
        g = vdb.FloatGrid(0.0)
        g.name = name
        g.copyFromArray(np.ascontiguousarray(a), ijk=(0, 0, 0), tolerance=tol)
        g.transform = vdb.createLinearTransform(voxelSize=VOXEL)
        g.saveFloatAsHalf = True
        grids.append(g)
    vdb.write(path + ".tmp", grids=grids)
    os.replace(path + ".tmp", path)
    return grids


def write_piece(d, t):
    """The vdb fuzz target's seed: a 20^3 piece of both grids above the source, where the
    plume's eddies begin."""
    cx, cz = NX // 2, NZ // 2
    cut = (slice(cx - 10, cx + 10), slice(30, 50), slice(cz - 10, cz + 10))
    seed = os.path.join(HERE, "..", "tests", "fuzz-corpus", "vdb", "smoke-plume-piece.vdb")
    write(seed, d[cut], t[cut])


def main():
    t0 = time.time()
    rng = np.random.default_rng(SEED)
    psi = [perlin_tile(rng, 4) + 0.5 * perlin_tile(rng, 8) for _ in range(3)]
    offsets = rng.uniform(0, 1000, size=(3, 3))
    shape = (NX, NY, NZ)
    d = np.zeros(shape, np.float32)
    t = np.zeros(shape, np.float32)
    gx, gy, gz = np.meshgrid(np.arange(NX, dtype=np.float32), np.arange(NY, dtype=np.float32),
                             np.arange(NZ, dtype=np.float32), indexing="ij")
    cx, cz = NX / 2.0, NZ / 2.0
    burner = ((gx - cx) / R0) ** 2 + ((gy - 5.0) / 4.0) ** 2 + ((gz - cz) / R0) ** 2 < 1.0
    pulse = 1.0
    ramp = np.linspace(1.0, 0.0, SPONGE, dtype=np.float32)[None, :, None]
    for step in range(STEPS):
        if step % 3 == 0:
            u, v, w = velocity(psi, step, offsets)
        # A slow random pulse between about 0.3 and 1: puffs.
        pulse = float(np.clip(pulse + 0.25 * rng.normal(), 0.3, 1.0))
        d[burner] = np.maximum(d[burner], pulse)
        t[burner] = np.maximum(t[burner], SOURCE_T * pulse)
        x, y, z = gx - u, gy - v, gz - w
        d, t = sample(d, x, y, z), sample(t, x, y, z)
        d *= np.float32(1.0 - FADE)
        t *= np.float32(1.0 - COOLING)
        d[:, -SPONGE:, :] *= ramp
        t[:, -SPONGE:, :] *= ramp
        if step % 50 == 0:
            print(f"step {step}/{STEPS}: max density {d.max():.3f}, {time.time() - t0:.0f} s",
                  file=sys.stderr)
    for f in (d, t):
        f[:2] = f[-2:] = 0.0
        f[:, :, :2] = f[:, :, -2:] = 0.0
        f[:, -2:] = 0.0
    t[d <= 1e-3] = 0.0
    path = os.path.join(HERE, "smoke-plume.vdb")
    grids = write(path, d, t)
    write_piece(d, t)
    preview(d)
    print(f"wrote smoke-plume.vdb: {os.path.getsize(path)} bytes, active voxels "
          f"{[g.activeVoxelCount() for g in grids]}, {time.time() - t0:.0f} s")


if __name__ == "__main__":
    main()
