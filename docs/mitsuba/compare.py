#!/usr/bin/env python3
"""Equal-time comparison of haze with Mitsuba 3 (docs/mitsuba/README.md).

For each scene: a long haze path-traced reference; a long Mitsuba volpath render (several seeds)
whose per-region agreement with the reference is reported with standard errors; then, at equal
wall time on the same number of threads, the relative RMSE against the reference of Mitsuba
volpath (in each variant asked for: llvm_ad_rgb, the one Mitsuba's CPU users pick, and
scalar_rgb) and of haze's integrators (path, photons, hybrid, combined). Writes a Markdown table
to stdout.

Mitsuba renders in chunks of at most 16 samples per pixel (one mi.render of thousands of samples
does not fit in memory with the LLVM variant), each chunk with a seed of its own, averaged. Its
time excludes the JIT warm-up: one chunk is rendered first and not timed, as for a user who has
rendered the scene before (Dr.Jit caches compiled kernels).

Run with the virtualenv that has Mitsuba 3, numpy and OpenEXR (see the README); scenes with a
VDB medium also need Debian's python3-openvdb for /usr/bin/python3 (the grid is exported to a
numpy file there, since pyopenvdb is not on PyPI).
"""

import argparse
import math
import os
import subprocess
import sys
import tempfile
import time
import tomllib
import re

import numpy as np

SEEDS = 8  # independent renders behind each region mean and its standard error
HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))


def rotation(mi, deg):
    """haze's rotation: about x, then y, then z (degrees)."""
    T = mi.ScalarTransform4f
    return (T().rotate([0, 0, 1], deg[2]) @ T().rotate([0, 1, 0], deg[1])
            @ T().rotate([1, 0, 0], deg[0]))


def placement(mi, t):
    """haze's transform table: translate · rotate · scale."""
    T = mi.ScalarTransform4f
    scale = t.get("scale", 1.0)
    scale = [scale] * 3 if isinstance(scale, (int, float)) else scale
    return (T().translate(t.get("translate", [0, 0, 0])) @ rotation(mi, t.get("rotate", [0, 0, 0]))
            @ T().scale(scale))


def rgb(v):
    return {"type": "rgb", "value": [v] * 3 if isinstance(v, (int, float)) else list(v)}


def coefficients(m):
    """(sigma_t, albedo) per channel from haze's (sigma_a, sigma_s) or (albedo, sigma_t)."""
    def vec(v):
        return np.array([v] * 3 if isinstance(v, (int, float)) else v, dtype=float)
    if "sigma_t" in m:
        return vec(m["sigma_t"]), vec(m["albedo"])
    a, s = vec(m["sigma_a"]), vec(m["sigma_s"])
    t = a + s
    return t, np.divide(s, t, out=np.zeros(3), where=t > 0)


def export_grid(vdb, grid, out):
    """Dense density array and index->world map of an OpenVDB grid, via /usr/bin/python3."""
    code = f"""
import pyopenvdb, numpy as np
g = pyopenvdb.read({vdb!r}, {grid!r})
lo, hi = g.evalActiveVoxelBoundingBox()
dims = [hi[i] - lo[i] + 1 for i in range(3)]
a = np.zeros(dims, dtype=np.float32)
g.copyToArray(a, ijk=lo)
o = g.transform.indexToWorld((0, 0, 0))
x = g.transform.indexToWorld((1, 1, 1))
np.savez({out!r}, density=a, lo=np.array(lo), origin=np.array(o), voxel=np.array(x) - np.array(o))
"""
    subprocess.run(["/usr/bin/python3", "-c", code], check=True)
    return np.load(out)


