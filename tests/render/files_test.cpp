// The one atomic writer (base/files.h): a complete file or nothing, never a temporary left.
#include "shadefit/base/files.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>

#include "shadefit/base/error.h"

namespace shadefit {
namespace {
namespace fs = std::filesystem;

fs::path CleanDir(const std::string& name) {
  const fs::path dir = fs::path(SHADEFIT_TEST_OUTPUT) / "files_test" / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string Read(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

int Entries(const fs::path& dir) {
  return static_cast<int>(std::distance(fs::directory_iterator(dir), fs::directory_iterator()));
}

TEST(WriteAtomicTest, FillWritesTheTemporaryThenItIsRenamed) {
  const fs::path dir = CleanDir("fill");
  const std::string path = (dir / "out.bin").string();
  std::string seen;
  WriteAtomic(path, [&](const std::string& tmp) {
    seen = tmp;
    EXPECT_EQ(fs::path(tmp).parent_path(), dir);
    EXPECT_EQ(fs::path(tmp).filename().string().rfind(".out.bin.", 0), 0u) << tmp;
    std::ofstream(tmp, std::ios::binary) << std::string("a\0b", 3);
  });
  EXPECT_FALSE(fs::exists(seen));
  EXPECT_EQ(Read(path), std::string("a\0b", 3));
  EXPECT_EQ(Entries(dir), 1);
}

TEST(WriteAtomicTest, AFailingFillLeavesNothingAndKeepsTheOldFile) {
  const fs::path dir = CleanDir("fail");
  const std::string path = (dir / "out.txt").string();
  WriteTextAtomic(path, "old\n");
  EXPECT_THROW(WriteAtomic(path,
                           [](const std::string& tmp) {
                             std::ofstream(tmp) << "half";
                             throw std::runtime_error("fill failed");
                           }),
               std::runtime_error);
  EXPECT_EQ(Read(path), "old\n");
  EXPECT_EQ(Entries(dir), 1);  // No temporary left.
}

TEST(WriteAtomicTest, BadPathFailsBeforeFilling) {
  bool filled = false;
  EXPECT_THROW(WriteAtomic("/nonexistent-dir/x.txt", [&](const std::string&) { filled = true; }),
               Error);
  EXPECT_FALSE(filled);
}

}  // namespace
}  // namespace shadefit
