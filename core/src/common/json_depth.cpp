// The JSON nesting cap (json_depth.h).

#include "gvd/common/json_depth.h"

#include <string>

namespace gvd {

void check_json_depth(std::string_view text, std::string_view what, ErrorCode code,
                      size_t max_depth) {
  size_t depth = 0;
  bool in_string = false;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\') {
        ++i;  // the escaped character, whatever it is
      } else if (c == '"') {
        in_string = false;
      }
      continue;
    }
    if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > max_depth) {
        ErrorLocation where;
        where.offset = static_cast<int64_t>(i);
        throw Error(code,
                    std::string(what) + ": JSON nested deeper than " + std::to_string(max_depth) +
                        " levels (at byte " + std::to_string(i) + ")",
                    where);
      }
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
}

}  // namespace gvd
