// The study file itself: its TOML, the file patterns it names and its [quick] filter
// (docs/studies.md).
#include "study_file.h"

#include <fnmatch.h>

#include <fstream>
#include <sstream>

#include "shadefit/base/files.h"

namespace shadefit::studies::internal {

// Expands one pattern relative to `base`: wildcards are allowed in the last path component only.
std::vector<fs::path> Glob(const Reader& r, const toml::node* node, const std::string& key,
                           const fs::path& base, const std::string& pattern) {
  const fs::path full = (base / pattern).lexically_normal();
  const fs::path dir = full.parent_path();
  const std::string leaf = full.filename().string();
  std::vector<fs::path> out;
  try {
    if (leaf.find_first_of("*?[") == std::string::npos) {
      if (PathExists(full)) out.push_back(full);
      return out;
    }
    if (KindOfPath(dir) != PathKind::kDirectory) return out;
  } catch (const Error& e) {
    r.Fail(node, key, e.what());
  }
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code type_ec;
    if (it->is_regular_file(type_ec) &&
        fnmatch(leaf.c_str(), it->path().filename().c_str(), 0) == 0) {
      out.push_back(it->path());
    }
  }
  if (ec) r.Fail(node, key, fmt::format("{}: cannot be listed: {}", dir.string(), ec.message()));
  std::sort(out.begin(), out.end());
  return out;
}

// Whether a file's name matches one of the `exclude` patterns.
bool Excluded(const std::vector<std::string>& exclude, const std::string& leaf) {
  return std::any_of(exclude.begin(), exclude.end(), [&](const std::string& x) {
    return fnmatch(x.c_str(), leaf.c_str(), 0) == 0;
  });
}

// The study file's bytes and its TOML.
toml::table ParseStudyFile(const std::string& path, const Reader& r, StudySpec* spec) {
  const fs::path file = fs::absolute(path).lexically_normal();
  const PathKind kind = KindOfPath(file, "study");
  if (kind == PathKind::kMissing) throw Error(path, "", "study file not found");
  if (kind != PathKind::kFile) throw Error(path, "", "study file is not a regular file");
  {
    std::ifstream in(file, std::ios::binary);
    std::ostringstream ss;
    ss << in.rdbuf();
    spec->text = ss.str();
  }
  spec->path = file.string();
  toml::table root;
  try {
    root = toml::parse(spec->text, spec->path);
  } catch (const toml::parse_error& e) {
    throw Error(fmt::format("{}:{}", path, e.source().begin.line), "",
                "malformed TOML: " + std::string(e.description()));
  }
  r.CheckKeys(
      root, "",
      {"study", "group", "measured", "fit", "metrics", "probes", "verdicts", "outputs", "quick"});
  return root;
}

// [quick], read first: it filters what follows. Its keys are checked with or without --quick.
QuickFilter ReadQuick(const Reader& r, const toml::table& root, bool quick) {
  QuickFilter q;
  if (const toml::table* qt = r.Table(root, "", "quick")) {
    std::set<std::string> allowed = kFitKeys;
    for (const char* k : {"materials", "lightings", "models", "probes", "training_sets"})
      allowed.insert(k);
    r.CheckKeys(*qt, "quick.", allowed);
  }
  q.table = quick ? r.Table(root, "", "quick") : nullptr;
  if (q.table != nullptr) {
    q.materials = r.Strings(*q.table, "quick.", "materials");
    q.lightings = r.Strings(*q.table, "quick.", "lightings");
  }
  return q;
}

}  // namespace shadefit::studies::internal
