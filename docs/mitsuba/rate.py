#!/usr/bin/env python3
"""Samples per pixel per second of Mitsuba 3 volpath (llvm_ad_rgb) and haze's path tracer on one
scene, measured in turn in one run (docs/performance.md, "Ray queries against Embree" and
docs/mitsuba/README.md).

    python rate.py [SCENE] [WxH] [HAZE,HAZE...] [MAX_BOUNCES]

SCENE is a bundled scene's name (default cornell-fog), WxH the resolution (default 200x200),
then one or more haze binaries (default target/release/haze) and the bounce limit (default the
scene's max_bounces; Mitsuba gets max_depth = bounces + 1, as compare.py converts it). Three
rounds; in each, Mitsuba renders chunks of 16 spp for 12 s (after one untimed chunk for the JIT),
then each haze renders 96 one-sample iterations on 2 threads. Prints every round's rate and its
ratio to Mitsuba's in the same round. Run with the virtualenv of compare.py.
"""

import os
import subprocess
import sys
import tempfile
import time
import tomllib

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
import compare as C  # noqa: E402


def main():
    name = sys.argv[1] if len(sys.argv) > 1 else "cornell-fog"
    res = [int(v) for v in (sys.argv[2] if len(sys.argv) > 2 else "200x200").split("x")]
    hazes = (sys.argv[3].split(",") if len(sys.argv) > 3
             else [os.path.join(ROOT, "target", "release", "haze")])
    scene_path = os.path.join(ROOT, "scenes", f"{name}.toml")
    with open(scene_path, "rb") as f:
        desc = tomllib.load(f)
    bounces = int(sys.argv[4]) if len(sys.argv) > 4 else desc.get("render", {}).get("max_bounces", 64)
    lib = C.llvm_library()
    if lib is None:
        raise SystemExit("needs libLLVM: apt-get install libllvm19, or set DRJIT_LIBLLVM_PATH")
    os.environ["DRJIT_LIBLLVM_PATH"] = lib
    import drjit as dr
    dr.set_thread_count(2)
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    tmp = tempfile.mkdtemp()
    scene = mi.load_dict(C.mitsuba_scene(mi, scene_path, res, bounces, tmp), parallel=False)
    C.mitsuba_render(mi, scene, C.CHUNK, 1)  # JIT warm-up, not timed
    rates = {"Mitsuba llvm_ad_rgb": []}
    rates.update({h: [] for h in hazes})
    for rnd in range(3):
        t0, spp, k = time.time(), 0, 0
        while time.time() - t0 < 12:
            C.mitsuba_render(mi, scene, C.CHUNK, 10 + 100 * rnd + k)
            spp, k = spp + C.CHUNK, k + 1
        rates["Mitsuba llvm_ad_rgb"].append(spp / (time.time() - t0))
        for h in hazes:
            n = 96
            t0 = time.time()
            subprocess.run([h, "render", scene_path, "--integrator", "path", "--resolution",
                            f"{res[0]}x{res[1]}", "--max-bounces", str(bounces), "-n", str(n),
                            "-j", "2", "-o", os.path.join(tmp, "haze.exr"), "-q"],
                           check=True, capture_output=True)
            rates[h].append(n / (time.time() - t0))
    mitsuba = rates["Mitsuba llvm_ad_rgb"]
    for who, v in rates.items():
        print(f"{name} {res[0]}x{res[1]}, {bounces} bounces, {who}: spp/s "
              + ", ".join(f"{x:.1f}" for x in v) + "; ratio to Mitsuba "
              + ", ".join(f"{x / m:.2f}" for x, m in zip(v, mitsuba)))


if __name__ == "__main__":
    main()
