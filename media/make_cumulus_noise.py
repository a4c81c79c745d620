#!/usr/bin/python3
"""Writes media/cumulus-noise.vdb: a cumulus cloud 591 voxels across shaped by noise, not by
spheres, with billowed tops, wispy edges and a flat base, stored sparsely in half floats.

Run with Debian's Python, numpy and pyopenvdb
(`apt-get install python3-openvdb python3-numpy`):

    /usr/bin/python3 media/make_cumulus_noise.py      # about 90 s, 2 GB of memory

The recipe is the one cloud-modelling papers and game engines use (Schneider, "The real-time
volumetric cloudscapes of Horizon Zero Dawn", SIGGRAPH 2015 course; Hillaire 2016): a smooth base
shape, pushed out at low frequency into billows, then eroded at high frequency into wisps. Here:

1. **Base shape**: the signed distance to a smooth union (polynomial smooth minimum over 24
   voxels) of flattened ellipsoids stacked as cumulus towers grow: a broad base of eight lobes,
   three towers that narrow as they rise, turrets budding off their sides. Smooth, so the towers
   merge without seams; computed on every second voxel and upsampled.
2. **Billows**: the surface is moved outwards by round lumps at four scales (sphere-capped
   inverted Worley noise, cells of about 100, 50, 25 and 12 voxels, tileable 128^3 textures
   sampled trilinearly), stronger higher up where the cloud grows, and by a large Perlin fBm
   warp: the cauliflower of a growing cumulus.
3. **Wisps**: near the surface the distance is eroded by three octaves of inverted Worley noise,
   billowy on top and turned inside out (1 - w) towards the base, where the eroded edge frays
   into strands.
4. **A flat base** at the condensation level: the density is cut by a ramp 3 voxels high.

The density rises from 0 at the surface to 1 six voxels inside and is exactly 1 deeper in,
which OpenVDB prunes into tiles, so the file holds the surface shell; it is written in half
floats. Voxels of 1/200 (the cloud is 591 voxels, about 2.95 units, wide, like cumulus.vdb's 280
voxels of 1/100). Deterministic (fixed seed; two runs' files differ only in the 36-byte UUID
OpenVDB writes into every file's header). Also writes the `vdb` fuzz target's seed
tests/fuzz-corpus/vdb/cumulus-noise-piece.vdb, a 40^3 piece of the cloud's top.
"""
import os
import time

import numpy as np
import pyopenvdb as vdb

HERE = os.path.dirname(os.path.abspath(__file__))
NX, NY, NZ = 640, 400, 480  # grid box (x, y up, z); the cloud spans about 576 x 330 x 420
VOXEL = 1.0 / 200.0
SEED = 23
TILE = 128  # tileable noise textures are TILE^3
BASE_Y = 28.0  # condensation level, in voxels
SMOOTH = 24.0  # voxels over which the base shape's blobs blend
# Billows (texture's cells, voxels a texture spans, voxels of displacement): round lumps of
# about 100, 50, 25 and 12 voxels.
BILLOWS = [(4, 400.0, 26.0), (8, 400.0, 13.0), (4, 100.0, 6.0), (8, 100.0, 3.0)]
WARP = 14.0  # voxels of large-scale Perlin warp
EROSION = 9.0  # voxels deep the Worley fBm eats into the surface
RAMP = 6.0  # voxels over which density rises from 0 to 1 inside the surface
SLAB = 32  # x-slices per batch (bounds memory)


