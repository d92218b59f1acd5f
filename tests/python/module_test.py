"""The Python module gvd against the `gvd` command and analytic answers (ctest label python).

Run by CTest with /usr/bin/python3 and PYTHONPATH = the build tree's python/ directory;
GVD_CLI is the `gvd` binary, GVD_TEST_DATA_DIR tests/data, GVD_TEST_OUTPUT_DIR a scratch
directory. Every check compares with something computed independently: the CLI's JSON on the
same scene, geometry known in advance (two boxes: the mirror plane), numpy's own memory
accounting (tracemalloc), a second Python thread, a signal sent to a child process.
"""

import glob
import json
import math
import os
import pydoc
import signal
import subprocess
import sys
import tempfile
import threading
import time
import tracemalloc
import unittest

import numpy as np

import gvd

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import meshes  # noqa: E402

CLI = os.environ.get("GVD_CLI", "gvd")
DATA = os.environ.get("GVD_TEST_DATA_DIR", os.path.join(os.path.dirname(__file__), "..", "data"))
OUT = os.path.join(os.environ.get("GVD_TEST_OUTPUT_DIR", "/tmp"), "python_module")
os.makedirs(OUT, exist_ok=True)
SCENES = sorted(glob.glob(os.path.join(DATA, "scenes", "*.json")))


def cli(*args):
    """Runs the gvd command; its stdout."""
    p = subprocess.run([CLI, *args], capture_output=True, text=True, timeout=300)
    if p.returncode != 0:
        raise AssertionError(f"gvd {' '.join(args)} exited {p.returncode}: {p.stderr}")
    return p.stdout


def scene_from_arrays(path):
    dim, objects = meshes.scene_arrays(path)
    scene = gvd.Scene(dimension=dim)
    for label, vertices, simplices in objects:
        scene.add(label, vertices, simplices)
    return scene


def assert_same_array(test, a, b):
    """Structured arrays equal field by field (tolist() would hold the (D,) fields as arrays)."""
    test.assertEqual(a.dtype.names, b.dtype.names)
    test.assertEqual(a.shape, b.shape)
    for name in a.dtype.names:
        test.assertTrue(np.array_equal(a[name], b[name]), name)


def two_boxes(gap=0.1):
    scene = gvd.Scene(3)
    scene.add("left", *meshes.box((0, 0, 0), (1, 1, 1)))
    scene.add("right", *meshes.box((1 + gap, 0, 0), (2 + gap, 1, 1)))
    return scene


class CliParity(unittest.TestCase):
    """The bundled scenes computed from numpy arrays equal `gvd compute` on the same files."""

    @classmethod
    def setUpClass(cls):
        cls.cases = {}
        for path in SCENES:
            name = os.path.splitext(os.path.basename(path))[0]
            saved = os.path.join(OUT, name + ".gvd")
            graph = os.path.join(OUT, name + "_graph.json")
            cli("compute", path, "--graph", graph, "--save", saved, "--backend", "cpu", "-q")
            with open(graph) as f:
                cli_graph = json.load(f)
            result = gvd.compute(scene_from_arrays(path), backend="cpu")
            cls.cases[name] = (path, saved, cli_graph, result)

    def test_scenes_are_there(self):
        self.assertGreaterEqual(len(self.cases), 2)

    def test_graph_equals_cli(self):
        for name, (_, _, cli_graph, r) in self.cases.items():
            with self.subTest(scene=name):
                g = r.graph
                self.assertEqual(len(g), len(cli_graph["edges"]))
                self.assertEqual([n["label"] for n in cli_graph["nodes"]], list(r.labels))
                for e, c in zip(g, cli_graph["edges"]):
                    self.assertEqual((int(e["a"]), int(e["b"])), (c["a"], c["b"]))
                    self.assertEqual(r.labels[e["a"]], c["label_a"])
                    self.assertEqual(r.labels[e["b"]], c["label_b"])
                    self.assertEqual(float(e["area"]), c["area"])
                    self.assertEqual(float(e["min_clearance"]), c["min_clearance"])
                    self.assertEqual(list(e["tightest_point"]), c["tightest_point"])
                    self.assertEqual(float(e["gap"]) if e["gap"] >= 0 else None, c["gap"])
                    self.assertEqual(bool(e["touching"]), c["touching"])

    def test_nearest_equals_cli(self):
        rng = np.random.default_rng(7)
        for name, (path, saved, _, r) in self.cases.items():
            with self.subTest(scene=name):
                dim, objects = meshes.scene_arrays(path)
                allv = np.concatenate([v for _, v, _ in objects])
                lo, hi = allv.min(axis=0), allv.max(axis=0)
                points = lo + rng.random((300, dim)) * (hi - lo)
                points_file = os.path.join(OUT, name + "_points.json")
                with open(points_file, "w") as f:
                    json.dump(points.tolist(), f)
                lines = cli("nearest", saved, "--points", points_file).splitlines()
                self.assertEqual(len(lines), len(points))
                near = r.nearest(points)
                loaded = gvd.load(saved).nearest(points)
                for i, line in enumerate(lines):
                    c = json.loads(line)
                    self.assertEqual(c["point"], points[i].tolist())
                    self.assertEqual(int(near.object[i]), c["object"])
                    self.assertEqual(r.labels[near.object[i]], c["label"])
                    self.assertEqual(float(near.distance[i]), c["signed_distance"])
                    self.assertEqual(abs(float(near.distance[i])), c["distance"])
                    self.assertEqual(int(loaded.object[i]), c["object"])
                    self.assertEqual(float(loaded.distance[i]), c["signed_distance"])
                    inside = {True: 1, False: 0, None: -1}[c["inside"]]
                    self.assertEqual(int(near.inside[i]), inside)
                    self.assertEqual(int(loaded.inside[i]), inside)
                # The closest point is on the object at the reported distance.
                d = np.linalg.norm(near.closest - points, axis=1)
                np.testing.assert_allclose(d, np.abs(near.distance), rtol=1e-12, atol=1e-12)

    def test_contacts_equal_cli(self):
        for name, (path, saved, _, r) in self.cases.items():
            with self.subTest(scene=name):
                doc = json.loads(cli("contacts", saved, "--max-gap", "0.05"))
                mine = r.contacts(0.05)
                self.assertEqual(len(mine), len(doc["contacts"]))
                self.assertGreater(len(mine), 0)
                for m, c in zip(mine, doc["contacts"]):
                    for key in ("a", "b", "label_a", "label_b", "gap", "interference",
                                "depth_lower_bound", "penetration_depth", "interface_area"):
                        self.assertEqual(m[key], c[key], key)
                    self.assertEqual(m["on_a"].tolist(), c["on_a"])
                    self.assertEqual(len(m["sites"]), len(c["sites"]))
                    for ms, cs in zip(m["sites"], c["sites"]):
                        self.assertEqual(ms["area"], cs["area"])
                        self.assertEqual(ms["min_gap"], cs["min_gap"])
                        self.assertEqual(ms["centroid"].tolist(), cs["centroid"])
                    self.assertLess(m["gap"], 0.05)
        with self.assertRaises(gvd.InvalidArgument):
            next(iter(self.cases.values()))[3].contacts(-1.0)

    def test_neighbors_equal_cli(self):
        for name, (_, saved, _, r) in self.cases.items():
            for label in r.labels:
                with self.subTest(scene=name, label=label):
                    c = json.loads(cli("neighbors", saved, "--object", label, "--ring", "2"))
                    n = r.neighbors(label, ring=2)
                    self.assertEqual(len(n), len(c["neighbors"]))
                    for mine, theirs in zip(n, c["neighbors"]):
                        self.assertEqual(int(mine["object"]), theirs["object"])
                        self.assertEqual(r.labels[mine["object"]], theirs["label"])
                        self.assertEqual(int(mine["ring"]), theirs["ring"])
                        self.assertEqual(int(mine["via"]), theirs["via"])
                        self.assertEqual(float(mine["area"]), theirs["area"])
                        self.assertEqual(float(mine["min_clearance"]), theirs["min_clearance"])
                        self.assertEqual(bool(mine["touching"]), theirs["touching"])
                    # By index too.
                    assert_same_array(self, r.neighbors(r.object(label), 2), n)

    def test_path_equals_cli(self):
        queries = {"balls_on_plate": ([0.5, 0.5, 0.8], [0.2, 0.9, 0.05], 0.0),
                   "gears2d": ([-1.3, -2.3], [3.3, 2.3], 0.05)}
        for name, (a, b, clearance) in queries.items():
            if name not in self.cases:
                continue
            with self.subTest(scene=name):
                _, saved, _, r = self.cases[name]
                args = ["path", saved, "--from", ",".join(map(repr, a)), "--to",
                        ",".join(map(repr, b)), "--min-clearance", repr(clearance)]
                p = subprocess.run([CLI, *args], capture_output=True, text=True, timeout=300)
                c = json.loads(p.stdout)
                mine = r.path(a, b, min_clearance=clearance)
                self.assertEqual(mine.found, p.returncode == 0)
                self.assertEqual(mine.points.tolist(), c["points"])
                if mine.found:
                    self.assertEqual(mine.length, c["length"])
                    self.assertEqual(mine.min_clearance, c["min_clearance"])
                else:
                    self.assertEqual(mine.reason, c["reason"])

    def test_scene_files_equal_arrays(self):
        for name, (path, _, _, r) in self.cases.items():
            with self.subTest(scene=name):
                from_file = gvd.compute(path, backend="cpu")
                assert_same_array(self, from_file.graph, r.graph)
                self.assertEqual(gvd.compute(gvd.Scene.load(path), backend="cpu").labels,
                                 r.labels)

    def test_files_equal_cli(self):
        name = "balls_on_plate"
        if name not in self.cases:
            self.skipTest("no balls_on_plate scene")
        path, saved, _, r = self.cases[name]
        mine = os.path.join(OUT, "py_graph.json")
        r.write_graph_json(mine)
        with open(mine) as f, open(os.path.join(OUT, name + "_graph.json")) as g:
            self.assertEqual(f.read(), g.read())
        r.save(os.path.join(OUT, "py.gvd"))
        self.assertEqual(json.loads(cli("info", os.path.join(OUT, "py.gvd"), "--json")),
                         gvd.load(os.path.join(OUT, "py.gvd")).info)
        r.write_glb(os.path.join(OUT, "py.glb"))
        with open(os.path.join(OUT, "py.glb"), "rb") as f:
            self.assertEqual(f.read(4), b"glTF")


