// hpcgi::sha256 against FIPS 180-4's examples and a length across the padding boundary (Python's hashlib).
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "common/sha256.hpp"

namespace {
std::string hex(const std::array<uint8_t, 32>& h) {
  std::string s;
  char b[3];
  for (uint8_t x : h) std::snprintf(b, sizeof b, "%02x", x), s += b;
  return s;
}
}  // namespace

TEST(Sha256, KnownDigests) {
  EXPECT_EQ(hex(hpcgi::sha256("")), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(hex(hpcgi::sha256("abc")), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(hex(hpcgi::sha256("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq")),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  EXPECT_EQ(hex(hpcgi::sha256(std::string(1000, 'a'))),
            "41edece42d63e8d9bf515a9ba6932e1c20cbc9f5a5d134645adb5db1b9737ea3");
}
