// Unit tests of the server's pieces (CTest label `unit`, also under ASan): no server process;
// the header gate's test listens on a loopback port of its own.

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <thread>

#include "gvd/common/error.h"
#include "gvd/common/memory_account.h"
#include "gvd/common/parallel.h"
#include "gvd/io/write_outputs.h"
#include "gvd/pipeline/pipeline.h"
#include "gvd/scene/label_volume.h"
#include "gvd/scene/load_scene.h"
#include "header_gate.h"
#include "job_document.h"
#include "job_manager.h"
#include "job_memory.h"
#include "job_params.h"
#include "job_stop.h"
#include "metrics.h"
#include "problem.h"
#include "result_cache.h"
#include "server_options.h"
#include "static_files.h"
#include "support/cancel.h"

namespace gvd::server {

using namespace gvd::scene;
using namespace gvd::result;
using namespace gvd::grid;
using namespace gvd::io;
using namespace gvd::pipeline;

namespace {

using Json = nlohmann::json;
namespace fs = std::filesystem;

TEST(ProblemTable, EveryCoreErrorCodeHasAClientOrServerStatus) {
  for (ErrorCode code :
       {ErrorCode::kInvalidScene, ErrorCode::kInvalidArgument, ErrorCode::kUnsupportedFormat,
        ErrorCode::kOutsideDomain, ErrorCode::kLimitExceeded, ErrorCode::kNotFound, ErrorCode::kIo,
        ErrorCode::kCancelled, ErrorCode::kInternal}) {
    const ProblemInfo& info = problem_info(problem_kind(code));
    EXPECT_GE(info.status, 400);
    EXPECT_LT(info.status, 600);
    const Json doc = Json::parse(problem_json(problem_kind(code), "d", "/x", "r1"));
    EXPECT_EQ(doc["code"], error_code_name(code));
  }
  EXPECT_EQ(problem_info(problem_kind(ErrorCode::kInvalidScene)).status, 422);
  EXPECT_EQ(problem_info(problem_kind(ErrorCode::kNotFound)).status, 404);
  EXPECT_EQ(problem_info(problem_kind(ErrorCode::kUnsupportedFormat)).status, 415);
  EXPECT_EQ(problem_info(problem_kind(ErrorCode::kInternal)).status, 500);
}

TEST(ProblemTable, TypesAreUniqueAndStable) {
  std::set<std::string_view> types;
  for (int k = 0; k < kProblemKindCount; ++k) {
    const ProblemInfo& info = problem_info(static_cast<ProblemKind>(k));
    EXPECT_TRUE(info.type.starts_with("/problems/")) << info.type;
    EXPECT_FALSE(info.title.empty());
    types.insert(info.type);
    if (info.status == 503) {
      EXPECT_TRUE(info.retryable) << info.type;
    }
  }
  EXPECT_EQ(types.size(), static_cast<size_t>(kProblemKindCount));
}

TEST(ProblemJson, IsRfc9457AndSaysWhere) {
  const Json doc = Json::parse(problem_json(
      ProblemKind::kInvalidScene,
      "objects[3] (\"gear \\\"b\\\"\"): triangles[7][1] = 99 is out of range", "/v1/jobs", "req-1",
      {}, {3, "gear \"b\"", "triangle", 7, "/objects/3/triangles/7/1"}));
  EXPECT_EQ(doc["type"], "/problems/invalid-scene");
  EXPECT_EQ(doc["title"], "Invalid scene");
  EXPECT_EQ(doc["status"], 422);
  EXPECT_EQ(doc["instance"], "/v1/jobs");
  EXPECT_EQ(doc["request_id"], "req-1");
  EXPECT_EQ(doc["object"]["index"], 3);
  EXPECT_EQ(doc["object"]["label"], "gear \"b\"");
  EXPECT_EQ(doc["element"]["kind"], "triangle");
  EXPECT_EQ(doc["element"]["index"], 7);
  EXPECT_EQ(doc["pointer"], "/objects/3/triangles/7/1");
  // The location comes from the error's fields, never from its text.
  const Json text_only = Json::parse(problem_json(
      ProblemKind::kInvalidScene, "object 2 (\"wall\"): vertex 5 coordinate 1e30", "/", ""));
  EXPECT_FALSE(text_only.contains("object"));
  EXPECT_FALSE(text_only.contains("element"));
  const Json label_only = Json::parse(
      problem_json(ProblemKind::kNotFound, "no object labelled 'x'", "/", "", {}, {.label = "x"}));
  EXPECT_EQ(label_only["object"], Json({{"label", "x"}}));
  EXPECT_FALSE(label_only.contains("line"));
  EXPECT_FALSE(label_only.contains("offset"));
  const Json lined = Json::parse(
      problem_json(ProblemKind::kInvalidScene, "OBJ \"a\" line 6: ...", "/", "", {}, {.line = 6}));
  EXPECT_EQ(lined["line"], 6);
  const Json offset = Json::parse(problem_json(
      ProblemKind::kInvalidScene, "JSON parse error at byte 0", "/", "", {}, {.offset = 0}));
  EXPECT_EQ(offset["offset"], 0);
  // Invalid UTF-8 in a detail does not throw.
  EXPECT_NO_THROW(problem_json(ProblemKind::kInvalidArgument, "bad \xff byte", "/", ""));
  const Json extra =
      Json::parse(problem_json(ProblemKind::kNoPath, "none", "/", "", R"({"path":{"points":[]}})"));
  EXPECT_TRUE(extra["path"]["points"].empty());
}

TEST(ServerOptions, FlagsOverrideEnvironment) {
  bool help = false;
  const ServerOptions o = parse_server_options(
      {"--port", "9000", "--workers=3", "--max-body", "1000"},
      {{"GVD_PORT", "7000"}, {"GVD_STORE", "/tmp/s"}, {"GVD_QUEUE", "5"}}, help);
  EXPECT_FALSE(help);
  EXPECT_EQ(o.port, 9000);
  EXPECT_EQ(o.workers, 3);
  EXPECT_EQ(o.max_body, 1000u);
  EXPECT_EQ(o.store, "/tmp/s");
  EXPECT_EQ(o.queue, 5);
  parse_server_options({"--help"}, {}, help);
  EXPECT_TRUE(help);
  EXPECT_NE(server_usage().find("GVD_MAX_LEAVES"), std::string::npos);
}

TEST(ServerOptions, BadValuesAreUsageErrors) {
  bool help = false;
  EXPECT_THROW(parse_server_options({"--port", "x"}, {}, help), UsageError);
  EXPECT_THROW(parse_server_options({"--port", "70000"}, {}, help), UsageError);
  EXPECT_THROW(parse_server_options({"--workers"}, {}, help), UsageError);
  EXPECT_THROW(parse_server_options({"--frobnicate", "1"}, {}, help), UsageError);
  EXPECT_THROW(parse_server_options({"--backend", "gpu"}, {}, help), UsageError);
  EXPECT_THROW(parse_server_options({}, {{"GVD_WORKERS", "-1"}}, help), UsageError);
  EXPECT_THROW(parse_server_options({"--job-seconds", "nan"}, {}, help), UsageError);
  // A budget for the bodies held at once that no body of the largest size fits in.
  EXPECT_THROW(parse_server_options({"--max-body", "1000", "--body-budget", "999"}, {}, help),
               UsageError);
  EXPECT_EQ(
      parse_server_options({"--max-body", "1000", "--body-budget", "1000"}, {}, help).body_budget,
      1000u);
}

TEST(ServerOptions, QueueIsABoundOrARedisUrl) {
  bool help = false;
  const ServerOptions local = parse_server_options({"--queue", "200"}, {}, help);
  EXPECT_TRUE(local.queue_url.empty());
  EXPECT_EQ(local.queue, 200);
  EXPECT_EQ(local.role, "both");
  const ServerOptions o = parse_server_options(
      {"--queue", "redis://10.1.2.3:6390/4", "--queue", "300", "--role", "api"}, {}, help);
  EXPECT_EQ(o.queue_url, "redis://10.1.2.3:6390/4");
  EXPECT_EQ(o.redis_host, "10.1.2.3");
  EXPECT_EQ(o.redis_port, 6390);
  EXPECT_EQ(o.redis_db, 4);
  EXPECT_EQ(o.queue, 300);
  const ServerOptions d = parse_server_options({}, {{"GVD_QUEUE", "redis://cache"}}, help);
  EXPECT_EQ(d.redis_host, "cache");
  EXPECT_EQ(d.redis_port, 6379);
  EXPECT_EQ(d.redis_db, 0);
  EXPECT_THROW(parse_server_options({"--queue", "http://x"}, {}, help), UsageError);
  EXPECT_THROW(parse_server_options({"--queue", "redis://:6379"}, {}, help), UsageError);
  EXPECT_THROW(parse_server_options({"--queue", "redis://h:0"}, {}, help), UsageError);
  EXPECT_THROW(parse_server_options({"--role", "worker"}, {}, help), UsageError);  // no Redis
  EXPECT_THROW(parse_server_options({"--queue", "redis://h", "--role", "boss"}, {}, help),
               UsageError);
  EXPECT_NE(server_usage().find("--reclaim-idle"), std::string::npos);
  EXPECT_NE(server_usage().find("GVD_RATE_LIMIT"), std::string::npos);
}

TEST(JobParams, NormalizedTextAndValidation) {
  JobParams a;
  a.set("max_depth", "12");
  a.set("domain", "0,0,1,1");
  JobParams b = JobParams::from_json(a.to_json());
  EXPECT_EQ(a.to_json(), b.to_json());
  EXPECT_EQ(b.max_depth, 12);
  EXPECT_THROW(a.set("max_depth", "12.5"), Error);
  EXPECT_THROW(a.set("max_depth", "99"), Error);
  EXPECT_THROW(a.set("domain", "0,0,1"), Error);
  EXPECT_THROW(a.set("domain", "0,nan,1,1"), Error);
  EXPECT_THROW(a.set("colour", "red"), Error);
  EXPECT_THROW(a.set("frame", "tilted"), Error);
  a.set("frame", "world");
  EXPECT_EQ(JobParams::from_json(a.to_json()).frame, DomainFrame::kWorld);
  EXPECT_EQ(JobParams::from_json(a.to_json()).pipeline_options({}).domain.frame,
            DomainFrame::kWorld);
  EXPECT_EQ(JobParams{}.pipeline_options({}).domain.frame, DomainFrame::kAuto);
  ServerOptions server;
  EXPECT_THROW(a.check(3, server), Error);  // a 2D box for a 3D scene
  EXPECT_NO_THROW(a.check(2, server));
  server.max_depth = 10;
  EXPECT_THROW(a.check(2, server), Error);  // above the server's cap
  // The memory limit no longer caps the leaves (at 1 KB a leaf it refused jobs that fit): a
  // job is charged for what it allocates (Service.AJobIsChargedForItsOwnMemory).
  server.max_memory_mb = 100;
  server.max_leaves = 1'000'000;
  EXPECT_EQ(JobParams{}.pipeline_options(server).max_leaves, 1'000'000u);
  EXPECT_EQ(JobParams{}.pipeline_options(server).max_depth, 10);
}

TEST(JobParams, GridModeIsItsOwnNormalizedTextAndAdaptiveIdsStay) {
  // An adaptive job's text (and so its id) holds no grid-mode parameter: what it was before
  // mode=grid existed, with `junctions` since junction cells became the default.
  EXPECT_EQ(JobParams{}.to_json(),
            "{\"ambiguity_levels\":-1,\"ambiguity_rounds\":-1,\"contact_depth\":0,"
            "\"curved_tolerance\":0.0,\"domain\":[],\"frame\":\"auto\",\"junctions\":\"on\","
            "\"max_depth\":0,\"refine\":\"certified\",\"resolution\":\"compact\","
            "\"unseen_rounds\":-1}");
  JobParams g;
  g.set("resolution", "64");  // before mode: the order of the query does not matter
  g.set("mode", "grid");
  g.set("metric", "linf");
  g.set("float64", "true");
  const JobParams back = JobParams::from_json(g.to_json());
  EXPECT_EQ(back.to_json(), g.to_json());
  EXPECT_TRUE(back.is_grid());
  EXPECT_EQ(back.grid_resolution, 64);
  EXPECT_EQ(back.metric, GridMetric::kLinf);
  EXPECT_TRUE(back.float64);
  EXPECT_EQ(back.grid_options({}).resolution, 64);
  EXPECT_EQ(back.grid_options({}).metric, GridMetric::kLinf);
  ServerOptions server;
  EXPECT_NO_THROW(g.check(2, server));
  JobParams h = g;
  h.set("resolution", "65");
  EXPECT_NE(h.to_json(), g.to_json());
  h.set("max_depth", "5");
  EXPECT_THROW(h.check(2, server), Error);  // adaptive-only with mode=grid
  JobParams no_resolution;
  no_resolution.set("mode", "grid");
  EXPECT_THROW(no_resolution.check(2, server), Error);
  JobParams adaptive;
  adaptive.set("metric", "l1");
  EXPECT_THROW(adaptive.check(2, server), Error);  // grid-only without mode=grid
  adaptive = {};
  adaptive.set("resolution", "12");
  EXPECT_THROW(adaptive.check(2, server), Error);
  EXPECT_THROW(adaptive.set("resolution", "-3"), Error);
  EXPECT_THROW(adaptive.set("mode", "voxels"), Error);
  EXPECT_THROW(adaptive.set("float64", "maybe"), Error);
}

TEST(JobId, ContentAddressed) {
  const std::string scene = R"({"dimension":2,"objects":[]})";
  const std::string id = job_id(scene, JobParams{}.to_json());
  EXPECT_EQ(id.size(), 32u);
  EXPECT_EQ(id, job_id(scene, JobParams{}.to_json()));
  JobParams p;
  p.max_depth = 5;
  EXPECT_NE(id, job_id(scene, p.to_json()));
  EXPECT_NE(id, job_id(scene + " ", JobParams{}.to_json()));
  // SHA-256 of the algorithm version and the texts, computed apart (python3:
  // hashlib.sha256(b'gvd-job\nalgorithm 5\n{}\n' + scene).hexdigest()[:32]); version 5 since
  // junction cells became the default (the results of such scenes changed).
  EXPECT_EQ(job_id(scene, "{}"), "289bef7984bf6cc9e783a96ea1c6d732");
}

// A labelled volume's job is addressed by its bytes and options as uploaded (the scene is only
// made by the worker): the same upload is the same job, any change another.
TEST(JobId, VolumesAreAddressedByTheirBytesAndOptions) {
  const std::string npy = "\x93NUMPY bytes", options = R"({"background":0,"spacing":[1,1,2]})";
  const std::string params = JobParams{}.to_json();
  const std::string id = volume_job_id(options, npy, params);
  EXPECT_EQ(id.size(), 32u);
  EXPECT_EQ(id, volume_job_id(options, npy, params));
  EXPECT_NE(id, volume_job_id(options, npy + " ", params));
  EXPECT_NE(id, volume_job_id(R"({"background":null,"spacing":[1,1,2]})", npy, params));
  JobParams p;
  p.max_depth = 5;
  EXPECT_NE(id, volume_job_id(options, npy, p.to_json()));
  EXPECT_NE(id, job_id(options + "\n" + npy, params));
}

/// A 3D .npy of uint8 labels (x fastest) of shape (nz, ny, nx).
std::string label_npy(const std::vector<uint8_t>& labels, int nx, int ny, int nz) {
  std::string header = "{'descr': '|u1', 'fortran_order': False, 'shape': (" + std::to_string(nz) +
                       ", " + std::to_string(ny) + ", " + std::to_string(nx) + "), }";
  while ((10 + header.size() + 1) % 64 != 0) header += ' ';
  header += '\n';
  std::string out = "\x93NUMPY";
  out += '\x01';
  out += '\x00';
  out += static_cast<char>(header.size() & 0xFF);
  out += static_cast<char>(header.size() >> 8);
  return out + header + std::string(labels.begin(), labels.end());
}

// The worker's side of a volume upload (read_stored_scene): the stored bytes become the scene
// the core makes of them, with the request's units, reporting stage "volume"; a set cancel flag
// stops the conversion; what the conversion finds wrong is the error the core gives.
TEST(StoredRequest, AVolumeIsConvertedByTheWorker) {
  const std::string dir =
      fs::temp_directory_path() / ("gvd-stored-volume-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::vector<uint8_t> labels(8 * 8 * 8, 1);
  for (size_t i = 0; i < labels.size() / 2; ++i) labels[i] = 2;  // z < 4: label 2
  LabelVolumeOptions options;
  options.spacing = {1, 1, 2};
  std::string npy = label_npy(labels, 8, 8, 8);
  JobRequest request;
  request.volume_npy = npy;
  request.volume_json = volume_options_json(options, 3);
  request.params_json = JobParams{}.to_json();
  request.units = "mm";
  request.id = volume_job_id(request.volume_json, request.volume_npy, request.params_json);
  const std::string base = dir + "/" + request.id;
  write_stored_request(base, request, unix_now());
  EXPECT_TRUE(fs::exists(base + ".volume.npy"));
  EXPECT_FALSE(fs::exists(base + ".scene.json"));
  EXPECT_TRUE(stored_input_exists(base, Json::parse(R"({"volume":{}})")));

  std::atomic<bool> cancel{true};
  test::expect_cancelled([&] { read_stored_scene(base, {}, &cancel); }, "read_stored_scene");
  cancel = false;
  std::vector<double> seen;
  const Scene scene = read_stored_scene(base, {}, &cancel, [&](const std::string& stage, double f) {
    EXPECT_EQ(stage, "volume");
    seen.push_back(f);
  });
  const auto* bytes = reinterpret_cast<const uint8_t*>(request.volume_npy.data());
  Scene direct =
      scene_from_label_volume(read_label_volume_npy({bytes, request.volume_npy.size()}, "v"),
                              volume_options_from_json(Json::parse(request.volume_json)));
  direct.units = "mm";
  EXPECT_EQ(scene_to_json(scene), scene_to_json(direct));
  ASSERT_EQ(scene.objects.size(), 2u);
  ASSERT_FALSE(seen.empty());
  EXPECT_EQ(seen.front(), 0);
  EXPECT_EQ(seen.back(), 1);
  EXPECT_TRUE(std::is_sorted(seen.begin(), seen.end()));

  // All background: the job fails as the upload did when the HTTP thread converted it.
  std::fill(labels.begin(), labels.end(), 0);
  npy = label_npy(labels, 8, 8, 8);
  request.volume_npy = npy;
  write_stored_request(base, request, unix_now());
  try {
    read_stored_scene(base, {});
    ADD_FAILURE() << "a volume of background only must fail";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidScene);
    EXPECT_NE(e.detail().find("no label other than the background"), std::string::npos)
        << e.detail();
  }
  remove_stored_request(base);
  EXPECT_FALSE(fs::exists(base + ".volume.npy"));
  EXPECT_FALSE(fs::exists(base + ".json"));
  fs::remove_all(dir);
}

TEST(Metrics, PrometheusText) {
  Metrics m;
  m.request("GET /x", "GET", 200, 0.001);
  m.request("GET /x", "GET", 200, 0.003);
  m.stage("octree", 0.2);
  m.job_finished("done", 1.5);
  m.count("gvd_job_cache_hits_total");
  m.gauge("gvd_test_gauge", "A test.", [] { return 4.0; });
  const std::string text = m.render();
  EXPECT_NE(text.find("gvd_http_requests_total{route=\"GET /x\",method=\"GET\",status=\"200\"} 2"),
            std::string::npos);
  EXPECT_NE(text.find("gvd_http_request_duration_seconds_bucket{route=\"GET /x\",le=\"0.001\"} 1"),
            std::string::npos);
  EXPECT_NE(text.find("gvd_http_request_duration_seconds_bucket{route=\"GET /x\",le=\"+Inf\"} 2"),
            std::string::npos);
  EXPECT_NE(text.find("gvd_job_stage_duration_seconds_count{stage=\"octree\"} 1"),
            std::string::npos);
  EXPECT_NE(text.find("gvd_job_cache_hits_total 1"), std::string::npos);
  EXPECT_NE(text.find("gvd_test_gauge 4"), std::string::npos);
  EXPECT_NE(text.find("gvd_jobs_finished_total{status=\"done\"} 1"), std::string::npos);
}

TEST(GlbToGltf, EmbedsTheBufferAsADataUri) {
  const Scene scene = parse_scene_json(R"({"dimension":2,"objects":[
      {"label":"a","vertices":[[0,0],[1,0]],"segments":[[0,1]]},
      {"label":"b","vertices":[[0,1],[1,1]],"segments":[[0,1]]}]})");
  PipelineOptions options;
  options.threads = 1;
  const GvdResult r = compute_gvd(scene, options);
  const std::vector<uint8_t> glb = gvd_to_glb(r.gvd, r.scene);
  const Json gltf = Json::parse(glb_to_gltf(std::string(glb.begin(), glb.end())));
  const std::string uri = gltf["buffers"][0]["uri"];
  ASSERT_TRUE(uri.starts_with("data:application/octet-stream;base64,"));
  const size_t b64 = uri.size() - std::string("data:application/octet-stream;base64,").size();
  EXPECT_EQ(b64 % 4, 0u);
  EXPECT_EQ(b64 / 4 * 3 - (uri.ends_with("==")  ? 2
                           : uri.ends_with("=") ? 1
                                                : 0),
            gltf["buffers"][0]["byteLength"].get<size_t>());
  EXPECT_THROW(glb_to_gltf("not a glb at all....."), Error);
}