class Volumes(unittest.TestCase):
    """Labelled volumes: Scene.from_labels equals `gvd compute --volume` on the same array."""

    def test_from_labels_equals_cli(self):
        labels = np.zeros((6, 4, 5), dtype=np.int32)  # (nz, ny, nx)
        labels[0:2] = 7
        labels[4:6, :, 0:3] = 9
        labels[4:6, :, 3:5] = 3
        path = os.path.join(OUT, "volume.npy")
        np.save(path, labels)
        graph_path = os.path.join(OUT, "volume_graph.json")
        cli("compute", "--volume", path, "--spacing", "1,2,10", "--graph", graph_path, "-q")
        with open(graph_path) as f:
            want = [(e["label_a"], e["label_b"], e["gap"]) for e in json.load(f)["edges"]]
        s = gvd.Scene.from_labels(labels, spacing=(1, 2, 10))
        self.assertEqual(s.labels, ("label_3", "label_7", "label_9"))
        r = gvd.compute(s)
        got = [(r.labels[e["a"]], r.labels[e["b"]], float(e["gap"])) for e in r.graph]
        self.assertEqual(got, want)
        # label_7 (z in [0, 20)) and the others (z from 40) are two 10-deep voxels apart.
        gaps = {(a, b): g for a, b, g in got}
        self.assertAlmostEqual(gaps[("label_7", "label_9")], 20.0, delta=1e-9)
        self.assertEqual(gaps[("label_3", "label_9")], 0.0)  # they touch
        with self.assertRaises(gvd.InvalidScene):
            gvd.Scene.from_labels(-labels)
        with self.assertRaises(gvd.InvalidArgument):
            gvd.Scene.from_labels(labels.astype(np.float32))
        every = gvd.Scene.from_labels(labels, background=None)
        self.assertEqual(len(every), 4)


def cell_centres(g):
    """The cell centres of a gvd.Grid, shape (..., D) in its arrays' layout (x fastest)."""
    d = len(g.origin)
    axes = [g.origin[a] + (np.arange(g.labels.shape[d - 1 - a]) + 0.5) * g.cell for a in range(d)]
    mesh = np.meshgrid(*reversed(axes), indexing="ij")  # (z,) y, x
    return np.stack(list(reversed(mesh)), axis=-1)  # x, y(, z) per cell