def export_colour(vdb, grids, lo, dims, out):
    """An extinction grid's three channels (three float grids, or a vector grid's components
    named NAME[k] or given as NAME) as one (x, y, z, 3) array over the density's box."""
    names = [grids] * 3 if isinstance(grids, str) else list(grids)
    code = f"""
import pyopenvdb, numpy as np, re
names, lo, dims = {names!r}, {list(map(int, lo))!r}, {list(map(int, dims))!r}
out = np.zeros(dims + [3], dtype=np.float32)
for c, n in enumerate(names):
    m = re.fullmatch(r"(.*)\\[([012])\\]", n)
    base, k = (m.group(1), int(m.group(2))) if m else (n, None)
    g = pyopenvdb.read({vdb!r}, base)
    if isinstance(g, pyopenvdb.Vec3SGrid):
        a = np.zeros(dims + [3], dtype=np.float32)
        g.copyToArray(a, ijk=lo)
        out[..., c] = a[..., c if k is None else k]
    else:
        a = np.zeros(dims, dtype=np.float32)
        g.copyToArray(a, ijk=lo)
        out[..., c] = a
np.save({out!r}, out)
"""
    subprocess.run(["/usr/bin/python3", "-c", code], check=True)
    return np.load(out)


def medium_dict(mi, name, m, scene_dir, tmp):
    sigma_t, albedo = coefficients(m)
    phase = {"type": "hg", "g": m.get("g", 0.0)}
    if m["type"] == "homogeneous":
        # Mitsuba reads an RGB sigma_t as a reflectance (at most 1): the rest goes in `scale`.
        scale = max(1.0, float(sigma_t.max()))
        return {"type": "homogeneous", "sigma_t": rgb((sigma_t / scale).tolist()), "scale": scale,
                "albedo": rgb(albedo.tolist()), "phase": phase}
    # A grid: σ_t = density_scale · density · σ_t (grey); padded by a voxel of zeros so that
    # trilinear lookups fall to zero outside, as haze's do. Mitsuba samples a grid of n voxels at
    # the centres (i + ½)/n of the unit cube.
    g = export_grid(os.path.join(scene_dir, m["file"]), m.get("grid", "density"),
                    os.path.join(tmp, f"{name}.npz"))
    dens = g["density"]  # (x, y, z)
    colour = None
    if "extinction_grid" in m:
        # σ_t,c = density · σ_t,c · scale · e_c: an RGB extinction volume.
        e = m["extinction_grid"]
        colour = export_colour(os.path.join(scene_dir, m["file"]), e["grids"], g["lo"],
                               dens.shape, os.path.join(tmp, f"{name}-colour.npy"))
        colour = np.pad(colour * float(e.get("scale", 1.0)), ((1, 1), (1, 1), (1, 1), (0, 0)))
    dens = np.pad(dens, 1)
    n = np.array(dens.shape, dtype=float)
    T = mi.ScalarTransform4f
    corner = g["origin"] + g["voxel"] * (g["lo"] - 1.5)
    to_world = (placement(mi, m.get("transform", {})) @ T().translate(corner.tolist())
                @ T().scale((g["voxel"] * n).tolist()))
    # Mitsuba's VolumeGrid wants (z, y, x, channels). A coloured σ_t becomes an RGB grid of
    # density · σ_t (Mitsuba's heterogeneous medium takes RGB extinction volumes).
    dens = np.transpose(dens, (2, 1, 0))[..., None]
    coloured = np.ptp(sigma_t) > 1e-6 * sigma_t.max() or colour is not None
    if colour is not None:
        colour = np.transpose(colour, (2, 1, 0, 3))
        data = np.ascontiguousarray(dens * sigma_t[None, None, None, :] * colour, dtype=np.float32)
        scale = float(m.get("density_scale", 1.0))
    elif coloured:
        data = np.ascontiguousarray(dens * sigma_t[None, None, None, :], dtype=np.float32)
        scale = float(m.get("density_scale", 1.0))
    else:
        data = np.ascontiguousarray(dens, dtype=np.float32)
        scale = float(m.get("density_scale", 1.0) * sigma_t.mean())
    return {"type": "heterogeneous", "phase": phase, "albedo": rgb(albedo.tolist()),
            "scale": scale,
            "sigma_t": {"type": "gridvolume", "grid": mi.VolumeGrid(data),
                        "to_world": to_world, "filter_type": "trilinear"}}


