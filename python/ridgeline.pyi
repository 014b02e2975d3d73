# Type stub of the `ridgeline` extension module (python/src/lib.rs), shipped in the
# wheel by maturin: what editors and type checkers know of the package.
import os
from typing import Any, Callable, Literal, Mapping, Optional, Sequence, Tuple, TypedDict, Union, final

import numpy as np
import numpy.typing as npt

__all__ = ["synthesize", "CancelToken", "Cancelled", "__version__", "STAGES"]

__version__: str

#: The labels a progress callback gets, in the order the stages run.
STAGES: Tuple[str, ...]

class Cancelled(Exception):
    """The job was stopped before it finished: by its CancelToken or by its
    progress callback returning False."""

@final
class CancelToken:
    """Stops the jobs it is given (`synthesize(..., cancel=token)`) at their next
    check; `cancel()` may be called from any thread. It stays cancelled."""

    def __init__(self) -> None: ...
    def cancel(self) -> None: ...
    @property
    def cancelled(self) -> bool: ...

class _StrokeRequired(TypedDict):
    pen: Literal["ridge", "valley", "eraser"]
    width: float
    points: Union[Sequence[Sequence[float]], npt.NDArray[np.floating]]

class _Stroke(_StrokeRequired, total=False):
    """A stroke: pen, pen diameter in cells, points [[x, y], ...] in cells, and
    optional per-point pen diameters and elevations (metres)."""

    widths: Sequence[float]
    elevations: Sequence[float]

class _StrokeDocument(TypedDict):
    """A vector sketch, as `ridgeline synth --sketch strokes.json` reads it."""

    width: int
    height: int
    strokes: Sequence[_Stroke]

_Path = Union[str, "os.PathLike[str]"]
_Heights = npt.NDArray[Union[np.floating[Any], np.integer[Any]]]
_Exemplar = Union[_Heights, Tuple[_Heights, float]]

_Sketch = Union[npt.NDArray[np.uint8], _Path, _StrokeDocument, Sequence[_Stroke]]
_Exemplars = Union[_Path, _Heights, Mapping[str, _Exemplar], Sequence[_Exemplar]]
_Progress = Callable[[str, int, int], Optional[bool]]

def synthesize(
    sketch: _Sketch,
    exemplars: _Exemplars,
    *,
    size: Optional[Tuple[int, int]] = None,
    seed: int = 0,
    patch_size: int = 64,
    cell_size: Optional[float] = None,
    threads: Optional[int] = None,
    large_scale: bool = True,
    fit_sketch: bool = True,
    elevation_range: Optional[Tuple[float, float]] = None,
    erode: Optional[float] = None,
    cache_dir: Optional[_Path] = None,
    max_memory: Union[int, str, None] = None,
    max_side: Optional[int] = None,
    progress: Optional[_Progress] = None,
    cancel: Optional[CancelToken] = None,
    wrap: bool = False,
    base: Union[npt.NDArray[np.floating], _Path, None] = None,
    mask: Optional[npt.NDArray[Any]] = None,
    extend: Optional[Tuple[int, int, int, int]] = None,
    blend: Optional[int] = None,
    regions: Optional[Mapping[str, Any]] = None,
) -> npt.NDArray[np.float32]:
    """Synthesises a terrain from a sketch and exemplar DEMs: a float32 array of
    shape (height, width), in metres. See the module's docstring at runtime
    (`help(ridgeline.synthesize)`) for every argument."""
    ...