def box_distance(p, lo, hi, metric):
    """Signed distance from points p (..., D) to the box [lo, hi] in the metric: the norm of
    the per-axis excess outside; inside, minus the least distance to a face (the same in every
    norm: the nearest boundary point is straight along one axis)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    excess = np.maximum(np.maximum(lo - p, p - hi), 0.0)
    order = {"l2": 2, "l1": 1, "linf": np.inf}[metric]
    outside = np.linalg.norm(excess, ord=order, axis=-1)
    depth = np.minimum(p - lo, hi - p).min(axis=-1)
    return np.where(depth > 0, -depth, outside)


def segment_distance(p, a, b):
    """Euclidean distance from points p (..., 2) to the segment [a, b]."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    t = np.clip(((p - a) @ (b - a)) / ((b - a) @ (b - a)), 0.0, 1.0)
    return np.linalg.norm(p - (a + t[..., None] * (b - a)), axis=-1)


def expect_grid_matches(test, g, distances, scale):
    """Labels equal the oracle's nearest object except at near-ties (the exact answer there is
    a rounding away), distances equal to float precision. `distances`: (objects, ...) signed."""
    unsigned = np.abs(distances)
    nearest = np.argmin(unsigned, axis=0)
    ordered = np.sort(unsigned, axis=0)
    clear = (ordered[1] - ordered[0]) > 1e-9 * scale if len(distances) > 1 else np.ones_like(
        nearest, dtype=bool)
    # Not vacuous: most cells are clear (L-infinity ties whole regions: where the same axis
    # dominates both objects' distances, they are equal).
    test.assertGreater(clear.mean(), 0.5)
    np.testing.assert_array_equal(g.labels[clear], nearest[clear])
    want = np.take_along_axis(distances, nearest[None], axis=0)[0]
    tol = (1e-9 if g.distance.dtype == np.float64 else 1e-6) * scale
    np.testing.assert_allclose(g.distance[clear], want[clear], rtol=0, atol=tol)


class Grids(unittest.TestCase):
    """gvd.grid and Result.grid against oracles written here: nearest object and distance at
    every cell centre from the analytic distance to a box, and brute force over segments."""

    BOXES = (((0, 0, 0), (1, 1, 1)), ((1.1, 0, 0), (2.1, 1, 1)))

    def test_boxes_every_metric(self):
        for metric in ("l2", "l1", "linf"):
            g = gvd.grid(two_boxes(), 24, metric=metric, float64=True)
            self.assertEqual(g.metric, metric)
            self.assertEqual(g.distance.dtype, np.float64)
            self.assertEqual(g.labels.dtype, np.int32)
            self.assertEqual(g.distance.shape, g.labels.shape)
            self.assertEqual(g.labels.shape[2], 24)  # x, the longest side, has 24 cells
            p = cell_centres(g)
            want = np.stack([box_distance(p, lo, hi, metric) for lo, hi in self.BOXES])
            expect_grid_matches(self, g, want, 2.1)
            self.assertTrue((g.distance < 0).any())  # cells inside the boxes, signed

    def test_float32_and_unsigned(self):
        g = gvd.grid(two_boxes(), 20)
        self.assertEqual(g.distance.dtype, np.float32)
        p = cell_centres(g)
        want = np.stack([box_distance(p, lo, hi, "l2") for lo, hi in self.BOXES])
        expect_grid_matches(self, g, want, 2.1)
        self.assertIsNone(g.units)
        scene = two_boxes()
        scene.units = "mm"
        self.assertEqual(gvd.grid(scene, 4).units, "mm")
        self.assertEqual(gvd.compute(scene, backend="cpu").grid(4).units, "mm")
        u = gvd.grid(two_boxes(), 20, signed=False)
        np.testing.assert_array_equal(u.distance, np.abs(g.distance))
        np.testing.assert_array_equal(u.labels, g.labels)

    def test_segments_2d_brute_force(self):
        rng = np.random.default_rng(11)
        scene = gvd.Scene(2)
        segments = []
        for i in range(25):
            a = rng.random(2)
            b = a + 0.1 * (rng.random(2) - 0.5)
            segments.append((a, b))
            scene.add(f"s{i}", np.array([a, b]), np.array([[0, 1]]))
        g = gvd.grid(scene, 80, domain=[-0.1, -0.1, 1.1, 1.1], float64=True)
        self.assertEqual(g.labels.shape, (80, 80))
        np.testing.assert_allclose(g.origin, [-0.1, -0.1])
        self.assertAlmostEqual(g.cell, 1.2 / 80)
        p = cell_centres(g)
        want = np.stack([segment_distance(p, a, b) for a, b in segments])
        expect_grid_matches(self, g, want, 1.2)
        self.assertFalse((g.distance < 0).any())  # open objects: never signed

    def test_result_grid_is_exact(self):
        r = gvd.compute(two_boxes(), backend="cpu", frame="world")
        g = r.grid(16, float64=True)
        self.assertEqual(g.labels.shape, (16, 16, 16))  # the result's domain is a cube
        self.assertIn("sampled", g.backend)
        p = cell_centres(g)
        want = np.stack([box_distance(p, lo, hi, "l2") for lo, hi in self.BOXES])
        expect_grid_matches(self, g, want, 2.1)
        # The same grid as gvd.grid on the scene over the same box.
        hi = g.origin + np.array(g.labels.shape[::-1]) * g.cell
        s = gvd.grid(two_boxes(), 16, float64=True, domain=[*g.origin, *hi])
        np.testing.assert_array_equal(s.labels, g.labels)
        np.testing.assert_allclose(s.distance, g.distance, rtol=0, atol=1e-12)
        g32 = r.grid(16, metric="linf")
        want = np.stack([box_distance(p, lo, hi, "linf") for lo, hi in self.BOXES])
        expect_grid_matches(self, g32, want, 2.1)

    def test_arrays_own_the_facade_vectors(self):
        g = gvd.grid(two_boxes(), 16, float64=True)
        for a in (g.distance, g.labels):
            self.assertFalse(a.flags.owndata)
            self.assertEqual(type(a.base).__name__, "PyCapsule")
            self.assertTrue(a.flags.c_contiguous)

    def test_errors(self):
        with self.assertRaises(gvd.InvalidArgument):
            gvd.grid(two_boxes(), 0)
        with self.assertRaises(gvd.InvalidArgument):
            gvd.grid(two_boxes(), 8, metric="l3")
        with self.assertRaises(gvd.InvalidArgument):
            gvd.grid(two_boxes(), 8, domain=[0, 0, 1, 1])  # 4 numbers for a 3D scene
        with self.assertRaises(gvd.InvalidArgument):
            gvd.grid(two_boxes(), 8, domain=[0.5, 0, 0, 3, 1, 1])  # cuts the left box
        with self.assertRaises(gvd.LimitExceeded):
            gvd.grid(two_boxes(), 1000, max_cells=1000)
        r = gvd.compute(two_boxes(), backend="cpu")
        with self.assertRaises(gvd.LimitExceeded):
            r.grid(1000, max_cells=1000)

    def test_progress_within_the_stage(self):
        seen = []
        # Long enough (~1 s) for the calling thread to deliver reports while it runs.
        gvd.grid(lattice_scene(3, 1e-2, 2), 96, threads=1,
                 progress=lambda stage, f: seen.append((stage, f)))
        self.assertEqual({s for s, _ in seen}, {"grid"})
        fractions = [f for _, f in seen]
        self.assertEqual(fractions, sorted(fractions))
        self.assertEqual(fractions[-1], 1.0)
        self.assertGreater(len([f for f in fractions if 0 < f < 1]), 3, fractions)

    def test_cancel_token_stops_within_a_second(self):
        # Coincident spheres: no site can be culled, the grid alone would take minutes.
        scene = gvd.Scene(3)
        v, f = meshes.icosphere((0, 0, 0), 1.0, 1)
        for i in range(300):
            scene.add(f"s{i}", v, f)
        token = gvd.CancelToken()
        asked = []

        def cancel_later():
            time.sleep(0.3)
            asked.append(time.monotonic())
            token.cancel()

        t = threading.Thread(target=cancel_later)
        t.start()
        with self.assertRaises(gvd.Cancelled):
            gvd.grid(scene, 64, threads=2, cancel=token)
        stopped = time.monotonic()
        t.join()
        self.assertLess(stopped - asked[0], 1.0)
        token.reset()
        r = gvd.compute(two_boxes(), backend="cpu")
        token.cancel()
        with self.assertRaises(gvd.Cancelled):
            r.grid(32, cancel=token)

    def test_gil_is_released(self):
        during, elapsed = Gil.count_during(
            self, lambda: gvd.grid(lattice_scene(2, 1e-2, 2), 96, threads=1, backend="cpu"))
        self.assertGreater(elapsed, 0.2, "the grid is too short to tell")
        self.assertGreater(during, 10_000, f"{during} loop turns in {elapsed:.2f} s")

    def test_help_and_stub(self):
        text = pydoc.render_doc(gvd.grid)
        for word in ("resolution", "metric", "signed", "float64", "cancel", "Ctrl-C"):
            self.assertIn(word, text)
        self.assertIn("sampled exactly", pydoc.render_doc(gvd.Result.grid))
        import ast
        stub = os.path.join(os.path.dirname(gvd.__file__), "__init__.pyi")
        with open(stub) as f:
            tree = ast.parse(f.read())
        result = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "Result")
        for fn, doc in ((next(n for n in tree.body
                              if isinstance(n, ast.FunctionDef) and n.name == "grid"), gvd.grid),
                        (next(n for n in result.body
                              if isinstance(n, ast.FunctionDef) and n.name == "grid"),
                         gvd.Result.grid)):
            stub_defaults = {a.arg: ast.literal_eval(d) for a, d in
                             zip(fn.args.kwonlyargs, fn.args.kw_defaults)}
            sig = doc.__doc__.splitlines()[0]
            actual = {}
            for part in sig[sig.index("*,") + 2:sig.rindex(")")].split(","):
                name, _, default = part.partition("=")
                actual[name.split(":")[0].strip()] = ast.literal_eval(default.strip())
            self.assertEqual(stub_defaults, actual, fn.name)