def bsdf_dict(m):
    kind = m["type"]
    if kind == "diffuse":
        return {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": rgb(m["albedo"])}}
    if kind == "mirror":
        return {"type": "conductor", "material": "none",
                "specular_reflectance": rgb(m.get("reflectance", 1.0))}
    if kind == "dielectric":
        return {"type": "dielectric", "int_ior": m["ior"], "ext_ior": 1.0}
    return {"type": "null"}


def surrounding_medium(shape, shapes):
    """The medium an opaque shape sits in. haze carries the ray's medium across a surface that
    names none; Mitsuba takes it from the surface, so every shape inside a medium must name it as
    its exterior. A shape whose centre lies in an interface box is in that box's interior; a scene
    closed by an interface rectangle (an open room, cornell-fog) has its medium all around."""
    centre = np.array(shape.get("transform", {}).get("translate", shape.get("center", [0, 0, 0])), float)
    for o in shapes:
        if "interior" not in o:
            continue
        t = np.array(o.get("transform", {}).get("translate", [0, 0, 0]), float)
        if o["type"] == "box" and np.all(np.abs(centre - t) <= np.array(o["size"]) / 2):
            return o["interior"]
    rooms = [o["interior"] for o in shapes if o["type"] == "rectangle" and "interior" in o]
    return rooms[0] if rooms else None


def shape_dict(mi, s, materials, media):
    T = mi.ScalarTransform4f
    place = placement(mi, s.get("transform", {}))
    kind = s["type"]
    if kind == "rectangle":
        w, h = s.get("size", [1, 1])
        d = {"type": "rectangle", "to_world": place @ T().scale([w / 2, h / 2, 1])}
    elif kind == "box":
        x, y, z = s.get("size", [1, 1, 1])
        d = {"type": "cube", "to_world": place @ T().scale([x / 2, y / 2, z / 2])}
    elif kind == "sphere":
        c = s.get("center", [0, 0, 0])
        d = {"type": "sphere", "to_world": place @ T().translate(c) @ T().scale(s["radius"])}
    else:
        raise SystemExit(f"shape type {kind} is not ported")
    d["bsdf"] = bsdf_dict(materials[s["material"]])
    for side in ("interior", "exterior"):
        if side in s:
            d[side] = media[s[side]]
    if "emission" not in s:
        return [d]
    # A Mitsuba 3.9 defect (../shared/DESIGN.md §10): a shadow ray that crossed a null surface
    # restarts nudged off it with its old remaining length, overshoots a nearby area light and is
    # blocked by the light's own surface. So the emitter is a null surface, and the lamp's body a
    # non-emitting copy 10⁻³ behind it.
    lamp = dict(d, bsdf={"type": "null"}, emitter={"type": "area", "radiance": rgb(s["emission"])})
    normal = np.array(d["to_world"] @ mi.ScalarVector3f(0, 0, 1))
    normal = normal / np.linalg.norm(normal)
    body = dict(d, to_world=T().translate((-1e-3 * normal).tolist()) @ d["to_world"])
    return [lamp, body]


def world_box(mi, to_world, lo, hi):
    """The axis-aligned world bounds of the cube [lo, hi]³ under `to_world` ([-1, 1]³ for a
    `cube` shape, [0, 1]³ for a grid)."""
    pts = np.array([np.array(to_world @ mi.ScalarPoint3f(x, y, z))
                    for x in (lo, hi) for y in (lo, hi) for z in (lo, hi)])
    return pts.min(axis=0), pts.max(axis=0)


def fit_container(mi, shape, medium):
    """A null-BSDF box around a grid medium, shrunk to the grid's bounds (padding voxel
    included) where the box is larger: exact, since the density is zero outside the grid, and
    needed because Mitsuba 3 darkens rays that cross a dense grid's container outside the grid
    (docs/mitsuba/README.md, "cumulus"). Boxes and grids that are rotated keep the box."""
    grid = medium.get("sigma_t", {})
    if medium.get("type") != "heterogeneous" or "to_world" not in grid:
        return shape
    box_lo, box_hi = world_box(mi, shape["to_world"], -1, 1)
    g_lo, g_hi = world_box(mi, grid["to_world"], 0, 1)
    rotated = any(abs(np.array(t.matrix)[i][j]) > 1e-9
                  for t in (shape["to_world"], grid["to_world"]) for i in range(3) for j in range(3)
                  if i != j)
    lo, hi = np.maximum(box_lo, g_lo), np.minimum(box_hi, g_hi)
    if rotated or np.any(hi <= lo):
        return shape
    T = mi.ScalarTransform4f
    to_world = T().translate(((lo + hi) / 2).tolist()) @ T().scale(((hi - lo) / 2).tolist())
    return dict(shape, to_world=to_world)


def up_for(position, look_at):
    """An up vector not parallel to the view direction."""
    v = np.subtract(look_at, position)
    return [0, 1, 0] if abs(v[1]) < 0.99 * np.linalg.norm(v) else [1, 0, 0]


def vec3(v):
    return [float(v)] * 3 if isinstance(v, (int, float)) else [float(x) for x in v]


def sky_lights(mi, light, tmp):
    """A haze `sky` as Mitsuba sees it: the dome written by `haze sky --no-sun` (the same model,
    the same map) as an `envmap`, and the sun as a `directional` emitter of the irradiance haze
    reports."""
    haze = os.environ.get("HAZE", os.path.join(ROOT, "target", "release", "haze"))
    out = os.path.join(tmp, "sky.exr")
    if "sun_direction" in light:
        v = np.array(light["sun_direction"], float)
        v /= np.linalg.norm(v)
        elevation, azimuth = math.degrees(math.asin(v[1])), math.degrees(math.atan2(v[0], v[2]))
    else:
        elevation, azimuth = light["elevation"], light.get("azimuth", 0.0)
    scale = light.get("scale", 1.0)
    if not isinstance(scale, (int, float)):
        raise SystemExit("a sky's colour scale is not ported (Mitsuba's envmap scale is a number)")
    albedo = light.get("ground_albedo", 0.3)
    if not isinstance(albedo, (int, float)):
        raise SystemExit("a sky's coloured ground albedo is not ported")
    run = subprocess.run([haze, "sky", "--elevation", str(elevation), "--azimuth", str(azimuth),
                          "--turbidity", str(light.get("turbidity", 3.0)), "--ground-albedo", str(albedo),
                          "--resolution", str(light.get("resolution", 512)), "--scale", str(scale),
                          "--no-sun", "-o", out], check=True, capture_output=True, text=True)
    sun = [float(x) for x in re.search(r"sun irradiance \[([^]]*)\]", run.stderr).group(1).split(",")]
    e, a = math.radians(elevation), math.radians(azimuth)
    towards = [math.cos(e) * math.sin(a), math.sin(e), math.cos(e) * math.cos(a)]
    lights = [{"type": "envmap", "filename": nearest_map(out, tmp)}]
    if light.get("sun", True) and max(sun) > 0:
        lights.append({"type": "directional", "direction": [-c for c in towards], "irradiance": rgb(sun)})
    return lights


MAP_UPSCALE = 8  # compare.py --map-upscale


def nearest_map(path, tmp):
    """`path` upscaled MAP_UPSCALE times by repeating texels, for Mitsuba's envmap: its bilinear
    lookup then reproduces haze's constant texels but within 1/(2 MAP_UPSCALE) texel of their
    edges. (On sunset-fog's 512 x 256 map, bilinear lookup of the map itself was 0.15-0.29 %
    brighter per image region than of its 8x copy, significant at up to 11 standard errors.)"""
    if MAP_UPSCALE <= 1:
        return path
    import OpenEXR
    with OpenEXR.File(path) as f:
        ch = f.channels()
        a = ch["RGB"].pixels if "RGB" in ch else np.stack([ch[c].pixels for c in "RGB"], -1)
    up = np.repeat(np.repeat(a, MAP_UPSCALE, axis=0), MAP_UPSCALE, axis=1).astype(np.float32)
    out = os.path.join(tmp, "nearest-" + os.path.basename(path))
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {"RGB": up}) as f:
        f.write(out)
    return out


