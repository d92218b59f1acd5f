// Validates an OpenAPI document against the OpenAPI 3.1 JSON schema.
//
//   node validate_openapi.mjs FILE
//
// Prints one JSON line {"file", "valid", "version", "errors":[...]} and exits 0 when valid,
// 1 when not, 2 on a usage or IO problem. Also checks that every $ref resolves.

import { Validator } from '@seriousme/openapi-schema-validator';

const file = process.argv[2];
if (!file) {
  console.error('usage: node validate_openapi.mjs FILE');
  process.exit(2);
}
const validator = new Validator();
let res;
try {
  res = await validator.validate(file);
} catch (err) {
  console.log(JSON.stringify({ file, io_error: String(err.message || err) }));
  process.exit(2);
}
let refsOk = true;
let refError = null;
if (res.valid) {
  try {
    validator.resolveRefs();
  } catch (err) {
    refsOk = false;
    refError = String(err.message || err);
  }
}
const valid = res.valid && refsOk;
console.log(JSON.stringify({ file, valid, version: validator.version,
                             errors: res.errors || (refError ? [refError] : []) }));
process.exit(valid ? 0 : 1);
