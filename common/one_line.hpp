// Messages quote the input they refuse, and input may hold any byte: a form-factor header's name fields, an XML
// attribute with &#10; in it. A refusal is one line on stderr (cli.hpp), so control characters are shown escaped.
#pragma once
#include <cstdio>
#include <string>
#include <string_view>

namespace hpcgi {

// s with every control character (bytes 0-31 and 127) written as \xHH; other bytes, UTF-8 included, as they are.
// A long value is cut after `max` bytes and says how long it was: a 10 MB attribute makes no 10 MB message.
inline std::string one_line(std::string_view s, size_t max = 200) {
  std::string out;
  const size_t total = s.size();
  if (total > max) s = s.substr(0, max);
  out.reserve(s.size() + 32);
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
  if (total > max) out += "... (" + std::to_string(total) + " bytes)";
  return out;
}

}  // namespace hpcgi
