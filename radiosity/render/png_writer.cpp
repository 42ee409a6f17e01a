// libpng encoding through a temporary file and a rename; see png_writer.hpp.
#include "radiosity/render/png_writer.hpp"
#include "common/files.hpp"

#include <png.h>

#include <cerrno>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace radiosity {
namespace {

// libpng reports errors by longjmp; this carries its message out. Nothing between setjmp and longjmp below owns
// a destructor, so the jump skips no cleanup.
struct PngError {
  std::jmp_buf jump;
  char message[256];
};

void on_png_error(png_structp png, png_const_charp msg) {
  PngError* err = static_cast<PngError*>(png_get_error_ptr(png));
  std::snprintf(err->message, sizeof err->message, "%s", msg);
  std::longjmp(err->jump, 1);
}

void on_png_warning(png_structp, png_const_charp) {}

// Encodes img into f; false with err.message set when libpng fails (a write error included).
bool encode(std::FILE* f, const Image& img, PngError& err) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &err, on_png_error, on_png_warning);
  if (!png) {
    std::snprintf(err.message, sizeof err.message, "out of memory");
    return false;
  }
  png_infop info = png_create_info_struct(png);
  if (!info || setjmp(err.jump)) {
    if (!info) std::snprintf(err.message, sizeof err.message, "out of memory");
    png_destroy_write_struct(&png, info ? &info : nullptr);
    return false;
  }
  png_init_io(png, f);
  png_set_IHDR(png, info, static_cast<png_uint_32>(img.width), static_cast<png_uint_32>(img.height), 8,
               PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  for (int y = 0; y < img.height; ++y) png_write_row(png, &img.rgb[3 * static_cast<size_t>(y) * img.width]);
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return true;
}

}  // namespace

void write_png(const std::string& path, const Image& img) {
  if (img.width < 1 || img.height < 1 || img.rgb.size() != 3 * static_cast<size_t>(img.width) * img.height)
    throw std::invalid_argument("write_png: the image's size and pixel count disagree");
  hpcgi::files::AtomicFile out(path);  // a unique temporary file beside it, renamed over it when whole
  PngError err{};
  if (!encode(out.stream(), img, err)) out.fail(err.message);
  out.commit();  // buffered bytes reach the disk only here: a full disk shows at the flush, not in libpng
}

}  // namespace radiosity
