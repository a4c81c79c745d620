"""The crafted inputs of the CLI's hostile-input tests (tests/suite/reliability.rs, issue 37), made
with Debian's pyopenvdb:

    /usr/bin/python3 tests/fuzz-corpus/cli/make.py          # the committed files
    /usr/bin/python3 tests/fuzz-corpus/cli/make.py --large  # also tiles-512.vdb (not committed)

- tiles-2048.vdb: one constant 2048^3 region of density 1, stored as OpenVDB tiles (9 KB).
- esc-name.vdb: a 4^3 grid named "den<ESC>[2Jsity" (the escape sequence clears a terminal).
- esc-map.vdb: a 4^3 grid `density` whose map name, UniformScaleMap, is patched to
  "<ESC>[2J<ESC>[HUniform<BEL>" (same length, so the file stays well formed).
- zero-channel.vdb: a 16^3 box of density 1 beside a constant colour grid `tint` = (0, 1e-3, 1):
  as an extinction grid at scale 1e30, a channel thinner than the largest by 30 orders of
  magnitude, whose spectral-tracking walks end only at the step cap.
- tiles-512.vdb (--large): a constant 512^3 region as tiles: loaded with layout = "dense" it is a
  537 MB copy, the case of a grid referenced five times.
"""
import sys
import pyopenvdb as vdb


def tiles(n, name):
    g = vdb.FloatGrid(0.0)
    g.name = "density"
    g.fill((0, 0, 0), (n - 1, n - 1, n - 1), 1.0, True)
    g.transform = vdb.createLinearTransform(voxelSize=1.0 / n)
    vdb.write(name, grids=[g])


def small(name, grid):
    g = vdb.FloatGrid(0.0)
    g.name = grid
    g.fill((0, 0, 0), (3, 3, 3), 1.0, True)
    g.transform = vdb.createLinearTransform(voxelSize=0.25)
    vdb.write(name, grids=[g])


tiles(2048, "tiles-2048.vdb")
small("esc-name.vdb", "den\x1b[2Jsity")
small("esc-map.vdb", "density")
b = open("esc-map.vdb", "rb").read()
new = b"\x1b[2J\x1b[HUniform\x07"
assert len(new) == len(b"UniformScaleMap") and b.count(b"UniformScaleMap") == 1
open("esc-map.vdb", "wb").write(b.replace(b"UniformScaleMap", new))
d = vdb.FloatGrid(0.0)
d.name = "density"
d.fill((0, 0, 0), (15, 15, 15), 1.0, True)
t = vdb.Vec3SGrid((0.0, 0.0, 0.0))
t.name = "tint"
t.fill((0, 0, 0), (15, 15, 15), (0.0, 1e-3, 1.0), True)
for g in (d, t):
    g.transform = vdb.createLinearTransform(voxelSize=1.0 / 16)
vdb.write("zero-channel.vdb", grids=[d, t])
if "--large" in sys.argv:
    tiles(512, "tiles-512.vdb")
