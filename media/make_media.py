#!/usr/bin/python3
"""Writes haze's OpenVDB test and demo assets with the real OpenVDB library.

Run with Debian's Python and pyopenvdb (`apt-get install python3-openvdb libopenvdb-tools`):

    /usr/bin/python3 media/make_media.py

Every grid is a FloatGrid named "density" unless stated; world units are the scene's. The files
in bad/ are deliberately broken in the ways vdb-rs 0.6 mishandles (see media/README.md).
"""
import math
import os

import pyopenvdb as vdb

HERE = os.path.dirname(os.path.abspath(__file__))


def grid(name="density", voxel=1.0 / 32.0, origin=(0.0, 0.0, 0.0)):
    g = vdb.FloatGrid(0.0)
    g.name = name
    t = vdb.createLinearTransform(voxelSize=voxel)
    t.translate(origin)
    g.transform = t
    return g


def set_voxels(g, size, density):
    """Sets voxel (i, j, k) for 0 <= i, j, k < size to density(i, j, k) where it is non-zero."""
    acc = g.getAccessor()
    nx, ny, nz = size
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                d = density(i, j, k)
                if d != 0.0:
                    acc.setValueOn((i, j, k), d)


def write(path, grids):
    full = os.path.join(HERE, path)
    os.makedirs(os.path.dirname(full), exist_ok=True)
    vdb.write(full, grids=grids)
    print("wrote", path, os.path.getsize(full), "bytes")


def noise(x, y, z):
    """Smooth deterministic value in [-1, 1]: a sum of sines at incommensurate frequencies."""
    v = 0.0
    amp = 1.0
    for octave in range(4):
        f = 2.0 ** octave
        v += amp * math.sin(f * 5.1 * x + 1.3 * octave) * math.sin(f * 4.3 * y + 0.7) * math.sin(
            f * 6.7 * z + 2.1 * octave
        )
        amp *= 0.5
    return v / 1.875


def cloud(i, j, k, n=64):
    # A puffy ball of radius ~0.85 (in units of the grid's half-width) with a noisy surface.
    x, y, z = (2.0 * (i + 0.5) / n - 1.0, 2.0 * (j + 0.5) / n - 1.0, 2.0 * (k + 0.5) / n - 1.0)
    r = math.sqrt(x * x + 1.4 * y * y + z * z)
    d = (0.85 + 0.25 * noise(x, y, z)) - r
    if d <= 0.0:
        return 0.0
    return min(1.0, 4.0 * d) * (0.6 + 0.4 * noise(2 * x + 3, 2 * y, 2 * z))


def tiles():
    """5. Constant regions stored as OpenVDB tiles (whole 8^3 leaves and a 128^3 internal node
    of one value, no voxels), beside single voxels: 2.0 over [0, 32)^3 by a sparse fill, 0.5 over
    [128, 256)^3, and voxels of density 3 along a line from (40, 4, 4). Voxel 1/32."""
    g = grid(voxel=1.0 / 32.0)
    g.fill((0, 0, 0), (31, 31, 31), 2.0, True)
    g.fill((128, 128, 128), (255, 255, 255), 0.5, True)
    acc = g.getAccessor()
    for i in range(40, 60):
        acc.setValueOn((i, 4, 4), 3.0)
    write("tiles.vdb", [g])


def half():
    """Half-float copies (16-bit values, OpenVDB's saveFloatAsHalf), which vdb-rs 0.6 misreads
    and haze decodes itself: cloud.vdb with each codec OpenVDB writes (vdb_tool from Debian's
    libopenvdb-tools, `bits=16`), tiles.vdb (tiles as half floats), and a small grid from
    pyopenvdb's own saveFloatAsHalf with the library's default codec (Blosc)."""
    import subprocess

    for src, codec in [("cloud", "zip"), ("cloud", "blosc"), ("cloud", "none"), ("tiles", "blosc")]:
        out = os.path.join(HERE, f"half/{src}-{codec}.vdb")
        os.makedirs(os.path.dirname(out), exist_ok=True)
        subprocess.run(
            ["vdb_tool", "-read", os.path.join(HERE, f"{src}.vdb"), "-write", f"codec={codec}",
             "bits=16", out],
            check=True, stdout=subprocess.DEVNULL,
        )
        print("wrote", os.path.relpath(out, HERE), os.path.getsize(out), "bytes")
    g = grid(voxel=1.0 / 16.0)
    set_voxels(g, (8, 8, 8), lambda i, j, k: 0.5)
    g.saveFloatAsHalf = True
    write("half/cube.vdb", [g])


