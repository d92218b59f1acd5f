// check_json_depth: the nesting cap checked on JSON text before parsing.
#include "gvd/common/json_depth.h"

#include <gtest/gtest.h>

#include <string>

namespace gvd {
namespace {

std::string nested(size_t levels, char open = '[', char close = ']') {
  return std::string(levels, open) + std::string(levels, close);
}

TEST(JsonDepth, AcceptsUpToTheCapAndNamesTheByteBeyondIt) {
  EXPECT_NO_THROW(check_json_depth(nested(kMaxJsonDepth), "x", ErrorCode::kInvalidScene));
  EXPECT_NO_THROW(
      check_json_depth("{\"a\":[1,{\"b\":[]}],\"c\":{}}", "x", ErrorCode::kInvalidScene, 4));
  try {
    check_json_depth("{\"a\":[1,{\"b\":[[]]}]}", "the scene", ErrorCode::kInvalidArgument, 3);
    ADD_FAILURE() << "five levels passed a cap of three";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
    EXPECT_EQ(e.detail(), "the scene: JSON nested deeper than 3 levels (at byte 13)");
    EXPECT_EQ(e.where().offset, 13);  // the fourth opening bracket
  }
  // 100,000 levels (what crashed the server's error messages) are refused, not parsed.
  EXPECT_THROW(check_json_depth(nested(100000), "x", ErrorCode::kInvalidScene), Error);
}

TEST(JsonDepth, BracketsInsideStringsDoNotCount) {
  const std::string deep_text = "[\"" + nested(500) + "\", \"\\\"[[[[\", \"\\\\\"]";
  EXPECT_NO_THROW(check_json_depth(deep_text, "x", ErrorCode::kInvalidScene, 1));
  // An escaped quote does not end the string; an escaped backslash before a quote does.
  EXPECT_THROW(check_json_depth("[\"\\\\\", [[]]]", "x", ErrorCode::kInvalidScene, 2), Error);
}

}  // namespace
}  // namespace gvd
