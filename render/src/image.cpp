#include "shadefit/render/image.h"

#include <fmt/format.h>
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imageio.h>

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

#include "shadefit/render/error.h"
#include "shadefit/render/files.h"

namespace shadefit {
namespace {

namespace fs = std::filesystem;

constexpr int kMaxImageSide = 16384;
constexpr std::uint64_t kMaxImageValues = std::uint64_t{1} << 28;

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

// libjpeg (through OpenImageIO) fills a JPEG cut short with grey and only warns, and PNG
// decoders may stop at the last complete row: check that the file ends the way the format says.
void CheckComplete(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char magic[4] = {};
  in.read(magic, sizeof magic);
  const bool jpeg = magic[0] == '\xFF' && magic[1] == '\xD8' && magic[2] == '\xFF';
  const bool png = magic[0] == '\x89' && magic[1] == 'P' && magic[2] == 'N' && magic[3] == 'G';
  if (!jpeg && !png) return;  // Other formats' decoders report short files themselves.
  in.seekg(0);
  const std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)),
                                         std::istreambuf_iterator<char>());
  auto find_last = [&](unsigned char a, unsigned char b) -> long long {
    for (long long i = static_cast<long long>(bytes.size()) - 2; i >= 0; --i) {
      if (bytes[i] == a && bytes[i + 1] == b) return i;
    }
    return -1;
  };
  if (bytes.size() >= 3 && bytes[0] == 0xFF && bytes[1] == 0xD8 && bytes[2] == 0xFF) {
    // JPEG (ITU T.81, B.2): entropy-coded data never holds FF D9 (FF is stuffed), so the image
    // is complete only if an EOI marker follows the last start-of-scan marker.
    const long long sos = find_last(0xFF, 0xDA), eoi = find_last(0xFF, 0xD9);
    if (sos < 0 || eoi < sos) {
      throw Error(path, "pixels", "truncated JPEG: no end-of-image marker after the last scan");
    }
  } else if (bytes.size() >= 8 && bytes[0] == 0x89 && bytes[1] == 'P' && bytes[2] == 'N' &&
             bytes[3] == 'G') {
    // PNG (ISO/IEC 15948, 5.6): the last chunk is IEND.
    const std::string tail(bytes.end() - std::min<std::size_t>(bytes.size(), 64), bytes.end());
    if (tail.find("IEND") == std::string::npos) {
      throw Error(path, "pixels", "truncated PNG: no IEND chunk at the end");
    }
  }
}

}  // namespace

void CheckImageHeader(const std::string& path) {
  // OpenEXR 3.1 (Debian 12) allocates what a header attribute's size field claims before it
  // reads it: a 541-byte file asked for 1.9 GB (found by fuzz_image). An EXR header is a list of
  // attributes, each a name, a type name (both NUL-terminated, at most 255 characters) and an
  // int32 size followed by that many bytes, ended by an empty name; a multi-part file has one
  // such list per part, ended by an empty list (OpenEXR file layout, "Header").
  std::ifstream in(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (bytes.size() < 8 || bytes.compare(0, 4, "\x76\x2f\x31\x01") != 0) return;
  const bool multipart = (static_cast<unsigned char>(bytes[5]) & 0x10) != 0;
  std::size_t pos = 8;
  auto read_name = [&](std::string* name) {
    const std::size_t end = bytes.find('\0', pos);
    if (end == std::string::npos || end - pos > 255) {
      throw Error(path, "header", "corrupt EXR header (unterminated attribute name)");
    }
    *name = bytes.substr(pos, end - pos);
    pos = end + 1;
  };
  for (;;) {  // one header per part
    std::string name, type;
    read_name(&name);
    while (!name.empty()) {
      read_name(&type);
      if (pos + 4 > bytes.size()) throw Error(path, "header", "EXR header cut short");
      std::int32_t size = 0;
      std::memcpy(&size, bytes.data() + pos, sizeof size);  // little-endian, as the host
      pos += 4;
      if (size < 0 || static_cast<std::size_t>(size) > bytes.size() - pos) {
        throw Error(path, "header",
                    fmt::format("EXR attribute '{}' claims {} bytes, {} are left in the file",
                                OneLine(name), size, bytes.size() - pos));
      }
      pos += static_cast<std::size_t>(size);
      read_name(&name);
    }
    if (!multipart || pos >= bytes.size() || bytes[pos] == '\0') return;  // empty list: the end
  }
}

namespace {

void WriteWithOiio(const std::string& path, const OIIO::ImageSpec& spec, OIIO::TypeDesc type,
                   const void* pixels) {
  WriteAtomic(path, [&](const std::string& tmp) {
    auto out = OIIO::ImageOutput::create(path);  // Format from the final name, not the temp one.
    if (!out) throw Error(path, "", "no writer for this file type: " + OIIO::geterror());
    if (!out->open(tmp, spec) || !out->write_image(type, pixels) || !out->close()) {
      throw Error(path, "", "write failed: " + OneLine(out->geterror()));
    }
  });
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

namespace {

Image ReadImageQuietly(const std::string& path, ImageMetadata* metadata) {
  auto in = OIIO::ImageInput::open(path);
  // The header is what OpenImageIO could not make sense of: the format, the size, the channels.
  if (!in) throw Error(path, "header", "cannot read image: " + OneLine(OIIO::geterror()));
  const OIIO::ImageSpec& spec = in->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0) {
    throw Error(path, "resolution", "image has no pixels");
  }
  // A header may claim any size; allocate only what a reference can be. Scenes render at most
  // 8192 x 8192 RGBA (docs/scenes.md): 16384 per side, 64 channels (the G-buffer AOVs have 10)
  // and 2^28 values in all (1 GiB of floats, an 8192^2 RGBA image) leave room while keeping a
  // forged header from asking for terabytes.
  const auto values = static_cast<std::uint64_t>(spec.width) * spec.height * spec.nchannels;
  if (spec.width > kMaxImageSide || spec.height > kMaxImageSide || spec.nchannels > 64 ||
      values > kMaxImageValues) {
    throw Error(
        path, "resolution",
        fmt::format("{}x{} with {} channel(s) is beyond what shadefit reads ({} per side, "
                    "64 channels, {} values)",
                    spec.width, spec.height, spec.nchannels, kMaxImageSide, kMaxImageValues));
  }
  CheckComplete(path);
  Image image(spec.width, spec.height, spec.nchannels);
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, image.data.data())) {
    throw Error(path, "pixels", "truncated or corrupt image: " + OneLine(in->geterror()));
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

}  // namespace

Image ReadImage(const std::string& path, ImageMetadata* metadata) {
  if (!fs::exists(path)) throw Error(path, "", "file not found");
  if (fs::is_directory(path)) throw Error(path, "", "is a directory, not an image");
  CheckImageHeader(path);
  StderrCapture quiet;  // libpng prints its errors itself; the Error below says it in one line
  try {
    return ReadImageQuietly(path, metadata);
  } catch (...) {
    quiet.Discard();
    throw;
  }
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
