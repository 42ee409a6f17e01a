// libFuzzer target: any bytes as a form-factor file for the mesh of fuzz_setup.hpp. The reader takes a path, so
// the bytes go to an in-memory file (memfd) opened by its /proc path: no disk traffic, no change to the API.
// Accepted, or refused with a one-line hpcgi::UsageError, are the only allowed outcomes.
#include <sys/mman.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "common/errors.hpp"
#include "radiosity/formfactor/file/format.hpp"
#include "tests/fuzz/fuzz_setup.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const radiosity::Mesh mesh = fuzz::ff_mesh();
  static const int fd = memfd_create("ff", 0);
  static const std::string path = "/proc/self/fd/" + std::to_string(fd);
  if (fd < 0 || ftruncate(fd, 0) != 0 || pwrite(fd, data, size, 0) != static_cast<ssize_t>(size)) std::abort();
  try {
    radiosity::load_form_factors(path, mesh);
  } catch (const hpcgi::UsageError& e) {
    // A refusal is one line on stderr (common/cli.hpp), however odd the input it quotes.
    if (std::string(e.what()).find_first_of("\r\n") != std::string::npos) std::abort();
  }
  return 0;
}
