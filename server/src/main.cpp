// gvd-server: the gvd REST service. Options by flag or GVD_* environment variable (--help).

#include <signal.h>
#include <sys/resource.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include "gvd/common/error.h"
#include "gvd/common/peak_memory.h"
#include "gvd/kernels/opencl_backend.h"
#include "http_server.h"
#include "server_options.h"
#include "static_files.h"

extern char** environ;

int main(int argc, char** argv) {
  using namespace gvd::server;
  // Jobs' freed arrays go back to the system (the memory watchdog reads the resident size).
  gvd::use_returning_heap();
  // Signals go to one thread that waits for them: blocked here, before any thread starts, so
  // every thread inherits the mask.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  signal(SIGPIPE, SIG_IGN);
  // Connections waiting for their headers cost a descriptor each (up to --max-waiting):
  // take the whole hard limit, not the usual soft 1024.
  rlimit files{};
  if (getrlimit(RLIMIT_NOFILE, &files) == 0 && files.rlim_cur < files.rlim_max) {
    files.rlim_cur = files.rlim_max;
    setrlimit(RLIMIT_NOFILE, &files);
  }

  ServerOptions options;
  try {
    std::map<std::string, std::string> env;
    for (char** e = environ; *e != nullptr; ++e) {
      const char* eq = std::strchr(*e, '=');
      if (eq != nullptr && std::strncmp(*e, "GVD_", 4) == 0)
        env[std::string(*e, static_cast<size_t>(eq - *e))] = eq + 1;
    }
    bool help = false;
    options = parse_server_options(std::vector<std::string>(argv + 1, argv + argc), env, help);
    if (help) {
      std::fputs(server_usage().c_str(), stdout);
      return 0;
    }
    std::error_code ec;
    const std::string exe = std::filesystem::read_symlink("/proc/self/exe", ec).string();
    try {
      options.web_root = find_web_root(options.web_root, exe);
    } catch (const std::runtime_error& e) {
      throw UsageError(e.what());
    }
    if (options.web_root.empty()) {
      std::fprintf(stderr,
                   "{\"level\":\"warning\",\"msg\":\"no web viewer found next to %s "
                   "(give --web-root): / answers a page of links\"}\n",
                   exe.c_str());
    }
  } catch (const UsageError& e) {
    std::fprintf(stderr, "gvd-server: %s\n(see gvd-server --help)\n", e.what());
    return 2;
  }

  try {
    // The compute backend, chosen once at start-up on this thread, before any job runs (PoCL
    // must not see its first OpenCL calls from several threads: it crashes).
    const gvd::kernels::BackendChoice choice = gvd::kernels::choose_backend(options.backend);
    options.compute = choice.compute;
    options.backend_note = choice.note;
    if (!options.quiet) {
      std::string msg = choice.log;  // one JSON log line: no quotes or backslashes inside
      for (char& c : msg) c = (c == '"' || c == '\\' || c < ' ') ? '\'' : c;
      std::fprintf(stderr, "{\"level\":\"info\",\"msg\":\"%s\"}\n", msg.c_str());
    }
    HttpServer server(options);
    const int port = server.bind();
    if (port < 0) {
      std::fprintf(stderr, "gvd-server: cannot listen on %s:%d\n", options.host.c_str(),
                   options.port);
      return 1;
    }
    std::printf("gvd-server listening on http://%s:%d (store %s, backend %s, %d workers)\n",
                options.host.c_str(), port, options.store.c_str(), server.backend().c_str(),
                options.workers);
    std::fflush(stdout);
    if (!options.quiet) {
      std::fprintf(stderr,
                   "{\"level\":\"info\",\"event\":\"listening\",\"port\":%d,\"workers\":%d,"
                   "\"http_threads\":%d,\"max_queued_requests\":%d,\"queue\":%d,"
                   "\"backend\":\"%s\"}\n",
                   port, options.workers, options.http_threads, options.max_queued_requests,
                   options.queue, server.backend().c_str());
    }

    std::thread waiter([&] {
      int sig = 0;
      sigwait(&signals, &sig);
      std::fprintf(stderr, "{\"level\":\"info\",\"msg\":\"%s: draining\"}\n",
                   sig == SIGTERM ? "SIGTERM" : "SIGINT");
      server.shutdown();
    });
    const bool ok = server.serve();
    if (!ok) {
      // Listening ended without a signal: wake the waiter so it can be joined.
      pthread_kill(waiter.native_handle(), SIGTERM);
    }
    waiter.join();
    std::fprintf(stderr, "{\"level\":\"info\",\"msg\":\"stopped\"}\n");
    return ok ? 0 : 1;
  } catch (const gvd::Error& e) {
    std::fprintf(stderr, "gvd-server: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "gvd-server: cannot start: %s\n", e.what());
    return 1;
  }
}
