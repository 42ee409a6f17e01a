// libFuzzer target, structure-aware: the bytes are a program that builds a scene of arbitrary size and depth (nested
// transforms by the thousand, long attribute values, many objects), which the byte-level fuzz_scene, at a few kB,
// never reaches: 16,000 nested <translate> (480 kB) once crashed the loader by recursion. The loader may accept the
// scene or refuse it with one line of hpcgi::UsageError; anything else is a bug (as in fuzz_scene.cpp).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "common/errors.hpp"
#include "radiosity/scene/rrv_reader.hpp"
#include "tests/fuzz/fuzz_setup.hpp"

namespace {

// Each byte is an instruction (its low 3 bits) and the next byte its argument.
std::string build(const uint8_t* data, size_t size) {
  static const char* kOpen[] = {"<translate dx=\"%\" dy=\"1\">", "<scale dx=\"%\" dy=\"1\" dz=\"1\">",
                                "<rotate angle=\"%\" dx=\"0\" dy=\"0\" dz=\"1\">", "<shear dx=\"%\">"};
  static const char* kClose[] = {"</translate>", "</scale>", "</rotate>", "</shear>"};
  std::string body, stack;  // stack: the kinds open, innermost last
  auto number = [](uint8_t b) { return std::to_string(int(b) - 128) + (b & 1 ? ".5" : ""); };
  auto open = [&](int kind, uint8_t arg) {
    std::string tag = kOpen[kind];
    tag.replace(tag.find('%'), 1, number(arg));
    body += tag;
    stack.push_back(char(kind));
  };
  for (size_t i = 0; i < size && body.size() < (4u << 20); i += 2) {
    const uint8_t op = data[i] & 7, arg = i + 1 < size ? data[i + 1] : 0;
    if (op < 4) {
      open(op, arg);
    } else if (op == 4 && !stack.empty()) {
      body += kClose[int(stack.back())];
      stack.pop_back();
    } else if (op == 5) {
      body += "<object name=\"o\"/>";
    } else if (op == 6) {  // a run of nested levels: thousands from a few bytes
      for (int k = 0; k < 64 * (int(arg) + 1); ++k) open(k % 4, arg);
    } else if (op == 7) {  // a long value where a number belongs
      body += "<translate dx=\"" + std::string(4096 * (size_t(arg) + 1), '9') + "\">";
      stack.push_back(0);
    }
  }
  body += "<object name=\"o\"/>";
  while (!stack.empty()) {
    body += kClose[int(stack.back())];
    stack.pop_back();
  }
  return "<scene><head><objectdef name=\"o\"><triangleset name=\"o\" emission=\"1,1,1\" reflectivity=\".5,.5,.5\">"
         "<triangle><vertex x=\"0\" y=\"0\" z=\"0\"/><vertex x=\"1\" y=\"0\" z=\"0\"/><vertex x=\"0\" y=\"1\" z=\"0\"/>"
         "</triangle></triangleset></objectdef></head><body>" +
         body + "</body></scene>";
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    radiosity::load_rrv_scene_string(build(data, size), fuzz::scene_options(), "fuzz");
  } catch (const hpcgi::UsageError& e) {
    if (std::string(e.what()).find_first_of("\r\n") != std::string::npos) std::abort();
  }
  return 0;
}