class Analytic(unittest.TestCase):
    """Two unit cubes 0.1 apart: the GVD is the plane x = 1.05, every answer known."""

    @classmethod
    def setUpClass(cls):
        cls.r = gvd.compute(two_boxes(), backend="cpu")

    def test_graph(self):
        g = self.r.graph
        self.assertEqual(len(g), 1)
        e = g[0]
        self.assertEqual((e["a"], e["b"]), (0, 1))
        self.assertAlmostEqual(float(e["gap"]), 0.1, delta=1e-12)
        self.assertAlmostEqual(float(e["min_clearance"]), 0.05, delta=1e-12)
        # The interface is the domain's cross-section: side 2.1 padded by 5 % each side.
        self.assertAlmostEqual(float(e["area"]), 2.31 * 2.31, delta=1e-6)
        self.assertEqual(g.dtype.names, ("a", "b", "area", "min_clearance", "tightest_point",
                                         "gap", "touching"))

    def test_neighbors(self):
        n = self.r.neighbors("left", ring=2)
        self.assertEqual([self.r.labels[o] for o in n["object"]], ["right"])
        self.assertEqual(int(n["ring"][0]), 1)
        self.assertEqual(int(n["via"][0]), 0)

    def test_nearest(self):
        pts = np.array([[1.03, 0.5, 0.5], [1.08, 0.5, 0.5], [0.5, 0.5, 1.4], [50, 0, 0]])
        near = self.r.nearest(pts)
        self.assertEqual(near.object.tolist(), [0, 1, 0, -1])
        for i, d in enumerate([0.03, 0.02, 0.4]):
            self.assertGreaterEqual(near.distance[i], d - 1e-12)
            self.assertLessEqual(near.distance[i], 1.5 * d)
        self.assertTrue(math.isnan(near.distance[3]))
        self.assertTrue(np.isnan(near.closest[3]).all())
        self.assertAlmostEqual(near.closest[2][2], 1.0, delta=1e-9)
        # The boxes are closed: outside them inside is 0; the domain's outside has no answer.
        self.assertEqual(near.inside.tolist(), [0, 0, 0, -1])
        # Unpacks as in the issue; one point gives scalars.
        obj, dist, closest, inside = near
        self.assertIs(obj, near.object)
        one = self.r.nearest([1.03, 0.5, 0.5])
        self.assertEqual(one.object, 0)
        self.assertIsInstance(one.distance, float)
        self.assertEqual(one.closest.shape, (3,))
        self.assertIs(one.inside, False)
        self.assertEqual(near._fields, ("object", "distance", "closest", "inside"))
        # Inside a box: signed, negative, 0.4 from its top face (within 3/2).
        deep = self.r.nearest([0.5, 0.5, 0.6])
        self.assertIs(deep.inside, True)
        self.assertLessEqual(deep.distance, -0.4 + 1e-12)
        self.assertGreaterEqual(deep.distance, -0.6)

    def test_path(self):
        p = self.r.path([0.5, 0.5, 1.3], [1.6, 0.5, 1.3], min_clearance=0.01)
        self.assertTrue(p.found)
        self.assertEqual(p.points.shape[1], 3)
        np.testing.assert_allclose(p.points[0], [0.5, 0.5, 1.3])
        np.testing.assert_allclose(p.points[-1], [1.6, 0.5, 1.3])
        self.assertGreaterEqual(p.length, 1.1 - 1e-12)
        seg = np.linalg.norm(np.diff(p.points, axis=0), axis=1).sum()
        self.assertAlmostEqual(seg, p.length, delta=1e-9)
        inside = self.r.path([0.5, 0.5, 0.5], [1.6, 0.5, 1.3])
        self.assertFalse(inside.found)
        self.assertTrue(inside.reason)
        self.assertEqual(inside.points.shape, (0, 3))

    def test_cell(self):
        c = self.r.cell("left")
        V, F = c
        self.assertIs(V, c.vertices)
        self.assertEqual(V.shape[1], 3)
        self.assertEqual(F.shape[1], 3)
        self.assertEqual(F.dtype, np.uint32)
        self.assertLess(int(F.max()), len(V))
        facing = c.other == 1
        self.assertTrue(facing.any())
        np.testing.assert_allclose(V[facing][:, 0], 1.05, atol=1e-6)
        self.assertLess(V[:, 0].max(), 1.05 + 1e-6)
        self.assertEqual(c.clearance.shape, (len(V),))
        self.assertEqual(c.other.dtype, np.int32)
        # Closed: every edge is shared by exactly two triangles (vertices are duplicated per
        # object across, so edges are compared by position).
        _, at = np.unique(V, axis=0, return_inverse=True)
        G = at.reshape(-1)[F]
        edges = np.sort(np.concatenate([G[:, [0, 1]], G[:, [1, 2]], G[:, [2, 0]]]), axis=1)
        _, counts = np.unique(edges, axis=0, return_counts=True)
        self.assertTrue((counts == 2).all())

    def test_explode(self):
        e = self.r.explode("left")
        self.assertEqual(e.ring.tolist(), [0, 1])
        self.assertEqual(e.displacement.shape, (2, 3))
        np.testing.assert_allclose(e.displacement[0], 0)
        self.assertGreater(e.displacement[1][0], 0)  # "right" moves away, along +x
        self.assertGreater(e.scale, 0)
        self.assertEqual(e.factor.tolist(), [1.0, 1.0])  # moving apart: nothing held back

    def test_save_load(self):
        path = os.path.join(OUT, "two_boxes.gvd")
        self.r.save(path)
        loaded = gvd.load(path)
        assert_same_array(self, loaded.graph, self.r.graph)
        self.assertEqual(loaded.labels, ("left", "right"))
        from pathlib import Path
        self.assertEqual(len(gvd.load(Path(path))), 2)
        self.r.write_glb(Path(OUT) / "two_boxes.glb")
        self.r.write_json(os.path.join(OUT, "two_boxes.json"))
        with open(os.path.join(OUT, "two_boxes.json")) as f:
            self.assertIn("objects", json.load(f))

    def test_two_segments_2d(self):
        # Two parallel segments y = 0 and y = 1 (x in [0, 1]): the GVD is the line y = 0.5.
        s = gvd.Scene(dimension=2)
        s.add("low", np.array([[0.0, 0.0], [1.0, 0.0]]), np.array([[0, 1]]))
        s.add("high", [[0.0, 1.0], [1.0, 1.0]], [[0, 1]])
        r = gvd.compute(s, backend="cpu")
        g = r.graph
        self.assertEqual(len(g), 1)
        self.assertAlmostEqual(float(g[0]["gap"]), 1.0, delta=1e-12)
        self.assertEqual(g[0]["tightest_point"].shape, (2,))
        near = r.nearest([[0.5, 0.4], [0.5, 0.6]])
        self.assertEqual(near.object.tolist(), [0, 1])
        self.assertEqual(near.inside.tolist(), [-1, -1])  # open segments: no inside
        np.testing.assert_allclose(near.distance, [0.4, 0.4], rtol=0.5)
        c = r.cell("low")
        self.assertEqual(c.faces.shape[1], 2)
        np.testing.assert_allclose(c.vertices[c.other == 1][:, 1], 0.5, atol=1e-6)


