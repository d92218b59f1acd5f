#include "py_errors.h"

#include <array>
#include <cstddef>
#include <exception>
#include <regex>
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

/// Where the core's detail says the error is: "object 2 (\"b\")", "triangle 7", ...
void parse_detail(const std::string& detail, py::object& label, py::object& object,
                  py::object& element, py::object& index) {
  static const std::regex object_with_label(R"re(object (\d+) \("([^"]*)"\))re");
  static const std::regex duplicate(R"re(duplicate label "([^"]*)": objects \d+ and (\d+))re");
  static const std::regex unknown_label(R"re(no object labelled '([^']*)')re");
  static const std::regex object_index(R"re((?:^|[^a-z])object (?:with index )?(\d+))re");
  static const std::regex element_index(R"re((vertex|triangle|segment|point) (\d+))re");
  std::smatch m;
  if (std::regex_search(detail, m, object_with_label)) {
    object = py::int_(std::stoll(m[1].str()));
    label = py::str(m[2].str());
  } else if (std::regex_search(detail, m, duplicate)) {
    label = py::str(m[1].str());
    object = py::int_(std::stoll(m[2].str()));
  } else if (std::regex_search(detail, m, unknown_label)) {
    label = py::str(m[1].str());
  } else if (std::regex_search(detail, m, object_index)) {
    object = py::int_(std::stoll(m[1].str()));
  }
  if (std::regex_search(detail, m, element_index)) {
    element = py::str(m[1].str());
    index = py::int_(std::stoll(m[2].str()));
  }
}

void set_error(const Error& error, const ErrorContext& context) {
  PyObject* cls = classes[static_cast<size_t>(error.code())];
  if (cls == nullptr) {  // not registered (cannot happen once the module is imported)
    PyErr_SetString(PyExc_RuntimeError, error.what());
    return;
  }
  py::object label = py::none(), object = py::none(), element = py::none(), index = py::none();
  parse_detail(error.detail(), label, object, element, index);
  if (context.label) label = py::str(*context.label);
  if (context.object) object = py::int_(*context.object);
  py::object instance = py::reinterpret_borrow<py::object>(cls)(error.what());
  instance.attr("code") = py::str(std::string(error_code_name(error.code())));
  instance.attr("detail") = py::str(error.detail());
  instance.attr("label") = label;
  instance.attr("object") = object;
  instance.attr("element") = element;
  instance.attr("index") = index;
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