def light_dicts(mi, light, media, scene_dir, tmp):
    """The Mitsuba emitters of one `[[lights]]` table (a sky is two)."""
    kind = light["type"]
    if kind == "sky":
        return sky_lights(mi, light, tmp)
    if kind == "environment":
        # Mitsuba's envmap shares haze's latitude-longitude convention (docs/scene-format.md);
        # it interpolates texels bilinearly where haze keeps each constant.
        if "file" in light:
            scale = light.get("scale", 1.0)
            if not isinstance(scale, (int, float)):
                raise SystemExit("an environment's colour scale is not ported (Mitsuba's is a number)")
            d = {"type": "envmap", "filename": nearest_map(os.path.join(scene_dir, light["file"]), tmp),
                 "scale": scale,
                 "to_world": rotation(mi, light.get("rotate", [0, 0, 0]))}
        else:
            radiance = np.multiply(vec3(light["radiance"]), vec3(light.get("scale", 1.0)))
            d = {"type": "constant", "radiance": rgb(radiance.tolist())}
        return [d]
    return [light_dict(mi, light, media)]


def light_dict(mi, light, media):
    kind = light["type"]
    power = light["power"] if "power" in light else None
    p3 = np.array([power] * 3 if isinstance(power, (int, float)) else power or [0, 0, 0], float)
    if kind == "point":
        d = {"type": "point", "position": light["position"], "intensity": rgb((p3 / (4 * math.pi)).tolist())}
    elif kind == "spot":
        # A hard edge in both renderers (compare.py renders haze with falloff_start = cone_angle):
        # Mitsuba's falloff is linear in angle, haze's a smoothstep in cos θ.
        cone = light["cone_angle"]
        omega = 2 * math.pi * (1 - math.cos(math.radians(cone)))
        d = {"type": "spot", "intensity": rgb((p3 / omega).tolist()), "cutoff_angle": cone,
             "beam_width": cone,
             "to_world": mi.ScalarTransform4f().look_at(light["position"], light["look_at"],
                                                        up_for(light["position"], light["look_at"]))}
    elif kind == "directional":
        d = {"type": "directional", "direction": light["direction"], "irradiance": rgb(light["irradiance"])}
    else:
        raise SystemExit(f"light type {kind} is not ported")
    if "medium" in light:
        d["medium"] = media[light["medium"]]
    return d


