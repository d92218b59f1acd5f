#include "support/gltf_validate.h"

#include <sys/wait.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <stdexcept>

namespace gvd::test {

namespace {

constexpr const char* kInstallHint =
    "the glTF validator is not installed: run docker/install-deps.sh (it runs `npm ci` in "
    "tests/js)";

/// Quotes a string for /bin/sh.
std::string shell_quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) {
    if (c == '\'') {
      out += "'\\''";
    } else {
      out += c;
    }
  }
  return out + "'";
}

/// Runs a shell command; returns its stdout and exit status (-1 when it could not run).
std::string run(const std::string& command, int* status) {
  *status = -1;
  FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) return std::string("popen failed: ") + std::strerror(errno);
  std::string out;
  char chunk[4096];
  size_t got = 0;
  while ((got = std::fread(chunk, 1, sizeof chunk, pipe)) > 0) out.append(chunk, got);
  const int raw = ::pclose(pipe);
  if (raw != -1 && WIFEXITED(raw)) *status = WEXITSTATUS(raw);
  return out;
}

uint32_t read_u32(const std::vector<uint8_t>& bytes, size_t offset) {
  if (offset + 4 > bytes.size()) throw std::runtime_error("GLB truncated");
  return uint32_t{bytes[offset]} | uint32_t{bytes[offset + 1]} << 8 |
         uint32_t{bytes[offset + 2]} << 16 | uint32_t{bytes[offset + 3]} << 24;
}

}  // namespace

GltfReport validate_glb_file(const std::string& path) {
  GltfReport report;
  const std::filesystem::path js_dir = GVD_TEST_JS_DIR;
  if (!std::filesystem::exists(js_dir / "node_modules" / "gltf-validator" / "package.json")) {
    report.output = std::string(kInstallHint) + " (missing " +
                    (js_dir / "node_modules" / "gltf-validator").string() + ")";
    return report;
  }
  int status = -1;
  run("node --version >/dev/null 2>&1", &status);
  if (status != 0) {
    report.output = std::string(kInstallHint) + " (no `node` on PATH)";
    return report;
  }
  const std::string script = (js_dir / "validate_glb.mjs").string();
  const std::string out =
      run("node " + shell_quote(script) + " " + shell_quote(path) + " 2>&1", &status);
  report.output = out;
  // Exit status 0 = valid, 1 = errors: both come with a report line; 2 = usage/IO problem.
  if (status != 0 && status != 1) {
    report.output = "validate_glb.mjs failed (status " + std::to_string(status) + "): " + out;
    return report;
  }
  const size_t end = out.find('\n');
  const nlohmann::json line =
      nlohmann::json::parse(out.substr(0, end), nullptr, /*allow_exceptions=*/false);
  if (!line.is_object() || !line.contains("errors") || !line.contains("warnings")) {
    report.output = "unexpected output of validate_glb.mjs: " + out;
    return report;
  }
  report.ran = true;
  report.errors = line["errors"].get<int>();
  report.warnings = line["warnings"].get<int>();
  return report;
}

GlbFile parse_glb(const std::vector<uint8_t>& bytes) {
  if (read_u32(bytes, 0) != 0x46546C67u) throw std::runtime_error("GLB magic is not 'glTF'");
  if (read_u32(bytes, 4) != 2) throw std::runtime_error("GLB version is not 2");
  if (read_u32(bytes, 8) != bytes.size()) throw std::runtime_error("GLB length mismatch");
  GlbFile glb;
  size_t offset = 12;
  bool has_json = false;
  while (offset < bytes.size()) {
    const uint32_t length = read_u32(bytes, offset);
    const uint32_t type = read_u32(bytes, offset + 4);
    offset += 8;
    if (length % 4 != 0 || offset + length > bytes.size()) {
      throw std::runtime_error("GLB chunk misaligned or truncated");
    }
    const auto begin = bytes.begin() + static_cast<std::ptrdiff_t>(offset);
    const auto end = begin + static_cast<std::ptrdiff_t>(length);
    if (type == 0x4E4F534Au) {
      glb.json = nlohmann::json::parse(begin, end);
      has_json = true;
    } else if (type == 0x004E4942u) {
      glb.bin.assign(begin, end);
    }
    offset += length;
  }
  if (!has_json) throw std::runtime_error("GLB has no JSON chunk");
  return glb;
}

std::vector<double> read_accessor(const GlbFile& glb, int index) {
  const nlohmann::json& accessor = glb.json.at("accessors").at(static_cast<size_t>(index));
  const nlohmann::json& view =
      glb.json.at("bufferViews").at(accessor.at("bufferView").get<size_t>());
  if (view.value("buffer", -1) != 0) throw std::runtime_error("accessor not in the GLB buffer");
  const std::string type = accessor.at("type").get<std::string>();
  const size_t components = type == "SCALAR" ? 1 : type == "VEC2" ? 2 : type == "VEC3" ? 3 : 4;
  const int component_type = accessor.at("componentType").get<int>();
  const size_t component_size = component_type == 5126 || component_type == 5125 ? 4
                                : component_type == 5123                         ? 2
                                                                                 : 1;
  const size_t count = accessor.at("count").get<size_t>();
  const size_t stride = view.value("byteStride", components * component_size);
  const size_t base = view.value("byteOffset", size_t{0}) + accessor.value("byteOffset", size_t{0});
  std::vector<double> values;
  values.reserve(count * components);
  for (size_t e = 0; e < count; ++e) {
    for (size_t c = 0; c < components; ++c) {
      const size_t at = base + e * stride + c * component_size;
      if (at + component_size > glb.bin.size()) throw std::runtime_error("accessor out of bin");
      const uint8_t* p = glb.bin.data() + at;
      switch (component_type) {
        case 5126: {
          float f = 0;
          std::memcpy(&f, p, 4);
          values.push_back(f);
          break;
        }
        case 5125: {
          uint32_t u = 0;
          std::memcpy(&u, p, 4);
          values.push_back(u);
          break;
        }
        case 5123: {
          uint16_t u = 0;
          std::memcpy(&u, p, 2);
          values.push_back(u);
          break;
        }
        case 5121:
          values.push_back(*p);
          break;
        default:
          throw std::runtime_error("unsupported component type " + std::to_string(component_type));
      }
    }
  }
  return values;
}

}  // namespace gvd::test