TEST(StaticFiles, MediaTypesBrowsersNeed) {
  EXPECT_EQ(media_type_for("three.module.js"), "text/javascript; charset=utf-8");
  EXPECT_EQ(media_type_for("index.html"), "text/html; charset=utf-8");
  EXPECT_EQ(media_type_for("viewer.css"), "text/css; charset=utf-8");
  EXPECT_EQ(media_type_for("LICENSE"), "text/plain; charset=utf-8");
  EXPECT_EQ(media_type_for("blob"), "application/octet-stream");
}

TEST(StaticFiles, ServesInsideTheRootOnlyWithETag) {
  namespace fs = std::filesystem;
  const fs::path root = fs::temp_directory_path() / ("gvd-web-" + std::to_string(::getpid()));
  fs::remove_all(root);
  fs::create_directories(root / "viewer");
  std::ofstream(root / "index.html") << "<!doctype html>";
  std::ofstream(root / "viewer" / "main.js") << "export {};";
  // Found next to a binary in <root>/../bin, as build/server/gvd-server finds build/web.
  fs::create_directories(root / "bin");
  fs::create_directories(root / "web");
  std::ofstream(root / "web" / "index.html") << "x";
  EXPECT_EQ(find_web_root("", (root / "bin" / "gvd-server").string()), (root / "web").string());
  EXPECT_EQ(find_web_root("", "/nonexistent/bin/gvd-server"), "");
  EXPECT_THROW(find_web_root((root / "viewer").string(), ""), std::runtime_error);

  const StaticFiles files(root.string());
  httplib::Request req;
  httplib::Response res;
  ASSERT_TRUE(files.serve(req, res, "viewer/main.js"));
  EXPECT_EQ(res.body, "export {};");
  EXPECT_EQ(res.get_header_value("Content-Type"), "text/javascript; charset=utf-8");
  const std::string etag = res.get_header_value("ETag");
  EXPECT_FALSE(etag.empty());
  httplib::Request again;
  again.headers.emplace("If-None-Match", etag);
  httplib::Response cached;
  ASSERT_TRUE(files.serve(again, cached, "viewer/main.js"));
  EXPECT_EQ(cached.status, 304);
  EXPECT_TRUE(cached.body.empty());
  for (const char* bad : {"../index.html", "viewer/../index.html", "/etc/passwd", "viewer//main.js",
                          ".hidden", "viewer/missing.js", "viewer", "", "viewer/main.js%00"}) {
    httplib::Response r;
    EXPECT_FALSE(files.serve(req, r, bad)) << bad;
  }
  fs::remove_all(root);
}