def perlin_tile(rng, period):
    """Tileable 3-D gradient noise on TILE^3 points with `period` lattice cells across, in
    about [-1, 1]."""
    g = rng.normal(size=(period, period, period, 3)).astype(np.float32)
    g /= np.linalg.norm(g, axis=-1, keepdims=True)
    c = (np.arange(TILE, dtype=np.float32) + 0.5) * period / TILE
    i0 = np.floor(c).astype(np.int32)
    f = c - i0
    fx, fy, fz = np.meshgrid(f, f, f, indexing="ij")
    ix, iy, iz = np.meshgrid(i0, i0, i0, indexing="ij")
    out = np.zeros((TILE,) * 3, np.float32)
    fade = lambda t: t * t * t * (t * (t * 6 - 15) + 10)  # noqa: E731
    ux, uy, uz = fade(fx), fade(fy), fade(fz)
    for dx in (0, 1):
        for dy in (0, 1):
            for dz in (0, 1):
                gv = g[(ix + dx) % period, (iy + dy) % period, (iz + dz) % period]
                dot = gv[..., 0] * (fx - dx) + gv[..., 1] * (fy - dy) + gv[..., 2] * (fz - dz)
                w = (ux if dx else 1 - ux) * (uy if dy else 1 - uy) * (uz if dz else 1 - uz)
                out += w * dot
    return out * 1.6


def worley_tile(rng, cells, cap=False):
    """Tileable inverted Worley noise on TILE^3 points with `cells` cells across: 1 - F1, F1
    the distance to the nearest feature point in cell widths (clamped to [0, 1]), or with `cap`
    the height of a unit sphere there, sqrt(1 - F1^2): round lumps with creases between them."""
    pts = rng.uniform(size=(cells, cells, cells, 3)).astype(np.float32)
    c = (np.arange(TILE, dtype=np.float32) + 0.5) * cells / TILE
    i0 = np.floor(c).astype(np.int32)
    f = c - i0
    fx, fy, fz = np.meshgrid(f, f, f, indexing="ij")
    ix, iy, iz = np.meshgrid(i0, i0, i0, indexing="ij")
    best = np.full((TILE,) * 3, 9.0, np.float32)
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            for dz in (-1, 0, 1):
                p = pts[(ix + dx) % cells, (iy + dy) % cells, (iz + dz) % cells]
                d2 = (p[..., 0] + dx - fx) ** 2 + (p[..., 1] + dy - fy) ** 2 \
                    + (p[..., 2] + dz - fz) ** 2
                np.minimum(best, d2, out=best)
    if cap:
        return np.sqrt(np.clip(1.0 - best, 0.0, 1.0))
    return np.clip(1.0 - np.sqrt(best), 0.0, 1.0)


def lookup(tile, x, y, z):
    """Trilinear, wrapping lookup of a TILE^3 texture at coordinates in texels."""
    i, j, k = np.floor(x), np.floor(y), np.floor(z)
    fx, fy, fz = x - i, y - j, z - k
    i, j, k = i.astype(np.int64) % TILE, j.astype(np.int64) % TILE, k.astype(np.int64) % TILE
    i1, j1, k1 = (i + 1) % TILE, (j + 1) % TILE, (k + 1) % TILE
    flat = tile.ravel()
    at = lambda a, b, c: flat[(a * TILE + b) * TILE + c]  # noqa: E731
    c00 = at(i, j, k) * (1 - fx) + at(i1, j, k) * fx
    c10 = at(i, j1, k) * (1 - fx) + at(i1, j1, k) * fx
    c01 = at(i, j, k1) * (1 - fx) + at(i1, j, k1) * fx
    c11 = at(i, j1, k1) * (1 - fx) + at(i1, j1, k1) * fx
    return (c00 * (1 - fy) + c10 * fy) * (1 - fz) + (c01 * (1 - fy) + c11 * fy) * fz


def upsample2(a, shape):
    """Linear upsampling by 2 along every axis (a's sample i sits at voxel 2i), to `shape`."""
    out = a
    for axis, n in enumerate(shape):
        m = out.shape[axis]
        x = np.arange(n, dtype=np.float32) / 2.0
        i = np.minimum(x.astype(np.int32), m - 2)
        f = (x - i).reshape([-1 if ax == axis else 1 for ax in range(3)])
        lo = np.take(out, i, axis=axis)
        out = lo + (np.take(out, i + 1, axis=axis) - lo) * f
    return out.astype(np.float32)


