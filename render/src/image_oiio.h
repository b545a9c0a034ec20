// The OpenImageIO side of image I/O, built as a module that image.cpp loads on first use.
//
// Why a module: OpenImageIO 2.4 (Debian 12) pulls in 261 shared libraries (OpenCV's video I/O,
// FFmpeg, GDAL, DCMTK, ...). Linked into shadefit they cost every process about 0.2 s of dynamic
// linking before main() runs, more than a whole fit (docs/rendering.md, "Start-up"). Plain
// RGB(A) EXR files, what fits read, go through OpenEXR directly (image.cpp); every other format
// and every write goes through here, with OpenImageIO's behaviour unchanged.
//
// Private to render/: one function table, the module's only exported symbol. Both sides are
// built by this project with one compiler, so C++ types cross the boundary; no exception does.
#pragma once

#include <map>
#include <string>
#include <utility>
#include <vector>

namespace shadefit::internal {

struct OiioSpec {
  int width = 0, height = 0, channels = 0;
  std::string format_name;  // OpenImageIO's name of the file format ("openexr", "png", ...).
  std::string pixel_type;   // Of the file's pixels ("half", "uint8", ...).
  bool is_float = false;
};

struct OiioWrite {
  std::string final_path;  // Its extension picks the format.
  std::string tmp_path;    // Where the bytes go (WriteAtomic renames it).
  int width = 0, height = 0, channels = 0;
  bool uint8 = false;      // 8-bit pixels; else float.
  const void* pixels = nullptr;
  std::vector<std::string> channel_names;  // Empty: the format's default names.
  int alpha_channel = -1;
  std::vector<std::pair<std::string, std::string>> attributes;  // In the order they are set.
  std::vector<std::pair<std::string, int>> int_attributes;       // After the string ones.
};

enum class OiioWriteStatus { kOk, kNoWriter, kFailed };

struct OiioBackend {
  // Opens `path`: a handle, or nullptr with *error = OpenImageIO's message.
  void* (*open)(const std::string& path, OiioSpec* spec, std::string* error);
  // All channels of subimage 0 as float, interleaved, row 0 on top. False with *error.
  bool (*read)(void* handle, float* pixels, std::string* error);
  // The header's string attributes.
  void (*string_attributes)(void* handle, std::map<std::string, std::string>* out);
  void (*close)(void* handle);
  OiioWriteStatus (*write)(const OiioWrite& request, std::string* error);
};

}  // namespace shadefit::internal

// The module's entry point (looked up with dlsym), its one exported symbol.
extern "C" __attribute__((visibility("default")))
const shadefit::internal::OiioBackend* ShadefitOiioBackend();
