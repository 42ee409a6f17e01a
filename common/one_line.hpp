// Messages quote the input they refuse, and input may hold any byte: a form-factor header's name fields, an XML
// attribute with &#10; in it. A refusal is one line on stderr (cli.hpp), so control characters are shown escaped.
#pragma once
#include <cstdio>
#include <string>
#include <string_view>

namespace hpcgi {

// s with every control character (bytes 0-31 and 127) written as \xHH; other bytes, UTF-8 included, as they are.
inline std::string one_line(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (const char ch : s) {
    const unsigned char c = static_cast<unsigned char>(ch);
    if (c >= 0x20 && c != 0x7f) {
      out += ch;
    } else {
      char esc[5];
      std::snprintf(esc, sizeof esc, "\\x%02x", c);
      out += esc;
    }
  }
  return out;
}

}  // namespace hpcgi