TEST(ResultCache, LeastRecentlyUsedIsEvicted) {
  int hits = 0, misses = 0;
  ResultCache cache("/nonexistent-dir", 2, [&](bool hit) { (hit ? hits : misses)++; });
  cache.put("a", std::make_shared<GvdResult>());
  cache.put("b", std::make_shared<GvdResult>());
  EXPECT_NE(cache.get("a", "{}"), nullptr);  // a is now the newest
  cache.put("c", std::make_shared<GvdResult>());
  EXPECT_EQ(cache.size(), 2u);
  EXPECT_EQ(cache.get("b", "{}"), nullptr);  // evicted, and not on disk
  EXPECT_NE(cache.get("a", "{}"), nullptr);
  EXPECT_NE(cache.get("c", "{}"), nullptr);
  EXPECT_EQ(hits, 3);
  EXPECT_EQ(misses, 1);
}

}  // namespace
namespace {

int connect_loopback(int port) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    close(fd);
    return -1;
  }
  timeval tv{3, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  return fd;
}

/// Everything the server sends until it closes the connection (or 3 s pass).
std::string read_all(int fd) {
  std::string out;
  char buf[1024];
  for (ssize_t n; (n = recv(fd, buf, sizeof buf, 0)) > 0;) out.append(buf, static_cast<size_t>(n));
  return out;
}

