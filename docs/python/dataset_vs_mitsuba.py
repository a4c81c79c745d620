"""The dataset use case of mitsuba3 #634, measured: the images of docs/python/dataset.py (the
OpenVDB cloud of scenes/vdb-cloud.toml under random suns and density scales) rendered by haze to
an estimated relative error (`target_error`) and by Mitsuba 3 volpath (llvm_ad_rgb) at the
samples per pixel that give the same measured error; images per minute for both.

1. References: for the first --check views, a long haze path-traced render (--reference-seconds
   each); its own variance is subtracted from the errors measured against it.
2. haze renders all --count views with target_error (the dataset script's settings); on the
   check views its error against the references is measured.
3. Mitsuba: on each check view, a calibration render at --calibration-spp gives its error e₀;
   the samples per pixel that reach haze's measured error e there are spp₀·(e₀/e)², rounded up
   to a multiple of 16, rendered and measured again, and rescaled until the measured error is
   at most e. A dataset run needs one count for all
   images: the largest over the check views, so that every check view reaches haze's error.
   Mitsuba then renders all --count views at that count (scene building included, as haze's).

Run with a virtual environment that has haze (pip install .), Mitsuba 3, numpy and OpenEXR, on
a quiet machine (see docs/mitsuba/README.md for Mitsuba's setup; the grid goes through
/usr/bin/python3's pyopenvdb once):

    .venv/bin/python docs/python/dataset_vs_mitsuba.py --count 100 --threads 2
"""

import argparse
import math
import os
import pathlib
import sys
import tempfile
import time

import numpy as np

import haze

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "mitsuba"))
import compare  # noqa: E402  (docs/mitsuba/compare.py: the scene conversion, Mitsuba's rendering)
import dataset  # noqa: E402  (docs/python/dataset.py: the views and the scene)


def scene_text(size):
    """The dataset's base scene as a file (sun only, fov 30, size²), for the conversion."""
    text = dataset.SCENE.read_text()
    text = text.replace("resolution = [640, 400]", f"resolution = [{size}, {size}]").replace("fov = 38", "fov = 30")
    text = text.replace('file = "../media/', f'file = "{dataset.SCENE.parent.parent}/media/')
    return text.split("[[lights]] # the sun")[0] + (
        '[[lights]]\ntype = "directional"\ndirection = [0, -1, 0]\nirradiance = [1.3, 1.22, 1.1]\n')


def rel_rmse(img, ref, ref_var):
    return compare.rel_rmse(np.asarray(img, np.float64), ref, ref_var)


