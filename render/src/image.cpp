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
#include <memory>
#include <string>
#include <vector>

#include "image_oiio.h"
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

// The checks below look at a file's header, its chunk headers or its last bytes, never at its
// pixels, so they read those pieces and no more (a reference or an environment map may be
// hundreds of MB, which the decoder then reads once).
class FilePieces {
 public:
  explicit FilePieces(const std::string& path) : in_(path, std::ios::binary) {
    in_.seekg(0, std::ios::end);
    const std::streamoff end = in_ ? static_cast<std::streamoff>(in_.tellg()) : 0;
    size_ = end > 0 ? static_cast<std::uint64_t>(end) : 0;
  }
  // The file's size; 0 when it cannot be read (the decoder then says why).
  std::uint64_t size() const { return size_; }
  // The bytes [pos, pos + n), cut at the end of the file.
  std::string Read(std::uint64_t pos, std::uint64_t n) {
    if (pos >= size_) return {};
    std::string out(static_cast<std::size_t>(std::min(n, size_ - pos)), '\0');
    in_.clear();
    in_.seekg(static_cast<std::streamoff>(pos));
    in_.read(out.data(), static_cast<std::streamsize>(out.size()));
    out.resize(static_cast<std::size_t>(std::max<std::streamsize>(in_.gcount(), 0)));
    return out;
  }
  unsigned char Byte(std::uint64_t pos) {
    const std::string b = Read(pos, 1);
    return b.empty() ? 0 : static_cast<unsigned char>(b[0]);
  }

 private:
  std::ifstream in_;
  std::uint64_t size_ = 0;
};

bool IsJpeg(const std::string& magic) {
  return magic.size() >= 3 && magic.compare(0, 3, "\xFF\xD8\xFF") == 0;
}
bool IsPng(const std::string& magic) {
  return magic.size() >= 8 && magic.compare(0, 8, std::string("\x89PNG\r\n\x1a\n", 8)) == 0;
}

// libjpeg (through OpenImageIO) fills a JPEG cut short with grey and only warns, and PNG
// decoders may stop at the last complete row: check that the file ends the way the format says.
void CheckComplete(const std::string& path) {
  FilePieces file(path);
  const std::string magic = file.Read(0, 8);
  if (IsJpeg(magic)) {
    // JPEG (ITU T.81, B.2): entropy-coded data never holds FF D9 (FF is stuffed), so the image
    // is complete only if an EOI marker (FF D9) follows the last start-of-scan marker (FF DA).
    // Scanned from the end, a block at a time (a pair may straddle two blocks): the first EOI
    // met is the last one, and the scan stops at the first SOS met.
    constexpr std::uint64_t kBlock = std::uint64_t{1} << 16;
    bool eoi_after_last_sos = false, sos_found = false;
    for (std::uint64_t end = file.size(); end >= 2 && !sos_found;) {
      const std::uint64_t begin = end > kBlock ? end - kBlock : 0;
      const std::string block = file.Read(begin, end - begin + (end < file.size() ? 1 : 0));
      if (block.size() < 2) break;  // a read error: the decoder reports it
      for (std::size_t i = block.size() - 1; i-- > 0;) {  // pairs (i, i + 1), last first
        if (static_cast<unsigned char>(block[i]) != 0xFF) continue;
        const auto next = static_cast<unsigned char>(block[i + 1]);
        if (next == 0xD9) eoi_after_last_sos = true;
        if (next == 0xDA) {
          sos_found = true;
          break;
        }
      }
      end = begin;
    }
    if (!sos_found || !eoi_after_last_sos) {
      throw Error(path, "pixels", "truncated JPEG: no end-of-image marker after the last scan");
    }
  } else if (magic.size() >= 8 && magic.compare(0, 4, "\x89PNG") == 0) {
    // PNG (ISO/IEC 15948, 5.6): the last chunk is IEND.
    const std::uint64_t tail = std::min<std::uint64_t>(file.size(), 64);
    if (file.Read(file.size() - tail, tail).find("IEND") == std::string::npos) {
      throw Error(path, "pixels", "truncated PNG: no IEND chunk at the end");
    }
  }
  // Other formats' decoders report short files themselves.
}

