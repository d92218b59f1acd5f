// Validates GLB files with the Khronos glTF-Validator.
//
//   node validate_glb.mjs FILE...
//
// Prints one JSON line per file:
//   {"file":..., "errors":n, "warnings":n, "messages":[{"code","severity","pointer","message"}..]}
// (the first 10 errors and warnings). Exit status: 0 when no file has errors, 1 when some file
// has errors, 2 on a usage or IO problem (a file that cannot be read is reported with
// "io_error" and counts as an IO problem).
//
// EXT_mesh_features is not known to the validator: UNSUPPORTED_EXTENSION is ignored, and the
// feature ids are checked by the C++ tests themselves.

import { readFile } from 'node:fs/promises';
import validator from 'gltf-validator';

const kMaxMessages = 10;

async function validateFile(file) {
  let bytes;
  try {
    bytes = await readFile(file);
  } catch (err) {
    return { line: { file, io_error: String(err.message || err) }, status: 2 };
  }
  let report;
  try {
    report = await validator.validateBytes(new Uint8Array(bytes), {
      ignoredIssues: ['UNSUPPORTED_EXTENSION'],
      // GLB output is self-contained: any external reference is itself a defect.
      externalResourceFunction: (uri) => Promise.reject(new Error(`external resource ${uri}`)),
    });
  } catch (err) {
    // The validator rejects only on input it cannot parse at all (not glTF, truncated).
    const line = {
      file,
      errors: 1,
      warnings: 0,
      messages: [{ code: 'VALIDATOR_REJECTED', severity: 0, pointer: '', message: String(err) }],
    };
    return { line, status: 1 };
  }
  const issues = report.issues;
  const messages = issues.messages
    .filter((m) => m.severity === 0 || m.severity === 1)
    .slice(0, kMaxMessages)
    .map((m) => ({
      code: m.code,
      severity: m.severity,
      pointer: m.pointer ?? '',
      message: m.message,
    }));
  const line = { file, errors: issues.numErrors, warnings: issues.numWarnings, messages };
  return { line, status: issues.numErrors > 0 ? 1 : 0 };
}

async function main(argv) {
  if (argv.length === 0) {
    process.stderr.write('usage: node validate_glb.mjs FILE...\n');
    return 2;
  }
  let status = 0;
  for (const file of argv) {
    const result = await validateFile(file);
    process.stdout.write(JSON.stringify(result.line) + '\n');
    status = Math.max(status, result.status);
  }
  return status;
}

main(process.argv.slice(2)).then(
  (status) => {
    process.exitCode = status;
  },
  (err) => {
    process.stderr.write(`validate_glb: ${err && err.stack ? err.stack : err}\n`);
    process.exitCode = 2;
  },
);
