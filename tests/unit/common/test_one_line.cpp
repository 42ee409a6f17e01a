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

TEST(OneLine, IsSafeForATerminal) {
  // C1 controls (U+009B is an 8-bit CSI), bidirectional overrides, invalid UTF-8 and an overlong NUL
  EXPECT_EQ(hpcgi::one_line("a\xc2\x9b" "31mb"), "a\\u009b31mb");
  EXPECT_EQ(hpcgi::one_line("light\xe2\x80\xae" "fel"), "light\\u202efel");
  EXPECT_EQ(hpcgi::one_line("x\xff\xfe\x9b" "y"), "x\\xff\\xfe\\x9by");
  EXPECT_EQ(hpcgi::one_line("\xc0\x80"), "\\xc0\\x80");
  EXPECT_EQ(hpcgi::one_line("\xe2\x82"), "\\xe2\\x82");  // cut short
  EXPECT_EQ(hpcgi::one_line("\x1b]0;title\x07"), "\\x1b]0;title\\x07");
  EXPECT_EQ(hpcgi::one_line("\xf0\x9f\x92\xa1 \xe2\x82\xac"), "\xf0\x9f\x92\xa1 \xe2\x82\xac");  // emoji, euro: kept
}
