#!/usr/bin/python3
"""Writes media/fire.vdb: a small smoke-and-fire simulation, with density and temperature grids.

Run with Debian's Python, numpy and pyopenvdb
(`apt-get install python3-openvdb python3-numpy`):

    /usr/bin/python3 media/make_fire.py

The simulation is the stable-fluids scheme of Stam ("Stable Fluids", SIGGRAPH 1999) on a
collocated grid, as Fedkiw, Stam and Jensen use it for smoke ("Visual Simulation of Smoke",
SIGGRAPH 2001): semi-Lagrangian advection (trilinear, backtraced one step), buoyancy from
temperature against the weight of the soot, vorticity confinement to keep the small swirls that
advection smooths away, and a pressure projection (Jacobi iterations) that makes the velocity
divergence-free. A hot, sooty source near the floor burns with a flicker from a fixed random
seed; temperature cools by radiation-like decay and soot dissipates slowly. Every step is
deterministic, so the file is the same on every run with the same numpy.

Grids: `density` (soot, about 0 to 1) and `temperature` (kelvin above ambient, 0 to about 2000),
both FloatGrid with voxels of 1/32 (the plume stands about 3 units tall), stored sparsely: only
voxels above a small threshold are active.
"""
import os
import sys

import numpy as np
import pyopenvdb as vdb

HERE = os.path.dirname(os.path.abspath(__file__))

# Grid (x, y, z) cells; y is up.
NX, NY, NZ = 64, 104, 64
STEPS = 150
DT = 0.6
JACOBI = 30
BUOYANCY = 0.0012   # per kelvin
WEIGHT = 0.02       # soot weight per unit density
VORTICITY = 2.5
COOLING = 0.08      # temperature decay rate per unit time
DISSIPATION = 0.003 # soot decay rate per unit time
SOURCE_T = 2000.0   # kelvin above ambient
SEED = 7


def sample(f, x, y, z):
    """Trilinear interpolation of f at fractional cell coordinates (clamped to the grid)."""
    nx, ny, nz = f.shape
    x = np.clip(x, 0.0, nx - 1.001)
    y = np.clip(y, 0.0, ny - 1.001)
    z = np.clip(z, 0.0, nz - 1.001)
    i, j, k = x.astype(np.int32), y.astype(np.int32), z.astype(np.int32)
    fx, fy, fz = x - i, y - j, z - k
    c000 = f[i, j, k]
    c100 = f[i + 1, j, k]
    c010 = f[i, j + 1, k]
    c110 = f[i + 1, j + 1, k]
    c001 = f[i, j, k + 1]
    c101 = f[i + 1, j, k + 1]
    c011 = f[i, j + 1, k + 1]
    c111 = f[i + 1, j + 1, k + 1]
    c00 = c000 + (c100 - c000) * fx
    c10 = c010 + (c110 - c010) * fx
    c01 = c001 + (c101 - c001) * fx
    c11 = c011 + (c111 - c011) * fx
    c0 = c00 + (c10 - c00) * fy
    c1 = c01 + (c11 - c01) * fy
    return c0 + (c1 - c0) * fz


def advect(fields, u, v, w, grid):
    """Semi-Lagrangian advection of each field by the velocity (cells per unit time)."""
    gx, gy, gz = grid
    x, y, z = gx - DT * u, gy - DT * v, gz - DT * w
    return [sample(f, x, y, z) for f in fields]


def gradient(p):
    """Central differences (one-sided at the walls)."""
    return np.gradient(p)


def project(u, v, w):
    """Removes the divergent part of the velocity: solve ∇²p = ∇·u (Jacobi), subtract ∇p."""
    div = np.zeros_like(u)
    div[1:-1, :, :] += 0.5 * (u[2:, :, :] - u[:-2, :, :])
    div[:, 1:-1, :] += 0.5 * (v[:, 2:, :] - v[:, :-2, :])
    div[:, :, 1:-1] += 0.5 * (w[:, :, 2:] - w[:, :, :-2])
    p = np.zeros_like(u)
    for _ in range(JACOBI):
        q = np.zeros_like(p)
        q[1:-1, 1:-1, 1:-1] = (
            p[2:, 1:-1, 1:-1]
            + p[:-2, 1:-1, 1:-1]
            + p[1:-1, 2:, 1:-1]
            + p[1:-1, :-2, 1:-1]
            + p[1:-1, 1:-1, 2:]
            + p[1:-1, 1:-1, :-2]
            - div[1:-1, 1:-1, 1:-1]
        ) / 6.0
        p = q
    gx, gy, gz = gradient(p)
    return u - gx, v - gy, w - gz


