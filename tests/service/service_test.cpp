// Service tests (CTest label `service`): the real gvd-server on an ephemeral port with a temp
// store, driven by a real HTTP client.

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string_view>
#include <thread>
#include <vector>

#include "routes.h"
#include "server_process.h"
#include "support/gltf_validate.h"

namespace gvd::test {

namespace {

using Json = nlohmann::json;
namespace fs = std::filesystem;

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string data(const std::string& rel) {
  return read_text(std::string(GVD_TEST_DATA_DIR) + "/" + rel);
}

std::unique_ptr<httplib::Client> client(int port) {
  auto c = std::make_unique<httplib::Client>("127.0.0.1", port);
  c->set_connection_timeout(5);
  c->set_read_timeout(30);
  c->set_write_timeout(30);
  return c;
}

/// Two interpenetrating unit cubes: the octree refines along their contact down to
/// contact_depth, so the job's run time grows ~2x per level (about 0.1 s at 9, 2 s at 11, 4 s
/// at 12 on the project's 2-core machine) — a slow job on demand.
std::string slow_scene() {
  Json objects = Json::array();
  const int tris[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                           {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  for (int k = 0; k < 2; ++k) {
    Json v = Json::array(), t = Json::array();
    for (int i = 0; i < 8; ++i)
      v.push_back({0.5 * k + (i & 1), 0.5 * k + ((i >> 1) & 1), 0.5 * k + ((i >> 2) & 1)});
    for (const auto& tri : tris) t.push_back({tri[0], tri[1], tri[2]});
    objects.push_back({{"label", "cube" + std::to_string(k)}, {"vertices", v}, {"triangles", t}});
  }
  return Json{{"dimension", 3}, {"objects", objects}}.dump();
}

struct Submitted {
  int status = 0;
  std::string id;
  Json body;
  httplib::Headers headers;
};

Submitted submit(httplib::Client& c, const std::string& body, const std::string& query = "",
                 const std::string& type = "application/json") {
  auto r = c.Post(("/v1/jobs" + query).c_str(), body, type.c_str());
  Submitted s;
  if (!r) return s;
  s.status = r->status;
  s.headers = r->headers;
  s.body = Json::parse(r->body, nullptr, false);
  if (s.body.is_object() && s.body.contains("id")) s.id = s.body["id"].get<std::string>();
  return s;
}

Json status_of(httplib::Client& c, const std::string& id) {
  auto r = c.Get(("/v1/jobs/" + id).c_str());
  if (!r || r->status != 200) return Json();
  return Json::parse(r->body);
}

/// Polls until the job reaches one of `wanted` (or `seconds` pass); returns the last status.
Json wait_for(httplib::Client& c, const std::string& id, const std::set<std::string>& wanted,
              double seconds = 30) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  Json s;
  while (std::chrono::steady_clock::now() < deadline) {
    s = status_of(c, id);
    if (s.is_object() && wanted.count(s.value("status", "")) != 0) return s;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return s;
}

/// A loopback connection to the server (-1 if it cannot connect).
/// A connection to the server on loopback; with `from`, made from that source address (any
/// of 127.0.0.0/8 is this host), so that the server sees several clients.
int connect_to(int port, const char* from = nullptr) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (from != nullptr) {
    sockaddr_in source{};
    source.sin_family = AF_INET;
    inet_pton(AF_INET, from, &source.sin_addr);
    if (bind(fd, reinterpret_cast<sockaddr*>(&source), sizeof source) != 0) {
      close(fd);
      return -1;
    }
  }
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    close(fd);
    return -1;
  }
  return fd;
}

/// Sends raw bytes on a new connection (from source address `from`, if given) and returns
/// whatever the server answers (until it closes or `ms` pass).
std::string raw_exchange(int port, const std::string& request, int ms = 2000,
                         const char* from = nullptr) {
  const int fd = connect_to(port, from);
  if (fd < 0) return "";
  timeval tv{ms / 1000, (ms % 1000) * 1000};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  (void)!send(fd, request.data(), request.size(), MSG_NOSIGNAL);
  std::string out;
  char buf[4096];
  for (;;) {
    const ssize_t n = recv(fd, buf, sizeof buf, 0);
    if (n <= 0) break;
    out.append(buf, static_cast<size_t>(n));
    if (out.find("\r\n\r\n") != std::string::npos) {
      // Stop after the body announced by Content-Length.
      const size_t head_end = out.find("\r\n\r\n") + 4;
      const size_t cl = out.find("Content-Length: ");
      if (cl != std::string::npos && cl < head_end) {
        const size_t len = std::stoul(out.substr(cl + 16));
        if (out.size() >= head_end + len) break;
      }
    }
  }
  close(fd);
  return out;
}

int raw_status(const std::string& response) {
  if (response.size() < 12 || !response.starts_with("HTTP/1.1 ")) return 0;
  return std::stoi(response.substr(9, 3));
}

const Json& corpus_expected() {
  static const Json j = Json::parse(data("malformed/expected.json"));
  return j;
}

// ---------------------------------------------------------------------------------------------

TEST(Service, SubmitPollFetchEveryOutput) {
  ServerProcess server(fresh_dir("submit"));
  auto c = client(server.port());
  const Submitted s = submit(*c, data("scenes/gears2d.json"));
  ASSERT_EQ(s.status, 202) << s.body.dump();
  ASSERT_EQ(s.id.size(), 32u);
  EXPECT_EQ(std::string(httplib::detail::get_header_value(s.headers, "Location", 0, "")),
            "/v1/jobs/" + s.id);
  EXPECT_EQ(std::string(httplib::detail::get_header_value(s.headers, "X-Gvd-Cache", 0, "")),
            "miss");
  EXPECT_TRUE(s.body["status"] == "queued" || s.body["status"] == "running" ||
              s.body["status"] == "done");

  const Json done = wait_for(*c, s.id, {"done", "failed"});
  ASSERT_EQ(done.value("status", ""), "done") << done.dump();
  EXPECT_EQ(done["progress"]["fraction"], 1.0);
  EXPECT_FALSE(done["progress"]["stages"].empty());
  EXPECT_GT(done["result"]["leaves"].get<uint64_t>(), 0u);
  EXPECT_GT(done["result"]["depth"].get<int>(), 0);
  EXPECT_EQ(done["scene"]["objects"], 3);
  EXPECT_TRUE(done["finished_at"].is_string());

  auto glb = c->Get(("/v1/jobs/" + s.id + "/gvd.glb").c_str());
  ASSERT_TRUE(glb);
  ASSERT_EQ(glb->status, 200);
  EXPECT_EQ(glb->get_header_value("Content-Type"), "model/gltf-binary");
  EXPECT_EQ(glb->get_header_value("ETag"), "\"" + s.id + "\"");
  ASSERT_GT(glb->body.size(), 20u);
  EXPECT_EQ(glb->body.substr(0, 4), "glTF");
  // Written, read back and validated: a GLB that only looks right is not checked.
  const std::string glb_path = fresh_dir("submit-glb") + "/gvd.glb";
  std::ofstream(glb_path, std::ios::binary) << glb->body;
  const GltfReport report = validate_glb_file(glb_path);
  ASSERT_TRUE(report.ran) << report.output;
  EXPECT_EQ(report.errors, 0) << report.output;
  const GlbFile parsed = parse_glb(std::vector<uint8_t>(glb->body.begin(), glb->body.end()));
  std::set<std::string> names;
  for (const Json& n : parsed.json["nodes"]) names.insert(n["name"].get<std::string>());
  EXPECT_EQ(names, (std::set<std::string>{"gear_a", "gear_b", "frame"}));

  auto gltf = c->Get(("/v1/jobs/" + s.id + "/gvd.gltf").c_str());
  ASSERT_TRUE(gltf);
  ASSERT_EQ(gltf->status, 200);
  const Json gltf_doc = Json::parse(gltf->body);
  EXPECT_TRUE(gltf_doc["buffers"][0]["uri"].get<std::string>().starts_with(
      "data:application/octet-stream;base64,"));
  EXPECT_EQ(gltf_doc["nodes"].size(), parsed.json["nodes"].size());

  for (const std::string path : {"/gvd.json", "/gvd.glb?format=json"}) {
    auto j = c->Get(("/v1/jobs/" + s.id + path).c_str());
    ASSERT_TRUE(j);
    ASSERT_EQ(j->status, 200) << path;
    const Json doc = Json::parse(j->body);
    EXPECT_EQ(doc["dimension"], 2);
    EXPECT_EQ(doc["objects"].size(), 3u);
  }
  auto graph = c->Get(("/v1/jobs/" + s.id + "/graph").c_str());
  ASSERT_TRUE(graph);
  ASSERT_EQ(graph->status, 200);
  const Json g = Json::parse(graph->body);
  EXPECT_EQ(g["nodes"].size(), 3u);
  EXPECT_FALSE(g["edges"].empty());

  auto file = c->Get(("/v1/jobs/" + s.id + "/result.gvd").c_str());
  ASSERT_TRUE(file);
  ASSERT_EQ(file->status, 200);
  EXPECT_EQ(file->body.substr(0, 6), "GVDRES");

  auto list = c->Get("/v1/jobs");
  ASSERT_TRUE(list);
  EXPECT_EQ(Json::parse(list->body)["jobs"][0]["id"], s.id);
}

TEST(Service, ResubmitIsACacheHitAndETagGives304) {
  ServerProcess server(fresh_dir("cache"));
  auto c = client(server.port());
  const Submitted first = submit(*c, data("scenes/gears2d.json"));
  ASSERT_EQ(first.status, 202);
  ASSERT_EQ(wait_for(*c, first.id, {"done"}).value("status", ""), "done");
  // Same scene, reformatted and with the keys in another order: the same normalized job.
  Json scene = Json::parse(data("scenes/gears2d.json"));
  const Submitted again = submit(*c, scene.dump(2));
  EXPECT_EQ(again.status, 200);
  EXPECT_EQ(again.id, first.id);
  EXPECT_EQ(std::string(httplib::detail::get_header_value(again.headers, "X-Gvd-Cache", 0, "")),
            "hit");
  // Different parameters: a different job.
  const Submitted other = submit(*c, data("scenes/gears2d.json"), "?max_depth=12");
  EXPECT_EQ(other.status, 202);
  EXPECT_NE(other.id, first.id);

  httplib::Headers inm = {{"If-None-Match", "\"" + first.id + "\""}};
  for (const std::string out : {"/gvd.glb", "/gvd.gltf", "/gvd.json", "/graph"}) {
    auto r = c->Get(("/v1/jobs/" + first.id + out).c_str(), inm);
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 304) << out;
    EXPECT_TRUE(r->body.empty());
  }
  httplib::Headers stale = {{"If-None-Match", "\"0000\", W/\"1111\""}};
  auto r = c->Get(("/v1/jobs/" + first.id + "/gvd.glb").c_str(), stale);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);

  auto m = c->Get("/metrics");
  ASSERT_TRUE(m);
  EXPECT_NE(m->body.find("gvd_job_cache_hits_total 1"), std::string::npos) << m->body;
}

TEST(Service, MalformedCorpusGetsDocumentedProblemsAndServerKeepsServing) {
  ServerProcess server(fresh_dir("malformed"));
  auto c = client(server.port());
  // A good job submitted first must finish despite the bad ones.
  const Submitted good = submit(*c, data("scenes/gears2d.json"));
  ASSERT_EQ(good.status, 202);
  const std::map<std::string, std::pair<int, std::string>> by_code = {
      {"invalid_scene", {422, "/problems/invalid-scene"}},
      {"unsupported_format", {415, "/problems/unsupported-format"}},
      {"limit_exceeded", {422, "/problems/limit-exceeded"}},
      {"invalid_argument", {400, "/problems/invalid-argument"}}};
  int files = 0;
  for (const auto& [name, expected] : corpus_expected()["files"].items()) {
    const std::string body = data("malformed/" + name);
    // Single-object formats take their label from ?label= (the CLI uses the file stem).
    const std::string stem = fs::path(name).stem().string();
    auto r = c->Post(("/v1/jobs?label=" + stem).c_str(), body, "application/octet-stream");
    ASSERT_TRUE(r) << name;
    const auto& [status, type] = by_code.at(expected["code"].get<std::string>());
    EXPECT_EQ(r->status, status) << name << ": " << r->body;
    EXPECT_EQ(r->get_header_value("Content-Type"), "application/problem+json") << name;
    const Json doc = Json::parse(r->body, nullptr, false);
    ASSERT_TRUE(doc.is_object()) << name;
    EXPECT_EQ(doc.value("type", ""), type) << name;
    EXPECT_EQ(doc.value("status", 0), status) << name;
    EXPECT_EQ(doc.value("code", ""), expected["code"]) << name;
    EXPECT_NE(doc.value("detail", "").find(expected["contains"].get<std::string>()),
              std::string::npos)
        << name << ": " << doc.value("detail", "");
    EXPECT_FALSE(doc.value("request_id", "").empty());
    ++files;
  }
  EXPECT_GE(files, 40);
  // Where: bad geometry names the object and the element.
  auto r = c->Post("/v1/jobs", data("malformed/json_index_out_of_range.json"), "application/json");
  const Json doc = Json::parse(r->body);
  EXPECT_TRUE(doc.contains("object")) << r->body;
  EXPECT_EQ(doc["element"]["kind"], "triangle") << r->body;
  EXPECT_EQ(doc["element"]["index"], 2) << r->body;
  // A GLB's container fault: its byte offset (the version field at byte 4).
  r = c->Post("/v1/jobs", data("malformed/glb_bad_version.glb"), "model/gltf-binary");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422) << r->body;
  const Json glb = Json::parse(r->body);
  EXPECT_EQ(glb["offset"], 4) << r->body;
  EXPECT_FALSE(glb.contains("pointer")) << r->body;
  // A glTF's fault in a node's mesh: a pointer into the glTF and the object it becomes.
  r = c->Post("/v1/jobs", data("malformed/gltf_accessor_overflow.gltf"), "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422) << r->body;
  const Json gltf = Json::parse(r->body);
  EXPECT_EQ(gltf["pointer"], "/accessors/0") << r->body;
  EXPECT_EQ(gltf["object"]["index"], 0) << r->body;
  EXPECT_EQ(gltf["object"]["label"], "tet_child") << r->body;

  EXPECT_EQ(wait_for(*c, good.id, {"done", "failed"}).value("status", ""), "done");
  EXPECT_TRUE(server.running());
}

