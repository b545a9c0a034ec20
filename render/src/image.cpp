#include "shadefit/render/image.h"

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imageio.h>

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <memory>

#include "shadefit/render/error.h"
#include "shadefit/render/files.h"

namespace shadefit {
namespace {

namespace fs = std::filesystem;

// Temporary sibling path, unique per process and call so that concurrent writers of the same
// file (two study jobs writing one reference preview) never share it; the rename that follows
// is atomic on one file system and the last writer wins with a complete file.
void CommitTemp(const std::string& tmp, const std::string& path) {
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw Error(path, "", "cannot write file (rename failed)");
  }
}

// "YYYY:MM:DD HH:MM:SS" (UTC) of $SOURCE_DATE_EPOCH (https://reproducible-builds.org/specs/
// source-date-epoch/), or of 0 when it is unset or not a number.
std::string ReproducibleDateTime() {
  std::time_t t = 0;
  if (const char* env = std::getenv("SOURCE_DATE_EPOCH")) {
    char* end = nullptr;
    const long long v = std::strtoll(env, &end, 10);
    if (end != env && *end == '\0' && v >= 0) t = static_cast<std::time_t>(v);
  }
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y:%m:%d %H:%M:%S", &tm);
  return buf;
}

void WriteWithOiio(const std::string& path, const OIIO::ImageSpec& spec, OIIO::TypeDesc type,
                   const void* pixels) {
  const fs::path parent = fs::path(path).parent_path();
  if (!parent.empty() && !fs::is_directory(parent)) {
    throw Error(path, "", "output directory does not exist");
  }
  const std::string tmp = TemporaryPathFor(path);
  auto out = OIIO::ImageOutput::create(path);  // Format from the final name, not the temp one.
  if (!out) throw Error(path, "", "no writer for this file type: " + OIIO::geterror());
  if (!out->open(tmp, spec) || !out->write_image(type, pixels) || !out->close()) {
    std::string msg = out->geterror();
    std::error_code ec;
    fs::remove(tmp, ec);
    throw Error(path, "", "write failed: " + msg);
  }
  CommitTemp(tmp, path);
}

}  // namespace

Image Image::Channels(int first, int count) const {
  Image out(width, height, count);
  for (std::size_t i = 0; i < PixelCount(); ++i) {
    for (int c = 0; c < count; ++c) out.data[i * count + c] = data[i * channels + first + c];
  }
  return out;
}

float SrgbOetf(float x) {
  if (!(x > 0.0f)) return 0.0f;
  // IEC 61966-2-1: linear segment below 0.0031308, then a 1/2.4 power with offset.
  return x <= 0.0031308f ? 12.92f * x : 1.055f * std::pow(x, 1.0f / 2.4f) - 0.055f;
}

float SrgbToLinear(float v) {
  return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
}

Image ReadImage(const std::string& path, ImageMetadata* metadata) {
  if (!fs::exists(path)) throw Error(path, "", "file not found");
  auto in = OIIO::ImageInput::open(path);
  if (!in) throw Error(path, "", "cannot read image: " + OIIO::geterror());
  const OIIO::ImageSpec& spec = in->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0) {
    throw Error(path, "resolution", "image has no pixels");
  }
  Image image(spec.width, spec.height, spec.nchannels);
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, image.data.data())) {
    throw Error(path, "pixels", "truncated or corrupt image: " + in->geterror());
  }
  if (metadata) {
    metadata->clear();
    for (const auto& attr : spec.extra_attribs) {
      if (attr.type() == OIIO::TypeDesc::STRING) {
        (*metadata)[attr.name().string()] = attr.get_string();
      }
    }
  }
  in->close();
  return image;
}

void WriteExr(const std::string& path, const Image& image, const ImageMetadata& metadata,
              const std::vector<std::string>& channel_names) {
  OIIO::ImageSpec spec(image.width, image.height, image.channels, OIIO::TypeDesc::FLOAT);
  if (!channel_names.empty()) {
    spec.channelnames = channel_names;
  } else if (image.channels == 4) {
    spec.alpha_channel = 3;
  }
  spec.attribute("compression", "zip");
  // OpenImageIO's EXR writer stores "DateTime" as capDate and fills in the wall-clock time when
  // it is absent, which made every render differ from the last in its header. A render is a
  // function of its inputs, so it gets the reproducible-builds timestamp: $SOURCE_DATE_EPOCH
  // when set, else the epoch (not a capture date; the sidecar holds the provenance).
  spec.attribute("DateTime", ReproducibleDateTime());
  for (const auto& [key, value] : metadata) spec.attribute(key, value);
  WriteWithOiio(path, spec, OIIO::TypeDesc::FLOAT, image.data.data());
}

void WritePngPreview(const std::string& path, const Image& image, float exposure_stops) {
  const float scale = std::exp2(exposure_stops);
  // RGB only: renders are premultiplied (transparent film), so this composites over black.
  const int out_channels = std::min(image.channels, 3);
  Image display(image.width, image.height, out_channels);
  for (std::size_t i = 0; i < image.PixelCount(); ++i) {
    for (int c = 0; c < out_channels; ++c) {
      const float v = image.data[i * image.channels + c];
      display.data[i * out_channels + c] = SrgbOetf(v * scale);
    }
  }
  WritePng8(path, display);
}

void WritePng8(const std::string& path, const Image& image) {
  std::vector<unsigned char> bytes(image.data.size());
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    const float v = std::clamp(image.data[i], 0.0f, 1.0f);
    bytes[i] = static_cast<unsigned char>(std::lround(v * 255.0f));
  }
  OIIO::ImageSpec spec(image.width, image.height, image.channels, OIIO::TypeDesc::UINT8);
  if (image.channels == 4) spec.alpha_channel = 3;
  WriteWithOiio(path, spec, OIIO::TypeDesc::UINT8, bytes.data());
}

}  // namespace shadefit