// libpng 1.6 (Debian 12, through OpenImageIO) allocates what a chunk's length field claims
// before it reads the chunk: a 336-byte PNG whose tEXt chunk claimed 1.87 GB took the process
// past 2 GB (found by fuzz_image). A PNG is the signature and then chunks, each a big-endian
// length (at most 2^31 - 1), a four-letter type, that many bytes and a CRC (ISO/IEC 15948,
// 5.3); every length must fit in what is left of the file.
void CheckPngChunks(const std::string& path, FilePieces& file) {
  std::uint64_t pos = 8;
  while (pos + 8 <= file.size()) {
    const std::string head = file.Read(pos, 8);
    std::uint32_t length = 0;
    for (int i = 0; i < 4; ++i) length = (length << 8) | static_cast<unsigned char>(head[i]);
    const std::string type = head.substr(4, 4);
    const std::uint64_t left = file.size() - pos - 8;
    if (length > 0x7fffffffu || length > left || left - length < 4) {
      // A file cut short and a length that lies look the same here (CheckComplete's error).
      throw Error(path, "pixels",
                  fmt::format("truncated PNG: chunk '{}' claims {} bytes, {} are left in the file",
                              OneLine(type), length, left < 4 ? 0 : left - 4));
    }
    if (type == "IEND") return;
    pos += 12 + std::uint64_t{length};
  }
}

}  // namespace

void CheckImageHeader(const std::string& path) {
  // OpenEXR 3.1 (Debian 12) allocates what a header attribute's size field claims before it
  // reads it: a 541-byte file asked for 1.9 GB (found by fuzz_image). An EXR header is a list of
  // attributes, each a name, a type name (both NUL-terminated, at most 255 characters) and an
  // int32 size followed by that many bytes, ended by an empty name; a multi-part file has one
  // such list per part, ended by an empty list (OpenEXR file layout, "Header").
  FilePieces file(path);
  const std::string magic = file.Read(0, 8);
  if (IsPng(magic)) {
    CheckPngChunks(path, file);
    return;
  }
  if (magic.size() < 8 || magic.compare(0, 4, "\x76\x2f\x31\x01") != 0) return;
  const bool multipart = (static_cast<unsigned char>(magic[5]) & 0x10) != 0;
  const std::uint64_t size = file.size();
  std::uint64_t pos = 8;
  auto read_name = [&](std::string* name) {
    const std::string piece = file.Read(pos, 256);  // at most 255 characters and the NUL
    const std::size_t end = piece.find('\0');
    if (end == std::string::npos) {
      throw Error(path, "header", "corrupt EXR header (unterminated attribute name)");
    }
    *name = piece.substr(0, end);
    pos += end + 1;
  };
  for (;;) {  // one header per part
    std::string name, type;
    read_name(&name);
    while (!name.empty()) {
      read_name(&type);
      if (pos + 4 > size) throw Error(path, "header", "EXR header cut short");
      const std::string field = file.Read(pos, 4);
      std::int32_t attribute_size = 0;
      std::memcpy(&attribute_size, field.data(), sizeof attribute_size);  // little-endian host
      pos += 4;
      if (attribute_size < 0 || static_cast<std::uint64_t>(attribute_size) > size - pos) {
        throw Error(path, "header",
                    fmt::format("EXR attribute '{}' claims {} bytes, {} are left in the file",
                                OneLine(name), attribute_size, size - pos));
      }
      pos += static_cast<std::uint64_t>(attribute_size);
      read_name(&name);
    }
    if (!multipart || pos >= size || file.Byte(pos) == 0) return;  // empty list: the end
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
  if (!fs::exists(path)) throw Error(path, "", "file not found");
  if (fs::is_directory(path)) throw Error(path, "", "is a directory, not an image");
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
    const float v = std::clamp(image.data[i], 0.0f, 1.0f);
    bytes[i] = static_cast<unsigned char>(std::lround(v * 255.0f));
  }
  internal::OiioWrite w;
  w.final_path = path;
  w.width = image.width;
  w.height = image.height;
  w.channels = image.channels;
  w.uint8 = true;
  w.pixels = bytes.data();
  if (image.channels == 4) w.alpha_channel = 3;
  WriteWithOiio(std::move(w));
}

}  // namespace shadefit
