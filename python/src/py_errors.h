#pragma once

// gvd::Error as Python exceptions: gvd.Error and one subclass per gvd::ErrorCode (the table in
// py_errors.cpp), each instance carrying the code's name, the detail, and where it happened
// (object label and index, the element and its index) when the core says so.

#include <pybind11/pybind11.h>

#include <optional>
#include <string>

#include "gvd/common/error.h"

namespace gvd::python {

namespace py = pybind11;

/// Creates gvd.Error and its subclasses in `module` and registers the translator that turns
/// every gvd::Error escaping a binding into the subclass of its code.
void register_errors(py::module_& module);

/// What a binding knows of where an error happened, beyond what the core's detail says.
struct ErrorContext {
  std::optional<std::string> label;
  std::optional<int> object;
};

/// Sets the Python error for `error` (the class of its code, with its attributes) and
/// returns the exception to throw: `throw error_for(e, {...});`.
py::error_already_set error_for(const Error& error, const ErrorContext& context = {});

}  // namespace gvd::python
