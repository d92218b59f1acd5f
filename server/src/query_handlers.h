#pragma once

namespace httplib {
struct Request;
struct Response;
}  // namespace httplib

namespace gvd::server {

class JobManager;

/// The query endpoints on a finished job (neighbours, nearest, paths, exploded view,
/// clearance report): parse the request, ask the job's GvdIndex, write its JSON. Throw
/// ProblemError / gvd::Error for the catch boundary of the HTTP layer.
class QueryHandlers {
 public:
  explicit QueryHandlers(JobManager& jobs) : jobs_(jobs) {}
  void neighbors(const httplib::Request& req, httplib::Response& res);
  void nearest(const httplib::Request& req, httplib::Response& res);
  void nearest_batch(const httplib::Request& req, httplib::Response& res);
  void paths(const httplib::Request& req, httplib::Response& res);
  void explode(const httplib::Request& req, httplib::Response& res);
  void tight(const httplib::Request& req, httplib::Response& res);

 private:
  JobManager& jobs_;
};

}  // namespace gvd::server
