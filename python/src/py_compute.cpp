#include "py_compute.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace gvd::python {

namespace {

/// How long the calling thread waits without the GIL between two looks at signals, the
/// cancel token and progress: Ctrl-C is noticed within this, the GIL is taken ~50 times/s.
constexpr auto kSlice = std::chrono::milliseconds(20);

/// `progress=True`: one line on sys.stderr, redrawn when the stage or the percentage changes.
class TextBar {
 public:
  void operator()(const std::string& stage, double fraction) {
    const int percent = static_cast<int>(std::clamp(fraction, 0.0, 1.0) * 100);
    if (stage == stage_ && percent == percent_) return;
    stage_ = stage;
    percent_ = percent;
    const int width = 30, filled = percent * width / 100;
    std::string line = "\rgvd: " + stage;
    line.resize(std::max<size_t>(line.size(), 16), ' ');
    line += " [" + std::string(static_cast<size_t>(filled), '#') +
            std::string(static_cast<size_t>(width - filled), '.') + "] " + std::to_string(percent) +
            "%";
    if (stage == "done") line += "\n";
    write(line);
    open_ = stage != "done";
  }
  /// Ends the line when the computation stopped before "done".
  void finish() {
    if (open_) write("\n");
    open_ = false;
  }

 private:
  static void write(const std::string& text) {
    py::object err = py::module_::import("sys").attr("stderr");
    if (err.is_none()) return;
    err.attr("write")(text);
    err.attr("flush")();
  }
  std::string stage_;
  int percent_ = -1;
  bool open_ = false;
};

/// What the worker thread hands to the calling thread.
struct Shared {
  std::mutex mutex;
  std::condition_variable changed;
  std::vector<std::pair<std::string, double>> events;  ///< progress not yet delivered
  bool finished = false;
  std::exception_ptr error;
};

/// Joins the worker on every way out (an exception in the loop included), asking it to stop
/// first if it is still running; waits without the GIL.
class JoinOnExit {
 public:
  JoinOnExit(std::thread& worker, std::atomic<bool>& cancel) : worker_(worker), cancel_(cancel) {}
  JoinOnExit(const JoinOnExit&) = delete;
  JoinOnExit& operator=(const JoinOnExit&) = delete;
  ~JoinOnExit() {
    if (!worker_.joinable()) return;
    cancel_ = true;
    if (PyGILState_Check()) {
      py::gil_scoped_release unlocked;
      worker_.join();
    } else {
      worker_.join();
    }
  }

 private:
  std::thread& worker_;
  std::atomic<bool>& cancel_;
};

}  // namespace

void run_in_python(const std::function<void(const std::atomic<bool>*, const WorkProgress&)>& work,
                   const py::object& progress, CancelToken* token) {
  const bool bar = py::isinstance<py::bool_>(progress) && progress.cast<bool>();
  const bool callback = !progress.is_none() && !py::isinstance<py::bool_>(progress);
  if (callback && !PyCallable_Check(progress.ptr())) {
    throw Error(ErrorCode::kInvalidArgument,
                "progress must be None, a bool or a callable(stage, fraction)");
  }
  TextBar text_bar;
  Shared shared;
  std::atomic<bool> cancel{token != nullptr && token->cancelled()};
  WorkProgress report;
  if (bar || callback) {
    report = [&shared](std::string_view stage, double fraction) {
      std::lock_guard<std::mutex> lock(shared.mutex);
      // Consecutive reports of one stage collapse into the latest: every stage is delivered.
      if (!shared.events.empty() && shared.events.back().first == stage) {
        shared.events.back().second = fraction;
      } else {
        shared.events.emplace_back(std::string(stage), fraction);
      }
      shared.changed.notify_one();
    };
  }

  std::thread worker([&shared, &work, &cancel, &report] {
    std::exception_ptr error;
    try {
      work(&cancel, report);
    } catch (...) {
      error = std::current_exception();
    }
    std::lock_guard<std::mutex> lock(shared.mutex);
    shared.error = error;
    shared.finished = true;
    shared.changed.notify_all();
  });
  JoinOnExit join(worker, cancel);

  // The first Python exception (KeyboardInterrupt, the callback's) stops the computation and
  // is raised once the worker is done.
  std::optional<py::error_already_set> raised;
  for (bool done = false; !done;) {
    std::vector<std::pair<std::string, double>> events;
    {
      py::gil_scoped_release unlocked;
      std::unique_lock<std::mutex> lock(shared.mutex);
      shared.changed.wait_for(lock, kSlice,
                              [&] { return shared.finished || !shared.events.empty(); });
      events.swap(shared.events);
      done = shared.finished;
    }
    for (const auto& [stage, fraction] : events) {
      if (raised) break;
      try {
        if (bar) text_bar(stage, fraction);
        if (callback) progress(stage, fraction);
      } catch (py::error_already_set& e) {
        raised.emplace(std::move(e));
        cancel = true;
      }
    }
    if (!raised && PyErr_CheckSignals() != 0) {
      raised.emplace();  // fetches the KeyboardInterrupt (or a signal handler's exception)
      cancel = true;
    }
    if (!raised && token != nullptr && token->cancelled()) cancel = true;
  }
  {
    py::gil_scoped_release unlocked;
    worker.join();
  }
  if (bar) text_bar.finish();
  if (raised) throw std::move(*raised);
  if (shared.error) std::rethrow_exception(shared.error);
}

api::Result compute_in_python(PyScene& scene, api::ComputeOptions options,
                              const py::object& progress, CancelToken* token) {
  Reading reading(scene);
  const api::Scene& input = scene.scene;
  std::optional<api::Result> result;
  run_in_python(
      [&](const std::atomic<bool>* cancel, const WorkProgress& report) {
        options.cancel = cancel;
        options.progress = report;
        result.emplace(api::compute(input, options));
      },
      progress, token);
  return std::move(*result);
}

}  // namespace gvd::python
