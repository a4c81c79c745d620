"""Render a dataset of cloud images: N views of the OpenVDB cloud of scenes/vdb-cloud.toml,
each under a random sun direction and with a random density scale, each rendered until its
estimated relative error reaches a target. Writes, per image, the radiance and its error layers
as NumPy arrays (`NNNN.npz`: rgb, variance, bias; float32, (H, W, 3)) and, with --exr, an
OpenEXR file with the same layers and a PNG preview; plus `labels.json` with each image's sun
direction, density scale, iterations, time and estimated error.

    python docs/python/dataset.py --count 100 --size 128 --target-error 0.05 --out cloud-set

Progress is drawn with tqdm if it is installed (pip install tqdm), else printed per image.
"""

import argparse
import json
import math
import pathlib
import random
import sys
import time
import tomllib

import numpy as np

import haze

REPO = pathlib.Path(__file__).resolve().parents[2]
SCENE = REPO / "scenes" / "vdb-cloud.toml"


def cloud_scene(sun, density_scale, size):
    """vdb-cloud.toml as a dict, lit by the sun alone from `sun` (a unit vector towards the
    light), with the cloud's density scaled, at size x size pixels."""
    with open(SCENE, "rb") as f:
        d = tomllib.load(f)
    d["camera"]["resolution"] = [size, size]
    d["camera"]["fov"] = 30
    d["media"]["cloud"]["density_scale"] = density_scale
    d["lights"] = [{"type": "directional", "direction": [-c for c in sun], "irradiance": [1.3, 1.22, 1.1]}]
    return haze.Scene.from_dict(d, base_dir=SCENE.parent)


def random_sun(rng):
    """A sun direction uniform over the upper hemisphere above 15 degrees of elevation."""
    z = rng.uniform(math.sin(math.radians(15)), 1.0)
    phi = rng.uniform(0, 2 * math.pi)
    r = math.sqrt(1 - z * z)
    return [r * math.cos(phi), z, r * math.sin(phi)]


def views(count, seed):
    """The dataset's random parameters: (sun direction, density scale) per image."""
    rng = random.Random(seed)
    return [(random_sun(rng), rng.uniform(3.0, 9.0)) for _ in range(count)]


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--count", type=int, default=100, help="images to render")
    p.add_argument("--size", type=int, default=128, help="image width and height in pixels")
    p.add_argument("--target-error", type=float, default=0.05, help="estimated relative error per image")
    p.add_argument("--max-iterations", type=int, default=4000, help="bound on each image's iterations")
    p.add_argument("--photons", type=int, default=20000, help="light paths per iteration")
    p.add_argument("--integrator", default="combined", help="haze's integrator")
    p.add_argument("--threads", type=int, default=None, help="worker threads (default: every core)")
    p.add_argument("--seed", type=int, default=1, help="seed of the random views")
    p.add_argument("--exr", action="store_true", help="also write OpenEXR files with PNG previews")
    p.add_argument("--out", type=pathlib.Path, default=pathlib.Path("cloud-set"))
    args = p.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)

    try:
        from tqdm import tqdm
    except ImportError:
        tqdm = None
    items = list(enumerate(views(args.count, args.seed)))
    bar = tqdm(items, unit="image") if tqdm else items
    labels, missed = [], []
    start = time.perf_counter()
    for i, (sun, scale) in bar:
        scene = cloud_scene(sun, scale, args.size)
        image = haze.render(
            scene,
            iterations=args.max_iterations,
            target_error=args.target_error,
            photons=args.photons,
            integrator=args.integrator,
            threads=args.threads,
            seed=i,
        )
        layers = {"rgb": image.rgb, "variance": image.variance, "bias": image.bias}
        np.savez(args.out / f"{i:04d}.npz", **{k: v for k, v in layers.items() if v is not None})
        if args.exr:
            image.write(args.out / f"{i:04d}.exr")
        labels.append(
            {
                "image": i,
                "sun": sun,
                "density_scale": scale,
                "iterations": image.iterations,
                "seconds": image.elapsed,
                "error": image.error,
            }
        )
        error = "-" if image.error is None else f"{100 * image.error:.2f} %"
        if image.error is None or image.error > args.target_error:
            missed.append(i)
        if tqdm:
            bar.set_postfix(error=error)
        else:
            print(f"image {i + 1}/{args.count}: {image.iterations} iterations, error {error}")
    (args.out / "labels.json").write_text(json.dumps(labels, indent=1))
    if missed:
        print(f"warning: {len(missed)} images stopped at --max-iterations above the target error: {missed}",
              file=sys.stderr)
    minutes = (time.perf_counter() - start) / 60
    print(f"{args.count} images in {60 * minutes:.1f} s: {args.count / minutes:.1f} images per minute", file=sys.stderr)
    return labels


if __name__ == "__main__":
    main()