def curl(u, v, w):
    du = gradient(u)
    dv = gradient(v)
    dw = gradient(w)
    return dw[1] - dv[2], du[2] - dw[0], dv[0] - du[1]


def confine(u, v, w):
    """Vorticity confinement (Fedkiw et al. 2001): push along N × ω, N = ∇|ω| / |∇|ω||."""
    ox, oy, oz = curl(u, v, w)
    mag = np.sqrt(ox * ox + oy * oy + oz * oz)
    nx, ny, nz = gradient(mag)
    norm = np.sqrt(nx * nx + ny * ny + nz * nz) + 1e-6
    nx, ny, nz = nx / norm, ny / norm, nz / norm
    fx = ny * oz - nz * oy
    fy = nz * ox - nx * oz
    fz = nx * oy - ny * ox
    return u + DT * VORTICITY * fx, v + DT * VORTICITY * fy, w + DT * VORTICITY * fz


def simulate():
    rng = np.random.default_rng(SEED)
    shape = (NX, NY, NZ)
    d = np.zeros(shape, np.float32)
    t = np.zeros(shape, np.float32)
    u = np.zeros(shape, np.float32)
    v = np.zeros(shape, np.float32)
    w = np.zeros(shape, np.float32)
    grid = np.meshgrid(
        np.arange(NX, dtype=np.float32),
        np.arange(NY, dtype=np.float32),
        np.arange(NZ, dtype=np.float32),
        indexing="ij",
    )
    gx, gy, gz = grid
    # The burner: a flattened ball near the floor.
    cx, cy, cz = NX / 2, 8.0, NZ / 2
    r2 = ((gx - cx) / 13.0) ** 2 + ((gy - cy) / 4.0) ** 2 + ((gz - cz) / 13.0) ** 2
    burner = r2 < 1.0
    for step in range(STEPS):
        # Flickering source: per-step random strength and a random lateral kick.
        flicker = 0.75 + 0.5 * rng.random()
        jitter = rng.normal(size=burner.sum()).astype(np.float32)
        t[burner] = np.maximum(t[burner], SOURCE_T * flicker * (0.85 + 0.15 * np.tanh(jitter)))
        d[burner] = np.maximum(d[burner], 0.5 * flicker)
        # Turbulent inflow: a random velocity per burner cell.
        n = burner.sum()
        u[burner] += 0.8 * rng.normal(size=n).astype(np.float32)
        v[burner] += 0.4 * rng.normal(size=n).astype(np.float32)
        w[burner] += 0.8 * rng.normal(size=n).astype(np.float32)
        # Hot gas rises; soot weighs it down.
        v += DT * (BUOYANCY * t - WEIGHT * d)
        u, v, w = confine(u, v, w)
        u, v, w = advect([u, v, w], u, v, w, grid)
        u, v, w = project(u, v, w)
        d, t = advect([d, t], u, v, w, grid)
        t *= np.float32(np.exp(-COOLING * DT))
        d *= np.float32(np.exp(-DISSIPATION * DT))
        # Nothing leaves through the walls but the top: zero velocity at the other walls.
        for f in (u, v, w):
            f[0, :, :] = f[-1, :, :] = 0.0
            f[:, 0, :] = 0.0
            f[:, :, 0] = f[:, :, -1] = 0.0
        if step % 25 == 0:
            print(f"step {step}/{STEPS}: max density {d.max():.3f}, max T {t.max():.0f} K",
                  file=sys.stderr)
    return d, t


def to_grid(a, name, tolerance):
    g = vdb.FloatGrid(0.0)
    g.name = name
    g.copyFromArray(np.ascontiguousarray(a.astype(np.float32)), ijk=(0, 0, 0), tolerance=tolerance)
    g.transform = vdb.createLinearTransform(voxelSize=1.0 / 32.0)
    return g


def main():
    d, t = simulate()
    # Fade the outermost cells so the grids end smoothly inside their box.
    d[:2, :, :] = d[-2:, :, :] = 0.0
    d[:, :, :2] = d[:, :, -2:] = 0.0
    t[d <= 0.0] = 0.0
    grids = [to_grid(d, "density", 1e-3), to_grid(t, "temperature", 1.0)]
    path = os.path.join(HERE, "fire.vdb")
    vdb.write(path, grids=grids)
    active = [g.activeVoxelCount() for g in grids]
    print(f"wrote fire.vdb: {os.path.getsize(path)} bytes, active voxels {active}")


if __name__ == "__main__":
    main()