TEST(Service, BadRequestsAreRefusedBeforeTheBody) {
  ServerProcess server(fresh_dir("hardening"), {"--max-body", "100000", "--max-headers", "20",
                                                "--max-header-bytes", "4000"});
  auto c = client(server.port());
  const int port = server.port();
  // Over the body limit: answered from the headers alone (no body sent at all), and the
  // connection is closed at once (raw_exchange would otherwise wait for its 2 s timeout).
  const auto t0 = std::chrono::steady_clock::now();
  std::string resp =
      raw_exchange(port,
                   "POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                   "Content-Length: 1000000000\r\n\r\n");
  EXPECT_EQ(raw_status(resp), 413) << resp;
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 1.0);
  EXPECT_NE(resp.find("application/problem+json"), std::string::npos);
  const size_t content_type = resp.find("Content-Type: ");
  EXPECT_EQ(resp.find("Content-Type: ", content_type + 1), std::string::npos) << "twice: " << resp;
  // Expect: 100-continue gets the refusal instead of the go-ahead.
  resp = raw_exchange(port,
                      "POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                      "Expect: 100-continue\r\nContent-Length: 1000000000\r\n\r\n");
  EXPECT_EQ(raw_status(resp), 413) << resp;
  // Chunked body.
  resp = raw_exchange(port,
                      "POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                      "Transfer-Encoding: chunked\r\n\r\nffffffff\r\n");
  EXPECT_EQ(raw_status(resp), 411) << resp;
  // No Content-Length.
  resp = raw_exchange(
      port, "POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n\r\n{}");
  EXPECT_EQ(raw_status(resp), 411) << resp;
  // A bad Content-Length.
  resp = raw_exchange(port,
                      "POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                      "Content-Length: -5\r\n\r\n");
  EXPECT_EQ(raw_status(resp), 400) << resp;
  // Compressed body.
  resp = raw_exchange(port,
                      "POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                      "Content-Encoding: gzip\r\nContent-Length: 4\r\n\r\nabcd");
  EXPECT_EQ(raw_status(resp), 415) << resp;
  // Too many headers / too large headers.
  std::string many = "GET /healthz HTTP/1.1\r\nHost: x\r\n";
  for (int i = 0; i < 30; ++i) many += "X-H" + std::to_string(i) + ": v\r\n";
  EXPECT_EQ(raw_status(raw_exchange(port, many + "\r\n")), 431);
  const std::string big = "GET /healthz HTTP/1.1\r\nHost: x\r\nX-Big: " + std::string(3000, 'a') +
                          "\r\nX-Big2: " + std::string(3000, 'b') + "\r\n\r\n";
  EXPECT_EQ(raw_status(raw_exchange(port, big)), 431);
  // Lines cpp-httplib cannot read (D8): each answer names its limit in a problem document.
  const auto problem_of = [](const std::string& response) {
    const size_t body = response.find("\r\n\r\n");
    return body == std::string::npos ? Json()
                                     : Json::parse(response.substr(body + 4), nullptr, false);
  };
  resp = raw_exchange(port, "GET /healthz HTTP/1.1\r\nHost: x\r\nX-Long: " +
                                std::string(100'000, 'a') + "\r\n\r\n");
  EXPECT_EQ(raw_status(resp), 431) << resp.substr(0, 200);
  EXPECT_EQ(problem_of(resp).value("type", ""), "/problems/headers-too-large");
  EXPECT_NE(problem_of(resp).value("detail", "").find("8192"), std::string::npos);
  resp = raw_exchange(
      port, "GET /healthz HTTP/1.1\r\nHost: x\r\nX-Long: " + std::string(9000, 'a') + "\r\n\r\n");
  EXPECT_EQ(raw_status(resp), 431) << resp.substr(0, 200);
  resp =
      raw_exchange(port, "GET /v1/jobs/" + std::string(9000, 'a') + " HTTP/1.1\r\nHost: x\r\n\r\n");
  EXPECT_EQ(raw_status(resp), 414) << resp.substr(0, 200);
  EXPECT_EQ(problem_of(resp).value("type", ""), "/problems/uri-too-long");
  // A multipart body whose boundary is not the one its Content-Type names.
  const std::string parts =
      "--other\r\nContent-Disposition: form-data; name=\"a\"; "
      "filename=\"a.obj\"\r\n\r\nv 0 0 0\r\n--other--\r\n";
  resp = raw_exchange(port,
                      "POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: multipart/form-data; "
                      "boundary=xyz\r\nContent-Length: " +
                          std::to_string(parts.size()) + "\r\n\r\n" + parts);
  EXPECT_EQ(raw_status(resp), 400) << resp;
  EXPECT_NE(problem_of(resp).value("detail", "").find("multipart"), std::string::npos) << resp;
  // Wrong content type for a scene; a form body.
  auto r = c->Post("/v1/jobs", "a=b", "application/x-www-form-urlencoded");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 415);
  EXPECT_EQ(Json::parse(r->body)["type"], "/problems/unsupported-media-type");
  // A body just over the limit, sent in full.
  r = c->Post("/v1/jobs", std::string(100001, ' '), "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 413);
  // Unknown job, unknown route, wrong method, bad parameters.
  r = c->Get("/v1/jobs/0123456789abcdef0123456789abcdef");
  EXPECT_EQ(r->status, 404);
  EXPECT_EQ(Json::parse(r->body)["type"], "/problems/not-found");
  r = c->Get("/v1/jobs/0123456789abcdef0123456789abcdef/gvd.glb");
  EXPECT_EQ(r->status, 404);
  r = c->Get("/nope");
  EXPECT_EQ(r->status, 404);
  EXPECT_EQ(Json::parse(r->body)["type"], "/problems/route-not-found");
  r = c->Put("/v1/jobs", "x", "application/json");
  EXPECT_EQ(r->status, 405);
  EXPECT_EQ(r->get_header_value("Allow"), "POST, GET");
  r = c->Post("/v1/jobs?max_depth=banana", data("scenes/gears2d.json"), "application/json");
  EXPECT_EQ(r->status, 400);
  r = c->Post("/v1/jobs?colour=red", data("scenes/gears2d.json"), "application/json");
  EXPECT_EQ(r->status, 400);
  r = c->Post("/v1/jobs?domain=0,0,1,1", data("scenes/gears2d.json"), "application/json");
  EXPECT_EQ(r->status, 400) << r->body;  // the box does not contain the scene
  // Still serving.
  r = c->Get("/healthz");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
}

TEST(Service, ProblemTypesAreDocumented) {
  ServerProcess server(fresh_dir("problems"));
  auto c = client(server.port());
  auto r = c->Get("/problems/invalid-scene");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200);
  EXPECT_EQ(Json::parse(r->body)["status"], 422);
}

TEST(Service, QueueFullAnswers503WithRetryAfter) {
  ServerProcess server(fresh_dir("queue"),
                       {"--workers", "1", "--queue", "1", "--retry-after", "7"});
  auto c = client(server.port());
  const std::string scene = slow_scene();
  const Submitted running = submit(*c, scene, "?contact_depth=12");
  ASSERT_EQ(running.status, 202);
  ASSERT_EQ(wait_for(*c, running.id, {"running"}).value("status", ""), "running");
  const Submitted queued = submit(*c, scene, "?contact_depth=11");
  ASSERT_EQ(queued.status, 202);
  EXPECT_EQ(queued.body["status"], "queued");
  EXPECT_EQ(queued.body["queue_position"], 1);
  auto r = c->Post("/v1/jobs?contact_depth=10", scene, "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 503);
  EXPECT_EQ(r->get_header_value("Retry-After"), "7");
  EXPECT_EQ(Json::parse(r->body)["type"], "/problems/queue-full");
  // The same job again is not a new one: no 503.
  EXPECT_EQ(submit(*c, scene, "?contact_depth=11").status, 202);
  auto m = c->Get("/metrics");
  EXPECT_NE(m->body.find("gvd_queue_depth 1"), std::string::npos);
  EXPECT_NE(m->body.find("gvd_jobs_rejected_total 1"), std::string::npos);
  // Clean up quickly.
  c->Delete(("/v1/jobs/" + queued.id).c_str());
  c->Delete(("/v1/jobs/" + running.id).c_str());
  EXPECT_EQ(wait_for(*c, running.id, {"cancelled"}, 10).value("status", ""), "cancelled");
}

TEST(Service, DeleteCancelsQueuedAndRunningJobsAndForgetsFinishedOnes) {
  ServerProcess server(fresh_dir("cancel"), {"--workers", "1"});
  auto c = client(server.port());
  const std::string scene = slow_scene();
  const Submitted running = submit(*c, scene, "?contact_depth=12");
  ASSERT_EQ(wait_for(*c, running.id, {"running"}).value("status", ""), "running");
  const Submitted queued = submit(*c, scene, "?contact_depth=11");
  auto r = c->Delete(("/v1/jobs/" + queued.id).c_str());
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(Json::parse(r->body)["status"], "cancelled");
  const auto t0 = std::chrono::steady_clock::now();
  r = c->Delete(("/v1/jobs/" + running.id).c_str());
  EXPECT_EQ(r->status, 202);
  const Json cancelled = wait_for(*c, running.id, {"cancelled", "done", "failed"}, 10);
  EXPECT_EQ(cancelled.value("status", ""), "cancelled");
  EXPECT_EQ(cancelled["error"]["type"], "/problems/cancelled");
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 3.0);
  r = c->Get(("/v1/jobs/" + running.id + "/gvd.glb").c_str());
  EXPECT_EQ(r->status, 409);
  // A cancelled job submitted again is computed again.
  const Submitted again = submit(*c, scene, "?contact_depth=8");
  ASSERT_EQ(wait_for(*c, again.id, {"done"}).value("status", ""), "done");
  r = c->Delete(("/v1/jobs/" + again.id).c_str());
  EXPECT_EQ(r->status, 204);
  EXPECT_EQ(c->Get(("/v1/jobs/" + again.id).c_str())->status, 404);
  EXPECT_EQ(c->Delete(("/v1/jobs/" + again.id).c_str())->status, 404);
}

/// Resident memory of process `pid`, MB (from /proc; 0 if unknown).
double resident_mb(pid_t pid, const std::string& field = "VmRSS:") {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(status, line);) {
    if (line.starts_with(field)) return std::stod(line.substr(field.size())) / 1024.0;
  }
  return 0;
}

// Reliability D4: the scene limits were checked after the whole body was parsed into a JSON
// document: the 66 MB scene of 11M vertices took ~10 s and ~0.7-1.4 GB before its 422, and so
// did the same body with a "params" key (whose parse read the whole body first). Both are now
// refused while the text is read: 422 limit-exceeded naming the vertex limit (3 per simplex of
// --max-simplices), in well under the 10 s and without a peak above the body's own memory.
TEST(Service, OversizedSceneIsRefusedWhileItIsParsed) {
  ServerProcess server(fresh_dir("big-body-early"));
  auto c = client(server.port());
  const double start_peak = resident_mb(server.pid(), "VmHWM:");
  std::string vertices;
  vertices.reserve(66'000'000);
  for (int i = 0; i < 11'000'000; ++i) vertices += i == 0 ? "[0,0]" : ",[0,0]";
  for (const std::string head : {"", R"("params":{"max_depth":9},)"}) {
    const std::string big = "{" + head + R"("dimension":2,"objects":[{"label":"a","vertices":[)" +
                            vertices + "],\"segments\":[[0,1]]}]}";
    const auto t0 = std::chrono::steady_clock::now();
    auto r = c->Post("/v1/jobs", big, "application/json");
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 422) << r->body.substr(0, 300);
    const Json p = Json::parse(r->body, nullptr, false);
    EXPECT_EQ(p.value("type", ""), "/problems/limit-exceeded") << r->body.substr(0, 300);
    EXPECT_NE(p.value("detail", "")
                  .find("more than the limit of 6000000 vertices (3 per simplex "
                        "of the limit of 2000000 simplices)"),
              std::string::npos)
        << r->body.substr(0, 300);
    std::printf("refused in %.2f s\n", seconds);
    EXPECT_LT(seconds, 5.0) << head;
  }
  // The body (66 MB, read into a string that grows by doubling) and little else.
  const double peak = resident_mb(server.pid(), "VmHWM:");
  std::printf("server peak resident: %.0f MB at start, %.0f MB after both bodies\n", start_peak,
              peak);
  EXPECT_LT(peak - start_peak, 300.0);
}

// D4 (in part): a rejected 66 MB scene (11M vertices) left ~1.4 GB resident, and with
// --max-memory-mb 512 every later job then failed the memory watchdog. The server now returns
// the heap after large bodies; a job submitted after it runs.
TEST(Service, MemoryOfALargeRejectedBodyIsGivenBack) {
  ServerProcess server(fresh_dir("big-body"), {"--max-memory-mb", "512"});
  auto c = client(server.port());
  std::string big = "{\"dimension\":2,\"objects\":[{\"label\":\"a\",\"vertices\":[";
  big.reserve(66'000'100);
  for (int i = 0; i < 11'000'000; ++i) big += i == 0 ? "[0,0]" : ",[0,0]";
  big += "],\"segments\":[[0,1]]}]}";
  auto r = c->Post("/v1/jobs", big, "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422) << r->body.substr(0, 300);
  big.clear();
  big.shrink_to_fit();
  // The heap is trimmed once the request is over, just after its answer is sent.
  double after = resident_mb(server.pid());
  for (int i = 0; i < 50 && after >= 300.0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    after = resident_mb(server.pid());
  }
  std::printf("server resident after the rejected body: %.0f MB\n", after);
  EXPECT_LT(after, 300.0);
  const Submitted s = submit(*c, data("scenes/balls_on_plate.json"));
  EXPECT_EQ(wait_for(*c, s.id, {"done", "failed"}).value("status", ""), "done");
}

// Each job is charged for the memory it allocates itself (the server's operator new charges
// the job's worker and the threads working for it), not for the process's resident size:
// a scene whose parsing and BVH need more than --job-memory-mb is stopped near that limit,
// saying so, and a small job on the same server runs and reports what it held.
TEST(Service, AJobIsChargedForItsOwnMemory) {
  // Two parallel plates of 300 x 300 quads each (360,000 triangles, ~15 MB of JSON).
  constexpr int n = 300;
  std::string scene = "{\"dimension\":3,\"objects\":[";
  for (int k = 0; k < 2; ++k) {
    scene +=
        std::string(k ? "," : "") + "{\"label\":\"plate_" + std::to_string(k) + "\",\"vertices\":[";
    for (int j = 0; j <= n; ++j) {
      for (int i = 0; i <= n; ++i) {
        scene += (i || j ? ",[" : "[") + std::to_string(static_cast<double>(i) / n) + "," +
                 std::to_string(static_cast<double>(j) / n) + (k ? ",0.05]" : ",0]");
      }
    }
    scene += "],\"triangles\":[";
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        const int a = j * (n + 1) + i, b = a + 1, c = a + n + 2, d = a + n + 1;
        scene += (i || j ? ",[" : "[") + std::to_string(a) + "," + std::to_string(b) + "," +
                 std::to_string(c) + "],[" + std::to_string(a) + "," + std::to_string(c) + "," +
                 std::to_string(d) + "]";
      }
    }
    scene += "]}";
  }
  scene += "]}";
  constexpr double kLimitMb = 48;
  ServerProcess server(fresh_dir("job-memory"), {"--job-memory-mb", "48"});
  auto c = client(server.port());
  const Submitted big = submit(*c, scene);
  const Json stopped = wait_for(*c, big.id, {"failed", "done"}, 60);
  ASSERT_EQ(stopped.value("status", ""), "failed") << stopped.dump().substr(0, 600);
  EXPECT_EQ(stopped["error"]["type"], "/problems/limit-exceeded");
  const std::string why = stopped["error"]["detail"];
  EXPECT_NE(why.find("own memory"), std::string::npos) << why;
  EXPECT_NE(why.find("48 MB per job (--job-memory-mb)"), std::string::npos) << why;
  // Stopped near the limit: past it by no more than what one step of a stage allocates
  // between two reads of the cancel flag (measured: 6-7 MB while a scene is read).
  const double held = stopped.value("memory_peak_bytes", 0.0) / (1 << 20);
  std::printf("the large scene's job held %.1f MB of its own when it was stopped\n", held);
  EXPECT_GT(held, kLimitMb);
  EXPECT_LT(held, kLimitMb * 1.25);
  const Submitted s = submit(*c, data("scenes/balls_on_plate.json"));
  const Json done = wait_for(*c, s.id, {"done", "failed"});
  ASSERT_EQ(done.value("status", ""), "done") << done.dump().substr(0, 600);
  const double small = done.value("memory_peak_bytes", 0.0) / (1 << 20);
  std::printf("balls_on_plate's job held %.1f MB of its own\n", small);
  EXPECT_GT(small, 0.1);
  EXPECT_LT(small, kLimitMb);
}

TEST(Service, JobLimitsAreCheckedWhileItRuns) {
  ServerProcess server(fresh_dir("limits"), {"--job-seconds", "0.3"});
  auto c = client(server.port());
  const std::string scene = slow_scene();
  const Submitted slow = submit(*c, scene, "?contact_depth=12");
  const Json timed_out = wait_for(*c, slow.id, {"failed", "done"}, 10);
  ASSERT_EQ(timed_out.value("status", ""), "failed") << timed_out.dump();
  EXPECT_EQ(timed_out["error"]["type"], "/problems/limit-exceeded");
  EXPECT_NE(timed_out["error"]["detail"].get<std::string>().find("longer than"), std::string::npos);
  auto r = c->Get(("/v1/jobs/" + slow.id + "/graph").c_str());
  EXPECT_EQ(r->status, 409);
  EXPECT_EQ(Json::parse(r->body)["type"], "/problems/job-failed");
  // Leaves: the engine's limit, set from --max-leaves.
  ServerProcess small(fresh_dir("limits2"), {"--max-objects", "2", "--max-leaves", "50000"});
  auto c2 = client(small.port());
  const Submitted big = submit(*c2, scene, "?contact_depth=10");
  const Json leaves = wait_for(*c2, big.id, {"failed", "done"}, 10);
  ASSERT_EQ(leaves.value("status", ""), "failed") << leaves.dump();
  EXPECT_EQ(leaves["error"]["code"], "limit_exceeded");
  EXPECT_NE(leaves["error"]["detail"].get<std::string>().find("leaves"), std::string::npos)
      << leaves.dump();
  // Objects: refused at submission.
  r = c2->Post("/v1/jobs", data("scenes/gears2d.json"), "application/json");
  EXPECT_EQ(r->status, 422);
  EXPECT_EQ(Json::parse(r->body)["code"], "limit_exceeded");
  // Memory: the process's resident memory (and, through it, the leaves per job) is bounded.
  ServerProcess mem(fresh_dir("limits3"), {"--max-memory-mb", "40"});
  auto c3 = client(mem.port());
  const Submitted hungry = submit(*c3, scene, "?contact_depth=12");
  const Json stopped = wait_for(*c3, hungry.id, {"failed", "done"}, 20);
  ASSERT_EQ(stopped.value("status", ""), "failed") << stopped.dump();
  EXPECT_EQ(stopped["error"]["type"], "/problems/limit-exceeded");
  const std::string why = stopped["error"]["detail"];
  EXPECT_TRUE(why.find("memory") != std::string::npos || why.find("leaves") != std::string::npos)
      << why;
  EXPECT_EQ(c3->Get("/healthz")->status, 200);
}

TEST(Service, EventStreamReportsProgressUntilDone) {
  ServerProcess server(fresh_dir("sse"));
  auto c = client(server.port());
  const Submitted s = submit(*c, slow_scene(), "?contact_depth=9");
  std::string stream;
  auto r = c->Get(("/v1/jobs/" + s.id + "/events").c_str(), [&](const char* d, size_t n) {
    stream.append(d, n);
    return true;
  });
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(r->get_header_value("Content-Type"), "text/event-stream");
  EXPECT_NE(stream.find("event: done\ndata: {"), std::string::npos) << stream.substr(0, 2000);
  // Every event is one JSON status document.
  std::istringstream lines(stream);
  std::string line;
  int events = 0;
  while (std::getline(lines, line)) {
    if (!line.starts_with("data: ")) continue;
    const Json doc = Json::parse(line.substr(6));
    EXPECT_EQ(doc["id"], s.id);
    ++events;
  }
  EXPECT_GE(events, 1);
  // A finished job: one final event, then the stream ends.
  stream.clear();
  r = c->Get(("/v1/jobs/" + s.id + "/events").c_str(), [&](const char* d, size_t n) {
    stream.append(d, n);
    return true;
  });
  EXPECT_TRUE(stream.starts_with("event: done\n")) << stream;
}

TEST(Service, RestartAfterKill9KeepsResultsAndResumesTheInterruptedJob) {
  const std::string store = fresh_dir("restart");
  std::string finished_id, finished_glb, interrupted_id;
  {
    ServerProcess server(store, {"--workers", "1"});
    auto c = client(server.port());
    const Submitted done = submit(*c, data("scenes/gears2d.json"));
    ASSERT_EQ(wait_for(*c, done.id, {"done"}).value("status", ""), "done");
    finished_id = done.id;
    finished_glb = c->Get(("/v1/jobs/" + done.id + "/gvd.glb").c_str())->body;
    const Submitted slow = submit(*c, slow_scene(), "?contact_depth=10");
    interrupted_id = slow.id;
    ASSERT_EQ(wait_for(*c, slow.id, {"running"}).value("status", ""), "running");
    const Submitted queued = submit(*c, data("scenes/gears2d.json"), "?max_depth=10");
    ASSERT_EQ(queued.body["status"], "queued");
    server.signal(SIGKILL);
    EXPECT_EQ(server.wait(), -SIGKILL);
  }
  ServerProcess server(store, {"--workers", "1"});
  auto c = client(server.port());
  // The finished result is served as it was.
  auto glb = c->Get(("/v1/jobs/" + finished_id + "/gvd.glb").c_str());
  ASSERT_TRUE(glb);
  ASSERT_EQ(glb->status, 200);
  EXPECT_EQ(glb->body, finished_glb);
  EXPECT_EQ(status_of(*c, finished_id)["status"], "done");
  // The interrupted job runs again and completes.
  const Json resumed = wait_for(*c, interrupted_id, {"done", "failed"}, 30);
  EXPECT_EQ(resumed.value("status", ""), "done") << resumed.dump();
  EXPECT_EQ(resumed.value("recovered", false), true);
  auto jobs = Json::parse(c->Get("/v1/jobs")->body)["jobs"];
  int done = 0;
  for (const Json& j : jobs) {
    const std::string id = j["id"];
    if (wait_for(*c, id, {"done"}, 30).value("status", "") == "done") ++done;
  }
  EXPECT_EQ(done, 3);
  auto m = c->Get("/metrics");
  EXPECT_NE(m->body.find("gvd_jobs_recovered_total 2"), std::string::npos);
}

TEST(Service, RestartRebuildsAMissingStatusDocumentAndDropsTemporaryFiles) {
  const std::string store = fresh_dir("restart-files");
  std::string id;
  {
    ServerProcess server(store);
    auto c = client(server.port());
    id = submit(*c, data("scenes/gears2d.json")).id;
    ASSERT_EQ(wait_for(*c, id, {"done"}).value("status", ""), "done");
  }
  // As if killed between writing the result and its status document (the stored request,
  // removed after that document, is still there), and during a write.
  const Json done = Json::parse(read_text(store + "/results/" + id + ".json"));
  std::ofstream(store + "/requests/" + id + ".json")
      << Json{{"id", id}, {"params", done["params"]}};
  fs::remove(store + "/results/" + id + ".json");
  std::ofstream(store + "/results/" + id + ".gvd.tmp.123.0") << "partial";
  std::ofstream(store + "/requests/" + std::string(32, 'a') + ".scene.json") << "{}";  // orphan
  ServerProcess server(store);
  auto c = client(server.port());
  const Json s = status_of(*c, id);
  EXPECT_EQ(s.value("status", ""), "done");
  EXPECT_GT(s["result"]["leaves"].get<uint64_t>(), 0u);
  EXPECT_EQ(c->Get(("/v1/jobs/" + id + "/graph").c_str())->status, 200);
  EXPECT_TRUE(fs::exists(store + "/results/" + id + ".json"));
  EXPECT_FALSE(fs::exists(store + "/results/" + id + ".gvd.tmp.123.0"));
  EXPECT_FALSE(fs::exists(store + "/requests/" + std::string(32, 'a') + ".scene.json"));
  EXPECT_FALSE(fs::exists(store + "/requests/" + id + ".json"));
}

// The log lines of a server run with a log file, as JSON objects (other lines skipped).
std::vector<Json> log_lines(const std::string& file) {
  std::vector<Json> lines;
  std::istringstream in(read_text(file));
  for (std::string line; std::getline(in, line);) {
    const Json j = Json::parse(line, nullptr, false);
    if (j.is_object()) lines.push_back(j);
  }
  return lines;
}

bool logged(const std::vector<Json>& lines, const std::string& level, const std::string& event,
            const std::string& detail_part) {
  for (const Json& j : lines)
    if (j.value("level", "") == level && j.value("event", "") == event &&
        j.value("detail", "").find(detail_part) != std::string::npos)
      return true;
  return false;
}

// Reliability D7: a finished job whose stored result was truncated is a storage error (500
// io-error, logged at level error), not the client's 400; the server goes on serving.
TEST(Service, CorruptStoredResultIsAStorageErrorAndLogged) {
  const std::string store = fresh_dir("corrupt-result");
  std::string id, good;
  {
    ServerProcess server(store);
    auto c = client(server.port());
    id = submit(*c, data("scenes/gears2d.json")).id;
    good = submit(*c, data("scenes/gears2d.json"), "?max_depth=12").id;
    ASSERT_EQ(wait_for(*c, id, {"done"}).value("status", ""), "done");
    ASSERT_EQ(wait_for(*c, good, {"done"}).value("status", ""), "done");
  }
  const std::string gvd = store + "/results/" + id + ".gvd";
  fs::resize_file(gvd, fs::file_size(gvd) / 2);
  const std::string log = store + "/server.log";
  ServerProcess server(store, {}, log);
  auto c = client(server.port());
  EXPECT_EQ(status_of(*c, id).value("status", ""), "done");
  for (const std::string out : {"/graph", "/gvd.glb", "/result.gvd"}) {
    auto r = c->Get(("/v1/jobs/" + id + out).c_str());
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 500) << out;
    const Json p = Json::parse(r->body);
    EXPECT_EQ(p.value("type", ""), "/problems/io-error") << out;
    const std::string detail = p.value("detail", "");
    EXPECT_NE(detail.find("job " + id), std::string::npos) << detail;
    EXPECT_NE(detail.find("checksum"), std::string::npos) << detail;
    EXPECT_EQ(detail.find(store), std::string::npos) << "the store's path leaks: " << detail;
  }
  auto r =
      c->Post(("/v1/jobs/" + id + "/nearest").c_str(), R"({"points":[[0,0]]})", "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 500);
  EXPECT_EQ(c->Get(("/v1/jobs/" + good + "/graph").c_str())->status, 200);
  EXPECT_EQ(c->Get("/healthz")->status, 200);
  server.signal(SIGTERM);
  EXPECT_EQ(server.wait(), 0);
  const std::vector<Json> lines = log_lines(log);
  bool error_line = false;
  for (const Json& j : lines)
    error_line |= j.value("level", "") == "error" &&
                  j.value("error", "").find("stored result of job " + id) != std::string::npos;
  EXPECT_TRUE(error_line) << read_text(log);
}

// Reliability D7: a job's id is the hash of its scene and parameters, but a result file copied
// (or restored) under another job's id was served as that job. Loaded from the store, a file's
// scene with the job's parameters must make the job's id: one that does not is a storage error
// (500 io-error naming the job, not the store's path, and an error log line). (A result file
// holds no parameters: a copy between two jobs of the same scene is not detected.) A result without
// its status document is listed again only when its stored request gives its parameters and they
// make its id; otherwise it is dropped with a store_entry_dropped line.
TEST(Service, StoredResultUnderAnotherJobsIdIsNotServed) {
  const std::string store = fresh_dir("result-other-id");
  std::string a, b;
  {
    ServerProcess server(store);
    auto c = client(server.port());
    a = submit(*c, data("scenes/gears2d.json")).id;
    // Another scene (one label differs) with other parameters.
    Json other = Json::parse(data("scenes/gears2d.json"));
    other["objects"][0]["label"] = other["objects"][0]["label"].get<std::string>() + "_b";
    b = submit(*c, other.dump(), "?max_depth=12").id;
    ASSERT_EQ(wait_for(*c, a, {"done"}).value("status", ""), "done");
    ASSERT_EQ(wait_for(*c, b, {"done"}).value("status", ""), "done");
  }
  const std::string results = store + "/results/";
  fs::copy_file(results + a + ".gvd", results + b + ".gvd", fs::copy_options::overwrite_existing);
  // A result under a new id, without a status document: with a stored request whose
  // parameters make another id, and without any request.
  const std::string with_request(32, 'c'), bare(32, 'd');
  fs::copy_file(results + a + ".gvd", results + with_request + ".gvd");
  fs::copy_file(results + a + ".gvd", results + bare + ".gvd");
  const Json params = Json::parse(read_text(results + a + ".json"))["params"];
  std::ofstream(store + "/requests/" + with_request + ".json")
      << Json{{"id", with_request}, {"params", params}};
  const std::string log = store + "/server.log";
  ServerProcess server(store, {}, log);
  auto c = client(server.port());
  EXPECT_EQ(status_of(*c, b).value("status", ""), "done");
  for (const std::string out : {"/graph", "/gvd.glb", "/result.gvd", "/gvd.json"}) {
    auto r = c->Get(("/v1/jobs/" + b + out).c_str());
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 500) << out;
    const Json p = Json::parse(r->body, nullptr, false);
    EXPECT_EQ(p.value("type", ""), "/problems/io-error") << out;
    const std::string detail = p.value("detail", "");
    EXPECT_NE(detail.find("stored result of job " + b + " belongs to another job"),
              std::string::npos)
        << detail;
    EXPECT_NE(detail.find("with this job's parameters makes job "), std::string::npos) << detail;
    EXPECT_EQ(detail.find(store), std::string::npos) << "the store's path leaks: " << detail;
  }
  auto r =
      c->Post(("/v1/jobs/" + b + "/nearest").c_str(), R"({"points":[[0,0]]})", "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 500);
  // The job the file does belong to is served as before.
  EXPECT_EQ(c->Get(("/v1/jobs/" + a + "/graph").c_str())->status, 200);
  // Not listed: neither copy without a status document.
  for (const std::string& id : {with_request, bare}) {
    EXPECT_EQ(c->Get(("/v1/jobs/" + id).c_str())->status, 404) << id;
    EXPECT_EQ(c->Get(("/v1/jobs/" + id + "/graph").c_str())->status, 404) << id;
  }
  server.signal(SIGTERM);
  EXPECT_EQ(server.wait(), 0);
  const std::vector<Json> lines = log_lines(log);
  bool error_line = false;
  for (const Json& j : lines)
    error_line |= j.value("level", "") == "error" &&
                  j.value("error", "").find("stored result of job " + b) != std::string::npos;
  EXPECT_TRUE(error_line) << read_text(log);
  EXPECT_TRUE(logged(lines, "warn", "store_entry_dropped", "results/" + with_request + ".gvd"))
      << read_text(log);
  EXPECT_TRUE(logged(lines, "warn", "store_entry_dropped", "belongs to another job (" + a + ")"))
      << read_text(log);
  EXPECT_TRUE(logged(lines, "warn", "store_entry_dropped", "results/" + bare + ".gvd"))
      << read_text(log);
  EXPECT_TRUE(logged(lines, "warn", "store_entry_dropped", "no stored request holds its"))
      << read_text(log);
}

// Reliability D12: what the restart drops from the store, it says in the log, with the reason.
TEST(Service, RestartLogsEveryStoreEntryItDrops) {
  const std::string store = fresh_dir("restart-drops");
  std::string id;
  {
    ServerProcess server(store);
    auto c = client(server.port());
    id = submit(*c, data("scenes/gears2d.json")).id;
    ASSERT_EQ(wait_for(*c, id, {"done"}).value("status", ""), "done");
  }
  const std::string lost(32, 'b'), unreadable(32, 'c'), bare(32, 'd'), failed(32, 'e');
  // A status document whose result is gone; a pending request without its scene; a pending
  // request that is not JSON; a failed job's document that is not JSON.
  fs::copy_file(store + "/results/" + id + ".json", store + "/results/" + lost + ".json");
  std::ofstream(store + "/requests/" + bare + ".json") << R"({"params":{}})";
  std::ofstream(store + "/requests/" + unreadable + ".json") << "{not json";
  std::ofstream(store + "/requests/" + unreadable + ".scene.json") << "{}";
  fs::create_directories(store + "/failed");
  // Not JSON, and quoting it in the log line must not break the line: invalid UTF-8.
  std::ofstream(store + "/failed/" + failed + ".json") << "[\"\xff";
  const std::string log = store + "/server.log";
  ServerProcess server(store, {}, log);
  auto c = client(server.port());
  EXPECT_EQ(status_of(*c, id).value("status", ""), "done");
  EXPECT_EQ(c->Get(("/v1/jobs/" + lost).c_str())->status, 404);
  server.signal(SIGTERM);
  EXPECT_EQ(server.wait(), 0);
  const std::vector<Json> lines = log_lines(log);
  EXPECT_TRUE(logged(lines, "warn", "store_entry_dropped", "results/" + lost + ".json"))
      << read_text(log);
  EXPECT_TRUE(logged(lines, "warn", "store_entry_dropped", bare + ".scene.json, is missing"))
      << read_text(log);
  EXPECT_TRUE(logged(lines, "warn", "store_entry_dropped", "requests/" + unreadable + ".json"))
      << read_text(log);
  EXPECT_TRUE(logged(lines, "info", "store_entry_dropped", unreadable + ".scene.json"))
      << read_text(log);
  EXPECT_TRUE(logged(lines, "warn", "store_entry_dropped", "failed/" + failed + ".json"))
      << read_text(log);
  EXPECT_FALSE(fs::exists(store + "/requests/" + unreadable + ".scene.json"));
}

// Reliability D9: the saved result holds the run's stage times, so a job computed again is
// other bytes; its strong ETag must change with them (the GLB and graph stay the same bytes
// and keep the id).
// D11: a store that cannot be written is a 500 io-error naming the file in the store, not
// the directory where the server keeps it; the error log line has the full path.
TEST(Service, StorageErrorsDoNotShowTheStorePath) {
  const std::string store = fs::absolute(fresh_dir("store-path")).string();
  const std::string log = store + ".log";
  ServerProcess server(store, {}, log);
  fs::remove_all(store + "/requests");
  std::ofstream(store + "/requests") << "not a directory";
  auto c = client(server.port());
  auto r = c->Post("/v1/jobs", data("scenes/gears2d.json"), "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 500);
  const Json p = Json::parse(r->body);
  EXPECT_EQ(p.value("type", ""), "/problems/io-error");
  const std::string detail = p.value("detail", "");
  EXPECT_NE(detail.find("<store>/requests/"), std::string::npos) << detail;
  EXPECT_EQ(detail.find(store), std::string::npos) << detail;
  server.signal(SIGTERM);
  server.wait();
  EXPECT_NE(read_text(log).find(store + "/requests/"), std::string::npos);
}

TEST(Service, ResultFileETagFollowsItsBytes) {
  ServerProcess server(fresh_dir("result-etag"));
  auto c = client(server.port());
  const std::string id = submit(*c, data("scenes/gears2d.json")).id;
  ASSERT_EQ(wait_for(*c, id, {"done"}).value("status", ""), "done");
  auto first = c->Get(("/v1/jobs/" + id + "/result.gvd").c_str());
  ASSERT_TRUE(first);
  ASSERT_EQ(first->status, 200);
  const std::string tag = first->get_header_value("ETag");
  EXPECT_EQ(tag.rfind("\"" + id + "-", 0), 0u) << tag;
  auto same = c->Get(("/v1/jobs/" + id + "/result.gvd").c_str(), {{"If-None-Match", tag}});
  ASSERT_TRUE(same);
  EXPECT_EQ(same->status, 304);
  EXPECT_EQ(
      c->Get(("/v1/jobs/" + id + "/result.gvd").c_str(), {{"If-None-Match", "\"" + id + "\""}})
          ->status,
      200)
      << "the bare id must not validate the file";
  const std::string glb = c->Get(("/v1/jobs/" + id + "/gvd.glb").c_str())->body;
  ASSERT_EQ(c->Delete(("/v1/jobs/" + id).c_str())->status, 204);
  ASSERT_EQ(submit(*c, data("scenes/gears2d.json")).id, id);
  ASSERT_EQ(wait_for(*c, id, {"done"}).value("status", ""), "done");
  auto again = c->Get(("/v1/jobs/" + id + "/result.gvd").c_str());
  ASSERT_TRUE(again);
  ASSERT_EQ(again->status, 200);
  const bool same_bytes = again->body == first->body;
  EXPECT_EQ(again->get_header_value("ETag") == tag, same_bytes);
  auto revalidated = c->Get(("/v1/jobs/" + id + "/result.gvd").c_str(), {{"If-None-Match", tag}});
  ASSERT_TRUE(revalidated);
  EXPECT_EQ(revalidated->status, same_bytes ? 304 : 200) << "other bytes under the old tag";
  EXPECT_EQ(c->Get(("/v1/jobs/" + id + "/gvd.glb").c_str())->body, glb);
}

TEST(Service, SigtermDrainsThenExits) {
  const std::string store = fresh_dir("drain");
  ServerProcess server(store, {"--grace-seconds", "0.5", "--workers", "1"});
  auto c = client(server.port());
  const Submitted slow = submit(*c, slow_scene(), "?contact_depth=12");
  ASSERT_EQ(wait_for(*c, slow.id, {"running"}).value("status", ""), "running");
  server.signal(SIGTERM);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  auto ready = c->Get("/readyz");
  ASSERT_TRUE(ready);
  EXPECT_EQ(ready->status, 503);
  EXPECT_EQ(Json::parse(ready->body)["status"], "draining");
  auto r = c->Post("/v1/jobs", data("scenes/gears2d.json"), "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 503);
  EXPECT_FALSE(r->get_header_value("Retry-After").empty());
  EXPECT_EQ(server.wait(), 0);
  // The running job was persisted and is still pending for the next start.
  EXPECT_TRUE(fs::exists(store + "/requests/" + slow.id + ".json"));
}

TEST(Service, MultipartUploadOnePartPerObject) {
  ServerProcess server(fresh_dir("multipart"));
  auto c = client(server.port());
  // Two tetrahedra 3 units apart, one as OFF and one as PLY; the part names are the labels.
  const std::string off =
      "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
  const std::string ply =
      "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
      "property float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n"
      "3 0 0\n4 0 0\n3 1 0\n3 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
  httplib::MultipartFormDataItems items = {
      {"left tet", off, "left.off", "application/octet-stream"},
      {"right_tet", ply, "right.ply", "application/octet-stream"},
      {"params", R"({"max_depth": 8})", "", "application/json"},
  };
  auto r = c->Post("/v1/jobs", items);
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 202) << r->body;
  const Json job = Json::parse(r->body);
  EXPECT_EQ(job["params"]["max_depth"], 8);
  EXPECT_EQ(job["scene"]["objects"], 2);
  const std::string id = job["id"];
  const Json done = wait_for(*c, id, {"done", "failed"});
  ASSERT_EQ(done.value("status", ""), "done") << done.dump();
  const Json g = Json::parse(c->Get(("/v1/jobs/" + id + "/graph").c_str())->body);
  std::set<std::string> labels;
  for (const Json& n : g["nodes"]) labels.insert(n["label"]);
  EXPECT_EQ(labels, (std::set<std::string>{"left tet", "right_tet"}));
  // A label with a space, URL-encoded in the path.
  r = c->Get(("/v1/jobs/" + id + "/objects/left%20tet/neighbors").c_str());
  ASSERT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(Json::parse(r->body)["neighbors"][0]["label"], "right_tet");
  // Duplicate part names are duplicate labels; a bad part names itself.
  httplib::MultipartFormDataItems dup = {
      {"a", off, "a.off", "application/octet-stream"},
      {"a", ply, "a.ply", "application/octet-stream"},
  };
  r = c->Post("/v1/jobs", dup);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422) << r->body;
  httplib::MultipartFormDataItems broken = {
      {"good", off, "good.off", "application/octet-stream"},
      {"broken", "OFF\n4 1 0\n0 0 0\n", "broken.off", "application/octet-stream"},
  };
  r = c->Post("/v1/jobs", broken);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422) << r->body;
  EXPECT_NE(r->body.find("broken"), std::string::npos) << r->body;
}

// Units (docs/API.md, "Units"): a scene's "units", or the job parameter `units` over them,
// are the top-level "units" of the job's status (from the first answer on, and after a
// restart), of its graph and float64 JSON, of the query answers, and the GLB's asset extras.
// A scene without them gets none; an unknown unit is refused naming the field.
TEST(Service, UnitsTravelToTheStatusTheOutputsAndTheAnswers) {
  const std::string store = fresh_dir("units");
  Json scene = Json::parse(data("scenes/gears2d.json"));
  scene["units"] = "mm";
  std::string mm_id, plain_id;
  {
    ServerProcess server(store);
    auto c = client(server.port());
    const Submitted mm = submit(*c, scene.dump());
    ASSERT_EQ(mm.status, 202) << mm.body.dump();
    EXPECT_EQ(mm.body.value("units", ""), "mm") << mm.body.dump();
    mm_id = mm.id;
    const Json done = wait_for(*c, mm.id, {"done", "failed"});
    ASSERT_EQ(done.value("status", ""), "done") << done.dump();
    EXPECT_EQ(done.value("units", ""), "mm");
    EXPECT_EQ(done["result"].value("units", ""), "mm");
    const std::string base = "/v1/jobs/" + mm.id;
    for (const std::string path : {"/graph", "/gvd.json", "/tight?below=1", "/nearest?point=0,0",
                                   "/contacts?max_gap=0.1", "/objects/frame/neighbors"}) {
      auto r = c->Get((base + path).c_str());
      ASSERT_TRUE(r);
      ASSERT_EQ(r->status, 200) << path << ": " << r->body;
      EXPECT_EQ(Json::parse(r->body).value("units", ""), "mm") << path;
    }
    auto glb = c->Get((base + "/gvd.glb").c_str());
    ASSERT_TRUE(glb);
    const GlbFile parsed = parse_glb(std::vector<uint8_t>(glb->body.begin(), glb->body.end()));
    EXPECT_EQ(parsed.json["asset"]["extras"]["units"], "mm");

    // None declared: none shown, and a different job.
    const Submitted plain = submit(*c, data("scenes/gears2d.json"));
    plain_id = plain.id;
    EXPECT_NE(plain.id, mm.id);
    EXPECT_FALSE(plain.body.contains("units")) << plain.body.dump();
    ASSERT_EQ(wait_for(*c, plain.id, {"done"}).value("status", ""), "done");
    EXPECT_FALSE(status_of(*c, plain.id).contains("units"));
    EXPECT_FALSE(status_of(*c, plain.id)["result"].contains("units"));
    const Json g = Json::parse(c->Get(("/v1/jobs/" + plain.id + "/graph").c_str())->body);
    EXPECT_FALSE(g.contains("units")) << g.dump();

    // The parameter sets units (canonical name) and overrides the scene's own; the same
    // scene in the same units is the same job.
    const Submitted um = submit(*c, data("scenes/gears2d.json"), "?units=um");
    EXPECT_EQ(um.body.value("units", ""), "\u00b5m") << um.body.dump();
    EXPECT_NE(um.id, plain.id);
    const Submitted metres = submit(*c, scene.dump(), "?units=m");
    EXPECT_EQ(metres.body.value("units", ""), "m") << metres.body.dump();
    EXPECT_EQ(submit(*c, data("scenes/gears2d.json"), "?units=mm").id, mm.id);
    Json in_params = Json::parse(data("scenes/gears2d.json"));
    in_params["params"] = {{"units", "cm"}};
    EXPECT_EQ(submit(*c, in_params.dump()).body.value("units", ""), "cm");

    // Unknown units: refused, the field named, the value quoted.
    scene["units"] = "parsec";
    const Submitted bad_scene = submit(*c, scene.dump());
    EXPECT_EQ(bad_scene.status, 422) << bad_scene.body.dump();
    EXPECT_NE(bad_scene.body.value("detail", "").find("\"units\" must name a length unit"),
              std::string::npos)
        << bad_scene.body.dump();
    EXPECT_NE(bad_scene.body.value("detail", "").find("parsec"), std::string::npos);
    const Submitted bad_param = submit(*c, data("scenes/gears2d.json"), "?units=furlong");
    EXPECT_EQ(bad_param.status, 400) << bad_param.body.dump();
    EXPECT_NE(bad_param.body.value("detail", "").find("parameter \"units\""), std::string::npos)
        << bad_param.body.dump();
    for (const std::string& id : {um.id, metres.id}) wait_for(*c, id, {"done", "failed"});
  }
  // After a restart (the status rebuilt from the result file and the stored request when its
  // document is lost: killed between the two writes).
  const Json done = Json::parse(read_text(store + "/results/" + mm_id + ".json"));
  std::ofstream(store + "/requests/" + mm_id + ".json")
      << Json{{"id", mm_id}, {"params", done["params"]}};
  fs::remove(store + "/results/" + mm_id + ".json");
  ServerProcess server(store);
  auto c = client(server.port());
  EXPECT_EQ(status_of(*c, mm_id).value("units", ""), "mm");
  EXPECT_FALSE(status_of(*c, plain_id).contains("units"));
}

TEST(Service, ConcurrentClients) {
  // The eight clients share one address, and up to eight of them send a body at once: the
  // per-address cap (default a quarter of the 8 body readers) would turn the third away with
  // 503, as it should (its own test: OneAddressCannotTakeEveryBodyReader). That was this
  // test's rare failure.
  ServerProcess server(fresh_dir("concurrent"),
                       {"--http-threads", "16", "--max-body-readers-per-client", "8"});
  auto c = client(server.port());
  const Submitted s = submit(*c, data("scenes/gears2d.json"));
  ASSERT_EQ(wait_for(*c, s.id, {"done"}).value("status", ""), "done");
  std::atomic<int> ok{0}, bad{0};
  std::mutex failures_mutex;
  std::string failures;  // what each failed request got, for the report
  std::vector<std::thread> threads;
  const std::string scene = data("scenes/gears2d.json");
  for (int t = 0; t < 8; ++t) {
    threads.emplace_back([&, t] {
      auto tc = client(server.port());
      for (int i = 0; i < 25; ++i) {
        httplib::Result r = (i % 5 == 0)   ? tc->Post("/v1/jobs", scene, "application/json")
                            : (i % 5 == 1) ? tc->Get(("/v1/jobs/" + s.id + "/gvd.glb").c_str())
                            : (i % 5 == 2) ? tc->Get(("/v1/jobs/" + s.id + "/graph").c_str())
                            : (i % 5 == 3) ? tc->Get("/metrics")
                                           : tc->Get(("/v1/jobs/" + s.id).c_str());
        if (r && r->status == 200) {
          ++ok;
        } else {
          ++bad;
          std::lock_guard lock(failures_mutex);
          failures += "request " + std::to_string(i) + " of client " + std::to_string(t) + ": " +
                      (r ? std::to_string(r->status) + " " + r->body.substr(0, 300)
                         : "transport error " + httplib::to_string(r.error())) +
                      "\n";
        }
      }
    });
  }
  for (auto& th : threads) th.join();
  EXPECT_EQ(bad, 0) << failures;
  EXPECT_EQ(ok, 200);

  // The same new scene submitted by 8 clients at once: one job, one computation.
  std::atomic<int> misses{0};
  std::vector<std::string> ids(8);
  threads.clear();
  for (int t = 0; t < 8; ++t) {
    threads.emplace_back([&, t] {
      auto tc = client(server.port());
      auto r = tc->Post("/v1/jobs?max_depth=14", scene, "application/json");
      if (!r) return;
      if (r->get_header_value("X-Gvd-Cache") == "miss") ++misses;
      ids[static_cast<size_t>(t)] = Json::parse(r->body).value("id", "");
    });
  }
  for (auto& th : threads) th.join();
  EXPECT_EQ(misses, 1);
  for (const std::string& id : ids) EXPECT_EQ(id, ids[0]);
  auto m = c->Get("/metrics");
  EXPECT_NE(m->body.find("gvd_jobs_submitted_total 2"), std::string::npos);
}

/// Whatever arrives on `fd` within `ms` (until the server closes it: `closed`).
std::string read_for(int fd, int ms, bool& closed) {
  timeval tv{0, 50'000};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  std::string out;
  closed = false;
  const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(ms);
  char buf[4096];
  while (std::chrono::steady_clock::now() < end) {
    const ssize_t n = recv(fd, buf, sizeof buf, 0);
    if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) {
      closed = true;
      break;
    }
    if (n > 0) out.append(buf, static_cast<size_t>(n));
  }
  return out;
}

/// The kernel's count of connection attempts a listening socket dropped because its accept
/// queue was full (TcpExt ListenDrops, this network namespace's), or -1 where it cannot be
/// read. A dropped SYN is retried by the client after a second.
long long listen_drops() {
  std::ifstream in("/proc/net/netstat");
  std::string names, values;
  while (std::getline(in, names) && std::getline(in, values)) {
    if (!names.starts_with("TcpExt:")) continue;
    std::istringstream n(names), v(values);
    std::string name, value;
    while (n >> name && v >> value) {
      if (name == "ListenDrops") return std::stoll(value);
    }
  }
  return -1;
}

// The review's slowloris (D2): before the header gate, 129 connections sending a header byte a
// second held all 128 HTTP threads and no other request was answered for as long as they
// kept going. Here 200 attackers (a quarter of them after a fast first request on the same
// connection, so the kept-alive wait is attacked too) keep going for 20 s, reconnecting
// whenever the server closes them, while a prober asks /healthz every 50 ms.
TEST(Service, SlowHeadersDoNotStarveOtherClients) {
  ServerProcess server(fresh_dir("slowloris"), {"--header-timeout", "3"});
  const int port = server.port();
  constexpr int kAttackers = 200;
  const auto attack_end = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  std::atomic<bool> attacking{true};
  std::atomic<int> reconnects{0};
  std::thread attacker([&] {
    std::vector<int> fds(kAttackers, -1);
    const auto open_one = [&](int i) {
      const int fd = connect_to(port);
      if (fd < 0) return;
      std::string start = "GET /healthz HTTP/1.1\r\nHost: x\r\nX-Slow: ";
      if (i % 4 == 0) start = "GET /healthz HTTP/1.1\r\nHost: x\r\n\r\n" + start;
      (void)!send(fd, start.data(), start.size(), MSG_NOSIGNAL);
      fds[static_cast<size_t>(i)] = fd;
    };
    for (int i = 0; i < kAttackers; ++i) open_one(i);
    while (std::chrono::steady_clock::now() < attack_end) {
      for (int i = 0; i < kAttackers; ++i) {
        int& fd = fds[static_cast<size_t>(i)];
        char buf[4096];
        ssize_t n = 0;
        bool gone = false;
        while ((n = recv(fd, buf, sizeof buf, MSG_DONTWAIT)) != 0) {
          if (n < 0) {
            gone = errno != EAGAIN && errno != EWOULDBLOCK;
            break;
          }
        }
        if (n == 0 || gone || send(fd, "a", 1, MSG_NOSIGNAL) != 1) {
          close(fd);
          ++reconnects;
          open_one(i);
        }
      }
      std::this_thread::sleep_for(std::chrono::seconds(1));
    }
    attacking = false;
    for (const int fd : fds) close(fd);
  });

  std::this_thread::sleep_for(std::chrono::seconds(1));  // every attacker is connected
  const long long drops_before = listen_drops();
  std::vector<double> ms;
  int failed = 0;
  while (attacking) {
    const auto t0 = std::chrono::steady_clock::now();
    httplib::Client probe("127.0.0.1", port);
    probe.set_connection_timeout(2);
    probe.set_read_timeout(2);
    const auto r = probe.Get("/healthz");
    const double took =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    if (!r || r->status != 200) ++failed;
    ms.push_back(took);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  attacker.join();
  const long long drops = drops_before < 0 ? -1 : listen_drops() - drops_before;
  ASSERT_FALSE(ms.empty());
  std::sort(ms.begin(), ms.end());
  const double p99 = ms[ms.size() * 99 / 100];
  std::printf(
      "probes %zu, failed %d, median %.2f ms, p99 %.2f ms, max %.2f ms; attackers "
      "reconnected %d times; connection attempts dropped by a full accept queue %lld\n",
      ms.size(), failed, ms[ms.size() / 2], p99, ms.back(), reconnects.load(), drops);
  EXPECT_GT(ms.size(), 200u);
  // Every probe is answered within the issue's 100 ms: median 0.5-0.8 ms, p99 2-6 ms, the
  // slowest 6-10 ms, also beside a computation on both cores. Until the gate's events became
  // edge-triggered, each connection with partial headers was reported again at once after
  // every event (the gate peeks, so their bytes stay unread), the gate and the accept thread
  // spun on both cores, and probes took 1-3 s on a machine with slow system calls (p99
  // 140-220 ms in one run in six elsewhere). The kernel's count of dropped connection
  // attempts (a client retries after 1 s) is printed, not asserted: it counts every socket of
  // the namespace, and other tests run beside this one.
  EXPECT_EQ(failed, 0);
  EXPECT_LT(ms[ms.size() / 2], 100.0);
  EXPECT_LT(p99, 100.0);
  EXPECT_LT(ms.back(), 2000.0) << drops << " connection attempts dropped in the namespace";
  // The attackers were closed: all from one address, all but 64 of them at once to make room
  // (the oldest first), and those that stayed when their 3 s were up (with a 408).
  EXPECT_GT(reconnects.load(), kAttackers);
  auto m = client(port)->Get("/metrics");
  ASSERT_TRUE(m);
  const std::string key = "\ngvd_http_connections_evicted ";
  const size_t at = m->body.find(key);
  ASSERT_NE(at, std::string::npos);
  EXPECT_GE(std::stod(m->body.substr(at + key.size())), kAttackers - 64);
}

TEST(Service, HeaderDeadlineIdleCloseAndPipelinedRequests) {
  ServerProcess server(fresh_dir("header-gate"),
                       {"--header-timeout", "1", "--keep-alive-timeout", "1"});
  const int port = server.port();
  bool closed = false;
  // Headers that stop half-way: 408 after the header deadline (a problem document), then
  // closed.
  int fd = connect_to(port);
  ASSERT_GE(fd, 0);
  (void)!send(fd, "GET /healthz HTTP/1.1\r\nHost: x\r\n", 32, MSG_NOSIGNAL);
  auto t0 = std::chrono::steady_clock::now();
  std::string got = read_for(fd, 4000, closed);
  double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_TRUE(got.starts_with("HTTP/1.1 408 ")) << got;
  EXPECT_NE(got.find("/problems/request-timeout"), std::string::npos) << got;
  EXPECT_TRUE(closed);
  EXPECT_GT(took, 0.9);
  EXPECT_LT(took, 2.5);
  close(fd);

  // A connection that sends nothing is closed after the keep-alive time-out, silently.
  fd = connect_to(port);
  ASSERT_GE(fd, 0);
  t0 = std::chrono::steady_clock::now();
  got = read_for(fd, 4000, closed);
  took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(got, "");
  EXPECT_TRUE(closed);
  EXPECT_LT(took, 2.5);
  close(fd);

  // Three pipelined requests in one write (the second and third are read with the first):
  // three answers, in order, on the one connection.
  fd = connect_to(port);
  ASSERT_GE(fd, 0);
  const std::string three =
      "GET /healthz HTTP/1.1\r\nHost: x\r\n\r\n"
      "GET /v1/jobs/0000 HTTP/1.1\r\nHost: x\r\n\r\n"
      "GET /healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n";
  (void)!send(fd, three.data(), three.size(), MSG_NOSIGNAL);
  got = read_for(fd, 3000, closed);
  EXPECT_TRUE(closed);
  const size_t first = got.find("HTTP/1.1 200 ");
  const size_t second = got.find("HTTP/1.1 404 ", first + 1);
  const size_t third = got.find("HTTP/1.1 200 ", second + 1);
  EXPECT_EQ(first, 0u) << got;
  EXPECT_NE(second, std::string::npos) << got;
  EXPECT_NE(third, std::string::npos) << got;
  close(fd);

  // Headers sent a byte at a time but within the deadline are served.
  fd = connect_to(port);
  ASSERT_GE(fd, 0);
  for (const char ch :
       std::string("GET /healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")) {
    (void)!send(fd, &ch, 1, MSG_NOSIGNAL);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  got = read_for(fd, 2000, closed);
  EXPECT_TRUE(got.starts_with("HTTP/1.1 200 ")) << got;
  close(fd);
}

// With every HTTP thread busy and --max-queued-requests requests waiting for one, a
// further request is answered at once (503 /problems/overloaded + Retry-After) instead of
// waiting in an unbounded queue; /healthz stays 200 and /readyz says "overloaded". The threads
// are held legitimately, without CPU: POST bodies that arrive slowly (bodies are read in the
// threads; --max-body-readers 2 lets both threads read one, where by default only half of
// them may, and --max-body-readers-per-client 2 lets this one address read both). Afterwards
// the queued requests are served, not dropped, and so is everything else.
TEST(Service, FullRequestQueueAnswers503AtOnce) {
  const std::string dir = fresh_dir("overload");
  const std::string log = dir + "/server.log";
  ServerProcess server(
      dir + "/store",
      {"--http-threads", "2", "--max-queued-requests", "2", "--retry-after", "3", "--read-timeout",
       "30", "--max-body-readers", "2", "--max-body-readers-per-client", "2"},
      log);
  const int port = server.port();
  // Two requests hold the two threads, two more wait for them: headers and the first byte of
  // a 64-byte body each.
  const std::string body = R"({"dimension":3,"objects":[]})";
  const std::string padded = body + std::string(64 - body.size(), ' ');
  const std::string head =
      "POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
      "Content-Length: 64\r\nConnection: close\r\n\r\n";
  std::vector<int> holders;
  for (int i = 0; i < 4; ++i) {
    holders.push_back(connect_to(port));
    ASSERT_GE(holders.back(), 0);
    const std::string start = head + padded.substr(0, 1);
    (void)!send(holders.back(), start.data(), start.size(), MSG_NOSIGNAL);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // the gate hands over in µs

  // Excess requests: answered by the gate, each on its own new connection.
  std::vector<double> ms;
  for (int i = 0; i < 10; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::string got = raw_exchange(
        port, "GET /v1/jobs/abc?i=" + std::to_string(i) + " HTTP/1.1\r\nHost: x\r\n\r\n");
    ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    ASSERT_EQ(raw_status(got), 503) << got;
    EXPECT_NE(got.find("\r\nRetry-After: 3\r\n"), std::string::npos) << got;
    EXPECT_NE(got.find("\r\nContent-Type: application/problem+json\r\n"), std::string::npos);
    EXPECT_NE(got.find("\r\nConnection: close\r\n"), std::string::npos);
    const Json problem = Json::parse(got.substr(got.find("\r\n\r\n") + 4), nullptr, false);
    EXPECT_EQ(problem.value("type", ""), "/problems/overloaded") << got;
    EXPECT_EQ(problem.value("status", 0), 503);
    EXPECT_EQ(problem.value("instance", ""), "/v1/jobs/abc");
    EXPECT_FALSE(problem.value("request_id", "").empty());
  }
  std::sort(ms.begin(), ms.end());
  EXPECT_LT(ms[ms.size() / 2], 100) << "median ms";  // ~1 ms on a quiet machine
  EXPECT_LT(ms.back(), 1000) << "slowest ms";
  // Probes: liveness answered, readiness says why not.
  std::string got = raw_exchange(port, "GET /healthz HTTP/1.1\r\nHost: x\r\n\r\n");
  EXPECT_EQ(raw_status(got), 200) << got;
  got = raw_exchange(port, "GET /readyz HTTP/1.1\r\nHost: x\r\n\r\n");
  EXPECT_EQ(raw_status(got), 503) << got;
  EXPECT_NE(got.find("\"status\":\"overloaded\""), std::string::npos) << got;
  EXPECT_NE(got.find("\r\nRetry-After: 3\r\n"), std::string::npos) << got;

  // The bodies arrive: the two running requests and the two queued ones are all answered
  // (the scene has no objects: 422), none with 503.
  for (const int fd : holders) {
    (void)!send(fd, padded.data() + 1, padded.size() - 1, MSG_NOSIGNAL);
  }
  for (const int fd : holders) {
    bool closed = false;
    const std::string answer = read_for(fd, 10000, closed);
    EXPECT_EQ(raw_status(answer), 422) << answer;
    close(fd);
  }
  auto c = client(port);
  for (const char* path : {"/healthz", "/readyz", "/v1/jobs"}) {
    auto r = c->Get(path);
    ASSERT_TRUE(r) << path;
    EXPECT_EQ(r->status, 200) << path;
  }
  auto r = c->Get("/metrics");
  ASSERT_TRUE(r);
  EXPECT_NE(r->body.find("gvd_http_requests_overloaded_total 11\n"), std::string::npos);
  EXPECT_NE(r->body.find("gvd_http_requests_total{route=\"overloaded\",method=\"GET\","
                         "status=\"503\"} 11\n"),
            std::string::npos);
  EXPECT_NE(r->body.find("gvd_http_max_queued_requests 2\n"), std::string::npos);
  EXPECT_NE(r->body.find("gvd_http_queued_requests 0\n"), std::string::npos);
  // Logged once (at most a line a second), not once per refusal.
  int lines = 0;
  for (const Json& line : log_lines(log)) {
    if (line.value("event", "") == "overloaded") {
      ++lines;
      EXPECT_EQ(line.value("level", ""), "warn");
    }
  }
  EXPECT_GE(lines, 1);
  EXPECT_LE(lines, 3);
}

/// Sets an environment variable for the life of the object (servers started meanwhile see it:
/// an older gvd-server ignores variables it does not know, where it would refuse a flag).
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const std::string& value) : name_(name) {
    setenv(name, value.c_str(), 1);
  }
  ~ScopedEnv() { unsetenv(name_); }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  const char* name_;
};

/// Sends `request` on the kept-alive connection `fd` and returns one answer (its headers and
/// the body of its Content-Length), or what arrived before the server closed or `ms` passed.
std::string exchange_on(int fd, const std::string& request, int ms = 2000) {
  timeval tv{ms / 1000, (ms % 1000) * 1000};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  if (send(fd, request.data(), request.size(), MSG_NOSIGNAL) !=
      static_cast<ssize_t>(request.size())) {
    return "";
  }
  std::string out;
  char buf[4096];
  for (;;) {
    const size_t head_end = out.find("\r\n\r\n");
    if (head_end != std::string::npos) {
      const size_t cl = out.find("Content-Length: ");
      const size_t len =
          cl != std::string::npos && cl < head_end ? std::stoul(out.substr(cl + 16)) : 0;
      if (out.size() >= head_end + 4 + len) break;
    }
    const ssize_t n = recv(fd, buf, sizeof buf, 0);
    if (n <= 0) break;
    out.append(buf, static_cast<size_t>(n));
  }
  return out;
}

/// The value of a metric line `name value` in /metrics (-1 if absent).
double metric_value(int port, const std::string& name) {
  auto m = client(port)->Get("/metrics");
  if (!m) return -1;
  const std::string key = "\n" + name + " ";
  const size_t at = m->body.find(key);
  return at == std::string::npos ? -1 : std::stod(m->body.substr(at + key.size()));
}

/// The metric once it equals `value` (a request's body bytes are given back just after its
/// answer is sent), or its last value after 2 s.
double metric_becomes(int port, const std::string& name, double value) {
  double now = metric_value(port, name);
  for (int i = 0; i < 200 && now != value; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    now = metric_value(port, name);
  }
  return now;
}

// The per-address cap of the header gate closed kept-alive connections that sat
// idle between requests, so a client (or a proxy, or wrk) with more connections than the cap
// reconnected over and over: the 256-connection load test's p99. Only connections that have
// sent part of their headers count toward the cap now; an idle one holds a descriptor only.
// Here 40 kept-alive connections from one address, with room for 8, make a request, sit idle
// at the gate, and make another on the same connection: all answered. 12 connections that
// stall in their headers still find room for 8 only.
TEST(Service, IdleKeptAliveConnectionsAreNotEvicted) {
  ServerProcess server(fresh_dir("idle-keep-alive"), {"--max-waiting-per-client", "8"});
  const int port = server.port();
  const std::string request = "GET /v1/jobs HTTP/1.1\r\nHost: x\r\n\r\n";
  std::vector<int> idle;
  for (int i = 0; i < 40; ++i) {
    idle.push_back(connect_to(port));
    ASSERT_GE(idle.back(), 0);
    ASSERT_EQ(raw_status(exchange_on(idle.back(), request)), 200) << i;
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // all wait at the gate, idle
  int answered = 0;
  for (const int fd : idle) answered += raw_status(exchange_on(fd, request)) == 200 ? 1 : 0;
  EXPECT_EQ(answered, 40);
  EXPECT_EQ(metric_value(port, "gvd_http_connections_evicted"), 0);

  std::vector<int> stalled;
  for (int i = 0; i < 12; ++i) {
    stalled.push_back(connect_to(port));
    const std::string start = "GET /v1/jobs HTTP/1.1\r\nHost: x\r\nX-Slow: ";
    (void)!send(stalled.back(), start.data(), start.size(), MSG_NOSIGNAL);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_EQ(metric_value(port, "gvd_http_connections_evicted"), 4);
  answered = 0;
  for (const int fd : idle) answered += raw_status(exchange_on(fd, request)) == 200 ? 1 : 0;
  EXPECT_EQ(answered, 40);
  for (const int fd : idle) close(fd);
  for (const int fd : stalled) close(fd);
}

// Probes waited in the one FIFO queue of ready requests behind whatever held the
// threads, until it was full (then the gate answered them). They have a lane of their own now.
// Two slow bodies hold both threads and two more requests wait for them (the queue holds 8):
// /healthz, /readyz and /metrics are answered at once all the same. (The holders share one
// address: it may send both bodies.)
TEST(Service, ProbesAreAnsweredWhileRequestsWaitForThreads) {
  const ScopedEnv readers("GVD_MAX_BODY_READERS", "2");
  const ScopedEnv share("GVD_MAX_BODY_READERS_PER_CLIENT", "2");
  ServerProcess server(fresh_dir("probe-lane"), {"--http-threads", "2", "--max-queued-requests",
                                                 "8", "--read-timeout", "30"});
  const int port = server.port();
  const std::string body = R"({"dimension":3,"objects":[]})";
  const std::string padded = body + std::string(64 - body.size(), ' ');
  const std::string head =
      "POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
      "Content-Length: 64\r\nConnection: close\r\n\r\n";
  std::vector<int> holders;
  for (int i = 0; i < 4; ++i) {
    holders.push_back(connect_to(port));
    ASSERT_GE(holders.back(), 0);
    const std::string start = head + padded.substr(0, 1);
    (void)!send(holders.back(), start.data(), start.size(), MSG_NOSIGNAL);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  for (const char* path : {"/healthz", "/readyz", "/metrics", "/healthz?verbose=1"}) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::string got =
        raw_exchange(port, std::string("GET ") + path + " HTTP/1.1\r\nHost: x\r\n\r\n");
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_EQ(raw_status(got), 200) << path << ": " << got;
    EXPECT_LT(ms, 500) << path;
  }
  // Nothing was refused for it, and the requests that wait are still served.
  for (const int fd : holders) {
    (void)!send(fd, padded.data() + 1, padded.size() - 1, MSG_NOSIGNAL);
  }
  for (const int fd : holders) {
    bool closed = false;
    EXPECT_EQ(raw_status(read_for(fd, 10000, closed)), 422);
    close(fd);
  }
  EXPECT_GE(metric_value(port, "gvd_http_probes_served"), 4);
  EXPECT_LE(metric_value(port, "gvd_http_requests_overloaded_total"), 0);  // -1: never counted
}

// Request bodies are read in the threads with a time-out per recv only, so a body
// sent a byte at a time held a thread for as long as its sender liked. Now the whole body has
// --body-seconds + its length / --min-body-rate: then 408 and the connection is closed.
TEST(Service, SlowBodyGets408AtItsDeadline) {
  const ScopedEnv seconds("GVD_BODY_SECONDS", "1");
  const ScopedEnv rate("GVD_MIN_BODY_RATE", "1000000");
  ServerProcess server(fresh_dir("slow-body"), {"--read-timeout", "10"});
  const int port = server.port();
  const int fd = connect_to(port);
  ASSERT_GE(fd, 0);
  const std::string head =
      "POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
      "Content-Length: 200\r\n\r\n{";
  (void)!send(fd, head.data(), head.size(), MSG_NOSIGNAL);
  const auto t0 = std::chrono::steady_clock::now();
  std::string got;
  bool closed = false;
  for (int i = 0; i < 60 && !closed && got.find("\r\n\r\n") == std::string::npos; ++i) {
    (void)!send(fd, " ", 1, MSG_NOSIGNAL);  // a byte every 100 ms: each recv is quick
    got += read_for(fd, 100, closed);
  }
  got += read_for(fd, 500, closed);
  const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  close(fd);
  ASSERT_EQ(raw_status(got), 408) << got;
  EXPECT_NE(got.find("\r\nConnection: close\r\n"), std::string::npos) << got;
  const Json problem = Json::parse(got.substr(got.find("\r\n\r\n") + 4), nullptr, false);
  EXPECT_EQ(problem.value("type", ""), "/problems/request-timeout") << got;
  EXPECT_NE(problem.value("detail", "").find("--body-seconds"), std::string::npos) << got;
  EXPECT_TRUE(closed);
  EXPECT_GT(took, 0.9);
  EXPECT_LT(took, 3.0);
  EXPECT_EQ(metric_value(port, "gvd_http_body_timeouts"), 1);
  EXPECT_EQ(metric_value(port, "gvd_http_body_readers"), 0);
  // A body that arrives in time is read as before.
  auto r = client(port)->Post("/v1/jobs", R"({"dimension":3,"objects":[]})", "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422);
}

// However many threads, slow bodies could take every one of them. At most
// --max-body-readers threads read a body at once; one more body is refused before it is read
// (503 /problems/overloaded + Retry-After, connection closed) while requests without a body
// are served by the other threads.
TEST(Service, BodyReadersAreCapped) {
  const ScopedEnv readers("GVD_MAX_BODY_READERS", "1");
  ServerProcess server(fresh_dir("body-readers"),
                       {"--http-threads", "4", "--read-timeout", "30", "--retry-after", "2"});
  const int port = server.port();
  const std::string body = R"({"dimension":3,"objects":[]})";
  const std::string padded = body + std::string(64 - body.size(), ' ');
  const std::string head =
      "POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
      "Content-Length: 64\r\nConnection: close\r\n\r\n";
  const int holder = connect_to(port);
  ASSERT_GE(holder, 0);
  const std::string start = head + padded.substr(0, 1);
  (void)!send(holder, start.data(), start.size(), MSG_NOSIGNAL);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));

  const auto t0 = std::chrono::steady_clock::now();
  const std::string got = raw_exchange(port, start);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_EQ(raw_status(got), 503) << got;
  EXPECT_LT(ms, 1000);
  EXPECT_NE(got.find("\r\nRetry-After: 2\r\n"), std::string::npos) << got;
  const Json problem = Json::parse(got.substr(got.find("\r\n\r\n") + 4), nullptr, false);
  EXPECT_EQ(problem.value("type", ""), "/problems/overloaded") << got;
  EXPECT_NE(problem.value("detail", "").find("--max-body-readers"), std::string::npos) << got;
  auto c = client(port);
  auto r = c->Get("/v1/jobs");  // a request without a body: a free thread serves it
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(metric_value(port, "gvd_http_body_readers"), 1);
  EXPECT_EQ(metric_value(port, "gvd_http_body_readers_refused"), 1);

  (void)!send(holder, padded.data() + 1, padded.size() - 1, MSG_NOSIGNAL);
  bool closed = false;
  EXPECT_EQ(raw_status(read_for(holder, 10000, closed)), 422);
  close(holder);
  // The slot is free again.
  EXPECT_EQ(raw_status(raw_exchange(port, head + padded)), 422);
  EXPECT_EQ(metric_value(port, "gvd_http_body_readers"), 0);
}

// One client address could take every --max-body-readers slot, and every other
// client then got 503 for as long as its bodies took. Each address may now be reading
// --max-body-readers-per-client bodies (default: a quarter of the readers); one more from it
// is refused before its body (503 + Retry-After, naming the flag) while other addresses are
// read and answered.
TEST(Service, OneAddressCannotTakeEveryBodyReader) {
  ServerProcess server(
      fresh_dir("body-readers-per-client"),
      {"--http-threads", "8", "--max-body-readers", "4", "--max-body-readers-per-client", "2",
       "--read-timeout", "30", "--retry-after", "2"});
  const int port = server.port();
  const std::string body = R"({"dimension":3,"objects":[]})";
  const std::string padded = body + std::string(64 - body.size(), ' ');
  const std::string head =
      "POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
      "Content-Length: 64\r\nConnection: close\r\n\r\n";
  const std::string start = head + padded.substr(0, 1);
  // 127.0.0.1 sends two bodies slowly: both are read (its share).
  std::vector<int> holders;
  for (int i = 0; i < 2; ++i) {
    holders.push_back(connect_to(port));
    ASSERT_GE(holders.back(), 0);
    (void)!send(holders.back(), start.data(), start.size(), MSG_NOSIGNAL);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  ASSERT_EQ(metric_becomes(port, "gvd_http_body_readers", 2), 2);

  // A third body from the same address: refused at once, before its body.
  const auto t0 = std::chrono::steady_clock::now();
  const std::string got = raw_exchange(port, start, 2000, "127.0.0.1");
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_EQ(raw_status(got), 503) << got;
  EXPECT_LT(ms, 1000);
  EXPECT_NE(got.find("\r\nRetry-After: 2\r\n"), std::string::npos) << got;
  EXPECT_NE(got.find("\r\nConnection: close\r\n"), std::string::npos) << got;
  const Json problem = Json::parse(got.substr(got.find("\r\n\r\n") + 4), nullptr, false);
  EXPECT_EQ(problem.value("type", ""), "/problems/overloaded") << got;
  EXPECT_NE(problem.value("detail", "").find("--max-body-readers-per-client"), std::string::npos)
      << got;

  // Other addresses are read: one slowly (it holds a third slot) and one whole (answered).
  const int other = connect_to(port, "127.0.0.2");
  ASSERT_GE(other, 0);
  (void)!send(other, start.data(), start.size(), MSG_NOSIGNAL);
  EXPECT_EQ(raw_status(raw_exchange(port, head + padded, 5000, "127.0.0.3")), 422);
  EXPECT_EQ(metric_becomes(port, "gvd_http_body_readers", 3), 3);
  EXPECT_EQ(metric_value(port, "gvd_http_body_readers_refused_client"), 1);
  EXPECT_LE(metric_value(port, "gvd_http_body_readers_refused"), 0);

  // Once one of its bodies has arrived, the first address may send another.
  (void)!send(holders[0], padded.data() + 1, padded.size() - 1, MSG_NOSIGNAL);
  bool closed = false;
  EXPECT_EQ(raw_status(read_for(holders[0], 10000, closed)), 422);
  EXPECT_EQ(raw_status(raw_exchange(port, head + padded, 5000, "127.0.0.1")), 422);
  for (const int fd : {holders[1], other}) {
    (void)!send(fd, padded.data() + 1, padded.size() - 1, MSG_NOSIGNAL);
    EXPECT_EQ(raw_status(read_for(fd, 10000, closed)), 422);
    close(fd);
  }
  close(holders[0]);
  EXPECT_EQ(metric_value(port, "gvd_http_body_readers"), 0);
}

// The default share is a quarter of the readers, at least one; and the bytes of the bodies held
// at once have a budget (--body-budget, default 4 x --max-body), which must hold a body of the
// largest size.
TEST(Service, BodyReaderShareAndBudgetDefaults) {
  {
    ServerProcess server(fresh_dir("body-defaults"), {"--http-threads", "16"});
    EXPECT_EQ(metric_value(server.port(), "gvd_http_max_body_readers"), 8);
    EXPECT_EQ(metric_value(server.port(), "gvd_http_max_body_readers_per_client"), 2);
    EXPECT_EQ(metric_value(server.port(), "gvd_http_body_budget_bytes"), 4.0 * (64 << 20));
  }
  ServerProcess server(fresh_dir("body-defaults-small"),
                       {"--http-threads", "2", "--max-body", "1000"});
  EXPECT_EQ(metric_value(server.port(), "gvd_http_max_body_readers_per_client"), 1);
  EXPECT_EQ(metric_value(server.port(), "gvd_http_body_budget_bytes"), 4000);
}

// Reliability D4: bodies in memory had no bound but --max-body each times the threads reading
// them (128 x 64 MiB). The bytes of the bodies being read or handled now have a budget: a body
// that would take the sum past --body-budget is refused before it is read (503 + Retry-After),
// one that fits is read, and the bytes are given back once a request is answered.
TEST(Service, BodiesHeldAtOnceHaveAByteBudget) {
  ServerProcess server(fresh_dir("body-budget"),
                       {"--http-threads", "8", "--max-body", "1000", "--body-budget", "1500",
                        "--read-timeout", "30", "--retry-after", "2"});
  const int port = server.port();
  const auto post = [](size_t length) {
    return "POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
           "Content-Length: " +
           std::to_string(length) + "\r\nConnection: close\r\n\r\n";
  };
  const auto padded = [](size_t length) {
    const std::string body = R"({"dimension":3,"objects":[]})";
    return body + std::string(length - body.size(), ' ');
  };
  // A body of 1000 bytes arrives slowly: 1000 of the 1500 bytes are held.
  const int holder = connect_to(port, "127.0.0.1");
  ASSERT_GE(holder, 0);
  const std::string start = post(1000) + "{";
  (void)!send(holder, start.data(), start.size(), MSG_NOSIGNAL);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  ASSERT_EQ(metric_value(port, "gvd_http_body_bytes"), 1000);

  // 600 more would be 1600: refused before the body, whoever sends it.
  std::string got = raw_exchange(port, post(600), 2000, "127.0.0.2");
  ASSERT_EQ(raw_status(got), 503) << got;
  EXPECT_NE(got.find("\r\nRetry-After: 2\r\n"), std::string::npos) << got;
  const Json problem = Json::parse(got.substr(got.find("\r\n\r\n") + 4), nullptr, false);
  EXPECT_EQ(problem.value("type", ""), "/problems/overloaded") << got;
  EXPECT_NE(problem.value("detail", "").find("--body-budget"), std::string::npos) << got;
  EXPECT_NE(problem.value("detail", "").find("1500 bytes"), std::string::npos) << got;
  EXPECT_EQ(metric_value(port, "gvd_http_body_budget_refused"), 1);
  // 500 fit: read and answered, and their bytes given back.
  EXPECT_EQ(raw_status(raw_exchange(port, post(500) + padded(500), 5000, "127.0.0.3")), 422);
  EXPECT_EQ(metric_becomes(port, "gvd_http_body_bytes", 1000), 1000);

  // The slow body arrives: all bytes are free again, and 600 are read.
  const std::string rest = padded(1000).substr(1);
  (void)!send(holder, rest.data(), rest.size(), MSG_NOSIGNAL);
  bool closed = false;
  EXPECT_EQ(raw_status(read_for(holder, 10000, closed)), 422);
  close(holder);
  EXPECT_EQ(metric_becomes(port, "gvd_http_body_bytes", 0), 0);
  EXPECT_EQ(raw_status(raw_exchange(port, post(600) + padded(600), 5000, "127.0.0.2")), 422);
  EXPECT_EQ(metric_becomes(port, "gvd_http_body_bytes", 0), 0);
}

TEST(Service, HealthReadinessMetrics) {
  ServerProcess server(fresh_dir("health"));
  auto c = client(server.port());
  auto r = c->Get("/healthz");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_FALSE(r->get_header_value("X-Request-Id").empty());
  r = c->Get("/readyz", {{"X-Request-Id", "my-trace-1"}});
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(r->get_header_value("X-Request-Id"), "my-trace-1");
  const Json ready = Json::parse(r->body);
  EXPECT_EQ(ready["status"], "ready");
  EXPECT_EQ(ready["backend"], "cpu");
  const Submitted s = submit(*c, data("scenes/gears2d.json"));
  wait_for(*c, s.id, {"done"});
  c->Get(("/v1/jobs/" + s.id + "/graph").c_str());
  // A request is counted by the logger right after its answer is written: give it a moment.
  for (int i = 0; i < 100; ++i) {
    r = c->Get("/metrics");
    if (r->body.find("route=\"GET /v1/jobs/{id}/graph\",le=\"+Inf\"} 1") != std::string::npos)
      break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_EQ(r->status, 200);
  EXPECT_TRUE(r->get_header_value("Content-Type").starts_with("text/plain; version=0.0.4"));
  for (const char* needle :
       {"gvd_http_requests_total{route=\"GET /healthz\",method=\"GET\",status=\"200\"} 1",
        "gvd_http_requests_total{route=\"POST /v1/jobs\",method=\"POST\",status=\"202\"} 1",
        "gvd_http_request_duration_seconds_bucket{route=\"GET /v1/jobs/{id}/graph\",le=\"+Inf\"} 1",
        "gvd_job_stage_duration_seconds_count{stage=", "gvd_job_duration_seconds_count 1",
        "gvd_jobs_finished_total{status=\"done\"} 1", "gvd_queue_depth 0",
        "gvd_result_cache_hits_total", "process_resident_memory_bytes"}) {
    EXPECT_NE(r->body.find(needle), std::string::npos) << needle;
  }
  r = c->Get("/");
  EXPECT_EQ(r->status, 200);
  EXPECT_NE(r->body.find("openapi.json"), std::string::npos);
}

TEST(Service, OpenApiIsValidAndListsEveryRoute) {
  ServerProcess server(fresh_dir("openapi"));
  auto c = client(server.port());
  auto r = c->Get("/openapi.json");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200);
  const Json doc = Json::parse(r->body);
  EXPECT_EQ(doc["openapi"].get<std::string>().substr(0, 3), "3.1");
  for (const server::Route& route : server::kRoutes) {
    const std::string path(route.openapi_path);
    std::string method(route.method);
    for (char& ch : method) ch = static_cast<char>(std::tolower(ch));
    EXPECT_TRUE(doc["paths"].contains(path)) << path;
    if (doc["paths"].contains(path)) {
      EXPECT_TRUE(doc["paths"][path].contains(method)) << method << " " << path;
    }
  }
  size_t operations = 0;
  for (const auto& [path, item] : doc["paths"].items()) {
    for (const auto& [method, op] : item.items()) {
      if (method != "parameters") ++operations;
    }
  }
  EXPECT_EQ(operations, server::kRoutes.size());  // nothing documented that is not served
  const std::string file = fresh_dir("openapi-doc") + "/openapi.json";
  std::ofstream(file) << r->body;
  const std::string cmd = "node " + std::string(GVD_TEST_JS_DIR) + "/validate_openapi.mjs " + file +
                          " > " + file + ".out 2>&1";
  const int rc = std::system(cmd.c_str());
  EXPECT_EQ(rc, 0) << read_text(file + ".out");
}

}  // namespace
}  // namespace gvd::test

namespace gvd::test {
namespace {

/// A finished gears2d job (gear_a, gear_b inside a rectangular frame) for the query tests.
struct QueryFixture {
  explicit QueryFixture(const std::vector<std::string>& args = {})
      : server(fresh_dir("queries"), args), c(client(server.port())) {
    const Submitted s = submit(*c, data("scenes/gears2d.json"));
    id = s.id;
    const Json done = wait_for(*c, id, {"done", "failed"});
    EXPECT_EQ(done.value("status", ""), "done");
    graph = Json::parse(c->Get(("/v1/jobs/" + id + "/graph").c_str())->body);
  }
  std::string url(const std::string& tail) const { return "/v1/jobs/" + id + tail; }
  ServerProcess server;
  std::unique_ptr<httplib::Client> c;
  std::string id;
  Json graph;
};

TEST(ServiceQueries, NeighborsMatchTheDualGraph) {
  QueryFixture f;
  auto r = f.c->Get(f.url("/objects/gear_a/neighbors?ring=1").c_str());
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  const Json doc = Json::parse(r->body);
  std::set<std::string> got, want;
  for (const Json& n : doc["neighbors"]) got.insert(n["label"]);
  for (const Json& e : f.graph["edges"]) {
    if (e["label_a"] == "gear_a") want.insert(e["label_b"]);
    if (e["label_b"] == "gear_a") want.insert(e["label_a"]);
  }
  EXPECT_EQ(got, want);
  EXPECT_FALSE(got.empty());
  // Errors: unknown label, bad ring, unfinished/unknown job.
  r = f.c->Get(f.url("/objects/no_such_gear/neighbors").c_str());
  EXPECT_EQ(r->status, 404);
  EXPECT_NE(Json::parse(r->body)["detail"].get<std::string>().find("no_such_gear"),
            std::string::npos);
  EXPECT_EQ(f.c->Get(f.url("/objects/gear_a/neighbors?ring=0").c_str())->status, 400);
  EXPECT_EQ(f.c->Get(f.url("/objects/gear_a/neighbors?ring=x").c_str())->status, 400);
  EXPECT_EQ(f.c->Get("/v1/jobs/ffffffffffffffffffffffffffffffff/objects/a/neighbors")->status, 404);
}

TEST(ServiceQueries, NearestSingleAndBatch) {
  QueryFixture f;
  const Json scene = Json::parse(data("scenes/gears2d.json"));
  // A vertex of each object: that object is the nearest, at distance ~0.
  std::vector<std::pair<std::string, Json>> probes;
  for (const Json& o : scene["objects"]) probes.emplace_back(o["label"], o["vertices"][0]);
  Json points = Json::array();
  for (const auto& [label, p] : probes) {
    const std::string q =
        "?point=" + std::to_string(p[0].get<double>()) + "," + std::to_string(p[1].get<double>());
    auto r = f.c->Get(f.url("/nearest" + q).c_str());
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 200) << r->body;
    const Json a = Json::parse(r->body);
    EXPECT_EQ(a["label"], label);
    EXPECT_LT(a["distance"].get<double>(), 1e-4);
    points.push_back(p);
  }
  auto r =
      f.c->Post(f.url("/nearest").c_str(), Json{{"points", points}}.dump(), "application/json");
  ASSERT_EQ(r->status, 200) << r->body;
  const Json batch = Json::parse(r->body)["answers"];
  ASSERT_EQ(batch.size(), probes.size());
  for (size_t i = 0; i < probes.size(); ++i) {
    EXPECT_EQ(batch[i]["label"], probes[i].first);
    EXPECT_EQ(batch[i]["point"], probes[i].second);  // echoed as given
  }
  // A batch answers every point: the centre of gear_a (a closed outline) is inside it, with
  // the distance negative; a point outside the domain gets an error entry of its own.
  r = f.c->Post(f.url("/nearest").c_str(), R"({"points":[[0,0],[100,0]]})", "application/json");
  ASSERT_EQ(r->status, 200) << r->body;
  const Json mixed = Json::parse(r->body)["answers"];
  ASSERT_EQ(mixed.size(), 2u) << r->body;
  EXPECT_EQ(mixed[0]["label"], "gear_a");
  EXPECT_EQ(mixed[0]["inside"], true);
  EXPECT_EQ(mixed[0]["signed_distance"].get<double>(), -mixed[0]["distance"].get<double>());
  EXPECT_EQ(mixed[0]["closest"].size(), 2u);
  EXPECT_TRUE(mixed[1]["object"].is_null());
  EXPECT_EQ(mixed[1]["error"]["code"], "outside_domain");
  EXPECT_EQ(mixed[1]["point"], Json::parse("[100,0]"));
  // Errors: outside the domain (422), wrong arity / not a number / missing (400), bad JSON,
  // wrong content type.
  r = f.c->Get(f.url("/nearest?point=100,0").c_str());
  EXPECT_EQ(r->status, 422);
  EXPECT_EQ(Json::parse(r->body)["type"], "/problems/outside-domain");
  EXPECT_EQ(f.c->Get(f.url("/nearest?point=1,2,3").c_str())->status, 400);
  EXPECT_EQ(f.c->Get(f.url("/nearest?point=a,b").c_str())->status, 400);
  EXPECT_EQ(f.c->Get(f.url("/nearest").c_str())->status, 400);
  // fast=true answers with the same object on the object itself; a bad value is a 400.
  r = f.c->Get(
      f.url("/nearest?fast=true&point=" + std::to_string(probes[0].second[0].get<double>()) + "," +
            std::to_string(probes[0].second[1].get<double>()))
          .c_str());
  ASSERT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(Json::parse(r->body)["label"], probes[0].first);
  EXPECT_EQ(f.c->Get(f.url("/nearest?fast=maybe&point=0,0").c_str())->status, 400);
  EXPECT_EQ(f.c->Post(f.url("/nearest").c_str(), "{\"points\":[[0,", "application/json")->status,
            400);
  EXPECT_EQ(
      f.c->Post(f.url("/nearest").c_str(), "{\"points\":[[\"x\",0]]}", "application/json")->status,
      400);
  EXPECT_EQ(f.c->Post(f.url("/nearest").c_str(), "[[0,0]]", "application/xml")->status, 415);
  // `curl -d` labels the JSON body as a form: still read as JSON.
  EXPECT_EQ(
      f.c->Post(f.url("/nearest").c_str(), "[[0,0]]", "application/x-www-form-urlencoded")->status,
      200);
}

// Reliability D6: a batch larger than --max-batch-points is refused before any point is
// answered (422 limit-exceeded naming the limit); one at the limit is answered.
TEST(ServiceQueries, BatchNearestHasASizeLimit) {
  QueryFixture f({"--max-batch-points", "3"});
  auto r =
      f.c->Post(f.url("/nearest").c_str(), R"({"points":[[0,0],[1,1],[2,2]]})", "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200) << r->body;
  r = f.c->Post(f.url("/nearest").c_str(), R"({"points":[[0,0],[1,1],[2,2],[3,3]]})",
                "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422) << r->body;
  const Json problem = Json::parse(r->body);
  EXPECT_EQ(problem["type"], "/problems/limit-exceeded");
  EXPECT_NE(problem.value("detail", "").find("4 points exceed the batch limit of 3"),
            std::string::npos)
      << r->body;
}

TEST(ServiceQueries, ContactsAreTheCloseDualGraphPairsWithTheirGaps) {
  QueryFixture f;
  auto r = f.c->Get(f.url("/contacts?max_gap=0.1").c_str());
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  const Json doc = Json::parse(r->body);
  EXPECT_EQ(doc["max_gap"], 0.1);
  // The gears mesh 0.02 apart: a contact, with the dual graph's exact gap.
  bool gears = false;
  for (const Json& c : doc["contacts"]) {
    EXPECT_LT(c["gap"].get<double>(), 0.1);
    if (c["label_a"] != "gear_a" || c["label_b"] != "gear_b") continue;
    gears = true;
    for (const Json& e : f.graph["edges"]) {
      if (e["label_a"] == "gear_a" && e["label_b"] == "gear_b") {
        EXPECT_DOUBLE_EQ(c["gap"].get<double>(), e["gap"].get<double>());
      }
    }
    EXPECT_GE(c["sites"].size(), 1u);
  }
  EXPECT_TRUE(gears) << r->body;
  EXPECT_EQ(f.c->Get(f.url("/contacts?max_gap=-1").c_str())->status, 400);
  EXPECT_EQ(f.c->Get(f.url("/contacts").c_str())->status, 400);
}

TEST(ServiceQueries, PathsAnd422WhenNoneExists) {
  QueryFixture f;
  auto r = f.c->Post(f.url("/paths").c_str(), R"({"from":[-1.3,-2.3],"to":[3.3,2.3]})",
                     "application/json");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  const Json path = Json::parse(r->body);
  ASSERT_GE(path["points"].size(), 2u);
  EXPECT_EQ(path["points"].front(), Json::parse("[-1.3,-2.3]"));
  EXPECT_EQ(path["points"].back(), Json::parse("[3.3,2.3]"));
  EXPECT_GE(path["length"].get<double>(), std::hypot(4.6, 4.6) - 1e-9);
  EXPECT_GT(path["min_clearance"].get<double>(), 0.0);
  // A start inside gear_a: no path; the problem carries the path document.
  r = f.c->Post(f.url("/paths").c_str(), R"({"from":[0.5,0.5],"to":[3.3,2.3]})",
                "application/json");
  ASSERT_EQ(r->status, 422) << r->body;
  const Json problem = Json::parse(r->body);
  EXPECT_EQ(problem["type"], "/problems/no-path");
  EXPECT_TRUE(problem["path"]["points"].empty());
  EXPECT_TRUE(problem["path"]["length"].is_null());
  // As `curl -X POST .../paths -d '{...}'` sends it (a form content type).
  r = f.c->Post(f.url("/paths").c_str(), R"({"from":[-1.3,-2.3],"to":[3.3,2.3]})",
                "application/x-www-form-urlencoded");
  EXPECT_EQ(r->status, 200) << r->body;
  // Bad bodies.
  EXPECT_EQ(f.c->Post(f.url("/paths").c_str(), R"({"from":[0,0]})", "application/json")->status,
            400);
  EXPECT_EQ(f.c->Post(f.url("/paths").c_str(), R"({"from":[0,0],"to":[1,1],"min_clearance":-1})",
                      "application/json")
                ->status,
            400);
  EXPECT_EQ(f.c->Post(f.url("/paths").c_str(), R"(not json)", "application/json")->status, 400);
  // A point nested 70,000 levels deep (which overflowed the stack in error messages): 400
  // naming the nesting, and the server keeps answering.
  const std::string deep =
      "{\"from\":" + std::string(70000, '[') + std::string(70000, ']') + ",\"to\":[0,0]}";
  r = f.c->Post(f.url("/paths").c_str(), deep, "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 400) << r->body.substr(0, 300);
  EXPECT_NE(r->body.find("nested deeper than"), std::string::npos) << r->body.substr(0, 300);
  r = f.c->Post(f.url("/nearest").c_str(),
                "{\"points\":" + std::string(70000, '[') + std::string(70000, ']') + "}",
                "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 400) << r->body.substr(0, 300);
  EXPECT_EQ(f.c->Get(f.url("").c_str())->status, 200);
}

TEST(ServiceQueries, ExplodeJsonAndGlbAndClearanceReport) {
  QueryFixture f;
  auto r = f.c->Get(f.url("/explode?anchor=frame").c_str());
  ASSERT_EQ(r->status, 200) << r->body;
  const Json view = Json::parse(r->body);
  EXPECT_EQ(view["label"], "frame");
  EXPECT_EQ(view["objects"].size(), 3u);
  r = f.c->Get(f.url("/explode?anchor=frame&format=glb").c_str());
  ASSERT_EQ(r->status, 200);
  EXPECT_EQ(r->get_header_value("Content-Type"), "model/gltf-binary");
  const std::string glb_path = fresh_dir("explode-glb") + "/exploded.glb";
  std::ofstream(glb_path, std::ios::binary) << r->body;
  const GltfReport report = validate_glb_file(glb_path);
  ASSERT_TRUE(report.ran) << report.output;
  EXPECT_EQ(report.errors, 0) << report.output;
  EXPECT_EQ(f.c->Get(f.url("/explode").c_str())->status, 400);
  EXPECT_EQ(f.c->Get(f.url("/explode?anchor=nobody").c_str())->status, 404);
  EXPECT_EQ(f.c->Get(f.url("/explode?anchor=frame&format=obj").c_str())->status, 400);

  r = f.c->Get(f.url("/tight?below=1e9").c_str());
  ASSERT_EQ(r->status, 200);
  EXPECT_EQ(Json::parse(r->body)["pairs"].size(), f.graph["edges"].size());
  r = f.c->Get(f.url("/tight?below=0").c_str());
  EXPECT_TRUE(Json::parse(r->body)["pairs"].empty());
  EXPECT_EQ(f.c->Get(f.url("/tight").c_str())->status, 400);
  EXPECT_EQ(f.c->Get(f.url("/tight?below=-1").c_str())->status, 400);
}

/// Runs the gvd CLI (`args` after the binary); true when it exits 0.
bool run_cli(const std::string& args, const std::string& log) {
  const std::string cmd = std::string(GVD_CLI_BINARY) + " " + args + " > " + log + " 2>&1";
  return std::system(cmd.c_str()) == 0;
}

TEST(ServiceQueries, GridFieldAndLabelsAreTheCliGrid) {
  QueryFixture f;
  const std::string dir = fresh_dir("grid-npy");
  // The job's result as the CLI sees it.
  auto r = f.c->Get(f.url("/result.gvd").c_str());
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200);
  std::ofstream(dir + "/result.gvd", std::ios::binary) << r->body;
  struct Case {
    std::string query, cli;
  };
  for (const Case& k :
       {Case{"resolution=60", "--resolution 60"}, Case{"resolution=45&metric=l1&float64=1",
                                                       "--resolution 45 --metric l1 "
                                                       "--float64"}}) {
    const auto field = f.c->Get(f.url("/field.npy?" + k.query).c_str());
    const auto labels = f.c->Get(f.url("/labels.npy?" + k.query).c_str());
    ASSERT_TRUE(field && labels);
    ASSERT_EQ(field->status, 200) << field->body;
    ASSERT_EQ(labels->status, 200) << labels->body;
    EXPECT_EQ(field->get_header_value("Content-Type"), "application/octet-stream");
    EXPECT_EQ(field->body.substr(0, 6), "\x93NUMPY");
    ASSERT_TRUE(run_cli("grid " + dir + "/result.gvd " + k.cli + " -o " + dir + "/f.npy --labels " +
                            dir + "/l.npy -q",
                        dir + "/cli.log"))
        << read_text(dir + "/cli.log");
    EXPECT_TRUE(field->body == read_text(dir + "/f.npy")) << k.query;
    EXPECT_TRUE(labels->body == read_text(dir + "/l.npy")) << k.query;
  }
  // The same as CuRV on the scene over the job's domain (the grid's box by default).
  const Json status = status_of(*f.c, f.id);
  const Json& domain = status["result"]["domain"];
  const double x0 = domain["origin"][0], y0 = domain["origin"][1], side = domain["side"];
  char box[200];
  std::snprintf(box, sizeof box, "%.17g,%.17g,%.17g,%.17g", x0, y0, x0 + side, y0 + side);
  ASSERT_TRUE(run_cli("grid " + std::string(GVD_TEST_DATA_DIR) +
                          "/scenes/gears2d.json --resolution 60 --domain " + box + " --labels " +
                          dir + "/scene_l.npy -q",
                      dir + "/cli.log"))
      << read_text(dir + "/cli.log");
  EXPECT_TRUE(f.c->Get(f.url("/labels.npy?resolution=60").c_str())->body ==
              read_text(dir + "/scene_l.npy"));
  // The advice of grid_advice is in the job's summary.
  EXPECT_TRUE(status["result"]["grid"].is_object());
  // Bad requests: a clear problem, checked before any work.
  for (const char* q :
       {"", "?resolution=0", "?resolution=x", "?resolution=10&metric=l3",
        "?resolution=10&float64=maybe", "?resolution=10&domain=0,0,0,1,1,1", "?resolution=2000000",
        "?resolution=full", "?resolution=10&max_depth=3", "?resolution=10&domain=1,1,0,0"}) {
    r = f.c->Get(f.url(std::string("/field.npy") + q).c_str());
    EXPECT_EQ(r->status, 400) << q << " " << r->body;
    EXPECT_EQ(r->get_header_value("Content-Type"), "application/problem+json");
  }
  // The query parameters are the parameter table's (kGridQuery): its messages, naming them.
  for (const auto& [q, says] : std::vector<std::pair<std::string, std::string>>{
           {"?resolution=10&max_depth=3",
            "unknown parameter \"max_depth\" (known: domain, resolution, metric, float64, "
            "unsigned)"},
           {"?resolution=full", "parameter \"resolution\" must be an integer, got \"full\""},
           {"?resolution=2000000", "parameter \"resolution\" must be between 1 and 1048576"},
           {"?resolution=10&domain=0,0,0,1,1,1", "parameter \"domain\" needs 4 numbers"},
           {"", "parameter \"resolution\" is required"}}) {
    for (const char* file : {"/field.npy", "/labels.npy"}) {
      r = f.c->Get(f.url(file + q).c_str());
      EXPECT_NE(Json::parse(r->body).value("detail", "").find(says), std::string::npos)
          << file << q << " " << r->body;
    }
  }
  r = f.c->Get(f.url("/field.npy?resolution=100000").c_str());
  EXPECT_EQ(r->status, 422);
  EXPECT_EQ(Json::parse(r->body)["type"], "/problems/limit-exceeded");
  EXPECT_EQ(f.c->Get("/v1/jobs/ffffffffffffffffffffffffffffffff/field.npy?resolution=8")->status,
            404);
}

TEST(ServiceQueries, UnfinishedJobsAnswer409) {
  ServerProcess server(fresh_dir("queries-409"), {"--workers", "1"});
  auto c = client(server.port());
  const Submitted slow = submit(*c, slow_scene(), "?contact_depth=12");
  ASSERT_EQ(wait_for(*c, slow.id, {"running"}).value("status", ""), "running");
  auto r = c->Get(("/v1/jobs/" + slow.id + "/nearest?point=0,0,0").c_str());
  EXPECT_EQ(r->status, 409);
  EXPECT_EQ(Json::parse(r->body)["type"], "/problems/job-not-finished");
  EXPECT_EQ(c->Get(("/v1/jobs/" + slow.id + "/gvd.glb").c_str())->status, 409);
  EXPECT_EQ(c->Get(("/v1/jobs/" + slow.id + "/field.npy?resolution=8").c_str())->status, 409);
  c->Delete(("/v1/jobs/" + slow.id).c_str());
  wait_for(*c, slow.id, {"cancelled"}, 10);
}

// ---- grid jobs (mode=grid) and labelled volumes ---------------------------------

/// A numpy .npy file as the tests read it: the header's dict and the data after it.
struct Npy {
  std::string descr;
  std::vector<uint64_t> shape;
  std::string data;
};

/// Parses a .npy file by hand (magic, version 1.0, little-endian header length, dict).
Npy parse_npy(const std::string& bytes) {
  Npy n;
  if (bytes.size() < 10 || bytes.substr(0, 6) != "\x93NUMPY") return n;
  const size_t len = static_cast<unsigned char>(bytes[8]) |
                     (static_cast<size_t>(static_cast<unsigned char>(bytes[9])) << 8);
  const std::string header = bytes.substr(10, len);
  const size_t d = header.find("'descr': '");
  if (d != std::string::npos) n.descr = header.substr(d + 10, header.find('\'', d + 10) - d - 10);
  const size_t sh = header.find("'shape': (");
  if (sh != std::string::npos) {
    std::stringstream in(header.substr(sh + 10, header.find(')', sh) - sh - 10));
    std::string item;
    while (std::getline(in, item, ',')) {
      if (item.find_first_not_of(' ') != std::string::npos) n.shape.push_back(std::stoull(item));
    }
  }
  n.data = bytes.substr(10 + len);
  return n;
}

/// A .npy of a C-order array (`descr` e.g. "|u1", "<f4"), as numpy writes version 1.0.
std::string make_npy(const std::string& descr, const std::vector<uint64_t>& shape,
                     const std::string& data) {
  std::string dims;
  for (uint64_t v : shape) dims += std::to_string(v) + ",";
  if (shape.size() > 1) dims.pop_back();
  std::string header =
      "{'descr': '" + descr + "', 'fortran_order': False, 'shape': (" + dims + "), }";
  while ((10 + header.size() + 1) % 64 != 0) header += ' ';
  header += '\n';
  std::string out = "\x93NUMPY";
  out += '\x01';
  out += '\x00';
  out += static_cast<char>(header.size() & 0xff);
  out += static_cast<char>(header.size() >> 8);
  return out + header + data;
}

/// A 2D scene's segments per object, for brute-force nearest objects.
struct Segments2 {
  std::vector<std::vector<std::array<double, 4>>> objects;
};

Segments2 scene_segments(const Json& scene) {
  Segments2 s;
  for (const Json& o : scene["objects"]) {
    std::vector<std::array<double, 4>> segs;
    for (const Json& e : o["segments"]) {
      const Json& a = o["vertices"][e[0].get<size_t>()];
      const Json& b = o["vertices"][e[1].get<size_t>()];
      segs.push_back(
          {a[0].get<double>(), a[1].get<double>(), b[0].get<double>(), b[1].get<double>()});
    }
    s.objects.push_back(std::move(segs));
  }
  return s;
}

/// Brute force: the distance from (x, y) to each object (over all its segments).
std::vector<double> object_distances(const Segments2& s, double x, double y) {
  std::vector<double> out;
  for (const auto& segs : s.objects) {
    double best = 1e300;
    for (const auto& g : segs) {
      const double dx = g[2] - g[0], dy = g[3] - g[1];
      const double l2 = dx * dx + dy * dy;
      double t = l2 > 0 ? ((x - g[0]) * dx + (y - g[1]) * dy) / l2 : 0;
      t = std::clamp(t, 0.0, 1.0);
      const double px = g[0] + t * dx - x, py = g[1] + t * dy - y;
      best = std::min(best, std::sqrt(px * px + py * py));
    }
    out.push_back(best);
  }
  return out;
}

std::vector<double> header_numbers(const std::string& text) {
  std::vector<double> v;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) v.push_back(std::stod(item));
  return v;
}

/// The graph's edges as sorted label pairs.
std::set<std::pair<std::string, std::string>> label_pairs(const Json& graph) {
  std::set<std::pair<std::string, std::string>> pairs;
  for (const Json& e : graph["edges"]) {
    std::string a = graph["nodes"][e["a"].get<size_t>()]["label"];
    std::string b = graph["nodes"][e["b"].get<size_t>()]["label"];
    if (b < a) std::swap(a, b);
    pairs.insert({a, b});
  }
  return pairs;
}

TEST(ServiceGrid, GridJobGraphIsTheBruteForceAdjacencyAndTheCli) {
  const std::string store = fresh_dir("grid-job");
  ServerProcess server(store);
  auto c = client(server.port());
  const std::string scene_text = data("scenes/gears2d.json");
  const Submitted s = submit(*c, scene_text, "?mode=grid&resolution=40");
  ASSERT_EQ(s.status, 202) << s.body.dump();
  const Json done = wait_for(*c, s.id, {"done", "failed"});
  ASSERT_EQ(done.value("status", ""), "done") << done.dump();
  EXPECT_EQ(done["params"]["mode"], "grid");
  EXPECT_EQ(done["params"]["resolution"], 40);
  std::set<std::string> stages;
  for (const Json& st : done["progress"]["stages"]) stages.insert(st["name"].get<std::string>());
  EXPECT_EQ(stages.count("grid"), 1u) << done["progress"].dump();
  EXPECT_EQ(done["links"].value("field", ""), "/v1/jobs/" + s.id + "/field.npy");
  EXPECT_FALSE(done["links"].contains("glb"));
  EXPECT_EQ(done["result"].value("graph_edges", 0), 3);
  // Another resolution or metric is another job.
  const Submitted other = submit(*c, scene_text, "?mode=grid&resolution=41");
  EXPECT_NE(other.id, s.id);
  EXPECT_NE(submit(*c, scene_text, "?mode=grid&resolution=40&metric=l1").id, s.id);
  EXPECT_NE(submit(*c, scene_text).id, s.id);
  EXPECT_EQ(submit(*c, scene_text, "?resolution=40&mode=grid").id, s.id);

  const std::string url = "/v1/jobs/" + s.id;
  auto r = c->Get((url + "/graph").c_str());
  ASSERT_EQ(r->status, 200) << r->body;
  const Json graph = Json::parse(r->body);
  auto labels = c->Get((url + "/labels.npy").c_str());
  ASSERT_EQ(labels->status, 200) << labels->body;
  const Npy npy = parse_npy(labels->body);
  ASSERT_EQ(npy.descr, "<i4");
  ASSERT_EQ(npy.shape.size(), 2u);
  const uint64_t ny = npy.shape[0], nx = npy.shape[1];
  EXPECT_EQ(std::max(nx, ny), 40u);
  ASSERT_EQ(npy.data.size(), nx * ny * 4);
  const std::vector<double> origin = header_numbers(labels->get_header_value("X-Gvd-Grid-Origin"));
  const double h = std::stod(labels->get_header_value("X-Gvd-Grid-Cell"));
  ASSERT_EQ(origin.size(), 3u);

  // Oracle: the nearest object at every cell centre by brute force, and the pairs of objects
  // on two cells sharing a face.
  const Json scene = Json::parse(scene_text);
  const Segments2 segs = scene_segments(scene);
  std::vector<int> oracle(nx * ny);
  for (uint64_t j = 0; j < ny; ++j) {
    for (uint64_t i = 0; i < nx; ++i) {
      const std::vector<double> d =
          object_distances(segs, origin[0] + (i + 0.5) * h, origin[1] + (j + 0.5) * h);
      oracle[j * nx + i] = static_cast<int>(std::min_element(d.begin(), d.end()) - d.begin());
    }
  }
  std::set<std::pair<std::string, std::string>> expected;
  const auto add = [&](int a, int b) {
    if (a == b) return;
    std::string la = scene["objects"][a]["label"], lb = scene["objects"][b]["label"];
    if (lb < la) std::swap(la, lb);
    expected.insert({la, lb});
  };
  for (uint64_t j = 0; j < ny; ++j) {
    for (uint64_t i = 0; i < nx; ++i) {
      if (i + 1 < nx) add(oracle[j * nx + i], oracle[j * nx + i + 1]);
      if (j + 1 < ny) add(oracle[j * nx + i], oracle[(j + 1) * nx + i]);
    }
  }
  EXPECT_FALSE(expected.empty());
  EXPECT_EQ(label_pairs(graph), expected);

  // The same edges as `gvd compute --mode grid` on the same scene and parameters.
  const std::string dir = fresh_dir("grid-job-cli");
  ASSERT_TRUE(run_cli("compute " + std::string(GVD_TEST_DATA_DIR) +
                          "/scenes/gears2d.json --mode grid --resolution 40 --graph " + dir +
                          "/g.json -q",
                      dir + "/cli.log"))
      << read_text(dir + "/cli.log");
  const Json cli = Json::parse(read_text(dir + "/g.json"));
  ASSERT_EQ(cli["edges"].size(), graph["edges"].size());
  for (size_t e = 0; e < cli["edges"].size(); ++e) {
    EXPECT_EQ(cli["edges"][e]["a"], graph["edges"][e]["a"]);
    EXPECT_EQ(cli["edges"][e]["b"], graph["edges"][e]["b"]);
    EXPECT_NEAR(cli["edges"][e]["area"].get<double>(), graph["edges"][e]["area"].get<double>(),
                1e-9);
  }

  // Outputs that need the adaptive result: 409 adaptive-only; the grid's own files take no
  // sampling parameters.
  for (const char* tail : {"/gvd.glb", "/gvd.json", "/result.gvd", "/nearest?point=0,0",
                           "/objects/gear_a/neighbors", "/tight?below=1"}) {
    r = c->Get((url + tail).c_str());
    EXPECT_EQ(r->status, 409) << tail << " " << r->body;
    EXPECT_EQ(Json::parse(r->body).value("type", ""), "/problems/adaptive-only") << tail;
  }
  r = c->Get((url + "/field.npy?resolution=8").c_str());
  EXPECT_EQ(r->status, 400);
  EXPECT_NE(r->body.find("resolution"), std::string::npos);
  // DELETE removes the grid files with the result.
  const std::string results = store + "/results/" + s.id;
  EXPECT_TRUE(fs::exists(results + ".field.npy") && fs::exists(results + ".labels.npy"));
  EXPECT_EQ(c->Delete(url.c_str())->status, 204);
  EXPECT_EQ(c->Get(url.c_str())->status, 404);
  EXPECT_FALSE(fs::exists(results + ".field.npy") || fs::exists(results + ".labels.npy") ||
               fs::exists(results + ".gvd"));
}

TEST(ServiceGrid, GridJobFieldHasTheBruteForceLabelsAndDistances) {
  ServerProcess server(fresh_dir("grid-field"));
  auto c = client(server.port());
  const std::string scene_text = data("scenes/gears2d.json");
  const Submitted s = submit(*c, scene_text, "?mode=grid&resolution=64&unsigned=1");
  ASSERT_EQ(wait_for(*c, s.id, {"done", "failed"}).value("status", ""), "done");
  const auto field = c->Get(("/v1/jobs/" + s.id + "/field.npy").c_str());
  const auto labels = c->Get(("/v1/jobs/" + s.id + "/labels.npy").c_str());
  ASSERT_EQ(field->status, 200) << field->body;
  ASSERT_EQ(labels->status, 200) << labels->body;
  const Npy f = parse_npy(field->body), l = parse_npy(labels->body);
  ASSERT_EQ(f.descr, "<f4");
  ASSERT_EQ(f.shape, l.shape);
  ASSERT_EQ(f.shape.size(), 2u);
  const uint64_t ny = f.shape[0], nx = f.shape[1];
  EXPECT_EQ(std::max(nx, ny), 64u);
  ASSERT_EQ(f.data.size(), nx * ny * 4);
  const std::vector<double> origin = header_numbers(field->get_header_value("X-Gvd-Grid-Origin"));
  const double h = std::stod(field->get_header_value("X-Gvd-Grid-Cell"));
  EXPECT_FALSE(field->has_header("X-Gvd-Grid-Units"));  // the scene declared none
  const Segments2 segs = scene_segments(Json::parse(scene_text));
  int checked = 0;
  for (uint64_t j = 0; j < ny; j += 3) {
    for (uint64_t i = 0; i < nx; i += 3) {
      const std::vector<double> d =
          object_distances(segs, origin[0] + (i + 0.5) * h, origin[1] + (j + 0.5) * h);
      std::vector<double> sorted = d;
      std::sort(sorted.begin(), sorted.end());
      const int nearest = static_cast<int>(std::min_element(d.begin(), d.end()) - d.begin());
      float dist = 0;
      int32_t label = 0;
      std::memcpy(&dist, f.data.data() + 4 * (j * nx + i), 4);
      std::memcpy(&label, l.data.data() + 4 * (j * nx + i), 4);
      EXPECT_NEAR(dist, sorted[0], 1e-5 * (1 + sorted[0])) << i << "," << j;
      // Within one cell (its diagonal) of a Voronoi boundary the label may be either side.
      if (sorted[1] - sorted[0] <= std::sqrt(2.0) * h) continue;
      EXPECT_EQ(label, nearest) << i << "," << j;
      ++checked;
    }
  }
  EXPECT_GT(checked, 100);
}

// The scene's units label the grid's geometry headers (ASCII), on a grid job's own field and
// on a grid sampled from an adaptive job.
TEST(ServiceGrid, GridHeadersSayTheScenesUnits) {
  ServerProcess server(fresh_dir("grid-units"));
  auto c = client(server.port());
  Json scene = Json::parse(data("scenes/gears2d.json"));
  scene["units"] = "um";
  const Submitted grid_job = submit(*c, scene.dump(), "?mode=grid&resolution=16");
  const Submitted adaptive = submit(*c, scene.dump());
  ASSERT_EQ(wait_for(*c, grid_job.id, {"done", "failed"}).value("status", ""), "done");
  ASSERT_EQ(wait_for(*c, adaptive.id, {"done", "failed"}).value("status", ""), "done");
  for (const std::string& url :
       {"/v1/jobs/" + grid_job.id + "/field.npy", "/v1/jobs/" + grid_job.id + "/labels.npy",
        "/v1/jobs/" + adaptive.id + "/field.npy?resolution=8"}) {
    const auto r = c->Get(url.c_str());
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 200) << url << " " << r->body;
    EXPECT_EQ(r->get_header_value("X-Gvd-Grid-Units"), "um") << url;
  }
}

/// `count` copies of one UV sphere (radius 1, 8 rings x 16 segments) as scene JSON: a grid
/// job over them can cull no site (every range sees all of them at the same distance).
std::string coincident_spheres_json(int count) {
  const int rings = 8, segments = 16;
  Json v = Json::array(), t = Json::array();
  v.push_back({0, 0, 1});
  for (int r = 1; r < rings; ++r) {
    const double theta = 3.141592653589793 * r / rings;
    for (int s = 0; s < segments; ++s) {
      const double phi = 2 * 3.141592653589793 * s / segments;
      v.push_back(
          {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)});
    }
  }
  v.push_back({0, 0, -1});
  const int south = 1 + (rings - 1) * segments;
  auto at = [&](int r, int s) { return 1 + (r - 1) * segments + s % segments; };
  for (int s = 0; s < segments; ++s) {
    t.push_back({0, at(1, s), at(1, s + 1)});
    t.push_back({south, at(rings - 1, s + 1), at(rings - 1, s)});
    for (int r = 1; r + 1 < rings; ++r) {
      t.push_back({at(r, s), at(r + 1, s), at(r + 1, s + 1)});
      t.push_back({at(r, s), at(r + 1, s + 1), at(r, s + 1)});
    }
  }
  Json objects = Json::array();
  for (int i = 0; i < count; ++i)
    objects.push_back({{"label", "s" + std::to_string(i)}, {"vertices", v}, {"triangles", t}});
  return Json{{"dimension", 3}, {"objects", objects}}.dump();
}

// A grid job was stopped only between its stages, so DELETE (and --job-seconds, the
// memory watchdog) waited for the whole grid. Now the grid reports progress within its stage
// and a DELETE stops it within about a second.
TEST(ServiceGrid, DeleteStopsARunningGridJobWithinASecond) {
  ServerProcess server(fresh_dir("grid-cancel"), {"--workers", "1"});
  auto c = client(server.port());
  const Submitted s = submit(*c, coincident_spheres_json(400), "?mode=grid&resolution=64");
  ASSERT_EQ(s.status, 202) << s.body.dump();
  // Progress inside the grid stage: a fraction strictly between 0 and 1.
  double fraction = 0;
  Json seen;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (std::chrono::steady_clock::now() < deadline && !(fraction > 0 && fraction < 1)) {
    seen = status_of(*c, s.id);
    for (const Json& st : seen["progress"].value("stages", Json::array()))
      if (st.value("name", "") == "grid") fraction = st.value("fraction", 0.0);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_EQ(seen.value("status", ""), "running") << seen.dump();
  EXPECT_GT(fraction, 0.0) << seen.dump();
  EXPECT_LT(fraction, 1.0) << seen.dump();
  const auto t0 = std::chrono::steady_clock::now();
  auto r = c->Delete(("/v1/jobs/" + s.id).c_str());
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 202);
  const Json cancelled = wait_for(*c, s.id, {"cancelled", "done", "failed"}, 20);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(cancelled.value("status", ""), "cancelled") << cancelled.dump();
  EXPECT_LT(seconds, 1.5) << "the grid job took " << seconds << " s to stop";
}

TEST(ServiceGrid, GridCellLimitIsCheckedBeforeWork) {
  ServerProcess server(fresh_dir("grid-limit"), {"--max-grid-cells", "1000"});
  auto c = client(server.port());
  const Submitted s = submit(*c, data("scenes/gears2d.json"), "?mode=grid&resolution=100");
  EXPECT_EQ(s.status, 422) << s.body.dump();
  EXPECT_EQ(s.body.value("type", ""), "/problems/limit-exceeded");
  EXPECT_TRUE(s.id.empty());
  // Nothing was queued or computed.
  EXPECT_TRUE(Json::parse(c->Get("/v1/jobs")->body)["jobs"].empty());
  EXPECT_EQ(submit(*c, data("scenes/gears2d.json"), "?mode=grid&resolution=30").status, 202);
}

/// A 16^3 volume of labels 1, 2, 3 (uint8, x fastest): 1 below z = 5; 3 above z = 11 for
/// x < 8; 2 elsewhere.
std::string three_label_volume(std::vector<uint8_t>& v) {
  const int n = 16;
  v.assign(n * n * n, 2);
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        uint8_t label = 2;
        if (z < 5) label = 1;
        if (z >= 11 && x < 8) label = 3;
        v[(z * n + y) * n + x] = label;
      }
  return make_npy("|u1", {16, 16, 16}, std::string(v.begin(), v.end()));
}

TEST(ServiceGrid, LabelledVolumeGraphIsTheVoxelAdjacency) {
  const std::string store = fresh_dir("volume");
  std::string adaptive_id;
  ServerProcess server(store);
  auto c = client(server.port());
  std::vector<uint8_t> v;
  const std::string npy = three_label_volume(v);
  // Oracle: label pairs on face-adjacent voxels.
  std::set<std::pair<std::string, std::string>> expected;
  const int n = 16;
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const int a = v[(z * n + y) * n + x];
        const int next[3][3] = {{x + 1, y, z}, {x, y + 1, z}, {x, y, z + 1}};
        for (const auto& q : next) {
          if (q[0] >= n || q[1] >= n || q[2] >= n) continue;
          const int b = v[(q[2] * n + q[1]) * n + q[0]];
          if (a == b) continue;
          std::string la = "label_" + std::to_string(a), lb = "label_" + std::to_string(b);
          if (lb < la) std::swap(la, lb);
          expected.insert({la, lb});
        }
      }
  ASSERT_EQ(expected.size(), 2u);
  for (const std::string query :
       {"?spacing=1,1,2&mode=grid&resolution=24", "?spacing=1,1,2&max_depth=6"}) {
    const Submitted s = submit(*c, npy, query, "application/x-npy");
    ASSERT_EQ(s.status, 202) << query << " " << s.body.dump();
    // The worker converts the volume: its objects are known once it has.
    EXPECT_EQ(s.body["scene"]["dimension"], 3) << s.body.dump();
    const Json done = wait_for(*c, s.id, {"done", "failed"});
    ASSERT_EQ(done.value("status", ""), "done") << done.dump();
    EXPECT_EQ(done["scene"]["objects"], 3) << done.dump();
    EXPECT_EQ(done["result"]["objects"], 3) << done.dump();
    const Json graph = Json::parse(c->Get(("/v1/jobs/" + s.id + "/graph").c_str())->body);
    EXPECT_EQ(label_pairs(graph), expected) << query << " " << graph.dump();
    if (query.find("mode=grid") == std::string::npos) {
      // The stored adaptive result is served as this job's (its id addresses the volume's
      // bytes, not the scene the worker made of them).
      const auto glb = c->Get(("/v1/jobs/" + s.id + "/gvd.glb").c_str());
      ASSERT_TRUE(glb);
      EXPECT_EQ(glb->status, 200) << glb->body;
      adaptive_id = s.id;
    }
  }
  {
    // ... also by a server started again, which loads it from the store.
    ServerProcess again(store);
    auto c2 = client(again.port());
    const auto glb = c2->Get(("/v1/jobs/" + adaptive_id + "/gvd.glb").c_str());
    ASSERT_TRUE(glb);
    EXPECT_EQ(glb->status, 200) << glb->body;
  }
  // The same volume as a multipart part (sniffed as application/octet-stream).
  httplib::MultipartFormDataItems items = {{"volume", npy, "v.npy", "application/octet-stream"}};
  auto r = c->Post("/v1/jobs?spacing=1,1,2&mode=grid&resolution=24", items);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200) << r->body;  // the same scene and parameters: the same job
  const std::string grid_job = Json::parse(r->body).value("id", "");
  // Its parameters may come in a "params" part, as for meshes.
  items.push_back({"params", R"({"mode":"grid","resolution":24})", "", "application/json"});
  r = c->Post("/v1/jobs?spacing=1,1,2", items);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200) << r->body;
  // The volume's own parameters too (they are job parameters of the table): the same job.
  items.back().content = R"({"mode":"grid","resolution":24,"spacing":[1,1,2],"background":0})";
  r = c->Post("/v1/jobs", items);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(Json::parse(r->body).value("id", ""), grid_job);
  // Label 3 as the background: two objects, another scene, another job.
  items.back().content = R"({"mode":"grid","resolution":24,"spacing":[1,1,2],"background":3})";
  r = c->Post("/v1/jobs", items);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->get_header_value("X-Gvd-Cache"), "miss") << r->body;
  const std::string other_job = Json::parse(r->body).value("id", "");
  EXPECT_NE(other_job, grid_job);
  // The worker converts the volume: its objects are known once it has.
  const Json other_done = wait_for(*c, other_job, {"done", "failed"});
  EXPECT_EQ(other_done["scene"]["objects"], 2) << other_done.dump();
  items.back().content = "{not json";
  r = c->Post("/v1/jobs?spacing=1,1,2", items);
  EXPECT_EQ(r->status, 400) << r->body;
  EXPECT_NE(r->body.find("params"), std::string::npos) << r->body;
}

