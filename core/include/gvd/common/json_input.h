#pragma once

// JSON input parsed the one way every reader of user JSON uses: nesting capped first
// (json_depth.h), then nlohmann's parser, with its errors said in our words — where (the
// byte offset) and what, without the library's exception names.

#include <atomic>
#include <nlohmann/json.hpp>
#include <string_view>

#include "gvd/common/error.h"

namespace gvd {

/// Parses `text`. Throws gvd::Error{code} naming `what` ("the scene") on nesting deeper than
/// kMaxJsonDepth, malformed JSON ("JSON parse error at byte N: ...", location.offset = N, 0-based)
/// and number literals that do not fit a double (their byte offset found in the text).
/// With `cancel`, the parse reads the flag every 65,536 values and keys (~0.4 MB of a scene's
/// numbers, a few ms) and stops with gvd::Error{kCancelled} once it is set: a 64 MB scene
/// takes about a second to parse.
nlohmann::json parse_json_input(std::string_view text, std::string_view what, ErrorCode code,
                                const std::atomic<bool>* cancel = nullptr);

/// nlohmann's message without its "[json.exception.parse_error.101] " prefix.
std::string_view plain_json_message(std::string_view what);

}  // namespace gvd