size_t count_of(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

}  // namespace

// The gate in process (the service test attacks a real gvd-server): two threads, so that two
// stalled connections would hold both if they waited in threads; they wait at the gate, a
// third client is answered, pipelined and kept-alive requests keep their order, the stalled
// ones get 408 at the deadline, and stop() closes what still waits.
TEST(HeaderGate, StalledHeadersWaitOutsideTheThreads) {
  GatedServer http(2);
  GateLimits limits;
  limits.header_seconds = 1;
  limits.idle_seconds = 5;
  limits.max_waiting_per_client = 3;
  http.set_gate_limits(limits);
  http.Get("/n", [](const httplib::Request& req, httplib::Response& res) {
    res.set_content("n" + req.get_header_value("X-N"), "text/plain");
  });
  const int port = http.bind_to_any_port("127.0.0.1");
  ASSERT_GT(port, 0);
  std::thread serving([&] { http.listen_after_bind(); });

  const std::string stall = "GET /n HTTP/1.1\r\nHost: x\r\nX-N: ";
  const int a = connect_loopback(port), b = connect_loopback(port);
  ASSERT_GE(a, 0);
  ASSERT_GE(b, 0);
  (void)!send(a, stall.data(), stall.size(), MSG_NOSIGNAL);
  // b: one whole request, then the next one stalls on the kept-alive connection.
  const std::string b_bytes = "GET /n HTTP/1.1\r\nHost: x\r\nX-N: 1\r\n\r\n" + stall;
  (void)!send(b, b_bytes.data(), b_bytes.size(), MSG_NOSIGNAL);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));

  const int c = connect_loopback(port);
  ASSERT_GE(c, 0);
  const std::string three =
      "GET /n HTTP/1.1\r\nHost: x\r\nX-N: 2\r\n\r\nGET /n HTTP/1.1\r\nHost: x\r\nX-N: 3\r\n\r\n"
      "GET /n HTTP/1.1\r\nHost: x\r\nX-N: 4\r\nConnection: close\r\n\r\n";
  const auto t0 = std::chrono::steady_clock::now();
  (void)!send(c, three.data(), three.size(), MSG_NOSIGNAL);
  const std::string c_got = read_all(c);
  const double c_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_LT(c_seconds, 0.5);  // not after the stalled ones' deadline
  const size_t n2 = c_got.find("\r\n\r\nn2"), n3 = c_got.find("\r\n\r\nn3"),
               n4 = c_got.find("\r\n\r\nn4");
  EXPECT_NE(n2, std::string::npos) << c_got;
  EXPECT_LT(n2, n3);
  EXPECT_LT(n3, n4);
  EXPECT_NE(n4, std::string::npos) << c_got;
  close(c);

  const std::string a_got = read_all(a), b_got = read_all(b);
  EXPECT_TRUE(a_got.starts_with("HTTP/1.1 408 ")) << a_got;
  EXPECT_EQ(count_of(b_got, "HTTP/1.1 200 "), 1u) << b_got;
  EXPECT_EQ(count_of(b_got, "HTTP/1.1 408 "), 1u) << b_got;
  close(a);
  close(b);
  EXPECT_EQ(http.gate_counts().timed_out, 2u);

  // Four stalled connections from one address with room for three: the oldest is closed.
  std::vector<int> fds;
  for (int i = 0; i < 4; ++i) {
    fds.push_back(connect_loopback(port));
    (void)!send(fds.back(), stall.data(), stall.size(), MSG_NOSIGNAL);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_EQ(read_all(fds[0]), "");  // closed at once, no answer
  EXPECT_EQ(http.gate_counts().evicted, 1u);
  EXPECT_EQ(http.gate_counts().waiting, 3u);

  http.stop();
  serving.join();
  for (size_t i = 1; i < fds.size(); ++i) {
    EXPECT_EQ(read_all(fds[i]), "");  // closed by stop, before their deadline
    close(fds[i]);
  }
  close(fds[0]);
  EXPECT_EQ(http.gate_counts().waiting, 0u);
}

