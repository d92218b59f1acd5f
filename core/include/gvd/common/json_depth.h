#pragma once

// A cap on how deeply a JSON text nests arrays and objects, checked on the text before it is
// parsed: deep nesting, not size, is what exhausts the stack (a 200 KB "[[[[...]]]]" in a
// label crashed `nlohmann::json::dump()` in error messages), and no document gvd reads needs
// more than a handful of levels.

#include <cstddef>
#include <string_view>

#include "gvd/common/error.h"

namespace gvd {

/// Levels of arrays and objects any JSON input may nest (a scene needs 4).
inline constexpr size_t kMaxJsonDepth = 100;

/// Throws gvd::Error{code} naming `what` and the byte offset when `text` nests arrays and
/// objects deeper than `max_depth` (brackets inside strings do not count). O(size); says
/// nothing about whether the text is valid JSON otherwise.
void check_json_depth(std::string_view text, std::string_view what, ErrorCode code,
                      size_t max_depth = kMaxJsonDepth);

}  // namespace gvd
