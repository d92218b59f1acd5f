# Type stubs of the gvd package (the C++ extension gvd._gvd, re-exported). docs/PYTHON.md.
import os
from typing import Any, Callable, Iterator, NamedTuple, Optional, Sequence, Union, overload

import numpy as np
import numpy.typing as npt

__version__: str

_PathLike = Union[str, os.PathLike[str]]
_Points = npt.ArrayLike  # (n, D) or (D,) numbers; C-contiguous float64 is read in place
_ObjectRef = Union[str, int]  # a label or an index

class Error(Exception):
    """A gvd::Error of the core; one subclass per code."""

    code: Optional[str]  # 'invalid_scene', 'invalid_argument', ..., 'io_error', 'internal'
    detail: str
    label: Optional[str]
    object: Optional[int]
    element: Optional[str]  # 'vertex', 'triangle', 'segment', 'point'
    index: Optional[int]
    line: Optional[int]  # 1-based line of a text mesh file
    offset: Optional[int]  # 0-based byte offset into malformed JSON

class InvalidScene(Error, ValueError): ...
class InvalidArgument(Error, ValueError): ...
class UnsupportedFormat(Error, ValueError): ...
class OutsideDomain(Error, ValueError): ...
class LimitExceeded(Error): ...
class NotFound(Error, LookupError): ...
class IoError(Error, OSError): ...
class Cancelled(Error): ...
class InternalError(Error, RuntimeError): ...

class CancelToken:
    def __init__(self) -> None: ...
    def cancel(self) -> None: ...
    def reset(self) -> None: ...
    @property
    def cancelled(self) -> bool: ...

class _MeshLike:
    vertices: npt.ArrayLike
    faces: npt.ArrayLike

class Scene:
    def __init__(self, dimension: int = 3) -> None: ...
    @staticmethod
    def load(paths: Union[_PathLike, Sequence[_PathLike]]) -> Scene: ...
    @overload
    def add(self, label: str, vertices: npt.ArrayLike, faces: npt.ArrayLike) -> int: ...
    @overload
    def add(self, label: str, vertices: Any, faces: None = None) -> int: ...  # a mesh-like
    @property
    def dimension(self) -> int: ...
    @property
    def units(self) -> Optional[str]: ...
    @units.setter
    def units(self, units: Optional[str]) -> None: ...
    @property
    def labels(self) -> tuple[str, ...]: ...
    def __len__(self) -> int: ...
    @staticmethod
    def from_labels(labels: np.ndarray, spacing: Optional[Sequence[float]] = None,
                    origin: Optional[Sequence[float]] = None,
                    background: Optional[int] = 0) -> Scene: ...

class Nearest(NamedTuple):
    """Fields may be added in later versions: read them by name."""

    object: Any  # np.ndarray int32 (n,), or int for one point
    distance: Any  # np.ndarray float64 (n,), or float; negative inside a closed object
    closest: np.ndarray  # float64 (n, D), or (D,)
    inside: Any  # np.ndarray int8 (n,): 1 in, 0 out, -1 open object; or True/False/None

class Path(NamedTuple):
    found: bool
    points: np.ndarray  # float64 (k, D)
    length: float
    min_clearance: float
    reason: str

class Explosion(NamedTuple):
    scale: float
    ring: np.ndarray  # int32 (n,)
    displacement: np.ndarray  # float64 (n, D)
    factor: np.ndarray  # float64 (n,): share of the paper's displacement kept (collision-free)

class Grid(NamedTuple):
    """A uniform grid (gvd.grid, Result.grid). Fields may be added: read them by name."""

    distance: np.ndarray  # float32 (float64 with float64=True), (ny, nx) / (nz, ny, nx)
    labels: np.ndarray  # int32, same shape: nearest object, -1 for none
    origin: np.ndarray  # float64 (D,): the corner of cell 0
    cell: float  # edge length of a cell
    metric: str  # 'l2', 'l1' or 'linf'
    units: Optional[str]  # the scene's length unit, None when it declared none
    backend: str

class Cell:
    vertices: np.ndarray  # float64 (n, D)
    faces: np.ndarray  # uint32 (m, D)
    other: np.ndarray  # int32 (n,)
    clearance: np.ndarray  # float64 (n,)
    def __len__(self) -> int: ...
    def __iter__(self) -> Iterator[np.ndarray]: ...
    def __getitem__(self, i: int) -> np.ndarray: ...

class Result:
    @property
    def dimension(self) -> int: ...
    @property
    def units(self) -> Optional[str]: ...
    @property
    def labels(self) -> tuple[str, ...]: ...
    def __len__(self) -> int: ...
    def object(self, label: str) -> int: ...
    @property
    def graph(self) -> np.ndarray:
        """Structured: a, b (int32), area, min_clearance, tightest_point (D,), gap, touching."""
    def neighbors(self, object: _ObjectRef, ring: int = 1) -> np.ndarray:
        """Structured: object, ring, via (int32), area, min_clearance, gap, touching."""
    def nearest(self, points: _Points, fast: bool = False, threads: int = 0) -> Nearest: ...
    def contacts(self, max_gap: float) -> list[dict[str, Any]]: ...
    def path(
        self, a: _Points, b: _Points, *, min_clearance: float = 0.0, by_clearance: bool = False
    ) -> Path: ...
    def cell(self, object: _ObjectRef) -> Cell: ...
    def explode(self, anchor: _ObjectRef, scale: float = 0.0) -> Explosion: ...
    def grid(
        self,
        resolution: int = 256,
        *,
        metric: str = "l2",
        signed: bool = True,
        float64: bool = False,
        domain: Optional[Sequence[float]] = None,
        max_cells: int = 134217728,
        threads: int = 0,
        progress: Union[None, bool, Callable[[str, float], Any]] = None,
        cancel: Optional[CancelToken] = None,
    ) -> Grid: ...
    def save(self, path: _PathLike) -> None: ...
    def write_glb(self, path: _PathLike) -> None: ...
    def write_json(self, path: _PathLike) -> None: ...
    def write_graph_json(self, path: _PathLike) -> None: ...
    def info_json(self) -> str: ...
    @property
    def info(self) -> dict[str, Any]: ...

def compute(
    scene: Union[Scene, _PathLike, Sequence[_PathLike]],
    *,
    progress: Union[None, bool, Callable[[str, float], Any]] = None,
    cancel: Optional[CancelToken] = None,
    max_depth: int = 0,
    domain: Optional[Sequence[float]] = None,
    frame: str = "auto",
    threads: int = 0,
    backend: str = "auto",
    octree_build: str = "levels",
    distance: str = "exact",
    refine: str = "certified",
    junctions: str = "on",
    resolution: str = "compact",
    curved_tolerance: float = 0.0,
    contact_depth: int = 0,
    max_leaves: int = 12000000,
    max_objects: int = 100000,
    max_simplices: int = 20000000,
    ambiguity_levels: int = -1,
    ambiguity_rounds: int = -1,
    unseen_rounds: int = -1,
) -> Result: ...
def grid(
    scene: Union[Scene, _PathLike, Sequence[_PathLike]],
    resolution: int = 256,
    *,
    metric: str = "l2",
    signed: bool = True,
    float64: bool = False,
    domain: Optional[Sequence[float]] = None,
    range_cells: int = 0,
    max_cells: int = 134217728,
    threads: int = 0,
    backend: str = "auto",
    progress: Union[None, bool, Callable[[str, float], Any]] = None,
    cancel: Optional[CancelToken] = None,
) -> Grid: ...
def load(path: _PathLike) -> Result: ...
