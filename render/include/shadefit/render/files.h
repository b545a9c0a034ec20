// Small file utilities shared by every writer: content hashes for provenance, atomic
// text writes, and one-line error text.
#pragma once

#include <string>

namespace shadefit {

// SHA-256 (FIPS 180-4) of a file's bytes / of a string, as 64 lowercase hex digits. The file
// variant throws shadefit::Error naming the file when it cannot be read.
std::string Sha256File(const std::string& path);
std::string Sha256String(const std::string& bytes);

// The hidden temporary that an atomic writer fills before renaming it to `path`:
// "<dir>/.<name>.<pid>.<n>.tmp", unique per process and call, in the same directory (so the
// rename stays on one file system). Every atomic writer in shadefit names its temporary here.
std::string TemporaryPathFor(const std::string& path);

// Writes text to a temporary sibling and renames it over `path`, so a reader never sees a partial
// file and a failure leaves nothing. Throws shadefit::Error naming the file.
void WriteTextAtomic(const std::string& path, const std::string& text);

// Collapses line breaks and runs of blanks so that library messages (OpenImageIO, HDF5) fit the
// one-line error format of shadefit::Error.
std::string OneLine(const std::string& text);

}  // namespace shadefit