// A labelled volume is converted by the job's worker, not by the HTTP thread: the upload is
// answered at once, the job shows stage "volume" while the volume is turned into a scene,
// DELETE stops it there, and what only the conversion finds fails the job with the problem
// the upload was answered with when the HTTP thread converted it.
TEST(ServiceGrid, VolumesAreConvertedByTheJob) {
  ServerProcess server(fresh_dir("volume-job"), {"--workers", "1"});
  auto c = client(server.port());
  // 256^3 voxels (16 MB of uint8), two labels: a second or more of conversion here.
  const uint64_t n = 256;
  std::string voxels(n * n * n, '\1');
  std::fill(voxels.begin(), voxels.begin() + static_cast<std::ptrdiff_t>(n * n * n / 2), '\2');
  const auto posted = std::chrono::steady_clock::now();
  const Submitted big =
      submit(*c, make_npy("|u1", {n, n, n}, voxels), "?spacing=1,1,1", "application/x-npy");
  const double answer =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - posted).count();
  ASSERT_EQ(big.status, 202) << big.body.dump();
  EXPECT_EQ(big.body["scene"]["objects"], 0) << big.body.dump();
  // Seen in its conversion, then cancelled there.
  Json seen;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (std::chrono::steady_clock::now() < deadline) {
    seen = status_of(*c, big.id);
    if (seen.value("status", "") != "queued") break;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  while (std::chrono::steady_clock::now() < deadline && seen.value("status", "") == "running" &&
         !seen["progress"]["stage"].is_string()) {
    seen = status_of(*c, big.id);
  }
  ASSERT_EQ(seen["progress"]["stage"], "volume") << seen.dump();
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_EQ(c->Delete(("/v1/jobs/" + big.id).c_str())->status, 202);
  const Json cancelled = wait_for(*c, big.id, {"cancelled", "done", "failed"}, 30);
  const double latency =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_EQ(cancelled.value("status", ""), "cancelled") << cancelled.dump();
  EXPECT_EQ(cancelled["progress"]["stages"].back()["name"], "volume") << cancelled.dump();
  EXPECT_LT(latency, 1.0);
  EXPECT_LT(answer, 2.0) << "the upload waited for its conversion";

  // Found by the conversion only: the job fails with the upload's old answer.
  struct Case {
    std::string npy;
    std::string type, says;
  };
  for (const Case& k : {
           Case{make_npy("|u1", {4, 4, 4}, std::string(64, '\0')), "/problems/invalid-scene",
                "no label other than the background"},
           Case{make_npy("|i1", {2, 2, 2}, std::string("\1\1\1\xff\1\1\1\1", 8)),
                "/problems/invalid-scene", "voxel 3"},
       }) {
    const Submitted s = submit(*c, k.npy, "?spacing=1,1,1", "application/x-npy");
    ASSERT_EQ(s.status, 202) << s.body.dump();
    const Json failed = wait_for(*c, s.id, {"done", "failed"});
    ASSERT_EQ(failed.value("status", ""), "failed") << failed.dump();
    EXPECT_EQ(failed["error"]["type"], k.type) << failed.dump();
    EXPECT_NE(failed["error"].value("detail", "").find(k.says), std::string::npos) << failed.dump();
  }
}

