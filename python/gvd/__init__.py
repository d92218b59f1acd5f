"""Generalized Voronoi diagrams of labelled 3D triangle meshes and 2D segment sets.

The engine of ``gvd compute`` in-process, on numpy arrays; docs/PYTHON.md is the guide::

    import numpy as np, gvd
    scene = gvd.Scene(dimension=3)
    scene.add("a", vertices_a, triangles_a)   # (n, 3) float64, (m, 3) integers
    scene.add("b", mesh_b)                    # anything with .vertices and .faces
    r = gvd.compute(scene, threads=0, progress=True)
    r.graph                                   # dual-graph edges (numpy structured array)
    r.neighbors("a", ring=2)
    near = r.nearest(points)                  # near.object, near.distance, near.closest
    r.path(p, q, min_clearance=0.01)
    V, F = r.cell("a")
    r.save("r.gvd"); gvd.load("r.gvd"); r.write_glb("gvd.glb")
    g = gvd.grid(scene, 256)                  # uniform grid: g.distance, g.labels (numpy)
"""

from ._gvd import (  # noqa: F401  (the module's whole API, implemented in C++)
    __version__,
    Scene,
    Result,
    Cell,
    CancelToken,
    Nearest,
    Path,
    Explosion,
    Grid,
    compute,
    grid,
    load,
    Error,
    InvalidScene,
    InvalidArgument,
    UnsupportedFormat,
    OutsideDomain,
    LimitExceeded,
    NotFound,
    IoError,
    Cancelled,
    InternalError,
)

__all__ = [
    "Scene", "Result", "Cell", "CancelToken", "Nearest", "Path", "Explosion", "Grid",
    "compute", "grid", "load",
    "Error", "InvalidScene", "InvalidArgument", "UnsupportedFormat", "OutsideDomain",
    "LimitExceeded", "NotFound", "IoError", "Cancelled", "InternalError",
]

# The classes are defined in gvd._gvd; they are documented and used as gvd.X.
for _cls in (Scene, Result, Cell, CancelToken, compute, grid, load):
    try:
        _cls.__module__ = "gvd"
    except (AttributeError, TypeError):
        pass
del _cls
