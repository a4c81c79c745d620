"""Type stub of the haze module (the native part is haze._haze; the guide is docs/python.md)."""

import os
from typing import Any, Callable, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

_Path = Union[str, os.PathLike[str]]
_Layer = npt.NDArray[np.float32]

class SceneError(ValueError):
    """A scene or render setting haze cannot use; the message names the file, the key (a
    dotted path such as `media.fog.sigma_s`) and, for scene files, the line."""

class Scene:
    """A scene, loaded and checked. Immutable; render it as often as you like."""

    @staticmethod
    def load(path: _Path) -> Scene:
        """Loads a scene file (docs/scene-format.md); its relative paths resolve against the
        file's directory. Raises SceneError (bad content) or OSError (unreadable file)."""
    @staticmethod
    def from_toml(text: str, base_dir: Optional[_Path] = None, name: str = "<string>") -> Scene:
        """A scene from the text of a scene file; relative paths resolve against `base_dir`
        (default: the working directory); `name` stands for the text in error messages."""
    @staticmethod
    def from_dict(scene: Mapping[str, Any], base_dir: Optional[_Path] = None) -> Scene:
        """A scene from a dict with the keys of a scene file (`camera`, `render`, `materials`,
        `media`, `shapes`, `lights`). Values may be numbers, strings, booleans, lists, tuples,
        dicts, NumPy arrays and scalars, and paths. Errors name the key, e.g.
        `<dict>: media.fog.sigma_s: ...`."""
    @property
    def resolution(self) -> Tuple[int, int]:
        """(width, height) of the camera's image."""
    @property
    def settings(self) -> dict[str, Any]:
        """The scene's render settings: every `[render]` key (None where unset)."""
    @property
    def path(self) -> Optional[str]:
        """The scene file, or None for a scene from text or a dict."""

class Progress:
    """What a progress callback receives, after an iteration."""

    iteration: int
    """Iterations finished in this call."""
    total: Optional[int]
    """Iterations this call renders at most, or None (a time limit alone)."""
    elapsed: float
    """Seconds since the render started."""
    time_limit: Optional[float]
    """The time limit in seconds, or None."""
    error: Optional[float]
    """The estimated relative error so far (as Image.error), or None (not computed yet)."""

class Image:
    """A rendered image: float32 layers of shape (height, width, 3), linear, top row first.
    The arrays own the buffers the renderer filled (no copy); `write` reads them back."""

    @property
    def rgb(self) -> _Layer:
        """Linear RGB radiance."""
    @property
    def variance(self) -> Optional[_Layer]:
        """Each pixel's estimated variance of the mean; None below two iterations."""
    @property
    def bias(self) -> Optional[_Layer]:
        """Each pixel's estimated kernel bias; None for the path tracer."""
    @property
    def resolution(self) -> Tuple[int, int]:
        """(width, height)."""
    @property
    def iterations(self) -> int:
        """Iterations averaged."""
    @property
    def first_iteration(self) -> int:
        """The first iteration's index (1 unless a range was rendered)."""
    @property
    def elapsed(self) -> float:
        """Seconds spent rendering."""
    @property
    def light_paths(self) -> int:
        """Light paths traced in all."""
    @property
    def relative_noise(self) -> Optional[float]:
        """Estimated relative noise of the whole image, or None."""
    @property
    def kernel_bias(self) -> Optional[Tuple[float, Optional[float]]]:
        """Estimated kernel bias relative to the mean, with its standard error; or None."""
    @property
    def error(self) -> Optional[float]:
        """Estimated relative error, the figure `target_error` stops on (the upper confidence
        limit of the relative RMSE from noise and kernel bias); or None."""
    @property
    def settings(self) -> dict[str, Any]:
        """The settings it was rendered with."""
    def write(self, path: _Path, exposure: float = 1.0) -> list[str]:
        """Writes OpenEXR (with the variance and bias layers) and a PNG preview beside it, or a
        PNG alone for a `.png` path, atomically; returns the paths written."""
    def _buffer_addresses(self) -> Tuple[int, int, int]: ...

class Partial:
    """A range of a render's iterations; parts of one render merge exactly."""

    @staticmethod
    def read(path: _Path) -> Partial:
        """Reads a partial render (`.hpr`)."""
    @staticmethod
    def merge(parts: Sequence[Union[Partial, _Path]]) -> Partial:
        """Merges parts of one render (objects or `.hpr` paths) into one partial render."""
    def image(self) -> Image:
        """The image of these iterations."""
    def write(self, path: _Path) -> None:
        """Writes the partial render (`.hpr`), for `haze merge` or `Partial.read`."""
    @property
    def first_iteration(self) -> int: ...
    @property
    def last_iteration(self) -> int: ...
    @property
    def iterations(self) -> int: ...

def render(
    scene: Scene,
    iterations: Union[int, range, None] = None,
    time: Optional[float] = None,
    target_error: Optional[float] = None,
    threads: Optional[int] = None,
    seed: Optional[int] = None,
    progress: Optional[Callable[[Progress], Any]] = None,
    **settings: Any,
) -> Any:
    """Renders `scene` with its settings, overridden by the arguments and by any `[render]` key
    given as a keyword (photons=, integrator=, alpha=, volume_estimate=, merges=, ...).

    iterations: a count (from iteration 1), or a range of iteration indices, counted from 1 as
        on the command line (range(1, 9) is iterations 1..8), which returns a Partial.
    time: a time limit in seconds (with no count, the render runs until it).
    target_error: stop once the estimated relative error (Image.error) is this low; the
        iteration count or time limit still bounds the render.
    threads: worker threads (default: every core).
    seed: the seed of every random stream; the same scene, seed and iterations give the same
        image whatever the thread count.
    progress: called with a Progress from this thread, at most four times a second and once
        at the end; an exception it raises stops the render and propagates.

    Returns an Image (a Partial for a range). Releases the GIL while rendering. Ctrl-C stops
    at the end of the current iteration and raises KeyboardInterrupt with the finished
    iterations as its `partial` attribute (a Partial, or None). Raises SceneError for a bad
    setting."""

def merge(parts: Sequence[Union[Partial, _Path]]) -> Image:
    """The image of parts of one render (Partial objects or `.hpr` paths), merged exactly:
    identical to rendering their union of iterations in one call."""