def box_with_vector(name, colour, lo=0, hi=16, as_half=False):
    """box.vdb's constant density (16^3 voxels of 1/16) beside a 3-vector grid `name` holding
    colour(i, j, k) on the voxels lo <= i, j, k < hi."""
    g = grid(voxel=1.0 / 16.0)
    set_voxels(g, (16, 16, 16), lambda i, j, k: 1.0)
    v = vdb.Vec3SGrid((0.0, 0.0, 0.0))
    v.name = name
    v.transform = vdb.createLinearTransform(voxelSize=1.0 / 16.0)
    acc = v.getAccessor()
    for i in range(lo, hi):
        for j in range(lo, hi):
            for k in range(lo, hi):
                acc.setValueOn((i, j, k), tuple(colour(i, j, k)))
    v.saveFloatAsHalf = as_half
    return [g, v]


def vector():
    """albedo.vdb's three channels as one 3-vector grid `albedo` beside its density, as Houdini
    and Blender write colour (`Cd`, `color`): vector.vdb in full floats and half/vector.vdb in
    half floats (saveFloatAsHalf: 6 bytes a value)."""
    def albedo(i, j, k):
        return (0.1 + 0.8 * i / 15.0, 0.9 - 0.8 * j / 15.0, 0.1 + 0.8 * k / 15.0)

    for path, as_half in [("vector.vdb", False), ("half/vector.vdb", True)]:
        write(path, box_with_vector("albedo", albedo, as_half=as_half))


def tinted():
    """box.vdb's constant density beside a constant 3-vector grid `tint` = (0.4, 1, 2) over the
    same voxels: an extinction colour that is the same everywhere, so that a grid medium coloured
    by it equals a homogeneous medium of coloured coefficients (tinted.vdb)."""
    write("tinted.vdb", box_with_vector("tint", lambda i, j, k: (0.4, 1.0, 2.0)))


def hue():
    """box.vdb's density beside a 3-vector grid `hue` that is linear in space (R rising along x,
    G along y, B falling along z, between about 0.3 and 2) on the density's voxels and one voxel
    beyond them on every side: an extinction colour that varies in space yet is smooth where the
    density falls to zero, so that haze's density x colour equals the trilinear product that
    Mitsuba 3's RGB extinction volume interpolates (docs/mitsuba; hue.vdb)."""
    def colour(i, j, k):
        return (0.4 + 0.1 * i, 0.3 + 0.1 * j, 2.0 - 0.1 * k)

    write("hue.vdb", box_with_vector("hue", colour, lo=-1, hi=17))


