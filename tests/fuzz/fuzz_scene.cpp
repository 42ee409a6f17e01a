// libFuzzer target: any bytes as an RRV scene. The loader may accept them or refuse them with hpcgi::UsageError;
// a refusal of more than one line, any other exception, a crash, a sanitizer report, a hang or a runaway
// allocation is a bug.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "common/errors.hpp"
#include "radiosity/scene/rrv_reader.hpp"
#include "tests/fuzz/fuzz_setup.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    radiosity::load_rrv_scene_string(std::string(reinterpret_cast<const char*>(data), size), fuzz::scene_options(),
                                     "fuzz");
  } catch (const hpcgi::UsageError& e) {
    // A refusal is one line on stderr (common/cli.hpp), however odd the input it quotes.
    if (std::string(e.what()).find_first_of("\r\n") != std::string::npos) std::abort();
  }
  return 0;
}