// Ready requests wait for a thread in a bounded queue. Two threads held by requests
// that block, one request queued: every further one is answered by the gate at once with its
// overloaded answer (here from the request line) and the connection closed; new connections
// are still taken in (not queued behind the busy threads); once the threads are free, the
// queued request is served and so is the next one.
TEST(HeaderGate, FullQueueIsAnsweredAtOnce) {
  GatedServer http(2);
  GateLimits limits;
  limits.max_queued = 1;
  limits.overloaded = [](std::string_view method, std::string_view path) {
    const std::string body = std::string(method) + " " + std::string(path);
    return "HTTP/1.1 503 Service Unavailable\r\nRetry-After: 1\r\nContent-Length: " +
           std::to_string(body.size()) + "\r\nConnection: close\r\n\r\n" + body;
  };
  http.set_gate_limits(limits);
  std::mutex mutex;
  std::condition_variable released_cv;
  bool released = false;
  http.Get("/block", [&](const httplib::Request&, httplib::Response& res) {
    std::unique_lock lock(mutex);
    released_cv.wait(lock, [&] { return released; });
    res.set_content("done", "text/plain");
  });
  http.Get("/n", [](const httplib::Request&, httplib::Response& res) {
    res.set_content("n", "text/plain");
  });
  const int port = http.bind_to_any_port("127.0.0.1");
  ASSERT_GT(port, 0);
  std::thread serving([&] { http.listen_after_bind(); });
  const auto wait_until = [&](auto done) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    while (!done() && std::chrono::steady_clock::now() < end) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return done();
  };

  const std::string block = "GET /block HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n";
  std::vector<int> blocked;
  for (int i = 0; i < 3; ++i) {
    blocked.push_back(connect_loopback(port));
    ASSERT_GE(blocked.back(), 0);
    (void)!send(blocked.back(), block.data(), block.size(), MSG_NOSIGNAL);
  }
  ASSERT_TRUE(wait_until([&] {
    const GateCounts n = http.gate_counts();
    return n.busy == 2 && n.queued == 1;
  }));

  for (int i = 0; i < 4; ++i) {
    const int fd = connect_loopback(port);
    ASSERT_GE(fd, 0);
    const std::string request = "GET /n?i=" + std::to_string(i) + " HTTP/1.1\r\nHost: x\r\n\r\n";
    const auto t0 = std::chrono::steady_clock::now();
    (void)!send(fd, request.data(), request.size(), MSG_NOSIGNAL);
    const std::string got = read_all(fd);  // the gate closes the connection after its answer
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    close(fd);
    EXPECT_TRUE(got.starts_with("HTTP/1.1 503 ")) << got;
    EXPECT_TRUE(got.ends_with("\r\n\r\nGET /n")) << got;  // method and path, no query
    EXPECT_LT(seconds, 1.0);
  }
  EXPECT_EQ(http.gate_counts().overloaded, 4u);
  EXPECT_EQ(http.gate_counts().queued, 1u);

  {
    std::lock_guard lock(mutex);
    released = true;
  }
  released_cv.notify_all();
  for (const int fd : blocked) {
    const std::string got = read_all(fd);
    EXPECT_TRUE(got.starts_with("HTTP/1.1 200 ")) << got;
    EXPECT_TRUE(got.ends_with("done")) << got;
    close(fd);
  }
  EXPECT_TRUE(wait_until([&] { return http.gate_counts().busy == 0; }));
  const int fd = connect_loopback(port);
  const std::string request = "GET /n HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n";
  (void)!send(fd, request.data(), request.size(), MSG_NOSIGNAL);
  EXPECT_TRUE(read_all(fd).starts_with("HTTP/1.1 200 "));
  close(fd);
  EXPECT_EQ(http.gate_counts().overloaded, 4u);

  http.stop();
  serving.join();
}

namespace {

/// One answer read from the kept-alive connection `fd` after sending `request` (headers and
/// the body of its Content-Length), or what came before the server closed it.
std::string exchange_on(int fd, const std::string& request) {
  if (send(fd, request.data(), request.size(), MSG_NOSIGNAL) !=
      static_cast<ssize_t>(request.size())) {
    return "";
  }
  std::string out;
  char buf[1024];
  for (;;) {
    const size_t head_end = out.find("\r\n\r\n");
    if (head_end != std::string::npos) {
      const size_t cl = out.find("Content-Length: ");
      const size_t len =
          cl != std::string::npos && cl < head_end ? std::stoul(out.substr(cl + 16)) : 0;
      if (out.size() >= head_end + 4 + len) return out;
    }
    const ssize_t n = recv(fd, buf, sizeof buf, 0);
    if (n <= 0) return out;
    out.append(buf, static_cast<size_t>(n));
  }
}

}  // namespace

