"""The Python module's overhead: the same render through `haze.render` (Python) and through
`haze::render` (Rust, benches/api_render.rs), paired: the two alternate, each rendering ROUNDS
times per turn in one process, scene loading excluded. Prints each case's median and shortest
times and the Python/Rust ratio of the medians.

    .venv/bin/python benches/python_overhead.py [--turns 5] [--rounds 3] [--threads 2]

Run from the repository root with the module installed (pip install .) and a quiet machine.
"""

import argparse
import pathlib
import statistics
import subprocess
import tempfile
import time

import haze

REPO = pathlib.Path(__file__).resolve().parents[1]

TINY = """
[camera]
type = "perspective"
position = [0, 0, 4]
look_at = [0, 0, 0]
fov = 40
resolution = [32, 32]
[materials.white]
type = "diffuse"
albedo = 0.7
[materials.air]
type = "interface"
[media.fog]
type = "homogeneous"
sigma_s = 0.5
sigma_a = 0.1
[[shapes]]
type = "rectangle"
size = [4, 4]
material = "white"
[[shapes]]
type = "sphere"
radius = 1
material = "air"
interior = "fog"
[[lights]]
type = "point"
position = [0, 2, 2]
power = 100
"""


def cases(tmp):
    tiny = pathlib.Path(tmp) / "tiny.toml"
    tiny.write_text(TINY)
    return [
        ("cornell-fog, 8 iterations", REPO / "scenes/cornell-fog.toml", 8, {}, 1),
        ("vdb-cloud, 8 iterations", REPO / "scenes/vdb-cloud.toml", 8, {}, 1),
        ("vdb-cloud, 128x128 dataset image", REPO / "scenes/vdb-cloud.toml", 40, {"photons": 20000}, 1),
        ("32x32 fog, 2 iterations of 1,000 paths", tiny, 2, {"photons": 1000}, 100),
    ]


def small_copy(path, tmp):
    """The scene at 128 x 128 pixels, as the dataset example renders it (docs/python/dataset.py)."""
    text = path.read_text().replace("resolution = [640, 400]", "resolution = [128, 128]")
    text = text.replace('file = "../media/', f'file = "{REPO}/media/')
    out = pathlib.Path(tmp) / "small.toml"
    out.write_text(text)
    return out


def rust_times(scene, iterations, threads, rounds, settings):
    assignments = ",".join(f"{k}={v}" for k, v in settings.items())
    out = subprocess.run(
        ["cargo", "bench", "-q", "--bench", "api_render", "--", str(scene), str(iterations), str(threads),
         str(rounds), assignments],
        cwd=REPO, check=True, capture_output=True, text=True,
    ).stdout
    return [float(line.split()[0]) for line in out.splitlines() if line.strip()]


def python_times(scene, iterations, threads, rounds, settings):
    times = []
    for _ in range(rounds):
        start = time.perf_counter()
        image = haze.render(scene, iterations=iterations, threads=threads, **settings)
        times.append(time.perf_counter() - start)
        assert image.iterations == iterations
    return times


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--turns", type=int, default=5)
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--only", default="", help="run the cases whose name contains this")
    args = p.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        for name, path, iterations, settings, more in cases(tmp):
            if args.only not in name:
                continue
            if "128x128" in name:
                path = small_copy(path, tmp)
            scene = haze.Scene.load(path)
            rounds = args.rounds * more
            rust_times(path, iterations, args.threads, 1, settings)  # builds the bench, warms the caches
            rust, py = [], []
            for _ in range(args.turns):
                rust += rust_times(path, iterations, args.threads, rounds, settings)
                py += python_times(scene, iterations, args.threads, rounds, settings)
            r, q = statistics.median(rust), statistics.median(py)
            print(f"{name}: Rust median {r:.4f} s (min {min(rust):.4f}), Python median {q:.4f} s "
                  f"(min {min(py):.4f}); Python/Rust {q / r:.3f} (min/min {min(py) / min(rust):.3f}); "
                  f"{len(rust)} renders each, {args.threads} threads")


if __name__ == "__main__":
    main()
