#pragma once

#include <sys/types.h>

#include <string>
#include <vector>

namespace gvd::test {

/// A real gvd-server process on an ephemeral port (--port 0; the port is read from the line it
/// prints on stdout), for the service tests.
class ServerProcess {
 public:
  /// Starts GVD_SERVER_BINARY with `--port 0 --store store --quiet` plus `args`; with a
  /// `log_file`, without `--quiet` and with the server's stderr (its log lines) written there.
  ServerProcess(const std::string& store, const std::vector<std::string>& args = {},
                const std::string& log_file = "");
  ~ServerProcess();  ///< SIGKILL if still running
  ServerProcess(const ServerProcess&) = delete;
  ServerProcess& operator=(const ServerProcess&) = delete;

  int port() const { return port_; }
  pid_t pid() const { return pid_; }
  /// Sends a signal; `wait` then reaps the process and returns its exit status (or -signal).
  void signal(int sig);
  int wait();
  bool running();

 private:
  pid_t pid_ = -1;
  int port_ = 0;
  int stdout_fd_ = -1;
};

/// A fresh empty directory under the test output directory.
std::string fresh_dir(const std::string& name);

}  // namespace gvd::test