def mitsuba_scene(mi, path, res, max_bounces, tmp, fit_containers=True):
    with open(path, "rb") as f:
        s = tomllib.load(f)
    scene_dir = os.path.dirname(os.path.abspath(path))
    media = {n: medium_dict(mi, n, m, scene_dir, tmp) for n, m in s.get("media", {}).items()}
    cam = s["camera"]
    sensor = {
        "type": "perspective", "fov": cam["fov"], "fov_axis": "y",
        "to_world": mi.ScalarTransform4f().look_at(cam["position"], cam["look_at"], cam.get("up", [0, 1, 0])),
        "film": {"type": "hdrfilm", "width": res[0], "height": res[1], "pixel_format": "rgb",
                 "rfilter": {"type": "box"}},
        "sampler": {"type": "independent"},
    }
    if "medium" in cam:
        sensor["medium"] = media[cam["medium"]]
    d = {"type": "scene", "integrator": {"type": "volpath", "max_depth": max_bounces + 1},
         "sensor": sensor}
    shapes = s.get("shapes", [])
    for i, sh in enumerate(shapes):
        if s["materials"][sh["material"]]["type"] != "interface" and not {"interior", "exterior"} & sh.keys():
            around = surrounding_medium(sh, shapes)
            if around:
                sh = dict(sh, exterior=around)
        for k, part in enumerate(shape_dict(mi, sh, s["materials"], media)):
            if sh["type"] == "box" and "interior" in sh and fit_containers:
                part = fit_container(mi, part, media[sh["interior"]])
            d[f"shape{i}_{k}"] = part
    for i, light in enumerate(s.get("lights", [])):
        for k, e in enumerate(light_dicts(mi, light, media, scene_dir, tmp)):
            d[f"light{i}_{k}"] = e
        if light["type"] in ("environment", "sky") and not light.get("visible", True):
            d["integrator"]["hide_emitters"] = True
    return d