TEST(ServiceGrid, BadGridAndVolumeInputNamesTheField) {
  ServerProcess server(fresh_dir("volume-bad"));
  auto c = client(server.port());
  std::vector<uint8_t> v;
  const std::string good = three_label_volume(v);
  struct Case {
    std::string body, query, type;
    int status;
    std::string says;
  };
  const std::string floats = make_npy("<f4", {4, 4, 4}, std::string(4 * 64, '\0'));
  const std::string flat = make_npy("|u1", {16}, std::string(16, '\1'));
  for (const Case& k : {
           // A .npy whose content is no label volume: invalid input (422), not 415.
           Case{floats, "?spacing=1,1,1", "application/x-npy", 422, "dtype <f4"},
           Case{flat, "?spacing=1", "application/x-npy", 422, "2 or 3 dimensions"},
           Case{std::string("\x93NUMPY\x09\x00\x10\x00", 10) + std::string(16, ' '), "?spacing=1",
                "application/x-npy", 415, "version"},
           Case{good, "", "application/x-npy", 400, "spacing"},
           Case{good, "?spacing=1,1", "application/x-npy", 400, "spacing"},
           Case{good, "?spacing=1,1,1&background=x", "application/x-npy", 400, "background"},
           Case{data("scenes/gears2d.json"), "?spacing=1,1", "application/json", 400, "spacing"},
           Case{data("scenes/gears2d.json"), "?mode=grid", "application/json", 400, "resolution"},
           Case{data("scenes/gears2d.json"), "?resolution=64", "application/json", 400,
                "mode=grid"},
           Case{data("scenes/gears2d.json"), "?mode=grid&resolution=8&max_depth=5",
                "application/json", 400, "max_depth"},
           Case{data("scenes/gears2d.json"), "?mode=grid&resolution=8&metric=l3",
                "application/json", 400, "l3"},
           Case{data("scenes/gears2d.json"), "?mode=voxels", "application/json", 400, "mode"},
       }) {
    const Submitted s = submit(*c, k.body, k.query, k.type);
    EXPECT_EQ(s.status, k.status) << k.query << " " << s.body.dump();
    EXPECT_NE(s.body.value("detail", "").find(k.says), std::string::npos)
        << k.query << " " << s.body.dump();
  }
  EXPECT_EQ(c->Get("/healthz")->status, 200);
}

}  // namespace
}  // namespace gvd::test