def blobs(rng):
    """Flattened ellipsoids (centre x, y, z, horizontal radius, vertical radius) in voxels: a
    broad base, three towers that narrow as they rise, turrets budding off their sides."""
    out = []
    for cx, cz, r in [(170, 250, 110), (300, 215, 125), (440, 245, 110), (300, 310, 100),
                      (240, 165, 85), (380, 170, 85), (100, 235, 65), (530, 225, 65)]:
        out.append((cx, BASE_Y + 40, cz, r, 50))
    for cx, cz, top, r0 in [(305, 230, 320, 100), (170, 255, 190, 72), (440, 240, 240, 78)]:
        y, r, x, z = BASE_Y + 80.0, float(r0), float(cx), float(cz)
        lean = rng.normal(size=2) * 5.0
        while y < BASE_Y + top - 0.6 * r:
            out.append((x, y, z, r, 0.85 * r))
            for _ in range(2):
                a = rng.uniform(0, 2 * np.pi)
                out.append((x + 0.7 * r * np.cos(a), y + 0.25 * r, z + 0.7 * r * np.sin(a),
                            0.5 * r, 0.45 * r))
            y += 0.5 * r
            r *= 0.84
            x += lean[0]
            z += lean[1]
    return out


def base_sdf(rng):
    """Signed distance (voxels, negative inside) to the smooth union of the blobs: computed on
    every second voxel and upsampled (the shape is smooth at that scale)."""
    hx, hy, hz = (NX + 1) // 2 + 1, (NY + 1) // 2 + 1, (NZ + 1) // 2 + 1
    x = np.arange(hx, dtype=np.float32)[:, None, None] * 2.0
    y = np.arange(hy, dtype=np.float32)[None, :, None] * 2.0
    z = np.arange(hz, dtype=np.float32)[None, None, :] * 2.0
    d = np.full((hx, hy, hz), 1e4, np.float32)
    for cx, cy, cz, rh, rv in blobs(rng):
        t = np.sqrt(((x - cx) / rh) ** 2 + ((y - cy) / rv) ** 2 + ((z - cz) / rh) ** 2)
        e = (t - 1.0) * min(rh, rv)
        # Polynomial smooth minimum: blobs merge over SMOOTH voxels, without a seam.
        h = np.clip(0.5 + 0.5 * (d - e) / SMOOTH, 0.0, 1.0)
        d = d * (1.0 - h) + e * h - SMOOTH * h * (1.0 - h)
    return upsample2(d, (NX, NY, NZ))


