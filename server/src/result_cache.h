#pragma once

#include <cstdint>
#include <functional>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>
#include <vector>

#include "gvd/pipeline/pipeline.h"
#include "gvd/query/gvd_index.h"

namespace gvd::server {

/// A finished result and the answers derived from it, each built on first use and then
/// shared by every request (thread-safe). Immutable once built: a job id names one result.
class LoadedResult {
 public:
  explicit LoadedResult(std::shared_ptr<const result::GvdResult> result)
      : result_(std::move(result)) {}

  const result::GvdResult& result() const { return *result_; }
  std::shared_ptr<const result::GvdResult> shared() const { return result_; }

  using Bytes = std::shared_ptr<const std::string>;
  Bytes glb() const;    ///< gvd_to_glb
  Bytes gltf() const;   ///< the same as glTF JSON with the buffer embedded (data URI)
  Bytes json() const;   ///< gvd_to_json (float64)
  Bytes graph() const;  ///< graph_to_json
  /// The query index (built on first use, O(result size); then shared, const, thread-safe).
  const query::GvdIndex& index() const;

 private:
  Bytes once(std::once_flag& flag, Bytes& slot, const std::function<std::string()>& make) const;

  std::shared_ptr<const result::GvdResult> result_;
  mutable std::once_flag glb_once_, gltf_once_, json_once_, graph_once_;
  mutable Bytes glb_, gltf_, json_, graph_;
  mutable std::once_flag index_once_;
  mutable std::unique_ptr<query::GvdIndex> index_;
};

/// An in-memory LRU of finished results in front of the on-disk store: `get` returns the
/// cached entry or loads `<dir>/<id>.gvd` (the engine's result file) and caches it.
class ResultCache {
 public:
  /// `on_lookup(hit)` is called on every get (for the metrics).
  ResultCache(std::string dir, size_t capacity, std::function<void(bool hit)> on_lookup);

  std::string path_of(const std::string& id) const { return dir_ + "/" + id + ".gvd"; }

  /// The result of finished job `id`, computed with the normalized parameters `params_json`
  /// (its status document's "params"); nullptr when there is no such file. A file loaded from
  /// the store must belong to the id: result_owner(it, params_json) == id (a result copied
  /// under another job's id is not served as that job). Throws gvd::Error
  /// {kIo} naming the job, not the store's path, when the file exists but cannot be read, is
  /// corrupt, or belongs to another job.
  std::shared_ptr<LoadedResult> get(const std::string& id, const std::string& params_json);
  /// The cached result of `id`, or nullptr (never loads).
  std::shared_ptr<LoadedResult> cached(const std::string& id);
  /// Caches a result just computed (already saved by the caller).
  void put(const std::string& id, std::shared_ptr<const result::GvdResult> result);
  void erase(const std::string& id);
  /// Drops every cached result (those still in use by a request live on until it ends).
  void clear();
  size_t size() const;

 private:
  void insert_locked(const std::string& id, std::shared_ptr<LoadedResult> entry);

  std::string dir_;
  size_t capacity_;
  std::function<void(bool)> on_lookup_;
  mutable std::mutex mutex_;
  std::list<std::pair<std::string, std::shared_ptr<LoadedResult>>> order_;  ///< front = newest
  std::unordered_map<std::string, decltype(order_)::iterator> index_;
};

/// A GLB converted to a self-contained .gltf: the JSON chunk with buffer 0 given as a base64
/// data URI. Throws gvd::Error{kInternal} when `glb` is not a GLB. (Container format only.)
std::string glb_to_gltf(const std::string& glb);

}  // namespace gvd::server
