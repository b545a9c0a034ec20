// Float images in linear radiance and their file I/O.
//
// Conventions (docs/scenes.md, "Conventions"): row 0 is the top row of the picture, pixel (x, y) has its
// centre at (x + 0.5, y + 0.5) in pixel units, channels are interleaved. Values are linear and
// unclamped (HDR) unless a function says otherwise.
#pragma once

#include <cstddef>
#include <map>
#include <string>
#include <vector>

namespace shadefit {

// A dense, interleaved float image.
struct Image {
  int width = 0;
  int height = 0;
  int channels = 0;
  std::vector<float> data;  // width * height * channels, row-major, row 0 on top.

  Image() = default;
  Image(int w, int h, int c, float fill = 0.0f)
      : width(w), height(h), channels(c), data(static_cast<std::size_t>(w) * h * c, fill) {}

  bool empty() const { return data.empty(); }
  std::size_t PixelCount() const { return static_cast<std::size_t>(width) * height; }
  float& at(int x, int y, int c) {
    return data[(static_cast<std::size_t>(y) * width + x) * channels + c];
  }
  float at(int x, int y, int c) const {
    return data[(static_cast<std::size_t>(y) * width + x) * channels + c];
  }
  // Copies channels [first, first + count) into a new image.
  Image Channels(int first, int count) const;
};

// String metadata written into EXR headers (and read back): model, parameters, scene, ...
using ImageMetadata = std::map<std::string, std::string>;

// Reads any image OpenImageIO understands. 8-bit files are returned as values in [0, 1] without
// any transfer-function conversion (callers decide: see reference import). Throws shadefit::Error
// naming the file and the field (header, resolution, pixels) on a missing, unreadable, truncated
// or corrupt file (JPEG and PNG files cut short included, which decoders fill silently) and on a
// size beyond 16384 per side or 64 channels.
// Plain RGB(A) EXR files without a metadata request are read with OpenEXR directly
// (ReadPlainExr); everything else goes through OpenImageIO, loaded on first use.
Image ReadImage(const std::string& path, ImageMetadata* metadata = nullptr);

// ReadImage's OpenEXR path: one part, channels R G B (A) in half or float, data window = display
// window. False for any other file or on any read error (ReadImage then asks OpenImageIO, which
// reports it); throws ReadImage's error for a size beyond its limits. Exposed for the test that
// holds it equal to OpenImageIO's reader.
bool ReadPlainExr(const std::string& path, Image* out);

// What a file's header says, as OpenImageIO reads it (the import's provenance).
struct ImageFileInfo {
  std::string format;   // Format and pixel type, e.g. "openexr half", "png uint8".
  bool is_float = false;
  int channels = 0;
};

// False with *error = OpenImageIO's message when the file cannot be opened as an image.
bool ReadImageInfo(const std::string& path, ImageFileInfo* info, std::string* error);

// Checks what a decoder would trust before reading a file: an EXR header attribute or a PNG chunk
// may not claim more bytes than the file holds (OpenEXR 3.1 and libpng 1.6 allocate the claimed
// size first). ReadImage and the import call it before OpenImageIO opens the file. Throws
// shadefit::Error(path, "header", ...).
void CheckImageHeader(const std::string& path);

// Writes a linear float EXR (half is never used: references need float). Written to a temporary
// file beside the target and renamed, so a failure never leaves a partial file.
void WriteExr(const std::string& path, const Image& image, const ImageMetadata& metadata = {},
              const std::vector<std::string>& channel_names = {});

// Writes an 8-bit PNG after the display transform: value * 2^exposure, sRGB OETF, clip to [0, 1].
// Only RGB is written (premultiplied renders composite over black). Atomic like WriteExr.
void WritePngPreview(const std::string& path, const Image& image, float exposure_stops = 0.0f);

// Writes an 8-bit PNG of values already in [0, 1] display space (false-colour maps, figures).
void WritePng8(const std::string& path, const Image& image);

// sRGB transfer functions (IEC 61966-2-1).
float SrgbOetf(float linear);
float SrgbToLinear(float encoded);

}  // namespace shadefit
