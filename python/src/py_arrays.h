#pragma once

// numpy in and out of the facade's flat arrays (gvd/gvd.h), without copies where the layout
// allows: a C-contiguous float64 (n, D) array is read in place, and every array handed back
// owns the facade's std::vector (moved into a capsule), so no element is copied either way.

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "gvd/gvd.h"

namespace gvd::python {

namespace py = pybind11;

/// Numbers as float64 in C order: the array itself when it already is one (no copy), else a
/// converted copy (float32, Fortran order, strided views, lists of lists).
using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

/// Points for a query: (n, D) rows, or one point of shape (D,) (`single`).
struct PointsIn {
  DoubleArray array;  ///< keeps the numbers alive while the facade reads them
  size_t count = 0;
  bool single = false;
  std::span<const double> span() const { return {array.data(), static_cast<size_t>(array.size())}; }
};

/// `what` as float64 points of dimension `dimension`: an (n, D) array or one (D,) point.
/// gvd::Error{kInvalidArgument} for anything else (names `what` and the shape).
PointsIn points_in(py::handle object, int dimension, const char* what);

/// Vertex indices of simplices for gvd::api::Scene::add: an (m, D) integer array (D = 3:
/// triangles, D = 2: segments). A C-contiguous uint32 or int32 array is read in place (int32
/// after checking that no index is negative); other integer types are converted.
struct SimplicesIn {
  py::array array;                  ///< the input, when read in place
  std::vector<uint32_t> converted;  ///< the converted copy otherwise
  std::span<const uint32_t> span;
};

/// gvd::Error{kInvalidArgument} for a wrong shape or a non-integer dtype, {kInvalidScene}
/// naming the simplex for an index below 0 or above 2^32 - 1.
SimplicesIn simplices_in(py::handle object, int dimension);

/// A vector moved into a numpy array of the given shape that owns it (a capsule deletes the
/// vector with the array): no copy. `shape`'s product must be v.size().
template <typename T>
py::array_t<T> to_numpy(std::vector<T>&& v, std::vector<py::ssize_t> shape) {
  if (v.empty()) return py::array_t<T>(shape);  // numpy's own empty array
  auto owned = std::make_unique<std::vector<T>>(std::move(v));
  T* data = owned->data();
  py::capsule owner(owned.get(), [](void* p) { delete static_cast<std::vector<T>*>(p); });
  owned.release();  // the capsule owns it now
  return py::array_t<T>(std::move(shape), data, owner);
}

/// The same for a vector of structs viewed through a structured dtype (the dual graph, the
/// neighbours): one element per struct, no copy.
template <typename T>
py::array struct_array(std::vector<T>&& v, const py::dtype& dtype) {
  const auto n = static_cast<py::ssize_t>(v.size());
  if (v.empty()) return py::array(dtype, std::vector<py::ssize_t>{n});
  auto owned = std::make_unique<std::vector<T>>(std::move(v));
  T* data = owned->data();
  py::capsule owner(owned.get(), [](void* p) { delete static_cast<std::vector<T>*>(p); });
  owned.release();
  return py::array(dtype, std::vector<py::ssize_t>{n},
                   std::vector<py::ssize_t>{static_cast<py::ssize_t>(sizeof(T))}, data, owner);
}

/// The dtype of gvd::api::Edge (fields a, b, area, min_clearance, tightest_point (D,), gap,
/// touching), laid over the struct itself.
py::dtype edge_dtype(int dimension);
/// The dtype of gvd::api::Neighbor (object, ring, via, area, min_clearance, gap, touching).
py::dtype neighbor_dtype();

}  // namespace gvd::python