class Errors(unittest.TestCase):
    """gvd::Error codes become the subclasses, with label, object, element and index."""

    def test_classes(self):
        codes = {gvd.InvalidScene: "invalid_scene", gvd.InvalidArgument: "invalid_argument",
                 gvd.UnsupportedFormat: "unsupported_format", gvd.OutsideDomain: "outside_domain",
                 gvd.LimitExceeded: "limit_exceeded", gvd.NotFound: "not_found",
                 gvd.IoError: "io_error", gvd.Cancelled: "cancelled", gvd.InternalError: "internal"}
        for cls, code in codes.items():
            self.assertTrue(issubclass(cls, gvd.Error))
            self.assertEqual(cls.code, code)
            self.assertEqual(cls.__module__, "gvd")
        self.assertTrue(issubclass(gvd.InvalidScene, ValueError))
        self.assertTrue(issubclass(gvd.NotFound, LookupError))

    def test_duplicate_label(self):
        s = two_boxes()
        with self.assertRaises(gvd.InvalidScene) as cm:
            s.add("left", *meshes.box((5, 5, 5), (6, 6, 6)))
        e = cm.exception
        self.assertEqual((e.code, e.label, e.object), ("invalid_scene", "left", 2))
        self.assertIn("duplicate", e.detail)
        self.assertEqual(len(s), 2)

    def test_negative_index(self):
        s = two_boxes()
        v, f = meshes.box((5, 5, 5), (6, 6, 6))
        f[4, 1] = -3
        with self.assertRaises(gvd.InvalidScene) as cm:
            s.add("third", v, f)
        e = cm.exception
        self.assertEqual((e.label, e.object, e.element, e.index), ("third", 2, "triangle", 4))
        with self.assertRaises(gvd.InvalidScene) as cm:
            s.add("third", v, f.astype(np.int32))
        self.assertEqual((cm.exception.element, cm.exception.index), ("triangle", 4))

    def test_index_out_of_range_named_by_compute(self):
        s = two_boxes()
        v, f = meshes.box((5, 5, 5), (6, 6, 6))
        f[7, 2] = 99
        s.add("third", v, f)
        with self.assertRaises(gvd.InvalidScene) as cm:
            gvd.compute(s, backend="cpu")
        e = cm.exception
        self.assertEqual((e.label, e.object, e.element, e.index), ("third", 2, "triangle", 7))
        self.assertIn("99", e.detail)
        self.assertTrue(str(e).startswith("invalid_scene: "))

    def test_nan_vertex_named_by_compute(self):
        s = gvd.Scene(3)
        v, f = meshes.box((0, 0, 0), (1, 1, 1))
        s.add("a", v, f)
        v, f = meshes.box((2, 0, 0), (3, 1, 1))
        v[5, 1] = np.nan
        s.add("b", v, f)
        with self.assertRaises(gvd.InvalidScene) as cm:
            gvd.compute(s)
        e = cm.exception
        self.assertEqual((e.label, e.object, e.element, e.index), ("b", 1, "vertex", 5))

    def test_file_errors_carry_line_and_offset(self):
        with tempfile.TemporaryDirectory() as d:
            obj = os.path.join(d, "bad.obj")
            with open(obj, "w") as f:
                f.write("v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 3\nf 1 2 4\n")
            with self.assertRaises(gvd.InvalidScene) as cm:
                gvd.Scene.load(obj)
            self.assertEqual((cm.exception.line, cm.exception.offset), (6, None))
            bad = os.path.join(d, "bad.json")
            text = '{"dimension": 3, "objects": [} '
            with open(bad, "w") as f:
                f.write(text)
            with self.assertRaises(gvd.InvalidScene) as cm:
                gvd.Scene.load(bad)
            self.assertEqual(text[cm.exception.offset], "}")
            self.assertIsNone(cm.exception.line)

    def test_shapes_and_types(self):
        s = gvd.Scene(3)
        with self.assertRaises(gvd.InvalidArgument) as cm:
            s.add("a", np.zeros((4, 2)), np.zeros((1, 3), dtype=int))
        self.assertEqual((cm.exception.label, cm.exception.object), ("a", 0))
        with self.assertRaises(gvd.InvalidArgument):
            s.add("a", np.zeros((4, 3)), np.zeros((1, 3)))  # float indices
        with self.assertRaises(ValueError):
            s.add("a", "not numbers", [[0, 1, 2]])
        with self.assertRaises(gvd.InvalidArgument):
            s.add("a", object())  # no .vertices / .faces
        with self.assertRaises(gvd.InvalidArgument):
            gvd.Scene(4)
        self.assertEqual(len(s), 0)

    def test_queries(self):
        r = gvd.compute(two_boxes(), backend="cpu")
        with self.assertRaises(gvd.NotFound) as cm:
            r.neighbors("middle")
        self.assertEqual(cm.exception.label, "middle")
        with self.assertRaises(gvd.NotFound) as cm:
            r.cell(7)
        self.assertEqual(cm.exception.object, 7)
        with self.assertRaises(gvd.OutsideDomain):
            r.path([50, 0, 0], [1.6, 0.5, 1.3])
        with self.assertRaises(gvd.InvalidArgument):
            r.nearest(np.zeros((5, 2)))
        with self.assertRaises(gvd.InvalidArgument):
            r.path([0, 0], [1, 1])

    def test_compute_options(self):
        with self.assertRaises(gvd.LimitExceeded):
            gvd.compute(two_boxes(), max_objects=1)
        with self.assertRaises(gvd.InvalidArgument):
            gvd.compute(two_boxes(), curved_tolerance=2.0)
        with self.assertRaises(gvd.InvalidArgument):
            gvd.compute(two_boxes(), domain=[0, 0, 0, 1])
        with self.assertRaises(gvd.InvalidScene):
            gvd.compute(gvd.Scene(3))  # no objects
        with self.assertRaises(gvd.InvalidArgument):
            gvd.compute(two_boxes(), progress=42)

    def test_files(self):
        with self.assertRaises(gvd.Error) as cm:
            gvd.load(os.path.join(OUT, "no_such_file.gvd"))
        self.assertIn(cm.exception.code, ("not_found", "io_error"))
        with self.assertRaises(gvd.Error) as cm:
            gvd.Scene.load(os.path.join(DATA, "malformed", "garbage.bin"))
        self.assertIn(cm.exception.code, ("unsupported_format", "invalid_scene"))
        r = gvd.compute(two_boxes(), backend="cpu")
        with self.assertRaises(gvd.IoError):
            r.save(os.path.join(OUT, "no_such_dir", "r.gvd"))


