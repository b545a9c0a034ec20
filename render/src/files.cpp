#include "shadefit/render/files.h"

#include <fmt/format.h>
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

#include "shadefit/render/error.h"

namespace shadefit {
namespace {

namespace fs = std::filesystem;

// SHA-256 as specified in FIPS 180-4, sections 4.1.2 (functions), 4.2.2 (constants), 5.1.1
// (padding), 5.3.3 (initial hash value) and 6.2.2 (computation).
class Sha256 {
 public:
  void Update(const unsigned char* p, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) {
      block_[fill_++] = p[i];
      if (fill_ == 64) {
        Compress();
        fill_ = 0;
      }
    }
    length_bits_ += static_cast<std::uint64_t>(n) * 8;
  }

  std::string HexDigest() {
    const std::uint64_t bits = length_bits_;
    const unsigned char one = 0x80, zero = 0x00;
    Update(&one, 1);
    while (fill_ != 56) Update(&zero, 1);
    unsigned char len[8];
    for (int i = 0; i < 8; ++i) len[i] = static_cast<unsigned char>(bits >> (56 - 8 * i));
    Update(len, 8);
    static const char* kHex = "0123456789abcdef";
    std::string out;
    for (std::uint32_t word : h_) {
      for (int shift = 28; shift >= 0; shift -= 4) out += kHex[(word >> shift) & 0xF];
    }
    return out;
  }

 private:
  static std::uint32_t Rotr(std::uint32_t x, int n) { return (x >> n) | (x << (32 - n)); }

  void Compress() {
    static constexpr std::uint32_t kK[64] = {
        0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4,
        0xab1c5ed5, 0xd807aa98, 0x12835b01, 0x243185be, 0x550c7dc3, 0x72be5d74, 0x80deb1fe,
        0x9bdc06a7, 0xc19bf174, 0xe49b69c1, 0xefbe4786, 0x0fc19dc6, 0x240ca1cc, 0x2de92c6f,
        0x4a7484aa, 0x5cb0a9dc, 0x76f988da, 0x983e5152, 0xa831c66d, 0xb00327c8, 0xbf597fc7,
        0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967, 0x27b70a85, 0x2e1b2138, 0x4d2c6dfc,
        0x53380d13, 0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85, 0xa2bfe8a1, 0xa81a664b,
        0xc24b8b70, 0xc76c51a3, 0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070, 0x19a4c116,
        0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a, 0x5b9cca4f, 0x682e6ff3,
        0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7,
        0xc67178f2};
    std::uint32_t w[64];
    for (int t = 0; t < 16; ++t) {
      w[t] = (std::uint32_t{block_[4 * t]} << 24) | (std::uint32_t{block_[4 * t + 1]} << 16) |
             (std::uint32_t{block_[4 * t + 2]} << 8) | std::uint32_t{block_[4 * t + 3]};
    }
    for (int t = 16; t < 64; ++t) {
      const std::uint32_t s0 = Rotr(w[t - 15], 7) ^ Rotr(w[t - 15], 18) ^ (w[t - 15] >> 3);
      const std::uint32_t s1 = Rotr(w[t - 2], 17) ^ Rotr(w[t - 2], 19) ^ (w[t - 2] >> 10);
      w[t] = w[t - 16] + s0 + w[t - 7] + s1;
    }
    std::uint32_t a = h_[0], b = h_[1], c = h_[2], d = h_[3], e = h_[4], f = h_[5], g = h_[6],
                  h = h_[7];
    for (int t = 0; t < 64; ++t) {
      const std::uint32_t t1 =
          h + (Rotr(e, 6) ^ Rotr(e, 11) ^ Rotr(e, 25)) + ((e & f) ^ (~e & g)) + kK[t] + w[t];
      const std::uint32_t t2 =
          (Rotr(a, 2) ^ Rotr(a, 13) ^ Rotr(a, 22)) + ((a & b) ^ (a & c) ^ (b & c));
      h = g;
      g = f;
      f = e;
      e = d + t1;
      d = c;
      c = b;
      b = a;
      a = t1 + t2;
    }
    h_[0] += a;
    h_[1] += b;
    h_[2] += c;
    h_[3] += d;
    h_[4] += e;
    h_[5] += f;
    h_[6] += g;
    h_[7] += h;
  }

  std::array<std::uint32_t, 8> h_ = {0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a,
                                     0x510e527f, 0x9b05688c, 0x1f83d9ab, 0x5be0cd19};
  unsigned char block_[64] = {};
  std::size_t fill_ = 0;
  std::uint64_t length_bits_ = 0;
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

void CheckOutputPath(const std::string& path) {
  const fs::path p(path);
  if (!p.parent_path().empty() && !fs::is_directory(p.parent_path())) {
    throw Error(path, "", "output directory does not exist");
  }
  if (fs::is_directory(p)) throw Error(path, "output", "is a directory");
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
