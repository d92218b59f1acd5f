#include "result_cache.h"

#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "gvd/common/error.h"
#include "gvd/io/result_file.h"
#include "gvd/io/write_outputs.h"
#include "gvd/scene/load_scene.h"
#include "job_queue.h"

namespace gvd::server {

using namespace gvd::result;
using namespace gvd::query;
using namespace gvd::io;

LoadedResult::Bytes LoadedResult::once(std::once_flag& flag, Bytes& slot,
                                       const std::function<std::string()>& make) const {
  std::call_once(flag, [&] { slot = std::make_shared<const std::string>(make()); });
  return slot;
}

LoadedResult::Bytes LoadedResult::glb() const {
  return once(glb_once_, glb_, [this] {
    const std::vector<uint8_t> bytes = gvd_to_glb(result_->gvd, result_->scene);
    return std::string(bytes.begin(), bytes.end());
  });
}

LoadedResult::Bytes LoadedResult::gltf() const {
  return once(gltf_once_, gltf_, [this] { return glb_to_gltf(*glb()); });
}

LoadedResult::Bytes LoadedResult::json() const {
  return once(json_once_, json_, [this] { return gvd_to_json(result_->gvd, result_->scene); });
}

LoadedResult::Bytes LoadedResult::graph() const {
  return once(graph_once_, graph_,
              [this] { return graph_to_json(result_->graph, result_->scene); });
}

const GvdIndex& LoadedResult::index() const {
  std::call_once(index_once_, [this] { index_ = std::make_unique<GvdIndex>(result_); });
  return *index_;
}

ResultCache::ResultCache(std::string dir, size_t capacity, std::function<void(bool)> on_lookup)
    : dir_(std::move(dir)),
      capacity_(std::max<size_t>(1, capacity)),
      on_lookup_(std::move(on_lookup)) {}

std::shared_ptr<LoadedResult> ResultCache::cached(const std::string& id) {
  std::lock_guard lock(mutex_);
  const auto it = index_.find(id);
  if (it == index_.end()) return nullptr;
  order_.splice(order_.begin(), order_, it->second);
  if (on_lookup_) on_lookup_(true);
  return it->second->second;
}

std::shared_ptr<LoadedResult> ResultCache::get(const std::string& id,
                                               const std::string& params_json) {
  if (auto hit = cached(id)) return hit;
  if (on_lookup_) on_lookup_(false);
  const std::string path = path_of(id);
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return nullptr;
  // Loaded outside the lock: a large result must not stall lookups of other results. Two
  // threads may load the same result at once; the second insert keeps the first entry.
  std::shared_ptr<LoadedResult> loaded;
  try {
    loaded = std::make_shared<LoadedResult>(
        std::make_shared<const GvdResult>(load_result_bytes(read_file_bytes(path))));
  } catch (const Error& e) {
    // The job is done and its file is there but does not read back (truncated, flipped,
    // emptied): the store's fault, not the client's, so a storage error (500), not the
    // loader's invalid-argument. The detail names the job, never the store's path.
    if (e.code() != ErrorCode::kInvalidArgument) throw;
    throw Error(ErrorCode::kIo, "the stored result of job " + id + " is corrupt (" + e.detail() +
                                    "); DELETE the job and submit it again to recompute it");
  }
  // A file of another job (copied or restored under this name) says so here: a file the
  // server wrote names its job; one without a name (written before jobs were named) holds its
  // scene as it was hashed into the job's id with the parameters.
  if (const std::string owner = result_owner(loaded->result(), params_json); owner != id) {
    throw Error(ErrorCode::kIo, "the stored result of job " + id +
                                    " belongs to another job: its scene with this job's "
                                    "parameters makes job " +
                                    owner + "; DELETE the job and submit it again to recompute it");
  }
  std::lock_guard lock(mutex_);
  if (const auto it = index_.find(id); it != index_.end()) return it->second->second;
  insert_locked(id, loaded);
  return loaded;
}

void ResultCache::put(const std::string& id, std::shared_ptr<const GvdResult> result) {
  std::lock_guard lock(mutex_);
  if (index_.count(id) != 0) return;
  insert_locked(id, std::make_shared<LoadedResult>(std::move(result)));
}

void ResultCache::insert_locked(const std::string& id, std::shared_ptr<LoadedResult> entry) {
  order_.emplace_front(id, std::move(entry));
  index_[id] = order_.begin();
  while (order_.size() > capacity_) {
    index_.erase(order_.back().first);
    order_.pop_back();
  }
}

void ResultCache::erase(const std::string& id) {
  std::lock_guard lock(mutex_);
  if (const auto it = index_.find(id); it != index_.end()) {
    order_.erase(it->second);
    index_.erase(it);
  }
}

void ResultCache::clear() {
  std::lock_guard lock(mutex_);
  order_.clear();
  index_.clear();
}

size_t ResultCache::size() const {
  std::lock_guard lock(mutex_);
  return order_.size();
}

namespace {

uint32_t read_u32(const std::string& s, size_t at) {
  uint32_t v = 0;
  std::memcpy(&v, s.data() + at, 4);  // GLB is little-endian, as is every target we build for
  return v;
}

std::string base64(const char* data, size_t size) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((size + 2) / 3 * 4);
  size_t i = 0;
  const auto byte = [&](size_t k) { return static_cast<uint32_t>(static_cast<uint8_t>(data[k])); };
  for (; i + 3 <= size; i += 3) {
    const uint32_t v = byte(i) << 16 | byte(i + 1) << 8 | byte(i + 2);
    for (int s = 18; s >= 0; s -= 6) out += kAlphabet[(v >> s) & 63];
  }
  if (size - i == 1) {
    const uint32_t v = byte(i) << 16;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += "==";
  } else if (size - i == 2) {
    const uint32_t v = byte(i) << 16 | byte(i + 1) << 8;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += '=';
  }
  return out;
}

}  // namespace

std::string glb_to_gltf(const std::string& glb) {
  const auto bad = [](const char* what) {
    return Error(ErrorCode::kInternal, std::string("glb_to_gltf: ") + what);
  };
  if (glb.size() < 20 || glb.compare(0, 4, "glTF") != 0) throw bad("not a GLB");
  const uint32_t json_length = read_u32(glb, 12);
  if (read_u32(glb, 16) != 0x4E4F534Au || 20ull + json_length > glb.size()) {
    throw bad("bad JSON chunk");
  }
  nlohmann::json doc = nlohmann::json::parse(glb.substr(20, json_length));
  const size_t bin_at = 20ull + json_length;
  if (bin_at + 8 <= glb.size() && read_u32(glb, bin_at + 4) == 0x004E4942u) {
    const uint32_t bin_length = read_u32(glb, bin_at);
    if (bin_at + 8 + bin_length > glb.size()) throw bad("bad BIN chunk");
    if (doc.contains("buffers") && !doc["buffers"].empty()) {
      const size_t used = doc["buffers"][0].value("byteLength", size_t{bin_length});
      doc["buffers"][0]["uri"] =
          "data:application/octet-stream;base64," +
          base64(glb.data() + bin_at + 8, std::min<size_t>(used, bin_length));
    }
  }
  return doc.dump();
}

}  // namespace gvd::server
