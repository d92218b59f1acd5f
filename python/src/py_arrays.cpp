#include "py_arrays.h"

#include <cstddef>
#include <limits>
#include <type_traits>

namespace gvd::python {

namespace {

std::string shape_of(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) {
    s += std::to_string(a.shape(i));
    if (a.ndim() == 1 || i + 1 < a.ndim()) s += ",";
    if (i + 1 < a.ndim()) s += " ";
  }
  return s + ")";
}

const char* simplex_name(int dimension) { return dimension == 3 ? "triangle" : "segment"; }

/// Checks converted indices (int64 or uint64) and narrows them to uint32.
template <typename T>
std::vector<uint32_t> narrow_indices(const py::array_t<T, py::array::c_style>& a, int dimension) {
  std::vector<uint32_t> out(static_cast<size_t>(a.size()));
  const T* p = a.data();
  for (size_t i = 0; i < out.size(); ++i) {
    const T v = p[i];
    if constexpr (std::is_signed_v<T>) {
      if (v < 0) {
        throw Error(
            ErrorCode::kInvalidScene,
            std::string(simplex_name(dimension)) + " " + std::to_string(i / dimension) +
                " vertex index " + std::to_string(v) + " is negative",
            {.element = simplex_name(dimension), .index = static_cast<int64_t>(i / dimension)});
      }
    }
    if (static_cast<uint64_t>(v) > std::numeric_limits<uint32_t>::max()) {
      throw Error(
          ErrorCode::kInvalidScene,
          std::string(simplex_name(dimension)) + " " + std::to_string(i / dimension) +
              " vertex index " + std::to_string(v) + " is above 2^32 - 1",
          {.element = simplex_name(dimension), .index = static_cast<int64_t>(i / dimension)});
    }
    out[i] = static_cast<uint32_t>(v);
  }
  return out;
}

struct Field {
  const char* name;
  std::string format;  ///< numpy's: "i4", "f8", "?", "(3,)f8" (native byte order)
  size_t offset;
};

/// A structured dtype laid over the struct T: named fields at their offsets, itemsize sizeof(T).
template <typename T>
py::dtype struct_dtype(const std::vector<Field>& fields) {
  py::list names, formats, offsets;
  for (const Field& f : fields) {
    names.append(f.name);
    formats.append(f.format);
    offsets.append(f.offset);
  }
  return py::dtype(names, formats, offsets, sizeof(T));
}

}  // namespace

PointsIn points_in(py::handle object, int dimension, const char* what) {
  PointsIn in;
  in.array = DoubleArray::ensure(object);
  if (!in.array) {
    throw Error(ErrorCode::kInvalidArgument, std::string(what) + " must be an array of numbers");
  }
  const DoubleArray& a = in.array;
  if (a.ndim() == 1 && a.shape(0) == dimension) {
    in.count = 1;
    in.single = true;
  } else if (a.ndim() == 2 && a.shape(1) == dimension) {
    in.count = static_cast<size_t>(a.shape(0));
  } else {
    throw Error(ErrorCode::kInvalidArgument,
                std::string(what) + " must have shape (n, " + std::to_string(dimension) +
                    ") for a " + std::to_string(dimension) + "D scene, not " + shape_of(a));
  }
  return in;
}

SimplicesIn simplices_in(py::handle object, int dimension) {
  SimplicesIn in;
  py::array a = py::array::ensure(object);
  if (!a) {
    throw Error(ErrorCode::kInvalidArgument,
                std::string("the ") + simplex_name(dimension) + "s must be an array of integers");
  }
  if (a.size() == 0) return in;  // compute() says that the object has none
  if (a.ndim() != 2 || a.shape(1) != dimension) {
    throw Error(ErrorCode::kInvalidArgument,
                std::string("the ") + simplex_name(dimension) + "s must have shape (m, " +
                    std::to_string(dimension) + "), not " + shape_of(a));
  }
  const char kind = a.dtype().kind();
  if (kind != 'i' && kind != 'u') {
    throw Error(ErrorCode::kInvalidArgument, std::string("the ") + simplex_name(dimension) +
                                                 "s must be integers, not dtype " +
                                                 py::str(a.dtype()).cast<std::string>());
  }
  const auto size = static_cast<size_t>(a.size());
  if (py::isinstance<py::array_t<uint32_t, py::array::c_style>>(a)) {
    in.span = {static_cast<const uint32_t*>(a.data()), size};
    in.array = std::move(a);
    return in;
  }
  if (py::isinstance<py::array_t<int32_t, py::array::c_style>>(a)) {
    // The same bits as uint32 once no index is negative.
    const auto* p = static_cast<const int32_t*>(a.data());
    for (size_t i = 0; i < size; ++i) {
      if (p[i] < 0) {
        throw Error(
            ErrorCode::kInvalidScene,
            std::string(simplex_name(dimension)) + " " + std::to_string(i / dimension) +
                " vertex index " + std::to_string(p[i]) + " is negative",
            {.element = simplex_name(dimension), .index = static_cast<int64_t>(i / dimension)});
      }
    }
    in.span = {static_cast<const uint32_t*>(a.data()), size};
    in.array = std::move(a);
    return in;
  }
  if (kind == 'u') {
    in.converted = narrow_indices(py::array_t<uint64_t, py::array::c_style>::ensure(a), dimension);
  } else {
    in.converted = narrow_indices(py::array_t<int64_t, py::array::c_style>::ensure(a), dimension);
  }
  in.span = in.converted;
  return in;
}

py::dtype edge_dtype(int dimension) {
  using api::Edge;
  static_assert(std::is_standard_layout_v<Edge>);
  static_assert(sizeof(api::Object) == 4 && sizeof(bool) == 1);
  return struct_dtype<Edge>(
      {{"a", "i4", offsetof(Edge, a)},
       {"b", "i4", offsetof(Edge, b)},
       {"area", "f8", offsetof(Edge, area)},
       {"min_clearance", "f8", offsetof(Edge, min_clearance)},
       {"tightest_point", "(" + std::to_string(dimension) + ",)f8", offsetof(Edge, tightest_point)},
       {"gap", "f8", offsetof(Edge, gap)},
       {"touching", "?", offsetof(Edge, touching)}});
}

py::dtype neighbor_dtype() {
  using api::Neighbor;
  static_assert(std::is_standard_layout_v<Neighbor>);
  static_assert(sizeof(int) == 4);
  return struct_dtype<Neighbor>({{"object", "i4", offsetof(Neighbor, object)},
                                 {"ring", "i4", offsetof(Neighbor, ring)},
                                 {"via", "i4", offsetof(Neighbor, via)},
                                 {"area", "f8", offsetof(Neighbor, area)},
                                 {"min_clearance", "f8", offsetof(Neighbor, min_clearance)},
                                 {"gap", "f8", offsetof(Neighbor, gap)},
                                 {"touching", "?", offsetof(Neighbor, touching)}});
}

}  // namespace gvd::python
