// write_png: the file reads back with libpng as the same picture, no temporary file is left, and a path that cannot be
// written is a std::runtime_error naming it.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <png.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <stdexcept>
#include <filesystem>
#include <string>
#include <vector>

#include "radiosity/render/png_writer.hpp"

using radiosity::Image;

namespace {

std::string temp_dir() {
  char tmpl[] = "/tmp/render_png_XXXXXX";
  const char* d = mkdtemp(tmpl);
  if (!d) throw std::runtime_error("mkdtemp failed");
  return d;
}

bool exists(const std::string& path) { return std::ifstream(path).good(); }

// A 7 × 5 picture whose every pixel differs: (x·30, y·50, x + y).
Image gradient() {
  Image img;
  img.width = 7;
  img.height = 5;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x)
      for (int v : {x * 30, y * 50, x + y}) img.rgb.push_back(static_cast<std::uint8_t>(v));
  return img;
}

}  // namespace

TEST(Png, ReadsBackAsTheSamePicture) {
  const std::string dir = temp_dir(), path = dir + "/picture.png";
  const Image img = gradient();
  radiosity::write_png(path, img);
  size_t files = 0;
  for (auto it = std::filesystem::directory_iterator(dir); it != std::filesystem::directory_iterator(); ++it) ++files;
  EXPECT_EQ(files, 1u);  // the picture and no temporary file

  png_image back{};
  back.version = PNG_IMAGE_VERSION;
  ASSERT_TRUE(png_image_begin_read_from_file(&back, path.c_str())) << back.message;
  EXPECT_EQ(back.width, 7u);
  EXPECT_EQ(back.height, 5u);
  back.format = PNG_FORMAT_RGB;
  std::vector<std::uint8_t> pixels(PNG_IMAGE_SIZE(back));
  ASSERT_TRUE(png_image_finish_read(&back, nullptr, pixels.data(), 0, nullptr)) << back.message;
  EXPECT_EQ(pixels, img.rgb);
  EXPECT_EQ(pixels[3 * (4 * 7 + 6) + 0], 180);  // pixel (6, 4)
  EXPECT_EQ(pixels[3 * (4 * 7 + 6) + 1], 200);
  EXPECT_EQ(pixels[3 * (4 * 7 + 6) + 2], 10);

  // Writing again replaces the file.
  Image black = img;
  std::fill(black.rgb.begin(), black.rgb.end(), 0);
  radiosity::write_png(path, black);
  png_image again{};
  again.version = PNG_IMAGE_VERSION;
  ASSERT_TRUE(png_image_begin_read_from_file(&again, path.c_str()));
  again.format = PNG_FORMAT_RGB;
  ASSERT_TRUE(png_image_finish_read(&again, nullptr, pixels.data(), 0, nullptr));
  EXPECT_EQ(pixels, black.rgb);
  std::remove(path.c_str());
  rmdir(dir.c_str());
}

TEST(Png, MissingFolderIsARuntimeErrorNamingThePath) {
  const std::string path = "/tmp/render_png_no_such_folder/a/picture.png";
  try {
    radiosity::write_png(path, gradient());
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

TEST(Png, FolderThatIsAFileIsARuntimeError) {
  // Unlike a read-only folder, this fails for root too.
  const std::string dir = temp_dir(), file = dir + "/not_a_folder";
  std::ofstream(file) << "x";
  EXPECT_THROW(radiosity::write_png(file + "/picture.png", gradient()), std::runtime_error);
  std::remove(file.c_str());
  rmdir(dir.c_str());
}

TEST(Png, FullDiskIsARuntimeErrorAndLeavesNoPng) {
  // A file-size limit makes the write fail as a full disk would (EFBIG instead of ENOSPC), at the flush.
  const std::string dir = temp_dir(), path = dir + "/picture.png";
  struct rlimit old {};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old), 0);
  const auto old_handler = signal(SIGXFSZ, SIG_IGN);
  struct rlimit tiny = old;
  tiny.rlim_cur = 64;
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &tiny), 0);
  bool threw = false;
  try {
    radiosity::write_png(path, gradient());
  } catch (const std::runtime_error& e) {
    threw = true;
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  setrlimit(RLIMIT_FSIZE, &old);
  signal(SIGXFSZ, old_handler);
  EXPECT_TRUE(threw) << "no error";
  EXPECT_FALSE(exists(path));
  EXPECT_EQ(rmdir(dir.c_str()), 0) << "a temporary file was left in " << dir;
}
