// The study file's reading helpers, shared by the files that read its tables (study.cpp,
// study_fit.cpp, study_materials.cpp, study_file.cpp): every key checked, errors naming the file,
// the line and the key.
#pragma once

#include <fmt/core.h>
#include <toml++/toml.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <set>
#include <string>
#include <vector>

#include "shadefit/base/error.h"
#include "shadefit/studies/study.h"

namespace shadefit::studies::internal {
namespace fs = std::filesystem;

// Reading helpers: every key is checked; an unknown key or a wrong type is an error naming the
// file, the line and the key.
class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}

  [[noreturn]] void Fail(const toml::node* node, const std::string& key,
                         const std::string& problem) const {
    std::string where = file_;
    if (node != nullptr && node->source().begin.line > 0) {
      where += fmt::format(":{}", node->source().begin.line);
    }
    throw Error(where, key, problem);
  }

  void CheckKeys(const toml::table& table, const std::string& prefix,
                 const std::set<std::string>& allowed) const {
    for (const auto& [key, node] : table) {
      if (!allowed.contains(std::string(key.str()))) {
        Fail(&node, prefix + std::string(key.str()),
             "unknown key" + DidYouMean(key.str(), {allowed.begin(), allowed.end()}));
      }
    }
  }

  std::string String(const toml::table& t, const std::string& prefix, const std::string& key,
                     const std::string& fallback) const {
    const toml::node* n = t.get(key);
    if (n == nullptr) return fallback;
    if (!n->is_string()) Fail(n, prefix + key, "expected a string");
    return *n->value<std::string>();
  }
  // A finite number in [min, max] (TOML allows nan and inf; no setting here means them).
  double Number(const toml::table& t, const std::string& prefix, const std::string& key,
                double fallback, double min = -1e300, double max = 1e300) const {
    const toml::node* n = t.get(key);
    if (n == nullptr) return fallback;
    if (!n->is_number()) Fail(n, prefix + key, "expected a number");
    const double v = *n->value<double>();
    if (!(v >= min && v <= max)) {
      Fail(n, prefix + key, fmt::format("value {} outside [{}, {}]", v, min, max));
    }
    return v;
  }
  // An integer in [min, max]; the default max keeps every value inside the int it is stored in.
  std::int64_t Integer(const toml::table& t, const std::string& prefix, const std::string& key,
                       std::int64_t fallback, std::int64_t min,
                       std::int64_t max = std::numeric_limits<int>::max()) const {
    const toml::node* n = t.get(key);
    if (n == nullptr) return fallback;
    if (!n->is_integer()) Fail(n, prefix + key, "expected an integer");
    const std::int64_t v = n->as_integer()->get();
    if (v < min) Fail(n, prefix + key, fmt::format("value {} below the minimum {}", v, min));
    if (v > max) Fail(n, prefix + key, fmt::format("value {} above the maximum {}", v, max));
    return v;
  }
  bool Bool(const toml::table& t, const std::string& prefix, const std::string& key,
            bool fallback) const {
    const toml::node* n = t.get(key);
    if (n == nullptr) return fallback;
    if (!n->is_boolean()) Fail(n, prefix + key, "expected true or false");
    return *n->value<bool>();
  }
  std::vector<std::string> Strings(const toml::table& t, const std::string& prefix,
                                   const std::string& key) const {
    std::vector<std::string> out;
    const toml::node* n = t.get(key);
    if (n == nullptr) return out;
    const toml::array* a = n->as_array();
    if (a == nullptr) Fail(n, prefix + key, "expected an array of strings");
    for (const toml::node& e : *a) {
      if (!e.is_string()) Fail(&e, prefix + key, "expected an array of strings");
      out.push_back(*e.value<std::string>());
    }
    return out;
  }
  const toml::table* Table(const toml::table& t, const std::string& prefix,
                           const std::string& key) const {
    const toml::node* n = t.get(key);
    if (n == nullptr) return nullptr;
    if (!n->is_table()) Fail(n, prefix + key, "expected a table");
    return n->as_table();
  }

  const std::string& file() const { return file_; }

 private:
  std::string file_;
};

// The keys of a fit's settings, in [fit], [fit.override.<model>] and [quick].
inline const std::set<std::string> kFitKeys = {
    "loss",           "loss_scale",   "starts",
    "seed",           "exposure",     "path",
    "max_iterations", "pixel_stride", "environment_samples",
    "fixed",          "encoding",     "start"};

// The [quick] filter of materials and lightings (empty: no filter), and its table when applied.
struct QuickFilter {
  const toml::table* table = nullptr;  // Set only when --quick applies it.
  std::vector<std::string> materials, lightings;

  bool KeepsMaterial(const std::string& m) const { return Keeps(materials, m); }
  bool KeepsLighting(const std::string& l) const { return Keeps(lightings, l); }

 private:
  static bool Keeps(const std::vector<std::string>& list, const std::string& x) {
    return list.empty() || std::find(list.begin(), list.end(), x) != list.end();
  }
};

// Expands one pattern relative to `base`: wildcards are allowed in the last path component only.
// A path the file system cannot look up or a folder it cannot list fails through `r` at `node`
// and `key`, the study's entry that gave the pattern.
std::vector<fs::path> Glob(const Reader& r, const toml::node* node, const std::string& key,
                           const fs::path& base, const std::string& pattern);

// Whether a file's name matches one of the `exclude` patterns.
bool Excluded(const std::vector<std::string>& exclude, const std::string& leaf);

// The study file's bytes and its TOML (study_file.cpp).
toml::table ParseStudyFile(const std::string& path, const Reader& r, StudySpec* spec);

// [quick], read first: it filters what follows (study_file.cpp).
QuickFilter ReadQuick(const Reader& r, const toml::table& root, bool quick);

// [[measured]] (study_materials.cpp).
void ReadMeasured(const Reader& r, const toml::table& root, const fs::path& base,
                  const QuickFilter& q, StudySpec* spec);

// [[group]], after [[measured]] (study_materials.cpp).
void ReadGroups(const Reader& r, const toml::table& root, const fs::path& base,
                const QuickFilter& q, StudySpec* spec);

// [fit]: models, their settings and `fixed` values, training sets (study_fit.cpp).
void ReadFit(const Reader& r, const toml::table& root, const QuickFilter& q, StudySpec* spec);

// [study] baseline and compare, after the models are known (study_fit.cpp).
void ReadComparisons(const Reader& r, const toml::table& root, const toml::table& fit,
                     StudySpec* spec);

}  // namespace shadefit::studies::internal
