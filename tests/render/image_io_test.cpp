// Image I/O: the OpenEXR fast path of ReadImage against OpenImageIO's reader, which it replaces
// for plain RGB(A) EXR files (render/src/image_oiio.h says why).
#include <gtest/gtest.h>
#include <OpenEXR/ImfRgbaFile.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "shadefit/base/error.h"
#include "shadefit/render/image.h"
#include "test_util.h"

namespace shadefit {
namespace {

namespace fs = std::filesystem;

// OpenImageIO's reading of `path`: ReadImage takes that path whenever metadata is asked for.
Image ReadWithOpenImageIO(const std::string& path) {
  ImageMetadata metadata;
  return ReadImage(path, &metadata);
}

void ExpectSameBits(const Image& a, const Image& b, const std::string& what) {
  ASSERT_EQ(a.width, b.width) << what;
  ASSERT_EQ(a.height, b.height) << what;
  ASSERT_EQ(a.channels, b.channels) << what;
  ASSERT_EQ(a.data.size(), b.data.size()) << what;
  EXPECT_EQ(std::memcmp(a.data.data(), b.data.data(), a.data.size() * sizeof(float)), 0) << what;
}

// A test image with distinct values per channel, row and column, so that a swapped channel, a
// flipped row order or a shifted window shows.
Image Gradient(int w, int h, int channels) {
  Image img(w, h, channels);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      for (int c = 0; c < channels; ++c) img.at(x, y, c) = 0.01f * x + 0.37f * y + 1.5f * c;
    }
  }
  return img;
}

TEST(ImageIo, ExrFastPathMatchesOpenImageIOOnShippedReferences) {
  int files = 0;
  for (const auto& entry :
       fs::directory_iterator(fs::path(SHADEFIT_SOURCE_DIR) / "reference_images" / "cycles")) {
    if (entry.path().extension() != ".exr") continue;
    const std::string path = entry.path().string();
    Image fast;
    ASSERT_TRUE(ReadPlainExr(path, &fast)) << path;
    ExpectSameBits(fast, ReadWithOpenImageIO(path), path);
    ExpectSameBits(ReadImage(path), fast, path);
    ++files;
  }
  EXPECT_GT(files, 40);
}

TEST(ImageIo, ExrFastPathMatchesOpenImageIOOnWrittenFiles) {
  const std::string dir = testing::TestOutputDir("image_io");
  for (const int channels : {3, 4}) {
    const std::string path = dir + "/float" + std::to_string(channels) + ".exr";
    const Image written = Gradient(37, 23, channels);
    WriteExr(path, written);
    Image fast;
    ASSERT_TRUE(ReadPlainExr(path, &fast)) << path;
    ExpectSameBits(fast, written, path);
    ExpectSameBits(fast, ReadWithOpenImageIO(path), path);
  }
  // Half channels (Blender's "Half" colour depth), written with OpenEXR's RGBA interface.
  const std::string path = dir + "/half.exr";
  const Image source = Gradient(19, 11, 4);
  std::vector<Imf::Rgba> pixels(source.PixelCount());
  for (std::size_t i = 0; i < pixels.size(); ++i) {
    pixels[i] = Imf::Rgba(source.data[4 * i], source.data[4 * i + 1], source.data[4 * i + 2],
                          source.data[4 * i + 3]);
  }
  {
    Imf::RgbaOutputFile out(path.c_str(), source.width, source.height, Imf::WRITE_RGBA);
    out.setFrameBuffer(pixels.data(), 1, source.width);
    out.writePixels(source.height);
  }
  Image fast;
  ASSERT_TRUE(ReadPlainExr(path, &fast));
  ExpectSameBits(fast, ReadWithOpenImageIO(path), path);
}

