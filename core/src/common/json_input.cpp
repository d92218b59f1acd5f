#include "gvd/common/json_input.h"

#include <cstdint>
#include <string>

#include "gvd/common/cancel.h"
#include "gvd/common/json_depth.h"

namespace gvd {

std::string_view plain_json_message(std::string_view what) {
  if (what.starts_with("[json.exception.")) {
    const size_t end = what.find("] ");
    if (end != std::string_view::npos) what.remove_prefix(end + 2);
  }
  return what;
}

nlohmann::json parse_json_input(std::string_view text, std::string_view what, ErrorCode code,
                                const std::atomic<bool>* cancel) {
  check_json_depth(text, what, code);
  try {
    if (cancel == nullptr) return nlohmann::json::parse(text.begin(), text.end());
    uint32_t events = 0;
    const nlohmann::json::parser_callback_t poll = [&](int, nlohmann::json::parse_event_t,
                                                       nlohmann::json&) {
      if ((++events & 0xffff) == 0 && is_cancelled(cancel)) {
        throw Error(ErrorCode::kCancelled, "parsing " + std::string(what) + " cancelled");
      }
      return true;
    };
    return nlohmann::json::parse(text.begin(), text.end(), poll);
  } catch (const nlohmann::json::parse_error& e) {
    ErrorLocation where;  // e.byte counts from 1: the character that failed
    where.offset = e.byte > 0 ? static_cast<int64_t>(e.byte) - 1 : 0;
    throw Error(code,
                "JSON parse error at byte " + std::to_string(where.offset) + ": " +
                    std::string(plain_json_message(e.what())),
                where);
  } catch (const nlohmann::json::out_of_range& e) {
    // A number literal too large for a double ("number overflow parsing '1e400'"): nlohmann
    // names the literal, not where it is, so find it (the first one in the text).
    const std::string_view message = plain_json_message(e.what());
    const size_t open = message.find('\'');
    const size_t close = open == std::string_view::npos ? open : message.find('\'', open + 1);
    if (close != std::string_view::npos) {
      const std::string literal(message.substr(open + 1, close - open - 1));
      const size_t at = text.find(literal);
      if (!literal.empty() && at != std::string_view::npos) {
        ErrorLocation where;
        where.offset = static_cast<int64_t>(at);
        throw Error(code,
                    "JSON number " + literal + " at byte " + std::to_string(at) +
                        " is out of the range of a double",
                    where);
      }
    }
    throw Error(code, "JSON parse error: " + std::string(message));
  } catch (const nlohmann::json::exception& e) {
    throw Error(code, "JSON parse error: " + std::string(plain_json_message(e.what())));
  }
}

}  // namespace gvd