// Kept-alive connections idle between requests hold nothing but a descriptor; only
// those with part of their headers count toward the per-address cap (before, 256 connections
// of one load generator were closed and reopened over and over with a cap of 64). Eight idle
// connections with room for three all make their next request; four stalled ones: the oldest
// stalled one is closed, no idle one.
TEST(HeaderGate, IdleConnectionsDoNotCountTowardTheClientCap) {
  GatedServer http(2);
  GateLimits limits;
  limits.max_waiting_per_client = 3;
  http.set_gate_limits(limits);
  http.Get("/n", [](const httplib::Request&, httplib::Response& res) {
    res.set_content("n", "text/plain");
  });
  const int port = http.bind_to_any_port("127.0.0.1");
  ASSERT_GT(port, 0);
  std::thread serving([&] { http.listen_after_bind(); });

  const std::string request = "GET /n HTTP/1.1\r\nHost: x\r\n\r\n";
  std::vector<int> idle;
  for (int i = 0; i < 8; ++i) {
    idle.push_back(connect_loopback(port));
    ASSERT_TRUE(exchange_on(idle.back(), request).starts_with("HTTP/1.1 200 "));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(100));  // past the threads' linger
  EXPECT_EQ(http.gate_counts().waiting, 8u);
  const std::string stall = "GET /n HTTP/1.1\r\nHost: x\r\nX-N: ";
  std::vector<int> stalled;
  for (int i = 0; i < 4; ++i) {
    stalled.push_back(connect_loopback(port));
    (void)!send(stalled.back(), stall.data(), stall.size(), MSG_NOSIGNAL);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_EQ(read_all(stalled[0]), "");  // the oldest stalled one, closed at once
  EXPECT_EQ(http.gate_counts().evicted, 1u);
  EXPECT_EQ(http.gate_counts().waiting, 11u);
  for (const int fd : idle) {
    EXPECT_TRUE(exchange_on(fd, request).starts_with("HTTP/1.1 200 "));
    close(fd);
  }
  EXPECT_EQ(http.gate_counts().evicted, 1u);
  http.stop();
  serving.join();
  for (const int fd : stalled) close(fd);
}

// A probe no longer waits in the queue behind requests that hold every thread: the
// gate sends /healthz to threads of its own. Two threads blocked, two requests queued (room
// for four): /healthz is answered at once, and a kept-alive probe connection can go on with a
// normal request, which then waits its turn.
TEST(HeaderGate, ProbesHaveALaneOfTheirOwn) {
  GatedServer http(2);
  GateLimits limits;
  limits.max_queued = 4;
  limits.priority_paths = {"/healthz"};
  http.set_gate_limits(limits);
  std::mutex mutex;
  std::condition_variable released_cv;
  bool released = false;
  http.Get("/block", [&](const httplib::Request&, httplib::Response& res) {
    std::unique_lock lock(mutex);
    released_cv.wait(lock, [&] { return released; });
    res.set_content("done", "text/plain");
  });
  http.Get("/healthz", [](const httplib::Request&, httplib::Response& res) {
    res.set_content("ok", "text/plain");
  });
  const int port = http.bind_to_any_port("127.0.0.1");
  ASSERT_GT(port, 0);
  std::thread serving([&] { http.listen_after_bind(); });

  const std::string block = "GET /block HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n";
  std::vector<int> blocked;
  for (int i = 0; i < 4; ++i) {
    blocked.push_back(connect_loopback(port));
    (void)!send(blocked.back(), block.data(), block.size(), MSG_NOSIGNAL);
  }
  // Waits for the steady state: all four may be queued before the two threads take theirs,
  // so "two queued" alone can be seen while a thread is still on its way (busy 1, queued 3
  // falling to 2).
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while ((http.gate_counts().busy < 2 || http.gate_counts().queued != 2) &&
         std::chrono::steady_clock::now() < end) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ASSERT_EQ(http.gate_counts().busy, 2u);
  ASSERT_EQ(http.gate_counts().queued, 2u);

  const int probe = connect_loopback(port);
  for (const char* target : {"/healthz", "/healthz?x=1"}) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::string got =
        exchange_on(probe, "GET " + std::string(target) + " HTTP/1.1\r\nHost: x\r\n\r\n");
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_TRUE(got.starts_with("HTTP/1.1 200 ")) << got;
    EXPECT_TRUE(got.ends_with("ok")) << got;
    EXPECT_LT(seconds, 0.5);
  }
  EXPECT_EQ(http.gate_counts().priority_served, 2u);
  // Not a probe: it waits for a main thread like the others.
  const std::string next = "GET /block HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n";
  (void)!send(probe, next.data(), next.size(), MSG_NOSIGNAL);
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (http.gate_counts().queued < 3 && std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_EQ(http.gate_counts().queued, 3u);
  {
    std::lock_guard lock(mutex);
    released = true;
  }
  released_cv.notify_all();
  blocked.push_back(probe);
  for (const int fd : blocked) {
    EXPECT_TRUE(read_all(fd).ends_with("done"));
    close(fd);
  }
  http.stop();
  serving.join();
}

// A body read in a thread had only a time-out per recv. With begin_body (called by
// the server's pre-routing handler), a body has a deadline (body_seconds + length /
// min_body_rate), past which the read fails and body_timed_out() says so; and at most
// max_body_readers threads read one at once.
TEST(HeaderGate, BodiesHaveADeadlineAndAReaderCap) {
  GatedServer http(4);
  GateLimits limits;
  limits.max_body_readers = 1;
  limits.body_seconds = 0.5;
  limits.min_body_rate = 1000;  // + 0.1 s for the 100 bytes below
  http.set_gate_limits(limits);
  http.set_pre_routing_handler([&](const httplib::Request& req, httplib::Response& res) {
    if (http.begin_body(std::stoull(req.get_header_value("Content-Length", 0))) ==
        BodyAdmission::kAdmitted) {
      return httplib::Server::HandlerResponse::Unhandled;
    }
    res.status = 503;
    res.set_content("busy", "text/plain");
    return httplib::Server::HandlerResponse::Handled;
  });
  http.set_error_handler([](const httplib::Request&, httplib::Response& res) {
    if (GatedServer::body_timed_out()) res.set_content("too slow", "text/plain");
  });
  http.Post("/p", [](const httplib::Request& req, httplib::Response& res) {
    res.set_content(std::to_string(req.body.size()), "text/plain");
  });
  const int port = http.bind_to_any_port("127.0.0.1");
  ASSERT_GT(port, 0);
  std::thread serving([&] { http.listen_after_bind(); });

  const std::string head =
      "POST /p HTTP/1.1\r\nHost: x\r\nContent-Length: 100\r\nConnection: close\r\n\r\n";
  const int slow = connect_loopback(port);
  const std::string start = head + "a";
  const auto t0 = std::chrono::steady_clock::now();
  (void)!send(slow, start.data(), start.size(), MSG_NOSIGNAL);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_EQ(http.gate_counts().body_readers, 1u);

  // A second body while the first is read: refused before it is read.
  const int second = connect_loopback(port);
  (void)!send(second, start.data(), start.size(), MSG_NOSIGNAL);
  const std::string refused = read_all(second);
  close(second);
  EXPECT_TRUE(refused.starts_with("HTTP/1.1 503 ")) << refused;
  EXPECT_EQ(http.gate_counts().body_refused, 1u);

  // The slow one sends a byte every 50 ms (each recv is quick): failed at ~0.6 s.
  timeval tv{0, 50'000};
  setsockopt(slow, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  std::string got;
  char buf[1024];
  while (std::chrono::steady_clock::now() - t0 < std::chrono::seconds(3)) {
    (void)!send(slow, "a", 1, MSG_NOSIGNAL);
    const ssize_t n = recv(slow, buf, sizeof buf, 0);
    if (n == 0) break;
    if (n > 0) got.append(buf, static_cast<size_t>(n));
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  close(slow);
  EXPECT_TRUE(got.ends_with("too slow")) << got;
  EXPECT_GT(seconds, 0.55);
  EXPECT_LT(seconds, 1.5);
  EXPECT_EQ(http.gate_counts().body_timed_out, 1u);
  EXPECT_EQ(http.gate_counts().body_readers, 0u);

  // A body that arrives in time is read, and gives its slot back.
  for (int i = 0; i < 2; ++i) {
    const int fd = connect_loopback(port);
    const std::string whole = head + std::string(100, 'b');
    (void)!send(fd, whole.data(), whole.size(), MSG_NOSIGNAL);
    const std::string answer = read_all(fd);
    close(fd);
    EXPECT_TRUE(answer.starts_with("HTTP/1.1 200 ")) << answer;
    EXPECT_TRUE(answer.ends_with("100")) << answer;
  }
  EXPECT_EQ(http.gate_counts().body_readers, 0u);
  http.stop();
  serving.join();
}

// begin_body's other two limits. Each address may be reading
// max_body_readers_per_client bodies; the bytes of the bodies held (being read, or read and
// still handled) stay within max_body_bytes, and are given back when the request is over,
// not when its body has been read.
TEST(HeaderGate, BodiesHaveAShareForEachAddressAndAByteBudget) {
  GatedServer http(8);
  GateLimits limits;
  limits.max_body_readers_per_client = 1;
  limits.max_body_bytes = 150;
  http.set_gate_limits(limits);
  http.set_pre_routing_handler([&](const httplib::Request& req, httplib::Response& res) {
    const BodyAdmission a = http.begin_body(std::stoull(req.get_header_value("Content-Length", 0)));
    if (a == BodyAdmission::kAdmitted) return httplib::Server::HandlerResponse::Unhandled;
    res.status = 503;
    res.set_content(a == BodyAdmission::kTooManyForClient ? "client"
                    : a == BodyAdmission::kOverBudget     ? "bytes"
                                                          : "readers",
                    "text/plain");
    return httplib::Server::HandlerResponse::Handled;
  });
  std::mutex mutex;
  std::condition_variable released_cv;
  bool released = false;
  http.Post("/hold", [&](const httplib::Request& req, httplib::Response& res) {
    std::unique_lock lock(mutex);
    released_cv.wait(lock, [&] { return released; });
    res.set_content(std::to_string(req.body.size()), "text/plain");
  });
  http.Post("/p", [](const httplib::Request& req, httplib::Response& res) {
    res.set_content(std::to_string(req.body.size()), "text/plain");
  });
  const int port = http.bind_to_any_port("127.0.0.1");
  ASSERT_GT(port, 0);
  std::thread serving([&] { http.listen_after_bind(); });
  const auto connect_from = [port](const char* from) {
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in source{};
    source.sin_family = AF_INET;
    inet_pton(AF_INET, from, &source.sin_addr);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<uint16_t>(port));
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (bind(fd, reinterpret_cast<sockaddr*>(&source), sizeof source) != 0 ||
        connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
      close(fd);
      return -1;
    }
    timeval tv{3, 0};
    setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    return fd;
  };
  const auto post = [](const char* path, size_t length) {
    return std::string("POST ") + path +
           " HTTP/1.1\r\nHost: x\r\nContent-Length: " + std::to_string(length) +
           "\r\nConnection: close\r\n\r\n";
  };
  const auto wait_until = [&](auto done) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    while (!done() && std::chrono::steady_clock::now() < end) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return done();
  };

  // 127.0.0.1 sends 10 bytes slowly: it reads its share, a second body of its is refused.
  const int slow = connect_from("127.0.0.1");
  ASSERT_GE(slow, 0);
  const std::string start = post("/p", 10) + "a";
  (void)!send(slow, start.data(), start.size(), MSG_NOSIGNAL);
  ASSERT_TRUE(wait_until([&] { return http.gate_counts().body_readers == 1; }));
  int fd = connect_from("127.0.0.1");
  std::string head = post("/p", 1) + "b";
  (void)!send(fd, head.data(), head.size(), MSG_NOSIGNAL);
  std::string got = read_all(fd);
  close(fd);
  EXPECT_TRUE(got.starts_with("HTTP/1.1 503 ") && got.ends_with("client")) << got;
  EXPECT_EQ(http.gate_counts().body_refused_client, 1u);

  // 127.0.0.2's body of 100 bytes is read and held by its handler: no longer a reader, but its
  // bytes are still held (110 of 150).
  const int held = connect_from("127.0.0.2");
  ASSERT_GE(held, 0);
  head = post("/hold", 100) + std::string(100, 'c');
  (void)!send(held, head.data(), head.size(), MSG_NOSIGNAL);
  ASSERT_TRUE(wait_until([&] { return http.gate_counts().body_bytes == 110; }));
  EXPECT_EQ(http.gate_counts().body_readers, 1u);

  // 50 more bytes would be 160: refused; 40 fit, are read, and given back once answered.
  fd = connect_from("127.0.0.3");
  head = post("/p", 50) + std::string(50, 'd');
  (void)!send(fd, head.data(), head.size(), MSG_NOSIGNAL);
  got = read_all(fd);
  close(fd);
  EXPECT_TRUE(got.starts_with("HTTP/1.1 503 ") && got.ends_with("bytes")) << got;
  EXPECT_EQ(http.gate_counts().body_refused_bytes, 1u);
  fd = connect_from("127.0.0.3");
  head = post("/p", 40) + std::string(40, 'e');
  (void)!send(fd, head.data(), head.size(), MSG_NOSIGNAL);
  got = read_all(fd);
  close(fd);
  EXPECT_TRUE(got.starts_with("HTTP/1.1 200 ") && got.ends_with("40")) << got;
  EXPECT_TRUE(wait_until([&] { return http.gate_counts().body_bytes == 110; }));

  // The held request is answered, the slow body arrives: nothing is held any more.
  {
    std::lock_guard lock(mutex);
    released = true;
  }
  released_cv.notify_all();
  EXPECT_TRUE(read_all(held).ends_with("100"));
  close(held);
  (void)!send(slow, "aaaaaaaaa", 9, MSG_NOSIGNAL);
  EXPECT_TRUE(read_all(slow).ends_with("10"));
  close(slow);
  EXPECT_TRUE(wait_until([&] { return http.gate_counts().body_bytes == 0; }));
  EXPECT_EQ(http.gate_counts().body_readers, 0u);
  EXPECT_EQ(http.gate_counts().body_refused, 0u);
  http.stop();
  serving.join();
}

// The server's operator new (counted_new.cpp, linked into this test as into gvd-server)
// charges the calling thread's account: what the thread and parallel_for's workers hold,
// given back when freed on any thread; threads without an account are not counted.
TEST(MemoryAccount, ChargesWhatAThreadAndItsWorkersHold) {
  constexpr int64_t kMiB = int64_t{1} << 20;
  MemoryAccount account;
  std::vector<std::vector<char>> parts(8);
  {
    const ScopedMemoryAccount charge(&account);
    auto block = std::make_unique<std::vector<char>>(8 * kMiB);
    // Each thread passes its charges on in steps of up to kMemoryChargeStep.
    EXPECT_GE(account.bytes(), 8 * kMiB - kMemoryChargeStep);
    // Each of the two threads waits for the other before its first block, so a worker of
    // the pool allocates some of them whatever the timing.
    std::atomic<int> started{0};
    std::atomic<bool> seen[2] = {false, false};
    std::atomic<bool> worker_allocated{false};
    parallel_for(
        parts.size(), 2,
        [&](size_t b, size_t e, int t) {
          if (!seen[t].exchange(true)) {
            ++started;
            const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(5);
            while (started.load() < 2 && std::chrono::steady_clock::now() < until)
              std::this_thread::yield();
          }
          if (t != 0) worker_allocated = true;
          for (size_t i = b; i < e; ++i) parts[i].resize(static_cast<size_t>(kMiB));
        },
        1);
    ASSERT_TRUE(worker_allocated.load());
    EXPECT_GE(account.bytes(), 16 * kMiB - kMemoryChargeStep);
    // Another thread without an account: not charged to anyone.
    std::thread([] { std::vector<char> elsewhere(static_cast<size_t>(32 * kMiB), 1); }).join();
    EXPECT_LT(account.bytes(), 18 * kMiB);
    block.reset();
  }
  // The scope passed on what it had gathered: 8 MiB freed, the workers' 8 MiB still held.
  EXPECT_GE(account.bytes(), 8 * kMiB);
  EXPECT_LT(account.bytes(), 9 * kMiB);
  EXPECT_GE(account.peak(), 16 * kMiB);
  EXPECT_LT(account.peak(), 18 * kMiB);
  // Freed by a thread with this account: given back, whichever thread allocated them.
  {
    const ScopedMemoryAccount charge(&account);
    parts.clear();
    parts.shrink_to_fit();
  }
  EXPECT_LT(std::abs(account.bytes()), kMemoryChargeStep);
  EXPECT_EQ(current_memory_account(), nullptr);
}

TEST(MemoryAccount, PassingItsLimitSetsTheFlagOnce) {
  constexpr size_t kMiB = size_t{1} << 20;
  MemoryAccount account;
  std::atomic<bool> flag{false};
  account.set_limit(int64_t{4} << 20, &flag);
  const ScopedMemoryAccount charge(&account);
  std::vector<char> first(3 * kMiB);
  EXPECT_FALSE(flag.load());
  EXPECT_FALSE(account.over());
  std::vector<char> second(3 * kMiB);
  EXPECT_TRUE(flag.load());
  EXPECT_TRUE(account.over());
  flag = false;
  std::vector<char> third(3 * kMiB);
  EXPECT_FALSE(flag.load());  // once: the job was told
}

// Over the process limit, the job that holds the most itself is stopped, not the newest.
TEST(JobMemory, TheJobThatHoldsTheMostIsStopped) {
  struct FakeJob {
    std::atomic<bool> cancel{false};
    MemoryAccount memory;
    std::chrono::steady_clock::time_point run_start;
  };
  const auto t0 = std::chrono::steady_clock::now();
  FakeJob big, small, newest_equal;
  big.run_start = t0;
  big.memory.add(int64_t{900} << 20);
  small.run_start = t0 + std::chrono::seconds(5);
  small.memory.add(int64_t{10} << 20);
  std::vector<FakeJob*> jobs{&big, &small};
  EXPECT_EQ(job_to_stop_for_memory(jobs), &big);
  big.cancel = true;  // already asked to stop: the next one
  EXPECT_EQ(job_to_stop_for_memory(jobs), &small);
  big.cancel = false;
  newest_equal.run_start = t0 + std::chrono::seconds(9);
  newest_equal.memory.add(int64_t{900} << 20);
  jobs.push_back(&newest_equal);
  EXPECT_EQ(job_to_stop_for_memory(jobs), &newest_equal);  // equals: the least work lost
  EXPECT_EQ(job_to_stop_for_memory(std::vector<FakeJob*>{}), nullptr);

  ServerOptions options;
  options.max_memory_mb = 512;
  EXPECT_EQ(job_memory_limit_bytes(options), uint64_t{512} << 20);
  options.job_memory_mb = 64;
  EXPECT_EQ(job_memory_limit_bytes(options), uint64_t{64} << 20);
  const std::string detail = job_memory_detail(small.memory, options);
  EXPECT_NE(detail.find("10.0 MB"), std::string::npos) << detail;
  EXPECT_NE(detail.find("--job-memory-mb"), std::string::npos) << detail;
  options.job_memory_mb = 0;
  options.max_memory_mb = 0;
  EXPECT_EQ(job_memory_limit_bytes(options), 0u);
}

// Both queues explain a job that did not finish with these (job_stop.h).
TEST(JobStop, FailuresAndStopsReadTheSameInBothQueues) {
  auto failure_of = [](auto&& thrower) {
    try {
      thrower();
    } catch (const std::exception&) {
      return current_job_failure();
    }
    return JobFailure{ProblemKind::kInternal, "nothing thrown"};
  };
  const JobFailure scene = failure_of(
      [] { throw Error(ErrorCode::kInvalidScene, "object 'a': triangle 3 has index 9"); });
  EXPECT_EQ(scene.kind, problem_kind(ErrorCode::kInvalidScene));
  EXPECT_EQ(scene.detail, "object 'a': triangle 3 has index 9");
  const JobFailure memory = failure_of([] { throw std::bad_alloc(); });
  EXPECT_EQ(memory.kind, ProblemKind::kLimitExceeded);
  EXPECT_EQ(memory.detail, "out of memory");
  const JobFailure other = failure_of([] { throw std::runtime_error("disk gone"); });
  EXPECT_EQ(other.kind, ProblemKind::kInternal);
  EXPECT_EQ(other.detail, "disk gone");

  // Nobody asked the job to stop, but its own account is over: its memory stopped it.
  MemoryAccount account;
  std::atomic<bool> cancel{false};
  EXPECT_EQ(stop_reason(StopReason::kNone, account), StopReason::kNone);
  account.set_limit(int64_t{4} << 20, &cancel);
  account.add(int64_t{5} << 20);
  ASSERT_TRUE(account.over());
  EXPECT_TRUE(cancel);
  EXPECT_EQ(stop_reason(StopReason::kNone, account), StopReason::kJobMemory);
  EXPECT_EQ(stop_reason(StopReason::kUser, account), StopReason::kUser);

  ServerOptions options;
  options.job_seconds = 2.5;
  options.max_memory_mb = 64;
  options.job_memory_mb = 4;
  const JobFailure cancelled{ProblemKind::kCancelled, "cancelled in the octree stage"};
  const JobFailure timeout = explain_stop(cancelled, StopReason::kTimeout, account, options);
  EXPECT_EQ(timeout.kind, ProblemKind::kLimitExceeded);
  EXPECT_NE(timeout.detail.find("2.5 s (--job-seconds)"), std::string::npos) << timeout.detail;
  const JobFailure own = explain_stop(cancelled, StopReason::kJobMemory, account, options);
  EXPECT_EQ(own.kind, ProblemKind::kLimitExceeded);
  EXPECT_EQ(own.detail, job_memory_detail(account, options));
  const JobFailure server = explain_stop(cancelled, StopReason::kMemory, account, options);
  EXPECT_EQ(server.kind, ProblemKind::kLimitExceeded);
  EXPECT_EQ(server.detail, server_memory_detail(account, options));
  for (const StopReason user : {StopReason::kUser, StopReason::kNone}) {
    const JobFailure deleted = explain_stop(cancelled, user, account, options);
    EXPECT_EQ(deleted.kind, ProblemKind::kCancelled);
    EXPECT_EQ(deleted.detail, "cancelled by DELETE while running");
  }
  // A shutdown is not a failure (the caller queues the job again), and a failure that is no
  // cancellation keeps its own words whatever the reason.
  EXPECT_EQ(explain_stop(cancelled, StopReason::kShutdown, account, options).detail,
            cancelled.detail);
  EXPECT_EQ(explain_stop(scene, StopReason::kTimeout, account, options).detail, scene.detail);
}

}  // namespace gvd::server