class Progress(unittest.TestCase):
    def test_callback_stages(self):
        seen = []
        caller = threading.get_ident()
        threads = set()

        def progress(stage, fraction):
            seen.append((stage, fraction))
            threads.add(threading.get_ident())

        gvd.compute(two_boxes(), progress=progress)
        stages = [s for s, _ in seen]
        self.assertEqual(stages[-1], "done")
        self.assertEqual(seen[-1][1], 1.0)
        for s in ("octree", "distance", "surface", "graph"):
            self.assertIn(s, stages)
        runs = [s for i, s in enumerate(stages) if i == 0 or stages[i - 1] != s]
        self.assertEqual(len(runs), len(set(runs)), "each stage one run, in order")
        for s in set(stages):
            fractions = [f for t, f in seen if t == s]
            self.assertEqual(fractions, sorted(fractions), "fractions grow within " + s)
        self.assertEqual(threads, {caller}, "called on the calling thread")

    def test_text_bar(self):
        import io
        err, sys.stderr = sys.stderr, io.StringIO()
        try:
            gvd.compute(two_boxes(), progress=True)
            text = sys.stderr.getvalue()
        finally:
            sys.stderr = err
        self.assertIn("done", text)
        self.assertIn("100%", text)
        self.assertTrue(text.endswith("\n"))

    def test_help(self):
        text = pydoc.render_doc(gvd.compute)
        for word in ("threads", "progress", "cancel", "max_depth", "Ctrl-C", "backend"):
            self.assertIn(word, text)
        self.assertIn("vertices", pydoc.render_doc(gvd.Scene.add))

    def test_stub_defaults_match(self):
        # The .pyi's defaults of compute() are the module's (read off its signature line).
        import ast
        stub = os.path.join(os.path.dirname(gvd.__file__), "__init__.pyi")
        with open(stub) as f:
            tree = ast.parse(f.read())
        fn = next(n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == "compute")
        stub_defaults = {a.arg: ast.literal_eval(d) for a, d in
                         zip(fn.args.kwonlyargs, fn.args.kw_defaults)}
        sig = gvd.compute.__doc__.splitlines()[0]
        actual = {}
        for part in sig[sig.index("*,") + 2:sig.rindex(")")].split(","):
            name, _, default = part.partition("=")
            actual[name.split(":")[0].strip()] = ast.literal_eval(default.strip())
        self.assertEqual(stub_defaults, actual)


    def test_keywords_are_the_parameter_table(self):
        # The keywords and defaults of compute(), grid() and Result.grid() are the core's
        # parameter table's for each (gvd/pipeline/parameters.h), none missing and none
        # besides (but scene, progress and cancel, which are no parameters).
        import ast
        for function, fn in (("compute", gvd.compute), ("grid", gvd.grid),
                             ("Result.grid", gvd.Result.grid)):
            sig = fn.__doc__.splitlines()[0]  # pybind11's: name(a: type = default, ...)
            actual = {}
            for part in sig[sig.index("(") + 1:sig.rindex(")")].split(","):
                name, _, default = part.partition("=")
                if default:  # not scene, self or the "*"
                    actual[name.split(":")[0].strip()] = ast.literal_eval(default.strip())
            for name in ("progress", "cancel"):
                del actual[name]
            table = {p["name"]: p for p in gvd._gvd._parameters(function)}
            self.assertEqual(set(actual), set(table), function)
            for name, p in table.items():
                self.assertEqual(actual[name], p["default"], (function, name))
                self.assertEqual(type(actual[name]), type(p["default"]), (function, name))
                for choice in p["choices"]:  # every choice is accepted by name
                    self.assertIn(choice, fn.__doc__, (function, name))
        self.assertEqual(gvd._gvd._parameters(), gvd._gvd._parameters("compute"))
        with self.assertRaises(gvd.InvalidArgument):
            gvd._gvd._parameters("explode")


