#include "query_handlers.h"

#include <httplib.h>

#include "job_manager.h"
#include "problem.h"

namespace gvd::server {
namespace {

// The queries arrive with the GvdIndex implementation (issue 3); until then they answer 501.
void not_yet(const httplib::Request& req, httplib::Response& res, JobManager& jobs) {
  (void)jobs.result(req.matches[1].str());  // unknown / unfinished jobs answer as usual
  res.status = 501;
  res.set_content(R"({"type":"about:blank","title":"Not implemented","status":501})",
                  "application/problem+json");
}

}  // namespace

void QueryHandlers::neighbors(const httplib::Request& req, httplib::Response& res) { not_yet(req, res, jobs_); }
void QueryHandlers::nearest(const httplib::Request& req, httplib::Response& res) { not_yet(req, res, jobs_); }
void QueryHandlers::nearest_batch(const httplib::Request& req, httplib::Response& res) { not_yet(req, res, jobs_); }
void QueryHandlers::paths(const httplib::Request& req, httplib::Response& res) { not_yet(req, res, jobs_); }
void QueryHandlers::explode(const httplib::Request& req, httplib::Response& res) { not_yet(req, res, jobs_); }
void QueryHandlers::tight(const httplib::Request& req, httplib::Response& res) { not_yet(req, res, jobs_); }

}  // namespace gvd::server