def read_exr(path):
    import OpenEXR
    f = OpenEXR.File(path)
    ch = f.parts[0].channels
    key = "RGB" if "RGB" in ch else sorted(ch)[0]
    return np.asarray(ch[key].pixels, dtype=np.float64)


def haze_render(haze, scene, res, seconds, integrator, seed, out, threads, extra=()):
    subprocess.run([haze, "render", scene, "--resolution", f"{res[0]}x{res[1]}", "-t", f"{seconds}s",
                    "--integrator", integrator, "-s", str(seed), "-j", str(threads), "-q", "-o", out,
                    *extra], check=True)
    return read_exr(out)


CHUNK = 16  # samples per pixel per mi.render call


def mitsuba_render(mi, scene, spp, seed):
    """The mean of `spp` samples per pixel, rendered in chunks of at most CHUNK."""
    total, done, k = None, 0, 0
    while done < spp:
        n = min(CHUNK, spp - done)
        img = np.array(mi.render(scene, spp=n, seed=seed * 100003 + k), dtype=np.float64)
        total = img * n if total is None else total + img * n
        done, k = done + n, k + 1
    return total / spp


def llvm_library():
    """libLLVM for Dr.Jit's LLVM backend: DRJIT_LIBLLVM_PATH if set, else Debian 12's libLLVM 19
    (its default libLLVM 15 crashes Mitsuba 3.9)."""
    if os.environ.get("DRJIT_LIBLLVM_PATH"):
        return os.environ["DRJIT_LIBLLVM_PATH"]
    for path in ("/usr/lib/x86_64-linux-gnu/libLLVM-19.so", "/usr/lib/llvm-19/lib/libLLVM.so"):
        if os.path.exists(path):
            return path
    return None


def rel_rmse(img, ref, ref_var):
    """RMSE over pixels and channels less the reference's own variance of the mean (as `haze
    converge` measures it), relative to the reference's mean."""
    return math.sqrt(max(np.mean((img - ref) ** 2) - np.mean(ref_var), 0.0)) / np.mean(ref)


def rel_rmse_trimmed(img, ref, ref_var, share=0.001):
    """`rel_rmse` with the pixels of the largest squared errors, `share` of them, left out (as
    haze leaves out its noisiest 0.1 % in its noise figures, docs/error.md): one firefly can
    hold most of an image's squared error."""
    e = np.sum((img - ref) ** 2, axis=-1).ravel()
    v = np.sum(ref_var, axis=-1).ravel()
    keep = np.argsort(e)[: len(e) - int(share * len(e))]
    return math.sqrt(max((e[keep].sum() - v[keep].sum()) / (3 * len(keep)), 0.0)) / np.mean(ref)


