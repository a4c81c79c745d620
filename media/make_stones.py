#!/usr/bin/python3
"""Writes media/stones.obj: the campfire's stones, a ring of twelve around the fire and three
boulders further out, each an icosphere displaced into a rock.

Run with Python 3 and numpy (`apt-get install python3-numpy`):

    /usr/bin/python3 media/make_stones.py      # a second

Each stone: an icosphere subdivided three times (642 vertices, 1,280 triangles; four times,
5,120 triangles, for the boulders), stretched to a
random ellipsoid, cut by five to seven random planes (the flat, broken faces of a field stone,
their edges rounded by a soft minimum), roughened by three octaves of smooth noise along the
radius, squashed flat underneath and sunk a little into the ground (y = 0). Vertex normals are
the area-weighted normals of the displaced mesh, so the stones shade smoothly; every triangle
faces outwards. One OBJ object per stone. Deterministic (fixed seed). Also writes the `obj`
fuzz target's seed tests/fuzz-corpus/obj/stone.obj, one stone subdivided once.
"""
import os

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SEED = 5


def icosphere(n):
    """Unit icosphere subdivided n times: vertices (V, 3) and outward triangles (T, 3)."""
    t = (1.0 + 5 ** 0.5) / 2.0
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t),
         (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
         (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
         (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    verts = [np.array(p, float) / np.linalg.norm(p) for p in v]
    for _ in range(n):
        cache, out = {}, []

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                m = verts[a] + verts[b]
                verts.append(m / np.linalg.norm(m))
                cache[key] = len(verts) - 1
            return cache[key]

        for a, b, c in f:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            out += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = out
    return np.array(verts), np.array(f, np.int64)


def noise(p, rng, octaves=3):
    """Smooth noise in about [-1, 1] at points p: octaves of random plane waves."""
    total = np.zeros(len(p))
    amp, norm = 1.0, 0.0
    for o in range(octaves):
        for _ in range(6):
            k = rng.normal(size=3)
            k *= (2.0 ** o) * 2.5 / np.linalg.norm(k)
            total += amp * np.sin(p @ k + rng.uniform(0, 2 * np.pi)) / 6 ** 0.5
        norm += amp
        amp *= 0.5
    return total / norm


def soft_min(a, b, k):
    h = np.clip(0.5 + 0.5 * (b - a) / k, 0.0, 1.0)
    return b * (1 - h) + a * h - k * h * (1 - h)


def stone(rng, size, subdivisions):
    """One rock of about `size` across at the origin, its base on y = 0: (vertices, faces)."""
    d, faces = icosphere(subdivisions)
    axes = np.array([1.0, rng.uniform(0.55, 0.75), rng.uniform(0.7, 0.95)]) * size / 2
    # Radius of the ellipsoid along each direction.
    r = 1.0 / np.sqrt(((d / axes) ** 2).sum(axis=1))
    # Broken faces: planes at 70-88 % of the radius along random directions, their edges
    # rounded over a tenth of the stone.
    for _ in range(rng.integers(5, 8)):
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        h = rng.uniform(0.7, 0.88) * float(1.0 / np.sqrt(((n / axes) ** 2).sum()))
        along = d @ n
        cut = np.where(along > 0.05, h / np.maximum(along, 0.05), 1e3)
        r = soft_min(r, cut, 0.1 * size)
    r *= 1.0 + 0.07 * noise(d, rng)
    p = d * r[:, None]
    # Flat underneath, a fifth of the height sunk into the ground.
    floor = p[:, 1].min() * 0.7
    p[:, 1] = np.maximum(p[:, 1], floor)
    p[:, 1] -= floor + 0.2 * (p[:, 1].max() - floor)
    # A random turn about the vertical.
    a = rng.uniform(0, 2 * np.pi)
    c, s = np.cos(a), np.sin(a)
    p = p @ np.array([[c, 0, -s], [0, 1, 0], [s, 0, c]])
    centre = p.mean(axis=0)
    fn = np.cross(p[faces[:, 1]] - p[faces[:, 0]], p[faces[:, 2]] - p[faces[:, 0]])
    assert ((fn * (p[faces].mean(axis=1) - centre)).sum(axis=1) > 0).all(), "inward triangle"
    return p, faces


def normals(p, faces):
    """Area-weighted vertex normals."""
    n = np.zeros_like(p)
    fn = np.cross(p[faces[:, 1]] - p[faces[:, 0]], p[faces[:, 2]] - p[faces[:, 0]])
    for k in range(3):
        np.add.at(n, faces[:, k], fn)
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def main():
    rng = np.random.default_rng(SEED)
    placed = []
    # The ring: twelve stones around the fire (whose container spans |x|, |z| <= 0.4,
    # so out to 0.57 at its corners).
    for i in range(12):
        a = 2 * np.pi * (i + rng.uniform(-0.15, 0.15)) / 12
        rad = 0.84 + rng.uniform(-0.02, 0.04)
        placed.append((rad * np.cos(a), rad * np.sin(a), rng.uniform(0.3, 0.38)))
    # Boulders further out, where the old boxes stood.
    placed += [(-2.0, 1.0, 0.75), (1.8, 1.6, 0.8), (0.5, -3.0, 1.3)]
    path = os.path.join(HERE, "stones.obj")
    triangles = write(path, [(x, z, size, stone(rng, size, 3 if size < 0.5 else 4))
                             for x, z, size in placed])
    print(f"wrote stones.obj: {len(placed)} stones, {triangles} triangles, "
          f"{os.path.getsize(path)} bytes")
    # The obj fuzz target's seed: one small stone in the same form.
    seed = os.path.join(HERE, "..", "tests", "fuzz-corpus", "obj", "stone.obj")
    write(seed, [(0.0, 0.0, 0.3, stone(rng, 0.3, 1))])


def write(path, stones):
    """Writes stones [(x, z, size, (vertices, faces))] as one OBJ object each, atomically;
    returns the number of triangles."""
    lines = [f"# {os.path.basename(path)}, written by media/make_stones.py"]
    base = 1
    triangles = 0
    for k, (x, z, size, (p, faces)) in enumerate(stones):
        p = p + np.array([x, 0.0, z])
        n = normals(p, faces)
        lines.append(f"o stone{k}")
        lines += [f"v {a:.4f} {b:.4f} {c:.4f}" for a, b, c in p]
        lines += [f"vn {a:.3f} {b:.3f} {c:.3f}" for a, b, c in n]
        lines += [f"f {a + base}//{a + base} {b + base}//{b + base} {c + base}//{c + base}"
                  for a, b, c in faces]
        base += len(p)
        triangles += len(faces)
    with open(path + ".tmp", "w") as f:
        f.write("\n".join(lines) + "\n")
    os.replace(path + ".tmp", path)
    return triangles


if __name__ == "__main__":
    main()
