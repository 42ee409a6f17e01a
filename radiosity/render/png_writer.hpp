// Pictures to PNG files (libpng).
#pragma once
#include <string>

#include "radiosity/render/image.hpp"

namespace radiosity {

// Writes img as an 8-bit RGB PNG: first to a unique temporary file, then renamed to path (common/files.hpp), so a failed or killed write
// never leaves a half-written PNG at path. Throws std::runtime_error naming the path when the file cannot be
// written (no such folder, no permission, disk full), std::invalid_argument for an image whose size and pixel
// count disagree.
void write_png(const std::string& path, const Image& img);

}  // namespace radiosity