def preview(density):
    """With PREVIEW=PREFIX in the environment, saves the density's middle z slice and its sum
    along z (a shadowgraph) as PREFIX-mid.npy and PREFIX-depth.npy, for a quick look."""
    if os.environ.get("PREVIEW"):
        np.save(os.environ["PREVIEW"] + "-mid.npy", density[:, :, density.shape[2] // 2])
        np.save(os.environ["PREVIEW"] + "-depth.npy", density.sum(axis=2))


def write_half(path, density):
    """Writes `density` as a sparse FloatGrid named density, pruned, in half floats, atomically;
    returns the grid."""
    g = vdb.FloatGrid(0.0)
    g.name = "density"
    g.copyFromArray(density, ijk=(0, 0, 0), tolerance=1e-3)
    g.prune(tolerance=0.0)
    g.transform = vdb.createLinearTransform(voxelSize=VOXEL)
    g.saveFloatAsHalf = True
    vdb.write(path + ".tmp", grids=[g])
    os.replace(path + ".tmp", path)
    return g


def main():
    t0 = time.time()
    rng = np.random.default_rng(SEED)
    sdf = base_sdf(rng)
    print(f"base shape in {time.time() - t0:.1f} s")
    # Noise textures: round lumps (sphere-capped Worley) at two cell counts, Perlin fBm for a
    # large, irregular warp, Worley fBm for the erosion.
    lumps4, lumps8 = worley_tile(rng, 4, cap=True), worley_tile(rng, 8, cap=True)
    perlin = sum(a * perlin_tile(rng, p) for a, p in ((1.0, 4), (0.5, 8), (0.25, 16))) / 1.75
    detail = (0.625 * worley_tile(rng, 8) + 0.25 * worley_tile(rng, 16)
              + 0.125 * worley_tile(rng, 32))
    print(f"noise textures in {time.time() - t0:.1f} s")

    density = np.zeros((NX, NY, NZ), np.float32)
    reach = sum(a for _, _, a in BILLOWS) + WARP + 2.0
    for x0 in range(0, NX, SLAB):
        s = sdf[x0:x0 + SLAB]
        near = s < reach
        if not near.any():
            continue
        ii, jj, kk = np.nonzero(near)
        fx, fy, fz = (ii + x0).astype(np.float32), jj.astype(np.float32), kk.astype(np.float32)
        d = s[near]
        h = np.clip((fy - BASE_Y) / 200.0, 0.0, 1.0)
        # Billows: lumps at four scales, stronger on the upper, growing parts.
        grow = 0.35 + 0.65 * h
        for tile, span, amp in BILLOWS:
            k = TILE / span
            lump = lookup(lumps4 if tile == 4 else lumps8, fx * k, fy * k, fz * k)
            d -= grow * amp * (lump - 0.7) * 2.0
        k = TILE / 500.0
        d -= WARP * lookup(perlin, fx * k + 37.0, fy * k, fz * k)
        # Erosion near the surface: billowy above, wispy (inverted) towards the base.
        k = TILE / 96.0
        w = lookup(detail, fx * k, fy * k, fz * k)
        w = h * w + (1.0 - h) * (1.0 - w)
        edge = np.clip(1.0 + d / (2.0 * RAMP), 0.0, 1.0)
        d += EROSION * edge * w
        # The flat base: a ramp 3 voxels high at the condensation level.
        base = np.clip((fy - BASE_Y) / 3.0, 0.0, 1.0)
        out = np.zeros(s.shape, np.float32)
        out[near] = np.clip(-d / RAMP, 0.0, 1.0) * base
        density[x0:x0 + SLAB] = out
    del sdf
    density[:2] = density[-2:] = 0.0
    density[:, :2] = density[:, -2:] = 0.0
    density[:, :, :2] = density[:, :, -2:] = 0.0
    occupied = np.nonzero(density.max(axis=(1, 2)) > 0)[0]
    print(f"density in {time.time() - t0:.1f} s; x extent {occupied.min()}..{occupied.max()} "
          f"({occupied.max() - occupied.min() + 1} voxels), "
          f"{np.count_nonzero(density)} nonzero, {np.count_nonzero(density == 1.0)} at 1")
    path = os.path.join(HERE, "cumulus-noise.vdb")
    g = write_half(path, density)
    # The fuzz seed: a 40^3 piece of the eroded shell near the top, written the same way.
    top = np.nonzero(density.max(axis=(0, 2)) > 0)[0].max()
    cx = int(np.argmax(density[:, top - 30, :].sum(axis=1)))
    cz = int(np.argmax(density[cx, top - 30, :]))
    piece = np.ascontiguousarray(density[cx - 20:cx + 20, top - 36:top + 4, cz - 20:cz + 20])
    crop = os.path.join(HERE, "..", "tests", "fuzz-corpus", "vdb", "cumulus-noise-piece.vdb")
    c = write_half(crop, piece)
    print(f"wrote the fuzz seed cumulus-noise-piece.vdb: {os.path.getsize(crop)} bytes, "
          f"{c.activeVoxelCount()} active voxels")
    preview(density)
    print(f"wrote cumulus-noise.vdb: {os.path.getsize(path)} bytes, {g.activeVoxelCount()} "
          f"active voxels, {g.leafCount()} leaves, {time.time() - t0:.1f} s")


if __name__ == "__main__":
    main()
