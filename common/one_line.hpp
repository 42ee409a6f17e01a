// Messages quote the input they refuse, and input may hold any byte: a form-factor header's name fields, an XML
// attribute with &#10; in it. A refusal is one line on stderr (cli.hpp), so control characters are shown escaped.
#pragma once
#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>

namespace hpcgi {

// The code point of the valid UTF-8 sequence at s[i] and its length, or length 0 where the bytes are no such
// sequence (a stray continuation byte, a truncated or overlong sequence, a surrogate, beyond U+10FFFF).
inline size_t utf8_at(std::string_view s, size_t i, uint32_t& cp) {
  const unsigned char c = static_cast<unsigned char>(s[i]);
  const size_t len = c < 0x80 ? 1 : (c >> 5) == 0x6 ? 2 : (c >> 4) == 0xe ? 3 : (c >> 3) == 0x1e ? 4 : 0;
  if (len == 0 || i + len > s.size()) return 0;
  cp = len == 1 ? c : len == 2 ? c & 0x1f : len == 3 ? c & 0x0f : c & 0x07;
  for (size_t k = 1; k < len; ++k) {
    const unsigned char d = static_cast<unsigned char>(s[i + k]);
    if ((d >> 6) != 0x2) return 0;
    cp = cp << 6 | (d & 0x3f);
  }
  static constexpr uint32_t least[5] = {0, 0, 0x80, 0x800, 0x10000};
  if (cp < least[len] || cp > 0x10ffff || (cp >= 0xd800 && cp <= 0xdfff)) return 0;
  return len;
}

// s made safe for one line of a terminal: every control character (bytes 0-31 and 127) and every byte that is not
// valid UTF-8 written as \xHH; the C1 controls (U+0080-U+009F, which some terminals obey as escapes) and the
// bidirectional controls (U+061C, U+200E, U+200F, U+202A-U+202E, U+2066-U+2069, which reorder what is shown) as
// \uHHHH; other text, UTF-8 included, as it is. A long value is cut after `max` bytes and says how long it was: a
// 10 MB attribute makes no 10 MB message.
inline std::string one_line(std::string_view s, size_t max = 200) {
  std::string out;
  const size_t total = s.size();
  if (total > max) s = s.substr(0, max);
  out.reserve(s.size() + 32);
  char esc[16];
  for (size_t i = 0; i < s.size();) {
    uint32_t cp = 0;
    const size_t len = utf8_at(s, i, cp);
    const bool c0 = len == 1 && (cp < 0x20 || cp == 0x7f);
    const bool hidden = (cp >= 0x80 && cp <= 0x9f) || cp == 0x61c || cp == 0x200e || cp == 0x200f ||
                        (cp >= 0x202a && cp <= 0x202e) || (cp >= 0x2066 && cp <= 0x2069);
    if (len == 0 || c0) {
      std::snprintf(esc, sizeof esc, "\\x%02x", static_cast<unsigned char>(s[i]));
      out += esc;
      ++i;
    } else if (len > 1 && hidden) {
      std::snprintf(esc, sizeof esc, "\\u%04x", static_cast<unsigned>(cp));
      out += esc;
      i += len;
    } else {
      out.append(s.substr(i, len));
      i += len;
    }
  }
  if (total > max) out += "... (" + std::to_string(total) + " bytes)";
  return out;
}

}  // namespace hpcgi