class Mitsuba:
    """The dataset's scene in Mitsuba 3, built once and varied per view."""

    def __init__(self, path, size, threads, tmp):
        lib = compare.llvm_library()
        if lib is None:
            raise SystemExit("llvm_ad_rgb needs libLLVM: apt-get install libllvm19, or set DRJIT_LIBLLVM_PATH")
        os.environ["DRJIT_LIBLLVM_PATH"] = lib
        import drjit as dr

        dr.set_thread_count(threads)
        import mitsuba as mi

        mi.set_variant("llvm_ad_rgb")
        self.mi = mi
        self.d = compare.mitsuba_scene(mi, str(path), (size, size), 64, tmp)
        self.media = [v["interior"] for v in self.d.values() if isinstance(v, dict) and "interior" in v]
        self.base_scale = self.media[0]["scale"] / 6.0  # vdb-cloud's density_scale is 6
        self.sun = next(v for v in self.d.values() if isinstance(v, dict) and v.get("type") == "directional")

    def render(self, view, spp, seed):
        sun, scale = view
        for m in self.media:
            m["scale"] = self.base_scale * scale
        self.sun["direction"] = [-c for c in sun]
        scene = self.mi.load_dict(self.d)
        return compare.mitsuba_render(self.mi, scene, spp, seed)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--count", type=int, default=100)
    p.add_argument("--size", type=int, default=128)
    p.add_argument("--target-error", type=float, default=0.05)
    p.add_argument("--check", type=int, default=4, help="views with references")
    p.add_argument("--reference-seconds", type=float, default=60)
    p.add_argument("--calibration-spp", type=int, default=64)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--integrator", default="combined", help="haze's integrator for the dataset (dataset.py's)")
    p.add_argument("--photons", type=int, default=20000)
    p.add_argument("--max-iterations", type=int, default=4000, help="as dataset.py")
    args = p.parse_args()
    views = dataset.views(args.count, 1)
    with tempfile.TemporaryDirectory() as tmp:
        path = pathlib.Path(tmp) / "cloud.toml"
        path.write_text(scene_text(args.size))
        # The file and the dataset script's dict are the same scene.
        a = haze.render(haze.Scene.load(path), iterations=2, photons=2000, seed=3).rgb
        b = haze.render(dataset.cloud_scene([0, 1, 0], 6.0, args.size), iterations=2, photons=2000, seed=3).rgb
        assert np.array_equal(a, b), "the converted scene differs from the dataset's"

        refs = []
        for v in views[: args.check]:
            r = haze.render(dataset.cloud_scene(v[0], v[1], args.size), time=args.reference_seconds,
                            integrator="path", threads=args.threads, seed=1000)
            refs.append((np.asarray(r.rgb, np.float64), np.asarray(r.variance, np.float64)))
            print(f"reference: {r.iterations} spp, relative noise {100 * r.relative_noise:.2f} %", flush=True)

        start = time.perf_counter()
        haze_err = []
        for i, v in enumerate(views):
            img = haze.render(dataset.cloud_scene(v[0], v[1], args.size), iterations=args.max_iterations,
                              target_error=args.target_error, photons=args.photons,
                              integrator=args.integrator, threads=args.threads, seed=i)
            if i < args.check:
                haze_err.append(rel_rmse(img.rgb, *refs[i]))
                print(f"haze view {i}: {img.iterations} iterations, {img.elapsed:.2f} s, estimated "
                      f"{100 * img.error:.2f} %, measured {100 * haze_err[-1]:.2f} %", flush=True)
            elif (i + 1) % 10 == 0:
                print(f"haze: {i + 1} images in {time.perf_counter() - start:.0f} s", flush=True)
        haze_minutes = (time.perf_counter() - start) / 60

        m = Mitsuba(path, args.size, args.threads, tmp)
        m.render(views[0], 16, 0)  # JIT warm-up, not timed (as compare.py)
        needed = []
        for i in range(args.check):
            spp, e = args.calibration_spp, rel_rmse(m.render(views[i], args.calibration_spp, 7), *refs[i])
            e0 = e
            # Error ∝ 1/√spp: rescale, render, again until the measured error is haze's or less.
            for k in range(4):
                if e <= haze_err[i]:
                    break
                spp = 16 * math.ceil(spp * (e / haze_err[i]) ** 2 / 16)
                e = rel_rmse(m.render(views[i], spp, 8 + k), *refs[i])
            needed.append(spp)
            print(f"mitsuba view {i}: {e0 * 100:.2f} % at {args.calibration_spp} spp; for haze's "
                  f"{100 * haze_err[i]:.2f} %: {spp} spp (measured there: {100 * e:.2f} %)", flush=True)
        spp = max(needed)
        start = time.perf_counter()
        for i, v in enumerate(views):
            m.render(v, spp, i)
            if (i + 1) % 10 == 0:
                print(f"mitsuba: {i + 1} images in {time.perf_counter() - start:.0f} s", flush=True)
        mitsuba_minutes = (time.perf_counter() - start) / 60

    print(f"\n{args.count} images of {args.size}x{args.size}, {args.threads} threads:")
    print(f"haze ({args.integrator}, target_error {args.target_error}): {haze_minutes * 60:.1f} s, "
          f"{args.count / haze_minutes:.2f} images per minute; measured error on the check views "
          + ", ".join(f"{100 * e:.2f} %" for e in haze_err))
    print(f"Mitsuba 3 llvm_ad_rgb volpath at {spp} spp (per check view {needed}): {mitsuba_minutes * 60:.1f} s, "
          f"{args.count / mitsuba_minutes:.2f} images per minute")
    print(f"haze/Mitsuba images per minute: {mitsuba_minutes / haze_minutes:.2f}x")


if __name__ == "__main__":
    main()
