#include "job_document.h"

#include <algorithm>
#include <cstdio>
#include <ctime>
#include <filesystem>

#include "gvd/io/write_outputs.h"
#include "gvd/scene/load_scene.h"

namespace gvd::server {

using namespace gvd::scene;
using namespace gvd::io;

using Json = nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

// Share of the whole computation each progress stage roughly takes (for the overall fraction
// of a running job; an estimate, documented as such).
const std::pair<const char*, double> kStageWeights[] =
    {
        {"scene", 0.02},     {"octree", 0.20},  {"distance", 0.30},
        {"ambiguity", 0.25}, {"surface", 0.16}, {"graph", 0.05},
        {"compact", 0.02},   {"grid", 0.93},  // a grid job (mode=grid): scene, grid, graph
        {"volume", 0.05},  // a labelled volume turned into a scene by the worker, first
};

double stage_weight(const std::string& name) {
  for (const auto& [n, w] : kStageWeights) {
    if (name == n) return w;
  }
  return 0;
}
}  // namespace

std::string_view job_status_name(JobStatus status) {
  switch (status) {
    case JobStatus::kQueued:
      return "queued";
    case JobStatus::kRunning:
      return "running";
    case JobStatus::kDone:
      return "done";
    case JobStatus::kFailed:
      return "failed";
    case JobStatus::kCancelled:
      return "cancelled";
  }
  return "unknown";
}
std::optional<JobStatus> job_status_from_name(std::string_view name) {
  for (const JobStatus s : {JobStatus::kQueued, JobStatus::kRunning, JobStatus::kDone,
                            JobStatus::kFailed, JobStatus::kCancelled}) {
    if (job_status_name(s) == name) return s;
  }
  return std::nullopt;
}

double unix_now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

double unix_from_iso(const Json& text) {
  if (!text.is_string()) return 0;
  std::tm tm{};
  int ms = 0;
  const std::string s = text.get<std::string>();
  if (std::sscanf(s.c_str(), "%d-%d-%dT%d:%d:%d.%dZ", &tm.tm_year, &tm.tm_mon, &tm.tm_mday,
                  &tm.tm_hour, &tm.tm_min, &tm.tm_sec, &ms) < 6) {
    return 0;
  }
  tm.tm_year -= 1900;
  tm.tm_mon -= 1;
  return static_cast<double>(timegm(&tm)) + ms / 1000.0;
}

Json iso_time(double unix_seconds) {
  if (unix_seconds <= 0) return nullptr;
  const auto whole = static_cast<std::time_t>(unix_seconds);
  std::tm tm{};
  gmtime_r(&whole, &tm);
  char buf[40];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &tm);
  char out[48];
  std::snprintf(out, sizeof out, "%s.%03dZ", buf,
                static_cast<int>((unix_seconds - static_cast<double>(whole)) * 1000));
  return out;
}

bool record_progress(JobRecord& job, const std::string& stage, double fraction) {
  const auto now = Clock::now();
  if (job.stages.empty() || job.stages.back().name != stage) {
    if (!job.stages.empty()) {
      job.stages.back().fraction = 1;
      job.stages.back().seconds = std::chrono::duration<double>(now - job.stage_start).count();
    }
    if (stage == "done") return false;
    job.stages.push_back({stage, fraction, 0});
    job.stage_start = now;
    return true;
  }
  if (fraction - job.stages.back().fraction < 0.01) return false;  // fewer wake-ups
  job.stages.back().fraction = fraction;
  return true;
}

std::string job_document(const JobRecord& job, JobStatus shown,
                         std::optional<size_t> queue_position) {
  const std::string self = "/v1/jobs/" + job.id;
  Json s = {
      {"id", job.id},
      {"status", job_status_name(shown)},
      {"submitted_at", iso_time(job.submitted_at)},
      {"started_at", iso_time(job.started_at)},
      {"finished_at", iso_time(job.finished_at)},
      {"scene",
       {{"dimension", job.dimension}, {"objects", job.objects}, {"simplices", job.simplices}}},
      {"params", Json::parse(job.params_json.empty() ? "{}" : job.params_json)}};
  // The length unit of every length in the document and the job's answers (the viewer reads
  // it here); none declared: no key, never a made-up one.
  if (!job.units.empty()) s["units"] = job.units;
  if (shown == JobStatus::kQueued && queue_position) s["queue_position"] = *queue_position;
  if (job.recovered) s["recovered"] = true;
  // The most the job held itself (what the limit per job is checked against): while it runs,
  // so far; once it has finished, in all. Absent where it is not known (a recovered document).
  if (job.memory_peak_bytes > 0 && shown != JobStatus::kQueued)
    s["memory_peak_bytes"] = job.memory_peak_bytes;
  Json progress = {{"fraction", 0.0}, {"stage", nullptr}, {"stages", Json::array()}};
  if (shown == JobStatus::kRunning || shown == JobStatus::kCancelled ||
      shown == JobStatus::kFailed) {
    double overall = 0;
    for (const JobRecord::StageTime& st : job.stages) {
      progress["stages"].push_back(
          {{"name", st.name}, {"fraction", st.fraction}, {"seconds", st.seconds}});
      overall += stage_weight(st.name) * st.fraction;
    }
    if (shown == JobStatus::kRunning && !job.stages.empty()) {
      progress["stages"].back()["seconds"] =
          std::chrono::duration<double>(Clock::now() - job.stage_start).count();
      progress["stage"] = job.stages.back().name;
    }
    progress["fraction"] = std::min(0.99, overall);
  }
  if (shown == JobStatus::kDone) {
    progress["fraction"] = 1.0;
    progress["stage"] = "done";
    s["result"] = Json::parse(job.result_info.empty() ? "{}" : job.result_info);
    for (const Json& st : s["result"].value("stages", Json::array())) {
      progress["stages"].push_back({{"name", st.value("name", "")},
                                    {"fraction", 1.0},
                                    {"seconds", st.value("seconds", 0.0)}});
    }
    if (s["params"].is_object() && s["params"].value("mode", "") == "grid") {
      // A grid job has its graph and grid; the rest needs the adaptive result.
      s["links"] = {{"self", self},
                    {"graph", self + "/graph"},
                    {"field", self + "/field.npy"},
                    {"labels", self + "/labels.npy"},
                    {"events", self + "/events"}};
    } else {
      s["links"] = {{"self", self},
                    {"glb", self + "/gvd.glb"},
                    {"gltf", self + "/gvd.gltf"},
                    {"json", self + "/gvd.json"},
                    {"graph", self + "/graph"},
                    {"result", self + "/result.gvd"},
                    {"events", self + "/events"}};
    }
  } else {
    s["links"] = {{"self", self}, {"events", self + "/events"}};
  }
  s["progress"] = progress;
  if (!job.error.empty() && (shown == JobStatus::kFailed || shown == JobStatus::kCancelled)) {
    s["error"] = Json::parse(job.error);
  }
  return s.dump(-1, ' ', false, Json::error_handler_t::replace);
}

