"""pathmix from Python: load a scene once, render it to NumPy arrays.

>>> import pathmix
>>> scene = pathmix.load("scenes/cornell.toml")
>>> image = pathmix.render(scene, spp=16)          # float32 (height, width, 3), linear
>>> image, error = pathmix.render(scene, spp=64, return_error=True)

A progressive run, stopped whenever the caller likes:

>>> with pathmix.Session(scene, spp=1024) as session:
...     for step in session.run(every=16):
...         if step.relative_error is not None and step.relative_error < 0.02:
...             break

`converge(scene, variants=["cosine", "light", "mixture"])` measures each
strategy's error against time, as `pathmix converge` does, and returns its
table as a list of dicts (`pandas.DataFrame(rows)` makes a frame of it).

Rendering releases the GIL, so renders from several threads run at once;
Ctrl-C stops a render between submissions (about a second) and raises
KeyboardInterrupt. What is kept between calls: the GPU device (opened at the
first render) and the kernels compiled for it, so that rendering a scene again
with the same kernel settings compiles nothing; and each `Scene`'s files, read
once by `load`. Nothing is printed; the library's notices are Python warnings.
"""

from typing import Any, Callable, Dict, Iterator, NamedTuple, Optional

import numpy as np

from ._pathmix import (
    RenderError,
    Run as _Run,
    Scene,
    SceneError,
    converge,
    load,
    read_exr,
    render,
    write_exr,
    write_png,
)

__all__ = [
    "RenderError",
    "Scene",
    "SceneError",
    "Session",
    "converge",
    "Step",
    "load",
    "read_exr",
    "render",
    "write_exr",
    "write_png",
]


class Step(NamedTuple):
    """What a progressive run holds after one of its steps."""

    image: np.ndarray
    """The mean radiance so far: float32 (height, width, 3), linear."""
    error: Optional[np.ndarray]
    """The standard error of each pixel's mean (None before 2 samples per pixel)."""
    samples: int
    """Samples per pixel so far (adaptive: their mean, rounded down)."""
    elapsed: float
    """Seconds spent rendering so far."""
    relative_error: Optional[float]
    """The image's estimated relative error at the run's last check, if made."""
    sample_counts: Optional[np.ndarray]
    """An adaptive run's samples of each pixel: uint32 (height, width)."""


class Session:
    """A progressive render of `scene`: the image and its error after each step.

    Takes the keyword arguments of `render` (the run stops at `spp`, after
    `time` seconds or at `target_error`, whichever comes first), and
    `checkpoint`, a file the state is saved to when the session closes (and
    every minute), or `resume`, a checkpoint to continue. Use it as a context
    manager, or call `close`.
    """

    def __init__(self, scene: Scene, **settings: Any) -> None:
        self._run = _Run(scene, **settings)

    def run(
        self,
        every: int = 16,
        progress: Optional[Callable[[Dict[str, Any]], None]] = None,
    ) -> Iterator[Step]:
        """Renders `every` samples per pixel at a time, yielding a `Step` after
        each, until the run's rule stops it or the caller stops iterating."""
        while True:
            step = self._run.step(every, progress)
            done = step.pop("done")
            yield Step(**step)
            if done:
                return

    def close(self) -> None:
        """Ends the run, saving the checkpoint where one was asked for."""
        self._run.close()

    def __enter__(self) -> "Session":
        return self

    def __exit__(self, *exception: Any) -> None:
        self.close()
