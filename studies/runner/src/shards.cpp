// Shards of a study (docs/cluster.md): which materials a shard runs, and the manifests a shard
// leaves for `shadefit study merge`.
#include <fmt/core.h>

#include <algorithm>
#include <charconv>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <regex>

#include "job_cost.h"
#include "shadefit/base/error.h"
#include "shadefit/studies/runner.h"

namespace shadefit::studies {
namespace fs = std::filesystem;
using json = nlohmann::json;

std::string Shard::Name() const { return fmt::format("{}-of-{}", index, count); }

Shard ParseShard(const std::string& text, const std::string& field) {
  const auto slash = text.find('/');
  auto number = [&](std::string_view s, int* out) {
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), *out);
    return ec == std::errc() && end == s.data() + s.size() && !s.empty();
  };
  Shard shard;
  if (slash == std::string::npos ||
      !number(std::string_view(text).substr(0, slash), &shard.index) ||
      !number(std::string_view(text).substr(slash + 1), &shard.count) || shard.count < 1 ||
      shard.count > 10000 || shard.index < 1 || shard.index > shard.count) {
    throw Error("", field, "want i/N with 1 <= i <= N <= 10000 (e.g. 2/4), got '" + text + "'");
  }
  shard.sharded = true;
  return shard;
}

std::map<std::string, int> AssignShards(const StudySpec& spec, int count) {
  struct Item {
    std::string material;
    double cost;
  };
  std::vector<Item> items;
  for (const ReferenceGroup& g : spec.groups) {
    items.push_back({g.material, MaterialCost(spec, g.references.size())});
  }
  for (const MeasuredSource& src : spec.measured) {
    for (const std::string& m : src.materials) {
      items.push_back({m, MaterialCost(spec, src.scenes.size())});
    }
  }
  // Longest processing time first (Graham 1969: within 4/3 of the best makespan).
  std::sort(items.begin(), items.end(), [](const Item& a, const Item& b) {
    return a.cost != b.cost ? a.cost > b.cost : a.material < b.material;
  });
  std::vector<double> load(static_cast<std::size_t>(count), 0.0);
  std::map<std::string, int> shard_of;
  for (const Item& item : items) {
    const auto least = std::min_element(load.begin(), load.end());
    *least += item.cost;
    shard_of[item.material] = static_cast<int>(least - load.begin()) + 1;
  }
  return shard_of;
}

std::set<std::string> RestrictToShard(StudySpec* spec, const Shard& shard) {
  const std::map<std::string, int> shard_of = AssignShards(*spec, shard.count);
  std::set<std::string> mine;
  for (const auto& [material, index] : shard_of) {
    if (index == shard.index) mine.insert(material);
  }
  std::erase_if(spec->groups,
                [&](const ReferenceGroup& g) { return mine.count(g.material) == 0; });
  return mine;
}

ShardedRun ReadShardManifests(const std::string& study_dir) {
  const fs::path dir = fs::path(study_dir) / "shards";
  if (!fs::is_directory(dir)) {
    throw Error(dir.string(), "", "no shard manifests (run `shadefit study run S.toml --shard i/N` "
                                  "for every i first)");
  }
  // shards/<i>-of-<N>.json; the newest sharding (by manifest time) is the one merged.
  const std::regex name(R"((\d+)-of-(\d+)\.json)");
  std::map<int, std::map<int, fs::path>> by_count;
  std::map<int, fs::file_time_type> newest;
  for (const auto& entry : fs::directory_iterator(dir)) {
    std::smatch m;
    const std::string leaf = entry.path().filename().string();
    if (!entry.is_regular_file() || !std::regex_match(leaf, m, name)) continue;
    const int i = std::stoi(m[1]), n = std::stoi(m[2]);
    by_count[n][i] = entry.path();
    newest[n] = std::max(newest[n], fs::last_write_time(entry.path()));
  }
  if (by_count.empty()) throw Error(dir.string(), "", "no shard manifest <i>-of-<N>.json");
  const int count = std::max_element(newest.begin(), newest.end(), [](auto& a, auto& b) {
                      return a.second < b.second;
                    })->first;
  ShardedRun run;
  run.count = count;
  for (int i = 1; i <= count; ++i) {
    const auto it = by_count[count].find(i);
    if (it == by_count[count].end()) {
      throw Error((dir / fmt::format("{}-of-{}.json", i, count)).string(), "",
                  fmt::format("missing: shard {}/{} has not finished (run it, or rerun it with "
                              "`shadefit study run S.toml --shard {}/{}`)", i, count, i, count));
    }
    std::ifstream in(it->second);
    json j;
    try {
      j = json::parse(in);
    } catch (const json::exception& e) {
      throw Error(it->second.string(), "", std::string("not valid JSON: ") + e.what());
    }
    for (const char* key : {"study_path", "study_sha256", "quick", "shadefit_version"}) {
      if (!j.contains(key)) throw Error(it->second.string(), key, "missing");
    }
    if (i == 1) {
      run.study_path = j["study_path"];
      run.study_sha256 = j["study_sha256"];
      run.quick = j["quick"];
    } else if (j["study_sha256"] != run.study_sha256 || j["quick"] != run.quick) {
      throw Error(it->second.string(), "study_sha256",
                  fmt::format("shard {} ran another version of the study (or --quick) than "
                              "shard 1; rerun it", i));
    }
    run.manifests.push_back(std::move(j));
  }
  return run;
}

}  // namespace shadefit::studies
