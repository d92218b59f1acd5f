#pragma once

// gvd.compute: gvd::api::compute on a worker thread, while the calling thread (holding the
// GIL only briefly, every few milliseconds) delivers progress to Python, notices Ctrl-C
// (PyErr_CheckSignals) and a gvd.CancelToken, and asks the computation to stop.

#include <pybind11/pybind11.h>

#include <atomic>

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

/// Runs api::compute(scene, options) without the GIL. `progress`: None/False (nothing), True
/// (a text bar on sys.stderr) or a callable(stage: str, fraction: float), called on the
/// calling thread, in order; an exception it raises stops the computation and propagates.
/// Ctrl-C stops it and raises KeyboardInterrupt; `cancel` (a CancelToken or None) set raises
/// gvd.Cancelled. Returns once the worker thread has finished, whatever happens.
api::Result compute_in_python(PyScene& scene, api::ComputeOptions options,
                              const py::object& progress, CancelToken* cancel);

}  // namespace gvd::python