def regions(img, n=4):
    """Means of an n × n grid of image regions."""
    h, w = img.shape[:2]
    return np.array([[img[i * h // n:(i + 1) * h // n, j * w // n:(j + 1) * w // n].mean()
                      for j in range(n)] for i in range(n)])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scenes", nargs="*", default=["cornell-fog", "spotlight-fog",
                                                   "cornell-cloud-homogeneous", "cornell-cloud",
                                                   "vdb-cloud", "cumulus"])
    ap.add_argument("--scale", type=int, default=4,
                    help="render at 1/SCALE of each scene's resolution, with 1/SCALE² of its photons")
    ap.add_argument("--resolution", metavar="WxH",
                    help="render every scene at this size instead (photons scaled by the pixel count)")
    ap.add_argument("--photons", type=int, help="haze's light paths per iteration, for every scene")
    ap.add_argument("--seconds", type=float, default=60)
    ap.add_argument("--reference-seconds", type=float, default=480)
    ap.add_argument("--agreement-seconds", type=float, default=240,
                    help="Mitsuba time for the agreement check, split over the seeds")
    ap.add_argument("--seeds", type=int, default=SEEDS,
                    help="independent renders behind each region mean and its standard error")
    ap.add_argument("--variants", default="llvm_ad_rgb,scalar_rgb",
                    help="Mitsuba variants to time (the first also renders the agreement check)")
    ap.add_argument("--agreement-only", action="store_true",
                    help="skip the equal-time renders: only the reference and the agreement check")
    ap.add_argument("--save", metavar="DIR",
                    help="keep every seed's per-region means (NAME-regions.npz) and the equal-time images")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--map-upscale", type=int, default=8,
                    help="repeat each environment-map texel N x N times for Mitsuba, whose envmap "
                         "interpolates bilinearly where haze keeps texels constant (1: the map as is)")
    ap.add_argument("--haze", default=os.path.join(ROOT, "target", "release", "haze"))
    ap.add_argument("--integrators", default="path,photons,hybrid,combined",
                    help="haze integrators timed at equal time, comma-separated")
    ap.add_argument("--skip-agreement", action="store_true",
                    help="skip the long Mitsuba renders of the agreement check")
    ap.add_argument("--keep-containers", action="store_true",
                    help="do not shrink a grid's null-BSDF container to the grid's bounds")
    args = ap.parse_args()
    if args.save:
        os.makedirs(args.save, exist_ok=True)
    global MAP_UPSCALE
    MAP_UPSCALE = args.map_upscale
    args.integrators = [i for i in args.integrators.split(",") if i]
    variants = [v for v in args.variants.split(",") if v]

    if any(v.startswith("llvm") for v in variants):
        lib = llvm_library()
        if lib is None:
            raise SystemExit("llvm variants need libLLVM: apt-get install libllvm19, or set DRJIT_LIBLLVM_PATH")
        os.environ["DRJIT_LIBLLVM_PATH"] = lib
    import drjit as dr
    dr.set_thread_count(args.threads)
    import mitsuba as mi

    cols = " | ".join(f"Mitsuba volpath {v}" for v in variants)
    hcols = " | ".join(f"haze {i}" for i in args.integrators)
    print(f"| scene | {cols} | {hcols} | Mitsuba − haze reference (regions, in s.e.) |")
    print("|---|" + "---|" * (len(variants) + len(args.integrators) + 1))
    for name in args.scenes:
        with tempfile.TemporaryDirectory() as tmp:
            toml = name if name.endswith(".toml") else os.path.join(ROOT, "scenes", f"{name}.toml")
            name = os.path.splitext(os.path.basename(toml))[0]
            text = open(toml).read()
            # Hard-edged spots in both renderers (see light_dict).
            text = re.sub(r"falloff_start = [0-9.]+\n", "", text)
            scene_path = os.path.join(os.path.dirname(toml), f".compare-{name}.toml")
            with open(scene_path, "w") as f:
                f.write(text)
            try:
                compare_scene(args, mi, name, scene_path, variants, tmp)
            finally:
                os.remove(scene_path)


