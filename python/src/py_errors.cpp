#include "py_errors.h"

#include <array>
#include <cstddef>
#include <exception>
#include <utility>

namespace gvd::python {

namespace {

/// The one table: ErrorCode -> Python class name, the built-in exception it also derives
/// from (so that `except ValueError` keeps working), and its docstring.
struct ErrorClass {
  ErrorCode code;
  const char* name;
  PyObject* builtin;  // nullptr: only gvd.Error
  const char* doc;
};

constexpr size_t kCodes = static_cast<size_t>(ErrorCode::kInternal) + 1;

std::array<ErrorClass, kCodes> error_table() {
  return {{
      {ErrorCode::kInvalidScene, "InvalidScene", PyExc_ValueError,
       "The scene's geometry is malformed (label, object, element and index say where)."},
      {ErrorCode::kInvalidArgument, "InvalidArgument", PyExc_ValueError,
       "An option, array shape or query is malformed or out of range."},
      {ErrorCode::kUnsupportedFormat, "UnsupportedFormat", PyExc_ValueError,
       "A scene file's format is not recognised."},
      {ErrorCode::kOutsideDomain, "OutsideDomain", PyExc_ValueError,
       "A query point lies outside the computed domain."},
      {ErrorCode::kLimitExceeded, "LimitExceeded", nullptr,
       "A configured limit (max_objects, max_simplices, max_leaves) was hit."},
      {ErrorCode::kNotFound, "NotFound", PyExc_LookupError,
       "An unknown object label or index, or a missing file."},
      {ErrorCode::kIo, "IoError", PyExc_OSError, "Reading or writing a file failed."},
      {ErrorCode::kCancelled, "Cancelled", nullptr,
       "The computation was cancelled through a gvd.CancelToken."},
      {ErrorCode::kInternal, "InternalError", PyExc_RuntimeError,
       "A bug in gvd: an internal consistency check failed."},
  }};
}

/// The classes, created once by register_errors (owned by the module from then on).
std::array<PyObject*, kCodes> classes{};

void set_error(const Error& error, const ErrorContext& context) {
  PyObject* cls = classes[static_cast<size_t>(error.code())];
  if (cls == nullptr) {  // not registered (cannot happen once the module is imported)
    PyErr_SetString(PyExc_RuntimeError, error.what());
    return;
  }
  // Where: the core's structured location (gvd::ErrorLocation), never the detail's text.
  const ErrorLocation& where = error.where();
  py::object label =
      where.label.empty() ? py::object(py::none()) : py::object(py::str(where.label));
  py::object object =
      where.object < 0 ? py::object(py::none()) : py::object(py::int_(where.object));
  py::object element =
      where.element.empty() ? py::object(py::none()) : py::object(py::str(where.element));
  py::object index = where.index < 0 ? py::object(py::none()) : py::object(py::int_(where.index));
  if (context.label) label = py::str(*context.label);
  if (context.object) object = py::int_(*context.object);
  py::object instance = py::reinterpret_borrow<py::object>(cls)(error.what());
  instance.attr("code") = py::str(std::string(error_code_name(error.code())));
  instance.attr("detail") = py::str(error.detail());
  instance.attr("label") = label;
  instance.attr("object") = object;
  instance.attr("element") = element;
  instance.attr("index") = index;
  instance.attr("line") =
      where.line < 0 ? py::object(py::none()) : py::object(py::int_(where.line));
  instance.attr("offset") =
      where.offset < 0 ? py::object(py::none()) : py::object(py::int_(where.offset));
  PyErr_SetObject(cls, instance.ptr());
}

}  // namespace

void register_errors(py::module_& module) {
  py::dict attributes;
  attributes["code"] = py::none();
  attributes["detail"] = py::str("");
  attributes["label"] = py::none();
  attributes["object"] = py::none();
  attributes["element"] = py::none();
  attributes["index"] = py::none();
  attributes["line"] = py::none();
  attributes["offset"] = py::none();
  PyObject* base = PyErr_NewExceptionWithDoc(
      "gvd.Error",
      "A gvd::Error of the core. str(e) is \"<code>: <detail>\". Attributes:\n"
      "  code     the code's stable name: 'invalid_scene', 'invalid_argument',\n"
      "           'unsupported_format', 'outside_domain', 'limit_exceeded', 'not_found',\n"
      "           'io_error', 'cancelled' or 'internal'\n"
      "  detail   what is wrong and where (the core's message)\n"
      "  label    the object's label, when the error names one (else None)\n"
      "  object   the object's index in the scene (order of Scene.add), or None\n"
      "  element  'vertex', 'triangle', 'segment' or 'point' when the error names one\n"
      "  index    that element's index within the object (or the batch), or None\n"
      "  line     the line (1-based) of a text mesh file (OBJ, PLY header, STL, OFF), or None\n"
      "  offset   the byte offset (0-based) into JSON text where it is malformed, or None\n"
      "Each code has its own subclass (gvd.InvalidScene, gvd.NotFound, ...).",
      PyExc_Exception, attributes.ptr());
  if (base == nullptr) throw py::error_already_set();
  module.attr("Error") = py::reinterpret_steal<py::object>(base);
  for (const ErrorClass& c : error_table()) {
    py::tuple bases = c.builtin != nullptr ? py::make_tuple(py::handle(base), py::handle(c.builtin))
                                           : py::make_tuple(py::handle(base));
    py::dict dict;
    dict["code"] = py::str(std::string(error_code_name(c.code)));
    const std::string name = std::string("gvd.") + c.name;
    PyObject* cls = PyErr_NewExceptionWithDoc(name.c_str(), c.doc, bases.ptr(), dict.ptr());
    if (cls == nullptr) throw py::error_already_set();
    module.attr(c.name) = py::reinterpret_steal<py::object>(cls);
    classes[static_cast<size_t>(c.code)] = cls;  // the module holds the reference
  }
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const Error& e) {
      set_error(e, {});
    }
  });
}

py::error_already_set error_for(const Error& error, const ErrorContext& context) {
  set_error(error, context);
  return py::error_already_set();
}

}  // namespace gvd::python
