"""Small meshes as numpy arrays for the tests of the Python module (no gvd involved)."""

import json

import numpy as np


def box(lo, hi):
    """An axis-aligned box as a closed triangle mesh with outward normals: (8, 3), (12, 3)."""
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    vertices = np.array([[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0],
                         [x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]], dtype=float)
    faces = np.array([[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4],
                      [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]],
                     dtype=np.int64)
    return vertices, faces


def icosphere(center, radius, subdivisions=2):
    """A closed sphere mesh: an icosahedron subdivided `subdivisions` times, projected."""
    t = (1 + 5 ** 0.5) / 2
    v = [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t],
         [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]]
    f = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
         [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
         [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]]
    vertices = [np.array(p, dtype=float) / np.linalg.norm(p) for p in v]
    for _ in range(subdivisions):
        midpoint = {}

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in midpoint:
                p = vertices[a] + vertices[b]
                vertices.append(p / np.linalg.norm(p))
                midpoint[key] = len(vertices) - 1
            return midpoint[key]

        nf = []
        for a, b, c in f:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            nf += [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
        f = nf
    return (np.array(vertices) * radius + np.asarray(center, dtype=float),
            np.array(f, dtype=np.int64))


def sphere_lattice(n, gap, subdivisions=2):
    """n^3 unit-diameter spheres on a lattice, `gap` apart: (label, vertices, faces) each."""
    out = []
    for i in range(n):
        for j in range(n):
            for k in range(n):
                c = np.array([i, j, k], dtype=float) * (1 + gap)
                v, f = icosphere(c, 0.5, subdivisions)
                out.append((f"s{i}{j}{k}", v, f))
    return out


def scene_arrays(path):
    """The objects of a scene JSON file as (dimension, [(label, vertices, simplices)])."""
    with open(path) as f:
        doc = json.load(f)
    dim = doc["dimension"]
    key = "triangles" if dim == 3 else "segments"
    return dim, [(o["label"], np.array(o["vertices"], dtype=float), np.array(o[key]))
                 for o in doc["objects"]]