// Anything else is OpenImageIO's: more channels, another format, a file cut short.
TEST(ImageIo, OtherFilesTakeOpenImageIOsPath) {
  const std::string dir = testing::TestOutputDir("image_io");
  const std::string aov = dir + "/aov.exr";
  WriteExr(aov, Gradient(8, 8, 10), {},
           {"P.X", "P.Y", "P.Z", "N.X", "N.Y", "N.Z", "V.X", "V.Y", "V.Z", "coverage"});
  Image image;
  EXPECT_FALSE(ReadPlainExr(aov, &image));
  EXPECT_EQ(ReadImage(aov).channels, 10);

  const std::string png = dir + "/grey.png";
  WritePng8(png, Image(8, 8, 3, 0.5f));
  EXPECT_FALSE(ReadPlainExr(png, &image));
  EXPECT_EQ(ReadImage(png).channels, 3);

  const std::string cut = dir + "/cut.exr";
  WriteExr(cut, Gradient(64, 64, 4));
  fs::resize_file(cut, fs::file_size(cut) / 2);
  EXPECT_FALSE(ReadPlainExr(cut, &image));
  try {
    ReadImage(cut);
    ADD_FAILURE() << "a truncated EXR was read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cut.exr"), std::string::npos) << e.what();
  }
}

// An 8-bit PNG stores each value clamped to [0, 1] and rounded half away from zero (NaN: 0):
// what std::lround gives, at every rounding boundary k + 1/2 of the 255 steps, the floats on
// either side of it, and the values outside [0, 1]; in the colour channels of an RGB image and
// in the alpha channel of an RGBA one (read back, colour is associated with alpha: only alpha
// is compared there).
TEST(ImageIo, Png8RoundsAsLroundAtEveryBoundary) {
  std::vector<float> values = {0.0f, 1.0f, -1.0f, 2.0f, std::numeric_limits<float>::quiet_NaN(),
                               std::numeric_limits<float>::infinity(),
                               -std::numeric_limits<float>::infinity(), 1e-30f};
  for (int k = 0; k < 255; ++k) {
    const float boundary = (static_cast<float>(k) + 0.5f) / 255.0f;
    values.push_back(boundary);
    values.push_back(std::nextafter(boundary, 0.0f));
    values.push_back(std::nextafter(boundary, 1.0f));
  }
  const auto expected = [](float v) {
    return static_cast<int>(std::lround(std::clamp(std::isnan(v) ? 0.0f : v, 0.0f, 1.0f) * 255.0f));
  };
  const auto byte = [](float read) { return static_cast<int>(std::lround(read * 255.0f)); };
  const std::string dir = testing::TestOutputDir("image_io");
  const int n = static_cast<int>(values.size());
  // Two rows each: the second row is stored as its differences from the first (Up filter).
  Image rgb((n + 2) / 3, 2, 3, 0.25f), rgba(n, 2, 4, 1.0f);
  std::copy(values.begin(), values.end(), rgb.data.begin());
  for (int i = 0; i < n; ++i) rgba.at(i, 0, 3) = values[i];
  WritePng8(dir + "/rounding-rgb.png", rgb);
  WritePng8(dir + "/rounding-rgba.png", rgba);
  const Image read_rgb = ReadImage(dir + "/rounding-rgb.png");
  const Image read_rgba = ReadImage(dir + "/rounding-rgba.png");
  ASSERT_EQ(read_rgb.data.size(), rgb.data.size());
  ASSERT_EQ(read_rgba.data.size(), rgba.data.size());
  for (std::size_t i = 0; i < rgb.data.size(); ++i) {
    ASSERT_EQ(byte(read_rgb.data[i]), expected(rgb.data[i])) << "RGB value " << rgb.data[i];
  }
  for (int y = 0; y < 2; ++y) {
    for (int x = 0; x < n; ++x) {
      ASSERT_EQ(byte(read_rgba.at(x, y, 3)), expected(rgba.at(x, y, 3)))
          << "alpha value " << rgba.at(x, y, 3);
    }
  }
}

}  // namespace
}  // namespace shadefit
