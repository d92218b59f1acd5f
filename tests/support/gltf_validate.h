#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace gvd::test {

/// What the Khronos glTF-Validator said about one file.
struct GltfReport {
  bool ran = false;    ///< false when node or tests/js/node_modules/gltf-validator is missing
  int errors = 0;      ///< validator errors (severity 0)
  int warnings = 0;    ///< validator warnings (severity 1)
  std::string output;  ///< the validator's JSON line, or why it did not run
};

/// Runs `node tests/js/validate_glb.mjs path` and parses its report. A test must fail, not
/// skip, when `ran` is false: the validator is installed by docker/install-deps.sh.
GltfReport validate_glb_file(const std::string& path);

/// A GLB split into its JSON and BIN chunks (an independent reader: the tests do not use
/// tinygltf, which also writes the files under test).
struct GlbFile {
  nlohmann::json json;
  std::vector<uint8_t> bin;
};

/// Parses the GLB container (header, JSON chunk, optional BIN chunk); throws
/// std::runtime_error on a malformed container.
GlbFile parse_glb(const std::vector<uint8_t>& bytes);

/// The values of accessor `index` as doubles, element after element, components in order
/// (FLOAT, UNSIGNED_BYTE, UNSIGNED_SHORT, UNSIGNED_INT; tightly packed or strided views).
std::vector<double> read_accessor(const GlbFile& glb, int index);

}  // namespace gvd::test
