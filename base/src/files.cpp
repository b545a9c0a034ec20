#include "shadefit/base/files.h"

#include <fmt/format.h>
#include <openssl/evp.h>
#include <sys/mman.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <mutex>
#include <sstream>
#include <stdexcept>

#include "shadefit/base/error.h"

namespace shadefit {
namespace {

namespace fs = std::filesystem;

// SHA-256 (FIPS 180-4) through OpenSSL's EVP interface (libcrypto): one well-kept
// implementation instead of our own. Throws std::runtime_error if libcrypto fails, which it
// does not for SHA-256 short of running out of memory.
class Sha256 {
 public:
  Sha256() : context_(EVP_MD_CTX_new()) {
    if (context_ == nullptr || EVP_DigestInit_ex(context_, EVP_sha256(), nullptr) != 1) {
      EVP_MD_CTX_free(context_);
      throw std::runtime_error("OpenSSL: cannot start a SHA-256 digest");
    }
  }
  ~Sha256() { EVP_MD_CTX_free(context_); }
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;

  void Update(const unsigned char* p, std::size_t n) {
    if (n > 0 && EVP_DigestUpdate(context_, p, n) != 1) {
      throw std::runtime_error("OpenSSL: SHA-256 update failed");
    }
  }

  std::string HexDigest() {
    unsigned char digest[EVP_MAX_MD_SIZE];
    unsigned int size = 0;
    if (EVP_DigestFinal_ex(context_, digest, &size) != 1) {
      throw std::runtime_error("OpenSSL: SHA-256 final failed");
    }
    static const char* kHex = "0123456789abcdef";
    std::string out;
    for (unsigned int i = 0; i < size; ++i) {
      out += kHex[digest[i] >> 4];
      out += kHex[digest[i] & 0xF];
    }
    return out;
  }

 private:
  EVP_MD_CTX* context_;
};

}  // namespace

std::string Sha256String(const std::string& bytes) {
  Sha256 sha;
  sha.Update(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size());
  return sha.HexDigest();
}

std::string Sha256File(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path, "", "cannot open file to hash it");
  Sha256 sha;
  std::array<char, 1 << 16> buffer;
  while (in) {
    in.read(buffer.data(), buffer.size());
    sha.Update(reinterpret_cast<const unsigned char*>(buffer.data()),
               static_cast<std::size_t>(in.gcount()));
  }
  if (in.bad()) throw Error(path, "", "read error while hashing");
  return sha.HexDigest();
}

std::string TemporaryPathFor(const std::string& path) {
  // Unique per process and call: concurrent writers of one file never share a temporary.
  static std::atomic<unsigned long> counter{0};
  const fs::path p(path);
  return (p.parent_path() /
          fmt::format(".{}.{}.{}.tmp", p.filename().string(), getpid(), ++counter))
      .string();
}

PathKind KindOfPath(const std::string& path, const std::string& field) {
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (ec && status.type() != fs::file_type::not_found) {
    throw Error(path, field, fmt::format("cannot be looked up: {}", OneLine(ec.message())));
  }
  switch (status.type()) {
    case fs::file_type::not_found: return PathKind::kMissing;
    case fs::file_type::regular: return PathKind::kFile;
    case fs::file_type::directory: return PathKind::kDirectory;
    default: return PathKind::kOther;
  }
}

void CheckOutputPath(const std::string& path) {
  const fs::path p(path);
  if (!p.parent_path().empty() &&
      KindOfPath(p.parent_path().string(), "output") != PathKind::kDirectory) {
    throw Error(path, "", "output directory does not exist");
  }
  if (KindOfPath(path, "output") == PathKind::kDirectory) {
    throw Error(path, "output", "is a directory");
  }
}

void WriteAllOrNothing(const std::vector<OutputWrite>& writes) {
  for (const auto& [path, write] : writes) CheckOutputPath(path);
  std::size_t done = 0;
  try {
    for (; done < writes.size(); ++done) writes[done].second();
  } catch (...) {
    std::error_code ec;
    for (std::size_t i = 0; i < done; ++i) fs::remove(writes[i].first, ec);
    throw;
  }
}

void WriteAtomic(const std::string& path, const AtomicFill& fill) {
  CheckOutputPath(path);
  const std::string tmp = TemporaryPathFor(path);
  std::error_code ec;
  try {
    fill(tmp);
  } catch (...) {
    fs::remove(tmp, ec);
    throw;
  }
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw Error(path, "", "cannot write file (rename failed)");
  }
}

void WriteTextAtomic(const std::string& path, const std::string& text) {
  WriteAtomic(path, [&](const std::string& tmp) {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << text;
    out.close();
    if (!out) throw Error(path, "", "cannot write file");
  });
}

namespace {
std::recursive_mutex& StderrMutex() {
  static std::recursive_mutex m;
  return m;
}
int& StderrDepth() {
  static int depth = 0;
  return depth;
}
}  // namespace

StderrCapture::StderrCapture() {
  StderrMutex().lock();
  if (StderrDepth()++ > 0) return;
  std::fflush(stderr);
  held_fd_ = memfd_create("shadefit-stderr", MFD_CLOEXEC);
  if (held_fd_ < 0) return;
  saved_fd_ = dup(STDERR_FILENO);
  if (saved_fd_ < 0 || dup2(held_fd_, STDERR_FILENO) < 0) {
    if (saved_fd_ >= 0) close(saved_fd_);
    close(held_fd_);
    saved_fd_ = held_fd_ = -1;
  }
}

StderrCapture::~StderrCapture() {
  if (saved_fd_ >= 0) {
    std::fflush(stderr);
    dup2(saved_fd_, STDERR_FILENO);
    close(saved_fd_);
    if (!discard_) {
      char buffer[4096];
      lseek(held_fd_, 0, SEEK_SET);
      for (ssize_t n; (n = read(held_fd_, buffer, sizeof buffer)) > 0;) {
        if (write(STDERR_FILENO, buffer, static_cast<std::size_t>(n)) < 0) break;
      }
    }
  }
  if (held_fd_ >= 0) close(held_fd_);
  --StderrDepth();
  StderrMutex().unlock();
}

std::string OneLine(const std::string& text) {
  std::string out;
  bool blank = false;
  for (char c : text) {
    const bool is_blank = c == '\n' || c == '\r' || c == '\t' || c == ' ';
    if (is_blank) {
      blank = true;
      continue;
    }
    if (blank && !out.empty()) out += ' ';
    blank = false;
    out += c;
  }
  return out;
}

}  // namespace shadefit