def lattice_scene(n, gap, subdivisions):
    s = gvd.Scene(3)
    for label, v, f in meshes.sphere_lattice(n, gap, subdivisions):
        s.add(label, v, f)
    return s


class Cancel(unittest.TestCase):
    def test_token_from_another_thread(self):
        token = gvd.CancelToken()
        started = threading.Event()
        timer = threading.Thread(target=lambda: (started.wait(60), time.sleep(0.05),
                                                 token.cancel()))
        timer.start()
        t0 = time.monotonic()
        with self.assertRaises(gvd.Cancelled) as cm:
            gvd.compute(lattice_scene(3, 1e-3, 2), cancel=token, threads=1,
                        progress=lambda stage, f: started.set())
        timer.join()
        self.assertEqual(cm.exception.code, "cancelled")
        self.assertLess(time.monotonic() - t0, 30)
        self.assertTrue(token.cancelled)
        token.reset()
        self.assertFalse(token.cancelled)

    def test_token_set_before(self):
        token = gvd.CancelToken()
        token.cancel()
        with self.assertRaises(gvd.Cancelled):
            gvd.compute(two_boxes(), cancel=token)

    def test_callback_exception_stops(self):
        class Stop(Exception):
            pass

        calls = []

        def progress(stage, fraction):
            calls.append(stage)
            if stage == "distance":
                raise Stop()

        with self.assertRaises(Stop):
            gvd.compute(lattice_scene(2, 1e-3, 2), progress=progress, threads=1)
        self.assertEqual(calls[-1], "distance")
        self.assertNotIn("done", calls)

    def test_scene_is_frozen_while_computing(self):
        s = two_boxes()
        errors = []

        def progress(stage, fraction):
            if stage == "octree" and not errors:
                try:
                    s.add("late", *meshes.box((5, 5, 5), (6, 6, 6)))
                except gvd.InvalidArgument as e:
                    errors.append(e)

        gvd.compute(s, progress=progress)
        self.assertEqual(len(errors), 1)
        self.assertEqual(len(s), 2)
        s.add("later", *meshes.box((5, 5, 5), (6, 6, 6)))  # fine once done
        self.assertEqual(len(s), 3)

    def test_ctrl_c(self):
        # A child computes a big lattice; SIGINT once it has started must end it promptly
        # with KeyboardInterrupt (and not after the computation).
        self.interrupt_child()

    def test_ctrl_c_stops_a_long_batch_nearest(self):
        # 3 million points on one thread take ~20 s; SIGINT ends the batch between slices.
        self.interrupt_child("nearest")

    def interrupt_child(self, *args):
        child = os.path.join(os.path.dirname(os.path.abspath(__file__)), "ctrl_c_child.py")
        p = subprocess.Popen([sys.executable, child, *args], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True, env=os.environ)
        try:
            line = p.stdout.readline()
            self.assertEqual(line.strip(), "started", p.stderr.read() if not line else line)
            time.sleep(0.5)
            t0 = time.monotonic()
            p.send_signal(signal.SIGINT)
            out, err = p.communicate(timeout=30)
            elapsed = time.monotonic() - t0
        finally:
            if p.poll() is None:
                p.kill()
                p.wait()
        self.assertEqual(p.returncode, 0, err)
        self.assertIn("KeyboardInterrupt", out)
        self.assertNotIn("finished", out)
        self.assertLess(elapsed, 5.0, f"the child took {elapsed:.1f} s to stop")


class ZeroCopy(unittest.TestCase):
    """numpy's allocations are traced by tracemalloc: copies of the inputs show up there."""

    @classmethod
    def setUpClass(cls):
        cls.r = gvd.compute(two_boxes(), backend="cpu")
        rng = np.random.default_rng(3)
        cls.points = rng.random((200_000, 3)) * 2.1  # 4.8 MB

    def traced_peak(self, fn):
        tracemalloc.start()
        try:
            tracemalloc.reset_peak()
            base = tracemalloc.get_traced_memory()[0]
            out = fn()
            peak = tracemalloc.get_traced_memory()[1] - base
        finally:
            tracemalloc.stop()
        return out, peak

    def test_nearest_reads_input_in_place(self):
        size = self.points.nbytes
        _, peak = self.traced_peak(lambda: self.r.nearest(self.points))
        self.assertLess(peak, size / 10)
        # The measurement sees a conversion: Fortran order and float32 are copied.
        fortran = np.asfortranarray(self.points)
        _, peak = self.traced_peak(lambda: self.r.nearest(fortran))
        self.assertGreaterEqual(peak, size)
        f32 = self.points.astype(np.float32)
        _, peak = self.traced_peak(lambda: self.r.nearest(f32))
        self.assertGreaterEqual(peak, size)

    def test_scene_add_reads_input_in_place(self):
        v, f = meshes.icosphere((0, 0, 0), 1.0, 5)  # 10k vertices, 20k triangles
        f32 = f.astype(np.uint32)
        s = gvd.Scene(3)
        _, peak = self.traced_peak(lambda: s.add("a", v, f32))
        self.assertLess(peak, v.nbytes / 10)
        _, peak = self.traced_peak(lambda: s.add("b", v.astype(np.float32), f32))
        self.assertGreaterEqual(peak, v.nbytes)

    def test_outputs_own_the_facade_vectors(self):
        near = self.r.nearest(self.points[:1000])
        arrays = [near.object, near.distance, near.closest, self.r.graph,
                  self.r.neighbors("left"), *self.r.cell("left"), self.r.cell("left").other,
                  self.r.path([0.5, 0.5, 1.3], [1.6, 0.5, 1.3]).points]
        for a in arrays:
            self.assertFalse(a.flags.owndata)
            self.assertEqual(type(a.base).__name__, "PyCapsule")
        self.assertEqual(near.object.dtype, np.int32)
        self.assertEqual(self.r.graph.dtype.itemsize, 64)  # laid over gvd::api::Edge


