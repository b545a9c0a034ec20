// Small file utilities shared by every writer: content hashes for provenance, the one atomic
// writer (text, bytes, or any file a callback fills: images, plots), and one-line error text.
#pragma once

#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace shadefit {

// SHA-256 (FIPS 180-4) of a file's bytes / of a string, as 64 lowercase hex digits. The file
// variant throws shadefit::Error naming the file when it cannot be read.
std::string Sha256File(const std::string& path);
std::string Sha256String(const std::string& bytes);

// The hidden temporary that an atomic writer fills before renaming it to `path`:
// "<dir>/.<name>.<pid>.<n>.tmp", unique per process and call, in the same directory (so the
// rename stays on one file system). Every atomic writer in shadefit names its temporary here.
std::string TemporaryPathFor(const std::string& path);

// What is at a path a user gave: nothing, a regular file, a folder, or something else (a FIFO, a
// device). When the file system cannot say (a name component past 255 bytes, a folder we may not
// enter), throws shadefit::Error naming `path` and `field`, never std::filesystem's own exception:
// a reader's bad input is a one-line error like any other (found by fuzz_scene). Not-found counts
// as kMissing, also when a parent is a file (ENOTDIR).
enum class PathKind { kMissing, kFile, kDirectory, kOther };
PathKind KindOfPath(const std::string& path, const std::string& field = "");
inline bool PathExists(const std::string& path, const std::string& field = "") {
  return KindOfPath(path, field) != PathKind::kMissing;
}

// Throws shadefit::Error naming `path` unless a file can be created there: its folder exists (and
// is a folder) and the path itself is not a folder. Every writer calls it before it writes, and
// commands with several outputs call it for all of them first, so that a bad path fails before
// anything is written.
void CheckOutputPath(const std::string& path);

// For commands with several outputs (an EXR and its PNG preview, a fit's images and JSON): checks
// every path first (CheckOutputPath), then runs the writers in order; when one throws, removes
// what the earlier ones wrote and rethrows, so the command leaves all of its outputs or none.
using OutputWrite = std::pair<std::string, std::function<void()>>;  // path, its atomic writer
void WriteAllOrNothing(const std::vector<OutputWrite>& writes);

// The one atomic writer: every output file of shadefit is written through it. Checks the path
// (CheckOutputPath), has `fill` write the complete file at `temporary` (TemporaryPathFor(path):
// a hidden sibling, so the rename stays on one file system), then renames it over `path`. A
// reader never sees a partial file; when `fill` throws or the rename fails the temporary is
// removed and nothing is left under `path`. Concurrent writers of one path each use their own
// temporary, and the last rename wins with a complete file. Throws shadefit::Error naming `path`
// (and rethrows what `fill` throws).
using AtomicFill = std::function<void(const std::string& temporary)>;
void WriteAtomic(const std::string& path, const AtomicFill& fill);

// WriteAtomic of `text`, byte for byte (binary-safe: any bytes, no newline translation).
void WriteTextAtomic(const std::string& path, const std::string& text);

// Holds back what C libraries print on stderr while it lives (libpng prints "libpng error: ..."
// itself before OpenImageIO reports the same failure), so that a bad file gives our one error
// line and nothing else. Discard() drops the held text (the failure is being reported in our
// words); otherwise the destructor passes it on to stderr, so warnings of a successful read and
// other threads' output are delayed, never lost. Process-wide and serialised; nested captures
// are no-ops.
class StderrCapture {
 public:
  StderrCapture();
  ~StderrCapture();
  StderrCapture(const StderrCapture&) = delete;
  StderrCapture& operator=(const StderrCapture&) = delete;
  void Discard() { discard_ = true; }

 private:
  int saved_fd_ = -1;   // the real stderr while captured; -1 when this capture is nested
  int held_fd_ = -1;    // the anonymous file that stands in for it
  bool discard_ = false;
};

// Collapses line breaks and runs of blanks so that library messages (OpenImageIO, HDF5) fit the
// one-line error format of shadefit::Error.
std::string OneLine(const std::string& text);

}  // namespace shadefit
