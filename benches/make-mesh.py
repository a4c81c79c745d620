#!/usr/bin/env python3
"""A large procedural mesh for `haze bench rays`: an icosphere subdivided LEVEL times (20·4^LEVEL
triangles; level 8 gives 1,310,720) and displaced along its normals by a sum of sines — a lumpy
asteroid — over a ground square, lit by the sun. Writes OUT/displaced-sphere.obj and
OUT/displaced-sphere.toml (a scene that uses it). Pure Python, deterministic, no downloads.

    python3 benches/make-mesh.py [OUT] [LEVEL]       (defaults: target/bench, 8)
"""

import math
import os
import sys


def icosphere(level):
    t = (1 + 5 ** 0.5) / 2
    verts = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t),
             (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    verts = [normalise(v) for v in verts]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
             (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
             (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(level):
        midpoints = {}

        def mid(a, b):
            key = (a, b) if a < b else (b, a)
            if key not in midpoints:
                pa, pb = verts[a], verts[b]
                verts.append(normalise(((pa[0] + pb[0]) / 2, (pa[1] + pb[1]) / 2, (pa[2] + pb[2]) / 2)))
                midpoints[key] = len(verts) - 1
            return midpoints[key]

        new = []
        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            new += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = new
    return verts, faces


def normalise(v):
    n = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    return (v[0] / n, v[1] / n, v[2] / n)


def displacement(v):
    x, y, z = v
    h = 0.0
    for k, (a, fx, fy, fz) in enumerate([(0.12, 3, 2, 1), (0.06, 7, 5, 3), (0.03, 13, 11, 17),
                                          (0.015, 29, 23, 31), (0.008, 61, 53, 47)]):
        h += a * math.sin(fx * x + 1.3 * k) * math.sin(fy * y + 0.7 * k) * math.sin(fz * z + 2.1 * k)
    return 1.0 + h


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join("target", "bench")
    level = int(sys.argv[2]) if len(sys.argv) > 2 else 8
    os.makedirs(out, exist_ok=True)
    verts, faces = icosphere(level)
    obj = os.path.join(out, "displaced-sphere.obj")
    with open(obj, "w") as f:
        f.write(f"# icosphere level {level}, displaced: {len(faces)} triangles (benches/make-mesh.py)\n")
        for v in verts:
            s = displacement(v)
            f.write(f"v {v[0] * s:.6f} {v[1] * s + 1.3:.6f} {v[2] * s:.6f}\n")
        for a, b, c in faces:
            f.write(f"f {a + 1} {b + 1} {c + 1}\n")
    with open(os.path.join(out, "displaced-sphere.toml"), "w") as f:
        f.write(f"""# {len(faces)} triangles of a displaced icosphere over a ground square (benches/make-mesh.py)
[camera]
type = "perspective"
position = [0, 1.6, 5]
look_at = [0, 1.2, 0]
fov = 40
resolution = [640, 400]

[materials.rock]
type = "diffuse"
albedo = 0.5

[[shapes]]
type = "obj"
file = "displaced-sphere.obj"
material = "rock"

[[shapes]]
type = "rectangle"
size = [8, 8]
material = "rock"
transform = {{ rotate = [-90, 0, 0] }}

[[lights]]
type = "directional"
direction = [0.3, -1, 0.2]
irradiance = 3
""")
    print(f"wrote {obj} ({len(faces)} triangles) and displaced-sphere.toml")


if __name__ == "__main__":
    main()
