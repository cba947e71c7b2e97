"""Type stubs of pathmix's native module (python/src/lib.rs)."""

import os
from typing import Any, Callable, Dict, List, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

_Path = Union[str, os.PathLike[str]]
_Progress = Callable[[Dict[str, Any]], None]

class SceneError(ValueError):
    """A scene file that cannot be read or is not valid (file, line, field)."""

class RenderError(RuntimeError):
    """A render that could not run or finish (no adapter, device, write)."""

class Scene:
    """A scene file as read, to render any number of times."""

    def info(self) -> Dict[str, Any]:
        """The scene's settings and contents, as `pathmix info` prints them."""

def load(path: _Path, **params: Any) -> Scene:
    """Reads a TOML or Mitsuba 3 XML scene; `params` as `mitsuba -D name=value`."""

def render(
    scene: Scene,
    *,
    spp: Optional[int] = None,
    strategy: Optional[str] = None,
    seed: Optional[int] = None,
    width: Optional[int] = None,
    height: Optional[int] = None,
    max_depth: Optional[int] = None,
    rr_depth: Union[int, str, None] = None,
    time: Optional[float] = None,
    target_error: Optional[float] = None,
    adaptive: bool = False,
    adaptive_metric: Optional[str] = None,
    light_weight: Optional[float] = None,
    sampler: Optional[str] = None,
    light_selection: Optional[str] = None,
    reconstruction: Optional[str] = None,
    return_error: bool = False,
    return_sample_counts: bool = False,
    aovs: Optional[str] = None,
    progress: Optional[_Progress] = None,
) -> Union[npt.NDArray[np.float32], Tuple[Any, ...]]:
    """Renders once: float32 (height, width, 3) linear radiance; with
    `return_error`, `return_sample_counts` and/or `aovs` (Mitsuba's `aovs`
    string, e.g. "albedo,nn:sh_normal"), a tuple (image, error, sample_counts,
    aovs) of those asked for, `aovs` a dict of float32 (height, width,
    channels) arrays by name."""

def converge(
    scene: Scene,
    *,
    variants: Optional[List[str]] = None,
    max_spp: int = 256,
    width: Optional[int] = None,
    height: Optional[int] = None,
    max_depth: Optional[int] = None,
    seed: Optional[int] = None,
    reference_spp: int = 4096,
    out: Optional[_Path] = None,
) -> List[Dict[str, Any]]:
    """Each variant's error against time and samples, as `pathmix converge`
    measures it: a dict per rung (variant, spp, seconds, paths_per_second,
    rmse, relative_rmse, estimated_error, efficiency)."""

class Run:
    def __init__(
        self,
        scene: Scene,
        *,
        spp: Optional[int] = None,
        strategy: Optional[str] = None,
        seed: Optional[int] = None,
        width: Optional[int] = None,
        height: Optional[int] = None,
        max_depth: Optional[int] = None,
        rr_depth: Union[int, str, None] = None,
        time: Optional[float] = None,
        target_error: Optional[float] = None,
        adaptive: bool = False,
        adaptive_metric: Optional[str] = None,
        light_weight: Optional[float] = None,
        sampler: Optional[str] = None,
        light_selection: Optional[str] = None,
        reconstruction: Optional[str] = None,
        checkpoint: Optional[_Path] = None,
        resume: Optional[_Path] = None,
    ) -> None: ...
    def step(self, every: int, progress: Optional[_Progress] = None) -> Dict[str, Any]: ...
    def close(self) -> None: ...

def write_exr(path: _Path, image: npt.NDArray[np.float32]) -> None:
    """Writes a linear (height, width, 3) image as RGB OpenEXR."""

def write_png(path: _Path, image: npt.NDArray[np.float32], exposure: float = 0.0) -> None:
    """Writes a linear (height, width, 3) image as 8-bit sRGB PNG."""

def read_exr(path: _Path) -> npt.NDArray[np.float32]:
    """Reads an RGB OpenEXR image as float32 (height, width, 3)."""
