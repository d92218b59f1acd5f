#pragma once

// gvd.compute and gvd.grid: the facade's computation on a worker thread, while the calling
// thread (holding the GIL only briefly, every few milliseconds) delivers progress to Python,
// notices Ctrl-C (PyErr_CheckSignals) and a gvd.CancelToken, and asks the computation to stop.

#include <pybind11/pybind11.h>

#include <atomic>
#include <functional>
#include <string_view>

#include "gvd/gvd.h"

namespace gvd::python {

namespace py = pybind11;

/// gvd.Scene: the facade's scene, and how many computations are reading it (add() refuses
/// to change a scene while a computation, which runs without the GIL, reads it).
struct PyScene {
  explicit PyScene(int dimension) : scene(dimension) {}
  explicit PyScene(api::Scene s) : scene(std::move(s)) {}
  api::Scene scene;
  int computing = 0;  ///< guarded by the GIL
};

/// gvd.CancelToken: a flag another Python thread (or a progress callback) may set to stop a
/// running compute(), which then raises gvd.Cancelled.
class CancelToken {
 public:
  void cancel() { flag_ = true; }
  void reset() { flag_ = false; }
  bool cancelled() const { return flag_; }

 private:
  std::atomic<bool> flag_{false};
};

/// Where a computation run by run_in_python reports progress (empty: nobody listens).
using WorkProgress = std::function<void(std::string_view stage, double fraction)>;

/// Runs `work(cancel, progress)` on a worker thread without the GIL; `work` must read `cancel`
/// and report to `progress` (when set) as the facade's options do. `progress` and `token` as
/// for compute_in_python. Returns once the worker thread has finished; rethrows its error.
void run_in_python(const std::function<void(const std::atomic<bool>*, const WorkProgress&)>& work,
                   const py::object& progress, CancelToken* token);

/// Marks a scene as read by a computation for the scope (GIL held on both ends): add()
/// refuses to change it meanwhile.
class Reading {
 public:
  explicit Reading(PyScene& scene) : scene_(scene) { ++scene_.computing; }
  Reading(const Reading&) = delete;
  Reading& operator=(const Reading&) = delete;
  ~Reading() { --scene_.computing; }

 private:
  PyScene& scene_;
};

/// Runs api::compute(scene, options) without the GIL (run_in_python). `progress`: None/False
/// (nothing), True (a text bar on sys.stderr) or a callable(stage: str, fraction: float), called on
/// the calling thread, in order; an exception it raises stops the computation and propagates.
/// Ctrl-C stops it and raises KeyboardInterrupt; `cancel` (a CancelToken or None) set raises
/// gvd.Cancelled. Returns once the worker thread has finished, whatever happens.
api::Result compute_in_python(PyScene& scene, api::ComputeOptions options,
                              const py::object& progress, CancelToken* cancel);

}  // namespace gvd::python
