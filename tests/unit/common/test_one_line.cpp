// hpcgi::one_line: what a refusal quotes from its input stays on one line and keeps everything else.
#include <gtest/gtest.h>

#include <string>

#include "common/one_line.hpp"

TEST(OneLine, EscapesControlCharactersOnly) {
  EXPECT_EQ(hpcgi::one_line("plain text, 1.5e3 \"quoted\""), "plain text, 1.5e3 \"quoted\"");
  EXPECT_EQ(hpcgi::one_line("a\nb\rc\td"), "a\\x0ab\\x0dc\\x09d");
  EXPECT_EQ(hpcgi::one_line(std::string("nul\0del\x7f", 8)), "nul\\x00del\\x7f");
  EXPECT_EQ(hpcgi::one_line("gr\xc3\xbcn"), "gr\xc3\xbcn");  // UTF-8 passes as it is
}
