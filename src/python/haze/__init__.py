"""haze: a progressive photon mapper for participating media — fog, smoke and clouds, with
error bars.

    import haze
    scene = haze.Scene.load("scenes/cornell-fog.toml")
    image = haze.render(scene, iterations=16, threads=2)
    image.rgb            # float32 NumPy array, (height, width, 3), linear radiance
    image.variance       # each pixel's estimated variance of the mean
    image.bias           # each pixel's estimated kernel bias (photon mapping)
    image.write("fog.exr")   # OpenEXR with the error layers, and a PNG preview

Scenes come from a scene file (`Scene.load`), the text of one (`Scene.from_toml`) or a dict
with the same keys (`Scene.from_dict`); bad input raises `SceneError`, naming the key and, for
files, the line. `render` takes the scene's `[render]` settings and any of them as keyword
arguments (`photons=`, `integrator=`, `alpha=`, ...); `iterations=range(a, b)` renders a range of
iterations as a `Partial`, and `merge` joins the parts of one render exactly.

Rendering releases the GIL. Ctrl-C stops a render at once (the iteration under way is dropped)
and raises `KeyboardInterrupt`, whose `partial` attribute holds the iterations finished (a
`Partial`, or None); so does an exception raised by the progress callback. A `progress` callback receives a `Progress` after iterations, from the
thread that called `render`, at most four times a second (and once at the end).

The guide is docs/python.md in the repository.
"""

from ._haze import Image, Partial, Progress, Scene, SceneError, __version__, merge, render

__all__ = ["Image", "Partial", "Progress", "Scene", "SceneError", "merge", "render", "__version__"]
