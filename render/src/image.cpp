#include "shadefit/render/image.h"

#include <dlfcn.h>
#include <fmt/format.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfVersion.h>
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

#include "image_oiio.h"
#include "shadefit/base/error.h"
#include "shadefit/base/files.h"

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

// libpng 1.6 (Debian 12, through OpenImageIO) allocates what a chunk's length field claims
// before it reads the chunk: a 336-byte PNG whose tEXt chunk claimed 1.87 GB took the process
// past 2 GB (found by fuzz_image). A PNG is the signature and then chunks, each a big-endian
// length (at most 2^31 - 1), a four-letter type, that many bytes and a CRC (ISO/IEC 15948,
// 5.3); every length must fit in what is left of the file.
void CheckPngChunks(const std::string& path, const std::string& bytes) {
  std::size_t pos = 8;
  while (pos + 8 <= bytes.size()) {
    std::uint32_t length = 0;
    for (int i = 0; i < 4; ++i) length = (length << 8) | static_cast<unsigned char>(bytes[pos + i]);
    const std::string type = bytes.substr(pos + 4, 4);
    const std::size_t left = bytes.size() - pos - 8;
    if (length > 0x7fffffffu || length > left || left - length < 4) {
      // A file cut short and a length that lies look the same here (CheckComplete's error).
      throw Error(path, "pixels",
                  fmt::format("truncated PNG: chunk '{}' claims {} bytes, {} are left in the file",
                              OneLine(type), length, left < 4 ? 0 : left - 4));
    }
    if (type == "IEND") return;
    pos += 12 + length;
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
  if (bytes.size() >= 8 && bytes.compare(0, 8, "\x89PNG\r\n\x1a\n") == 0) {
    CheckPngChunks(path, bytes);
    return;
  }
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

// The OpenImageIO module (image_oiio.h), loaded on first use and kept for the process: a process
// that reads only plain EXR files never loads OpenImageIO's 261 libraries.
const internal::OiioBackend& Oiio() {
  static const internal::OiioBackend* backend = [] {
    void* module = dlopen(SHADEFIT_OIIO_MODULE, RTLD_NOW | RTLD_LOCAL);
    if (!module) {
      throw Error(SHADEFIT_OIIO_MODULE, "", fmt::format("cannot load the OpenImageIO module: {}",
                                                        OneLine(dlerror())));
    }
    using Entry = const internal::OiioBackend* (*)();
    auto entry = reinterpret_cast<Entry>(dlsym(module, "ShadefitOiioBackend"));
    if (!entry) throw Error(SHADEFIT_OIIO_MODULE, "", "no ShadefitOiioBackend in the module");
    return entry();
  }();
  return *backend;
}

void WriteWithOiio(internal::OiioWrite request) {
  WriteAtomic(request.final_path, [&](const std::string& tmp) {
    request.tmp_path = tmp;
    std::string error;
    switch (Oiio().write(request, &error)) {
      case internal::OiioWriteStatus::kOk:
        return;
      case internal::OiioWriteStatus::kNoWriter:
        throw Error(request.final_path, "", "no writer for this file type: " + error);
      case internal::OiioWriteStatus::kFailed:
        throw Error(request.final_path, "", "write failed: " + OneLine(error));
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

// A header may claim any size; allocate only what a reference can be. Scenes render at most
// 8192 x 8192 RGBA (docs/scenes.md): 16384 per side, 64 channels (the G-buffer AOVs have 10)
// and 2^28 values in all (1 GiB of floats, an 8192^2 RGBA image) leave room while keeping a
// forged header from asking for terabytes.
void CheckImageSize(const std::string& path, int width, int height, int channels) {
  if (width <= 0 || height <= 0 || channels <= 0) {
    throw Error(path, "resolution", "image has no pixels");
  }
  const auto values = static_cast<std::uint64_t>(width) * height * channels;
  if (width > kMaxImageSide || height > kMaxImageSide || channels > 64 ||
      values > kMaxImageValues) {
    throw Error(
        path, "resolution",
        fmt::format("{}x{} with {} channel(s) is beyond what shadefit reads ({} per side, "
                    "64 channels, {} values)",
                    width, height, channels, kMaxImageSide, kMaxImageValues));
  }
}

Image ReadImageQuietly(const std::string& path, ImageMetadata* metadata) {
  const internal::OiioBackend& oiio = Oiio();
  internal::OiioSpec spec;
  std::string error;
  void* in = oiio.open(path, &spec, &error);
  // The header is what OpenImageIO could not make sense of: the format, the size, the channels.
  if (!in) throw Error(path, "header", "cannot read image: " + OneLine(error));
  struct Closer {
    const internal::OiioBackend& oiio;
    void* in;
    ~Closer() { oiio.close(in); }
  } closer{oiio, in};
  CheckImageSize(path, spec.width, spec.height, spec.channels);
  CheckComplete(path);
  Image image(spec.width, spec.height, spec.channels);
  if (!oiio.read(in, image.data.data(), &error)) {
    throw Error(path, "pixels", "truncated or corrupt image: " + OneLine(error));
  }
  if (metadata) oiio.string_attributes(in, metadata);
  return image;
}

}  // namespace

// Plain EXR files (one part, scanline or tiled, channels R G B or R G B A in half or float,
// data window = display window: every reference and render shadefit writes) read with OpenEXR
// directly, in the calling thread: OpenEXR's thread pool only adds a hand-off for a 256^2 file.
// False when the file is anything else or fails to read; the caller then takes OpenImageIO's
// path, which reports errors in its words. A size beyond the limits throws the error ReadImage
// gives for any format. Tests hold this path equal to OpenImageIO's, bit for bit
// (tests/render/image_io_test.cpp, ImageIo.ExrFastPath*).
bool ReadPlainExr(const std::string& path, Image* out) {
  char magic[4] = {};
  std::ifstream(path, std::ios::binary).read(magic, sizeof magic);
  if (std::memcmp(magic, "\x76\x2f\x31\x01", 4) != 0) return false;
  try {
    Imf::InputFile file(path.c_str(), /*numThreads=*/0);
    if (Imf::isMultiPart(file.version()) || Imf::isNonImage(file.version())) return false;
    const Imf::Header& header = file.header();
    const Imath::Box2i window = header.dataWindow();
    if (window != header.displayWindow()) return false;
    static const char* kNames[] = {"R", "G", "B", "A"};
    int channels = 0;
    for (auto it = header.channels().begin(); it != header.channels().end(); ++it, ++channels) {
      const Imf::Channel& c = it.channel();
      if ((c.type != Imf::HALF && c.type != Imf::FLOAT) || c.xSampling != 1 || c.ySampling != 1) {
        return false;
      }
    }
    if (channels != 3 && channels != 4) return false;
    for (int c = 0; c < channels; ++c) {
      if (!header.channels().findChannel(kNames[c])) return false;
    }
    const int width = window.max.x - window.min.x + 1, height = window.max.y - window.min.y + 1;
    CheckImageSize(path, width, height, channels);
    Image image(width, height, channels);
    Imf::FrameBuffer frame;
    const std::size_t x_stride = sizeof(float) * channels, y_stride = x_stride * width;
    // OpenEXR addresses a slice by absolute pixel coordinates: shift the base by the window.
    char* origin = reinterpret_cast<char*>(image.data.data()) -
                   static_cast<std::ptrdiff_t>(window.min.x) * x_stride -
                   static_cast<std::ptrdiff_t>(window.min.y) * y_stride;
    for (int c = 0; c < channels; ++c) {
      frame.insert(kNames[c],
                   Imf::Slice(Imf::FLOAT, origin + sizeof(float) * c, x_stride, y_stride));
    }
    file.setFrameBuffer(frame);
    file.readPixels(window.min.y, window.max.y);
    *out = std::move(image);
    return true;
  } catch (const Error&) {
    throw;  // A size beyond the limits: the same error either way.
  } catch (const std::exception&) {
    return false;
  }
}

Image ReadImage(const std::string& path, ImageMetadata* metadata) {
  if (!PathExists(path)) throw Error(path, "", "file not found");
  if (KindOfPath(path) == PathKind::kDirectory) throw Error(path, "", "is a directory, not an image");
  CheckImageHeader(path);
  // Metadata callers get OpenImageIO's attribute names (it renames some EXR attributes).
  Image image;
  if (!metadata && ReadPlainExr(path, &image)) return image;
  StderrCapture quiet;  // libpng prints its errors itself; the Error below says it in one line
  try {
    return ReadImageQuietly(path, metadata);
  } catch (...) {
    quiet.Discard();
    throw;
  }
}

bool ReadImageInfo(const std::string& path, ImageFileInfo* info, std::string* error) {
  const internal::OiioBackend& oiio = Oiio();
  internal::OiioSpec spec;
  void* in = oiio.open(path, &spec, error);
  if (!in) return false;
  oiio.close(in);
  info->format = spec.format_name + " " + spec.pixel_type;
  info->is_float = spec.is_float;
  info->channels = spec.channels;
  return true;
}

void WriteExr(const std::string& path, const Image& image, const ImageMetadata& metadata,
              const std::vector<std::string>& channel_names) {
  internal::OiioWrite w;
  w.final_path = path;
  w.width = image.width;
  w.height = image.height;
  w.channels = image.channels;
  w.pixels = image.data.data();
  if (!channel_names.empty()) {
    w.channel_names = channel_names;
  } else if (image.channels == 4) {
    w.alpha_channel = 3;
  }
  w.attributes.emplace_back("compression", "zip");
  // OpenImageIO's EXR writer stores "DateTime" as capDate and fills in the wall-clock time when
  // it is absent, which made every render differ from the last in its header. A render is a
  // function of its inputs, so it gets the reproducible-builds timestamp: $SOURCE_DATE_EPOCH
  // when set, else the epoch (not a capture date; the sidecar holds the provenance).
  w.attributes.emplace_back("DateTime", ReproducibleDateTime());
  for (const auto& [key, value] : metadata) w.attributes.emplace_back(key, value);
  WriteWithOiio(std::move(w));
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
    // v in [0, 1] (NaN: 0), rounded half away from zero as std::lround rounds, without its
    // library call (one a channel of every preview): x - whole is exact for 0 <= x <= 255.
    const float v = image.data[i] > 0.0f ? std::min(image.data[i], 1.0f) : 0.0f;
    const float x = v * 255.0f;
    const int whole = static_cast<int>(x);
    bytes[i] = static_cast<unsigned char>(whole + (x - static_cast<float>(whole) >= 0.5f ? 1 : 0));
  }
  internal::OiioWrite w;
  w.final_path = path;
  w.width = image.width;
  w.height = image.height;
  w.channels = image.channels;
  w.uint8 = true;
  w.pixels = bytes.data();
  if (image.channels == 4) w.alpha_channel = 3;
  // Each row stored as its differences from the row above (PNG's Up filter), deflated at zlib
  // level 2: a study writes thousands of previews. Against the earlier Sub filter at level 4, on
  // the measured study's previews (fits, error maps, references): deflating 1.9 times as fast
  // for files 9 to 11% larger, the previews stage 0.6x. libpng's default (every filter tried on
  // every row, level 6) had taken 2.2 to 2.7 times as long as Sub at level 4.
  w.int_attributes = {{"png:compressionLevel", 2}, {"png:filter", 0x20 /* PNG_FILTER_UP */}};
  WriteWithOiio(std::move(w));
}

}  // namespace shadefit
