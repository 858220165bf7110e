// porta::json_string (porta/json_text.hpp), the one JSON string escaper of every report: hand-worked
// literals for quotes, backslashes, the short escapes, other control characters and UTF-8.
#include <gtest/gtest.h>

#include <string>

#include "porta/json_text.hpp"

namespace porta {
namespace {

TEST(JsonString, EscapesWhatJsonRequiresAndNothingElse) {
  EXPECT_EQ(json_string(""), "\"\"");
  EXPECT_EQ(json_string("plain text, 1.5 m"), "\"plain text, 1.5 m\"");
  EXPECT_EQ(json_string("say \"hi\""), "\"say \\\"hi\\\"\"");
  EXPECT_EQ(json_string("C:\\maps\\a.pmap"), "\"C:\\\\maps\\\\a.pmap\"");
  EXPECT_EQ(json_string("two\nlines\tand a tab"), "\"two\\nlines\\tand a tab\"");
  EXPECT_EQ(json_string(std::string("nul\0bell\x07", 9)), "\"nul\\u0000bell\\u0007\"");
  EXPECT_EQ(json_string("\x1f"), "\"\\u001f\"");
  EXPECT_EQ(json_string("caf\xc3\xa9 \xe2\x86\x92"), "\"caf\xc3\xa9 \xe2\x86\x92\"");  // UTF-8 as it is
}

}  // namespace
}  // namespace porta
