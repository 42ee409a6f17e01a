// An XML document parsed with pugixml together with the text it came from, so that every complaint about the
// input can name the file and line (pugixml reports byte offsets), and the strict readers of the attribute
// values the RRV format uses: numbers and "r,g,b" colours. All complaints throw hpcgi::UsageError with one line
// "<file>:<line>: <what>".
#pragma once
#include <optional>
#include <pugixml.hpp>
#include <string>
#include <vector>

#include "radiosity/mesh.hpp"

namespace radiosity {

class XmlInput {
 public:
  // Parses `text`; `origin` names it in messages (a file path, or a label for text from elsewhere).
  XmlInput(std::string text, std::string origin);
  XmlInput(const XmlInput&) = delete;
  XmlInput& operator=(const XmlInput&) = delete;

  const pugi::xml_document& document() const { return doc_; }
  const std::string& origin() const { return origin_; }
  size_t line(const pugi::xml_node& n) const;        // 1-based line where the node starts
  std::string place(const pugi::xml_node& n) const;  // "<origin>:<line>"
  [[noreturn]] void fail(const pugi::xml_node& n, const std::string& what) const;

  // Refuses any attribute of n not in `allowed`, so that a misspelt name is not silently read as absent.
  void allow_only(const pugi::xml_node& n, const std::vector<std::string>& allowed) const;
  // A required attribute's value (refused if missing or empty).
  std::string text(const pugi::xml_node& n, const char* name) const;
  // A finite number; `fallback` when the attribute is missing, refused when missing and no fallback is given.
  double number(const pugi::xml_node& n, const char* name, std::optional<double> fallback = std::nullopt) const;
  // "r,g,b": three finite, non-negative numbers, spaces allowed; nullopt when the attribute is missing.
  std::optional<Rgb> colour(const pugi::xml_node& n, const char* name) const;

 private:
  std::string text_;
  std::string origin_;
  pugi::xml_document doc_;
};

}  // namespace radiosity