void write_stored_request(const std::string& base, const JobRequest& request, double submitted_at) {
  const bool volume = !request.volume_json.empty();
  if (volume) {
    write_file_atomic(base + ".volume.npy",
                      reinterpret_cast<const uint8_t*>(request.volume_npy.data()),
                      request.volume_npy.size());
  } else {
    write_file_atomic(base + ".scene.json", request.scene_json);
  }
  nlohmann::json meta = {{"id", request.id},
                         {"submitted_at", submitted_at},
                         {"params", nlohmann::json::parse(request.params_json)},
                         {"warnings", nlohmann::json::parse(request.warnings_json)},
                         {"dimension", request.dimension},
                         {"objects", request.objects},
                         {"simplices", request.simplices}};
  if (volume) meta["volume"] = nlohmann::json::parse(request.volume_json);
  if (!request.units.empty()) meta["units"] = request.units;
  write_file_atomic(base + ".json", meta.dump());
}

bool stored_input_exists(const std::string& base, const nlohmann::json& meta) {
  std::error_code ec;
  return std::filesystem::exists(base + (meta.contains("volume") ? ".volume.npy" : ".scene.json"),
                                 ec);
}

void remove_stored_request(const std::string& base) {
  std::error_code ec;
  std::filesystem::remove(base + ".json", ec);
  for (const char* suffix : kStoredInputSuffixes) std::filesystem::remove(base + suffix, ec);
}

Scene read_stored_scene(const std::string& base, const SceneLimits& limits,
                        const std::atomic<bool>* cancel,
                        const std::function<void(const std::string&, double)>& progress) {
  auto text = [](const std::string& path) {
    const std::vector<uint8_t> bytes = read_file_bytes(path);
    return std::string(bytes.begin(), bytes.end());
  };
  const nlohmann::json meta = nlohmann::json::parse(text(base + ".json"));
  if (meta.contains("volume")) {
    const auto report = [&](double f) {
      if (progress) progress("volume", f);
    };
    report(0);
    Scene scene;
    {
      const std::vector<uint8_t> bytes = read_file_bytes(base + ".volume.npy");
      const LabelVolume labels = read_label_volume_npy(bytes, "the volume", cancel);
      LabelVolumeOptions options = volume_options_from_json(meta["volume"]);
      options.cancel = cancel;
      options.progress = [&](double f) { report(0.95 * f); };  // validation: the rest
      scene = scene_from_label_volume(labels, options, limits);
    }
    report(1);
    if (const std::string units = meta.value("units", std::string()); !units.empty())
      scene.units = units;
    return scene;
  }
  Scene scene = parse_scene_json(text(base + ".scene.json"), limits, cancel);
  // Only what normalizing removed: the topology warnings are recomputed from the scene.
  std::vector<SceneWarning> warnings =
      warnings_from_json(meta.value("warnings", nlohmann::json::array()).dump());
  std::erase_if(warnings,
                [](const SceneWarning& w) { return w.kind != WarningKind::kDegenerateSimplices; });
  scene.warnings.insert(scene.warnings.begin(), warnings.begin(), warnings.end());
  return scene;
}

std::string volume_options_json(const LabelVolumeOptions& options, int dimension) {
  nlohmann::json spacing = nlohmann::json::array();
  for (int a = 0; a < dimension; ++a) spacing.push_back(options.spacing[static_cast<size_t>(a)]);
  nlohmann::json v = {{"spacing", spacing}, {"background", nullptr}};
  if (options.background) v["background"] = *options.background;
  return v.dump();
}

LabelVolumeOptions volume_options_from_json(const nlohmann::json& volume) {
  LabelVolumeOptions options;
  const nlohmann::json& spacing = volume.at("spacing");
  for (size_t a = 0; a < spacing.size() && a < 3; ++a)
    options.spacing[a] = spacing[a].get<double>();
  const nlohmann::json& background = volume.at("background");
  if (background.is_null()) {
    options.background.reset();
  } else {
    options.background = background.get<uint64_t>();
  }
  return options;
}

}  // namespace gvd::server
