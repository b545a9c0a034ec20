// Shared by the libFuzzer harnesses (tests/fuzz/*_fuzz.cpp): a private scratch folder and a file
// writer, for readers that take a path rather than bytes.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

namespace shadefit::fuzz {

// A folder of this process's own, removed at exit. On /dev/shm when it exists (a tmpfs: the MERL
// and image harnesses write a file per input), else the system temporary folder.
inline const std::filesystem::path& ScratchDir() {
  static const std::filesystem::path dir = [] {
    namespace fs = std::filesystem;
    const fs::path base =
        fs::is_directory("/dev/shm") ? fs::path("/dev/shm") : fs::temp_directory_path();
    fs::path d = base / ("shadefit-fuzz-" + std::to_string(getpid()));
    fs::create_directories(d);
    static fs::path to_remove = d;
    std::atexit([] {
      std::error_code ec;
      fs::remove_all(to_remove, ec);
    });
    return d;
  }();
  return dir;
}

inline std::string WriteFile(const std::string& name, const std::uint8_t* data, std::size_t size) {
  const std::filesystem::path p = ScratchDir() / name;
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return p.string();
}

inline std::string WriteFile(const std::string& name, const std::string& text) {
  return WriteFile(name, reinterpret_cast<const std::uint8_t*>(text.data()), text.size());
}

}  // namespace shadefit::fuzz
