// Parsing, places (file:line) and strict attribute values for the RRV reader; see xml_input.hpp.
#include "radiosity/scene/xml_input.hpp"

#include <algorithm>
#include <cstring>
#include <charconv>
#include <cmath>
#include <string_view>

#include "common/errors.hpp"
#include "common/one_line.hpp"

namespace radiosity {

namespace {

size_t line_at(const std::string& text, ptrdiff_t offset) {
  const size_t end = std::min(static_cast<size_t>(std::max<ptrdiff_t>(offset, 0)), text.size());
  return 1 + static_cast<size_t>(std::count(text.begin(), text.begin() + static_cast<ptrdiff_t>(end), '\n'));
}

std::string_view trim(std::string_view s) {
  const auto first = s.find_first_not_of(" \t\r\n");
  if (first == std::string_view::npos) return {};
  return s.substr(first, s.find_last_not_of(" \t\r\n") - first + 1);
}

struct Parsed {
  std::optional<double> value;  // nullopt: not a number, or out of range
  bool out_of_range = false;
};

// The whole of s (blanks around it allowed) as a double; std::from_chars so that the locale plays no part.
Parsed to_double(std::string_view s) {
  s = trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  double v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (s.empty() || end != s.data() + s.size()) return {};
  if (ec == std::errc::result_out_of_range) return {std::nullopt, true};
  if (ec != std::errc()) return {};
  return {v};
}

}  // namespace

XmlInput::XmlInput(std::string text, std::string origin) : text_(std::move(text)), origin_(std::move(origin)) {
  const pugi::xml_parse_result r = doc_.load_buffer(text_.data(), text_.size(), pugi::parse_default | pugi::parse_fragment);
  if (!r) {
    throw hpcgi::UsageError(origin_ + ":" + std::to_string(line_at(text_, r.offset)) +
                            ": malformed XML: " + r.description());
  }
  // Text outside the root element is not XML (parsed as a fragment, pugixml keeps it as a node of the document,
  // where it would otherwise drop it).
  for (const pugi::xml_node& c : doc_.children())
    if (c.type() == pugi::node_pcdata || c.type() == pugi::node_cdata)
      throw hpcgi::UsageError(place(c) + ": malformed XML: text outside the root element");
}

size_t XmlInput::line(const pugi::xml_node& n) const { return line_at(text_, n.offset_debug()); }

std::string XmlInput::place(const pugi::xml_node& n) const { return origin_ + ":" + std::to_string(line(n)); }

void XmlInput::fail(const pugi::xml_node& n, const std::string& what) const {
  throw hpcgi::UsageError(place(n) + ": " + hpcgi::one_line(what));
}

void XmlInput::allow_only(const pugi::xml_node& n, const std::vector<std::string>& allowed) const {
  for (const pugi::xml_attribute& a : n.attributes()) {
    // A value is UTF-8 text (pugixml converts a file declared in another encoding to it, and checks nothing): a name
    // goes into records, messages and the web page as it is.
    const std::string_view v = a.value();
    uint32_t cp = 0;
    for (size_t i = 0, len = 0; i < v.size(); i += len)
      if ((len = hpcgi::utf8_at(v, i, cp)) == 0)
        fail(n, std::string("attribute '") + a.name() + "' of <" + n.name() + "> is not UTF-8 text: '" + std::string(v) + "'");
    // XML forbids an attribute twice on one element (pugixml keeps both; which one would count is a guess)
    for (pugi::xml_attribute b = a.next_attribute(); b; b = b.next_attribute())
      if (std::strcmp(a.name(), b.name()) == 0) fail(n, std::string("attribute '") + a.name() + "' twice on <" + n.name() + ">");
    if (std::find(allowed.begin(), allowed.end(), a.name()) != allowed.end()) continue;
    std::string list;
    for (const std::string& name : allowed) list += (list.empty() ? "" : ", ") + name;
    fail(n, std::string("unknown attribute '") + a.name() + "' on <" + n.name() + ">" +
                (list.empty() ? " (it takes none)" : " (it takes " + list + ")"));
  }
}

std::string XmlInput::text(const pugi::xml_node& n, const char* name) const {
  const pugi::xml_attribute a = n.attribute(name);
  if (!a || trim(a.value()).empty()) fail(n, std::string("<") + n.name() + "> needs a non-empty '" + name + "'");
  return a.value();
}

double XmlInput::number(const pugi::xml_node& n, const char* name, std::optional<double> fallback) const {
  const pugi::xml_attribute a = n.attribute(name);
  if (!a) {
    if (fallback) return *fallback;
    fail(n, std::string("<") + n.name() + "> needs the attribute '" + name + "'");
  }
  const Parsed p = to_double(a.value());
  const std::string what = std::string("'") + name + "' of <" + n.name() + "> ";
  if (p.out_of_range) fail(n, what + "is out of range: \"" + a.value() + "\"");
  if (!p.value) fail(n, what + "is not a number: \"" + a.value() + "\"");
  if (!std::isfinite(*p.value)) fail(n, what + "is not finite: \"" + a.value() + "\"");
  return *p.value;
}

std::optional<Rgb> XmlInput::colour(const pugi::xml_node& n, const char* name) const {
  const pugi::xml_attribute a = n.attribute(name);
  if (!a) return std::nullopt;
  const std::string_view s = a.value();
  auto bad = [&](const std::string& why) {
    fail(n, std::string("'") + name + "' of <" + n.name() + "> " + why + ": \"" + a.value() + "\"");
  };
  Rgb c{};
  size_t start = 0;
  for (int k = 0; k < 3; ++k) {
    const size_t comma = s.find(',', start);
    if ((k < 2) != (comma != std::string_view::npos)) bad("must be three numbers r,g,b");
    const Parsed p = to_double(s.substr(start, comma == std::string_view::npos ? s.npos : comma - start));
    if (p.out_of_range) bad("has a channel out of range");
    if (!p.value) bad("must be three numbers r,g,b");
    if (!std::isfinite(*p.value)) bad("has a channel that is not finite");
    if (*p.value < 0) bad("has a negative channel");
    c[k] = *p.value;
    start = comma + 1;
  }
  return c;
}

}  // namespace radiosity