class Gil(unittest.TestCase):
    """Another Python thread runs while compute and a batch nearest do."""

    def count_during(self, fn):
        stop = threading.Event()
        count = [0]

        def spin():
            while not stop.is_set():
                count[0] += 1

        t = threading.Thread(target=spin)
        t.start()
        time.sleep(0.05)
        before = count[0]
        t0 = time.monotonic()
        fn()
        elapsed = time.monotonic() - t0
        during = count[0] - before
        stop.set()
        t.join()
        return during, elapsed

    def test_nearest_batch(self):
        r = gvd.compute(lattice_scene(2, 1e-2, 2), backend="cpu")
        pts = np.random.default_rng(5).random((1_000_000, 3)) * 2.0 - 0.5
        during, elapsed = self.count_during(lambda: r.nearest(pts, threads=1))
        self.assertGreater(elapsed, 0.2, "the batch is too short to tell")
        self.assertGreater(during, 10_000, f"{during} loop turns in {elapsed:.2f} s")

    def test_compute(self):
        during, elapsed = self.count_during(
            lambda: gvd.compute(lattice_scene(2, 1e-3, 2), threads=1, backend="cpu"))
        self.assertGreater(elapsed, 0.2, "the computation is too short to tell")
        self.assertGreater(during, 10_000, f"{during} loop turns in {elapsed:.2f} s")


class Interop(unittest.TestCase):
    def test_mesh_like_objects(self):
        class TrackedArray(np.ndarray):  # trimesh's arrays are an ndarray subclass
            pass

        class Mesh:
            def __init__(self, v, f):
                self.vertices = np.asarray(v).view(TrackedArray)
                self.faces = np.asarray(f).view(TrackedArray)

        class Open3DLike:  # after np.asarray: .vertices and .triangles
            def __init__(self, v, f):
                self.vertices, self.triangles = v, f

        s = gvd.Scene(3)
        s.add("left", Mesh(*meshes.box((0, 0, 0), (1, 1, 1))))
        s.add("right", Open3DLike(*meshes.box((1.1, 0, 0), (2.1, 1, 1))))
        r = gvd.compute(s, backend="cpu")
        ref = gvd.compute(two_boxes(), backend="cpu")
        assert_same_array(self, r.graph, ref.graph)

    def test_cell_goes_back_into_a_scene(self):
        r = gvd.compute(two_boxes(), backend="cpu")
        c = r.cell("left")
        s = gvd.Scene(3)
        self.assertEqual(s.add("cell_of_left", c), 0)
        V, F = c
        self.assertEqual(s.add("again", V, F), 1)
        self.assertEqual(s.labels, ("cell_of_left", "again"))

    def test_plain_lists_and_dtypes(self):
        v, f = meshes.box((0, 0, 0), (1, 1, 1))
        s = gvd.Scene(3)
        s.add("lists", v.tolist(), f.tolist())
        s.add("fortran", np.asfortranarray(v + [1.1, 0, 0]), np.asfortranarray(f))
        s.add("u64", v + [0, 1.1, 0], f.astype(np.uint64))
        s.add("i16", v + [0, 0, 1.1], f.astype(np.int16))
        r = gvd.compute(s, backend="cpu")
        self.assertEqual(len(r), 4)
        self.assertEqual(len(r.neighbors("lists")), 3)



class Units(unittest.TestCase):
    """A scene's length unit: read from a scene JSON or set on a Scene, carried by the result,
    its saved file and its documents; None when none was declared (never a default)."""

    def test_set_units_travel_with_the_result(self):
        s = two_boxes()
        self.assertIsNone(s.units)
        r = gvd.compute(s, backend="cpu")
        self.assertIsNone(r.units)
        self.assertNotIn("units", json.loads(r.info_json()))
        s.units = "um"
        self.assertEqual(s.units, "\u00b5m")  # the canonical name
        r = gvd.compute(s, backend="cpu")
        self.assertEqual(r.units, "\u00b5m")
        self.assertEqual(json.loads(r.info_json())["units"], "\u00b5m")
        saved = os.path.join(OUT, "units.gvd")
        r.save(saved)
        self.assertEqual(gvd.load(saved).units, "\u00b5m")
        graph = os.path.join(OUT, "units_graph.json")
        r.write_graph_json(graph)
        with open(graph, encoding="utf-8") as f:
            self.assertEqual(json.load(f)["units"], "\u00b5m")
        s.units = None
        self.assertIsNone(s.units)

    def test_scene_json_units_and_unknown_units(self):
        doc = {"dimension": 2, "units": "mm", "objects": [
            {"label": "a", "vertices": [[0, 0], [1, 0]], "segments": [[0, 1]]},
            {"label": "b", "vertices": [[0, 1], [1, 1]], "segments": [[0, 1]]}]}
        path = os.path.join(OUT, "units_scene.json")
        with open(path, "w") as f:
            json.dump(doc, f)
        self.assertEqual(gvd.Scene.load(path).units, "mm")
        self.assertEqual(gvd.compute(path, backend="cpu").units, "mm")
        doc["units"] = "parsec"
        with open(path, "w") as f:
            json.dump(doc, f)
        with self.assertRaises(gvd.InvalidScene) as e:
            gvd.Scene.load(path)
        self.assertIn('"units" must name a length unit', str(e.exception))
        self.assertIn("parsec", str(e.exception))
        s = gvd.Scene(2)
        with self.assertRaises(gvd.InvalidArgument) as e:
            s.units = "furlong"
        self.assertIn("units", str(e.exception))
        self.assertIsNone(s.units)


if __name__ == "__main__":
    unittest.main()