def main():
    # 1. A smooth procedural cloud, 64^3 voxels over [-1, 1]^3 (voxel 1/32).
    g = grid(voxel=1.0 / 32.0, origin=(-1.0, -1.0, -1.0))
    set_voxels(g, (64, 64, 64), lambda i, j, k: max(0.0, cloud(i, j, k)))
    write("cloud.vdb", [g])

    # 2. Constant density 1 in the box [0, 1]^3 (16^3 voxels of 1/16).
    g = grid(voxel=1.0 / 16.0)
    set_voxels(g, (16, 16, 16), lambda i, j, k: 1.0)
    write("box.vdb", [g])

    # 2b. The same box with a single-scattering albedo that varies linearly along each axis, one
    #     float grid per channel (vdb-rs reads no vector grids): R rises along x, G falls along
    #     y, B rises along z, each within [0.1, 0.9] at voxel centres.
    g = grid(voxel=1.0 / 16.0)
    set_voxels(g, (16, 16, 16), lambda i, j, k: 1.0)
    channels = [
        ("albedo.r", lambda i, j, k: 0.1 + 0.8 * i / 15.0),
        ("albedo.g", lambda i, j, k: 0.9 - 0.8 * j / 15.0),
        ("albedo.b", lambda i, j, k: 0.1 + 0.8 * k / 15.0),
    ]
    grids = [g]
    for name, f in channels:
        c = grid(name=name, voxel=1.0 / 16.0)
        set_voxels(c, (16, 16, 16), f)
        grids.append(c)
    write("albedo.vdb", grids)

    # 3. A linear gradient slab: density = (i + 0.5) / 32 along x over [0, 1] x [0, 0.5]^2
    #    (voxel 1/32), i.e. density(x) = x at voxel centres.
    g = grid(voxel=1.0 / 32.0)
    set_voxels(g, (32, 16, 16), lambda i, j, k: (i + 0.5) / 32.0)
    write("gradient.vdb", [g])

    # 4. Empty regions and sharp edges: two dense cubes (density 8) and a thin sheet (density 40)
    #    in an otherwise empty 48^3 grid over [0, 1.5]^3 (voxel 1/32).
    def holes(i, j, k):
        if 4 <= i < 16 and 4 <= j < 16 and 4 <= k < 16:
            return 8.0
        if 30 <= i < 44 and 28 <= j < 40 and 8 <= k < 40:
            return 8.0
        if 20 <= i < 22 and 0 <= j < 48 and 0 <= k < 48:
            return 40.0
        return 0.0

    g = grid(voxel=1.0 / 32.0)
    set_voxels(g, (48, 48, 48), holes)
    write("holes.vdb", [g])

    tiles()

    half()

    vector()

    tinted()

    hue()

    # --- Files vdb-rs 0.6 would mishandle --------------------------------------------------
    # A vector grid named "density": vdb-rs would read its bytes as floats.
    v = vdb.Vec3SGrid((0.0, 0.0, 0.0))
    v.name = "density"
    acc = v.getAccessor()
    for i in range(4):
        acc.setValueOn((i, 0, 0), (1.0, 2.0, 3.0))
    write("bad/vector.vdb", [v])

    # A rotated (affine) transform: vdb-rs panics on any map but (uniform) scale-translate.
    g = vdb.FloatGrid(0.0)
    g.name = "density"
    c, s = math.cos(0.5), math.sin(0.5)
    g.transform = vdb.createLinearTransform(
        [[0.1 * c, 0.1 * s, 0, 0], [-0.1 * s, 0.1 * c, 0, 0], [0, 0, 0.1, 0], [0, 0, 0, 1]]
    )
    set_voxels(g, (4, 4, 4), lambda i, j, k: 1.0)
    write("bad/affine.vdb", [g])

    # Two grids with the same name: vdb-rs keeps one of them silently.
    a, b = grid(), grid()
    set_voxels(a, (4, 4, 4), lambda i, j, k: 1.0)
    set_voxels(b, (4, 4, 4), lambda i, j, k: 2.0)
    write("bad/duplicate.vdb", [a, b])

    # Two voxels millions of voxels apart: a valid sparse grid far too large to copy densely.
    g = grid()
    acc = g.getAccessor()
    acc.setValueOn((0, 0, 0), 1.0)
    acc.setValueOn((4194303, 2097151, 2097151), 1.0)
    write("bad/far-apart.vdb", [g])

    # A root-level tile (an active 4096^3 region stored as one value): vdb-rs drops it.
    g = grid(voxel=1.0 / 4096.0)
    g.fill((0, 0, 0), (4095, 4095, 4095), 0.25, True)
    write("bad/root-tile.vdb", [g])


if __name__ == "__main__":
    main()