def compare_scene(args, mi, name, scene_path, variants, tmp):
    with open(scene_path, "rb") as f:
        desc = tomllib.load(f)
    bounces = desc.get("render", {}).get("max_bounces", 64)
    full = desc["camera"]["resolution"]
    if args.resolution:
        res = [int(v) for v in args.resolution.lower().split("x")]
    else:
        res = [v // args.scale for v in full]
    scene_photons = desc["render"]["photons"]
    count = args.photons or max(1, int(scene_photons * res[0] * res[1] / (full[0] * full[1])))
    photons = ["-p", str(count)]
    # The reference: haze's path tracer, over the seeds (their spread gives its standard errors).
    refs = [haze_render(args.haze, scene_path, res, args.reference_seconds / args.seeds, "path",
                        1000 + k, os.path.join(tmp, f"ref{k}.exr"), args.threads)
            for k in range(args.seeds)]
    ref = np.mean(refs, axis=0)
    ref_var = np.var(refs, axis=0, ddof=1) / args.seeds
    errs, trimmed, notes, agree = [], [], [], ""
    if args.save:
        np.save(os.path.join(args.save, f"{name}-reference.npy"), ref)
        np.save(os.path.join(args.save, f"{name}-reference-var.npy"), ref_var)
    for i, variant in enumerate(variants):
        mi.set_variant(variant)
        scene = mi.load_dict(mitsuba_scene(mi, scene_path, res, bounces, tmp,
                                         not args.keep_containers), parallel=False)
        # JIT warm-up (not timed), then Mitsuba's rate on two chunks.
        mitsuba_render(mi, scene, CHUNK, 1)
        t0 = time.time()
        mitsuba_render(mi, scene, 2 * CHUNK, 2)
        rate = 2 * CHUNK / (time.time() - t0)
        if i == 0 and not args.skip_agreement:
            agree = agreement(args, mi, name, scene, rate, refs, ref)
            if args.agreement_only:
                break
        spp = max(1, int(rate * args.seconds))
        t0 = time.time()
        mts = mitsuba_render(mi, scene, spp, 7)
        notes.append(f"{variant} {spp} spp in {time.time() - t0:.0f} s")
        errs.append(rel_rmse(mts, ref, ref_var))
        trimmed.append(rel_rmse_trimmed(mts, ref, ref_var))
        if args.save:
            np.save(os.path.join(args.save, f"{name}-mitsuba-{variant}.npy"), mts)
    if args.agreement_only:
        print(f"| {name} | " + " | " * (len(variants) + len(args.integrators) - 1) + f" | {agree} |")
        sys.stdout.flush()
        return
    for integ in args.integrators:
        img = haze_render(args.haze, scene_path, res, args.seconds, integ, 7,
                          os.path.join(tmp, f"{integ}.exr"), args.threads, photons)
        errs.append(rel_rmse(img, ref, ref_var))
        trimmed.append(rel_rmse_trimmed(img, ref, ref_var))
        if args.save:
            np.save(os.path.join(args.save, f"{name}-haze-{integ}.npy"), img)
    cells = " | ".join(f"{e * 100:.2f} %" for e in errs)
    noise = math.sqrt(np.mean(ref_var)) / np.mean(ref)
    trim = ", ".join(f"{e * 100:.2f} %" for e in trimmed)
    print(f"| {name} ({res[0]}×{res[1]}, -p {count}) | {cells} | {agree} |  <!-- without the "
          f"0.1 % of pixels with the largest errors: {trim}; Mitsuba: "
          f"{'; '.join(notes)}; reference noise {noise * 100:.2f} % -->")
    sys.stdout.flush()


def agreement(args, mi, name, scene, rate, refs, ref):
    """Per-region agreement of long Mitsuba renders with haze's reference (printed to stderr)."""
    long = [mitsuba_render(mi, scene, max(CHUNK, int(rate * args.agreement_seconds / args.seeds)), 100 + k)
            for k in range(args.seeds)]
    r = np.array([regions(x) for x in long])
    h = np.array([regions(x) for x in refs])
    if args.save:
        np.savez(os.path.join(args.save, f"{name}-regions.npz"), mitsuba=r, haze=h)
    diff = r.mean(axis=0) - h.mean(axis=0)
    # A region without noise (a constant sky seen straight on) still differs by float rounding:
    # its standard error is floored at 10⁻⁵ of the region's mean, far above f32's 6·10⁻⁸.
    means = regions(ref)
    se = np.sqrt(r.var(axis=0, ddof=1) / args.seeds + h.var(axis=0, ddof=1) / args.seeds)
    se = np.maximum(se, 1e-5 * np.abs(means))
    z = np.abs(diff) / np.maximum(se, 1e-12)
    # Regions that are black in both (the sky of vdb-cloud) have no relative difference.
    rel = np.divide(diff, means, out=np.zeros_like(diff), where=means > 0)
    print(f"{name}: Mitsuba − haze per region (row-major, top row first), relative "
          f"difference in % and z:\n{np.array2string(rel * 100, precision=2)}"
          f"\n{np.array2string(diff / np.maximum(se, 1e-12), precision=1)}", file=sys.stderr)
    return f"max |z| {z.max():.1f}, max rel. diff {np.max(np.abs(rel)) * 100:.2f} %"


if __name__ == "__main__":
    main()
