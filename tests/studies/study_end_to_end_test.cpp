// `shadefit study run` + `shadefit report` end to end on a small study of shipped references
// (2 materials x 2 models x 2 lightings), and verdicts that follow the data.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "shadefit/render/gl_context.h"
#include "shadefit/render/image.h"
#include "shadefit/render/models.h"
#include "shadefit/render/renderer.h"
#include "shadefit/render/scene.h"

namespace {
namespace fs = std::filesystem;
using json = nlohmann::json;

const std::string kRefs = std::string(SHADEFIT_SOURCE_DIR) + "/reference_images/cycles";

fs::path OutputDir(const std::string& name) {
  const fs::path dir = fs::path(SHADEFIT_TEST_OUTPUT) / "studies" / name;
  fs::create_directories(dir);
  return dir;
}

std::string ReadText(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Runs a command, output appended to <dir>/command.txt; returns its exit status.
int RunShadefit(const std::string& args, const fs::path& dir) {
  const std::string cmd = std::string("'") + SHADEFIT_EXE + "' " + args + " >> '" +
                          (dir / "command.txt").string() + "' 2>&1";
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// Job ids started by the runs after `offset` bytes of study.log.
std::set<std::string> StartedSince(const fs::path& log, std::size_t offset) {
  std::set<std::string> ids;
  std::istringstream in(ReadText(log).substr(offset));
  std::string line;
  while (std::getline(in, line)) {
    const auto p = line.find("  start ");
    if (p == std::string::npos) continue;
    std::string id = line.substr(p + 8);
    ids.insert(id.substr(0, id.find(' ')));
  }
  return ids;
}

// PNG width and height from the IHDR chunk; {0, 0} when the file is not a PNG.
std::pair<int, int> PngSize(const fs::path& p) {
  const std::string b = ReadText(p);
  if (b.size() < 24 || b.compare(0, 8, "\x89PNG\r\n\x1a\n") != 0) return {0, 0};
  const auto be32 = [&](std::size_t o) {
    return static_cast<int>((static_cast<std::uint32_t>(static_cast<unsigned char>(b[o])) << 24) |
                            (static_cast<unsigned char>(b[o + 1]) << 16) |
                            (static_cast<unsigned char>(b[o + 2]) << 8) |
                            static_cast<unsigned char>(b[o + 3]));
  };
  return {be32(16), be32(20)};
}

std::vector<std::map<std::string, std::string>> ReadCsv(const fs::path& p) {
  std::vector<std::map<std::string, std::string>> rows;
  std::istringstream in(ReadText(p));
  std::string line;
  std::vector<std::string> header;
  const auto split = [](const std::string& s) {
    std::vector<std::string> out;
    std::string cell;
    std::istringstream ss(s);
    while (std::getline(ss, cell, ',')) out.push_back(cell);
    if (!s.empty() && s.back() == ',') out.push_back("");
    return out;
  };
  while (std::getline(in, line)) {
    if (header.empty()) {
      header = split(line);
      continue;
    }
    const auto cells = split(line);
    EXPECT_EQ(cells.size(), header.size()) << line;
    std::map<std::string, std::string> row;
    for (std::size_t i = 0; i < header.size() && i < cells.size(); ++i) row[header[i]] = cells[i];
    rows.push_back(row);
  }
  return rows;
}

std::string SmallStudy(const std::string& name, const std::vector<std::string>& materials,
                       const std::string& dir, const std::string& extra) {
  std::string s = "[study]\nname = \"" + name + "\"\n";
  for (const std::string& m : materials) {
    s += "[[group]]\nmaterial = \"" + m + "\"\nimages = [\"" + dir + "/" + m +
         "-*.exr\"]\nlightings = [\"key\", \"rim\"]\n";
  }
  s += "[fit]\nmodels = [\"blinn-phong\", \"ggx\"]\ntrain = [[\"key\"]]\nstarts = 1\n"
       "max_iterations = 25\npixel_stride = 4\n"
       "[probes]\nrun = [\"fresnel\", \"highlight\", \"energy\", \"portability\"]\n"
       "[verdicts.image]\nsource = \"metrics\"\nmetric = \"flip_ldr_mean\"\nsplit = \"train\"\n"
       "kind = \"max\"\ntolerance = 0.05\n"
       "[verdicts.fresnel]\nsource = \"fresnel\"\nkind = \"relative\"\ntolerance = 0.25\n" +
       extra;
  return s;
}

TEST(StudyEndToEnd, RunReportRerunAndChangedOption) {
  const fs::path dir = OutputDir("e2e");
  fs::remove_all(dir / "out");
  fs::remove(dir / "command.txt");
  const fs::path study = dir / "e2e.toml";
  std::ofstream(study) << SmallStudy("e2e", {"red-plastic", "gold"}, kRefs, "");
  const std::string run = "study run '" + study.string() + "' -o '" + (dir / "out").string() + "' -j 2";
  ASSERT_EQ(RunShadefit(run, dir), 0) << ReadText(dir / "command.txt");

  const fs::path out = dir / "out" / "e2e";
  const std::vector<std::string> materials = {"red-plastic", "gold"};
  const std::vector<std::string> models = {"blinn-phong", "ggx"};
  const std::vector<std::string> lightings = {"key", "rim"};
  std::vector<fs::path> expected = {"study.json", "results.csv", "provenance.json", "study.log",
                                    "report/index.html", "report/summary.md",
                                    "report/verdicts.json", "report/figures.json",
                                    "report/report.tex", "report/figures/metric-flip_ldr_mean.png",
                                    "report/figures/metric-flip_ldr_mean.pdf"};
  for (const char* t : {"metrics", "parameters", "probes", "verdicts", "matrix"}) {
    for (const char* ext : {".tex", ".md", ".csv"}) {
      expected.push_back(fs::path("report/tables") / (std::string(t) + ext));
    }
  }
  for (const auto& m : materials) {
    expected.push_back("report/figures/grid-" + m + ".png");
    expected.push_back("report/figures/grid-" + m + ".pdf");
    expected.push_back("jobs/probe." + m + ".json");
    for (const auto& model : models) expected.push_back("jobs/fit." + m + "." + model + ".key.json");
    for (const auto& l : lightings) {
      expected.push_back("images/" + m + "-" + l + ".reference.png");
      for (const auto& model : models) {
        expected.push_back("images/" + m + "-" + l + "." + model + ".png");
        expected.push_back("images/" + m + "-" + l + "." + model + ".error.png");
      }
    }
  }
  for (const fs::path& p : expected) EXPECT_TRUE(fs::exists(out / p)) << "missing " << p;

  // results.csv: one row per reference x model, train on key, test on rim.
  const auto rows = ReadCsv(out / "results.csv");
  EXPECT_EQ(rows.size(), materials.size() * models.size() * lightings.size());
  std::set<std::string> seen;
  for (const auto& r : rows) {
    seen.insert(r.at("material") + "/" + r.at("lighting") + "/" + r.at("label"));
    EXPECT_EQ(r.at("split"), r.at("lighting") == "key" ? "train" : "test");
    EXPECT_GT(std::stod(r.at("rmse")), 0.0);
    EXPECT_GT(std::stod(r.at("flip_ldr_mean")), 0.0);
  }
  EXPECT_EQ(seen.size(), rows.size());

  // Provenance.
  const json prov = json::parse(ReadText(out / "provenance.json"));
  EXPECT_FALSE(prov["shadefit"]["version"].get<std::string>().empty());
  EXPECT_FALSE(prov["gl_renderer"].get<std::string>().empty());
  EXPECT_FALSE(prov["dependencies"]["ceres"].get<std::string>().empty());
  EXPECT_EQ(prov["inputs"].size(), materials.size() * lightings.size());
  EXPECT_EQ(prov["inputs"][0]["image"]["sha256"].get<std::string>().size(), 64u);

  // Images: previews at the references' size, error maps as tall with a colour bar, figures at
  // the sizes the report recorded.
  EXPECT_EQ(PngSize(out / "images/gold-key.reference.png"), std::make_pair(256, 256));
  EXPECT_EQ(PngSize(out / "images/gold-key.ggx.png"), std::make_pair(256, 256));
  const auto err = PngSize(out / "images/gold-rim.blinn-phong.error.png");
  EXPECT_EQ(err.second, 256);
  EXPECT_GT(err.first, 256);
  const json figures = json::parse(ReadText(out / "report/figures.json"));
  EXPECT_GE(figures.size(), 3u);
  for (const json& f : figures) {
    EXPECT_EQ(PngSize(out / "report" / f["png"].get<std::string>()),
              std::make_pair(f["width"].get<int>(), f["height"].get<int>()))
        << f["png"];
    EXPECT_EQ(ReadText(out / "report" / f["pdf"].get<std::string>()).substr(0, 4), "%PDF");
  }
  // Verdicts exist for every material x fit of the metric-based phenomenon.
  const json verdicts = json::parse(ReadText(out / "report/verdicts.json"));
  int image_verdicts = 0;
  for (const json& v : verdicts["summary"]) {
    if (v["phenomenon"] == "image") {
      ++image_verdicts;
      EXPECT_TRUE(v["reproduced"].is_boolean());
    }
  }
  EXPECT_EQ(image_verdicts, 4);

  // Rerun: every job is unchanged and skipped.
  std::size_t offset = fs::file_size(out / "study.log");
  ASSERT_EQ(RunShadefit(run, dir), 0) << ReadText(dir / "command.txt");
  EXPECT_TRUE(StartedSince(out / "study.log", offset).empty());
  EXPECT_NE(ReadText(out / "study.log").substr(offset).find(": 0 ran,"), std::string::npos);

  // A changed ggx option reruns the ggx fits (and the probes that read them) only.
  std::ofstream(study) << SmallStudy("e2e", {"red-plastic", "gold"}, kRefs,
                                     "[fit.override.ggx]\nmax_iterations = 24\n");
  offset = fs::file_size(out / "study.log");
  ASSERT_EQ(RunShadefit(run, dir), 0) << ReadText(dir / "command.txt");
  std::set<std::string> want = {"fit.gold.ggx.key", "fit.red-plastic.ggx.key"};
  want.insert({"probe.gold", "probe.red-plastic"});
  EXPECT_EQ(StartedSince(out / "study.log", offset), want);
}

TEST(StudyEndToEnd, LatexTablesCompile) {
  if (std::system("command -v pdflatex > /dev/null 2>&1") != 0) {
    GTEST_SKIP() << "pdflatex not installed: LaTeX tables not compiled";
  }
  const fs::path dir = OutputDir("latex");
  const fs::path study = dir / "latex.toml";
  std::ofstream(study) << SmallStudy("latex", {"red-plastic"}, kRefs, "");
  ASSERT_EQ(RunShadefit("study run '" + study.string() + "' -o '" + (dir / "out").string() + "'", dir), 0)
      << ReadText(dir / "command.txt");
  const fs::path report = dir / "out" / "latex" / "report";
  const std::string cmd = "cd '" + report.string() +
                          "' && pdflatex -interaction=nonstopmode -halt-on-error report.tex > '" +
                          (dir / "pdflatex.txt").string() + "' 2>&1";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << ReadText(dir / "pdflatex.txt");
  EXPECT_TRUE(fs::exists(report / "report.pdf"));
}

// Renders `model` on the red-plastic scenes with our renderer: a reference that has exactly the
// effects the model has (a Blinn-Phong one has no Fresnel rise at grazing angles).
void RenderReferences(const fs::path& dir, const std::string& material, const std::string& model,
                      const std::vector<std::string>& assignments,
                      const std::vector<std::string>& lightings) {
  shadefit::GlContext context;
  context.MakeCurrent();
  shadefit::Renderer renderer(context);
  const shadefit::ModelInfo& info = shadefit::FindModel(model);
  std::vector<double> params = shadefit::DefaultParams(info);
  for (const std::string& a : assignments) shadefit::SetParamFromString(info, a, "test", &params);
  for (const std::string& l : lightings) {
    const std::string scene_path = kRefs + "/scenes/sphere-" + l + ".toml";
    const shadefit::Scene scene = shadefit::LoadScene(scene_path);
    const shadefit::Image image = renderer.Render(scene, info.id, params);
    const std::string stem = (dir / (material + "-" + l)).string();
    shadefit::WriteExr(stem + ".exr", image);
    json sidecar = {{"name", material + "-" + l},
                    {"scene_file", scene_path},
                    {"material", {{"type", model}, {"set", assignments}}},
                    {"generator", "tests/studies/study_end_to_end_test.cpp"}};
    std::ofstream(stem + ".json") << sidecar.dump(1);
  }
}

bool FresnelReproduced(const fs::path& study_dir, const std::string& fit) {
  const json v = json::parse(ReadText(study_dir / "report/verdicts.json"));
  for (const json& s : v["summary"]) {
    if (s["phenomenon"] == "fresnel" && s["fit"] == fit) {
      EXPECT_TRUE(s["reproduced"].is_boolean()) << s.dump();
      return s["reproduced"].is_boolean() && s["reproduced"].get<bool>();
    }
  }
  ADD_FAILURE() << "no fresnel verdict for " << fit << " in " << study_dir;
  return false;
}

TEST(StudyVerdicts, FresnelVerdictFollowsTheReference) {
  const fs::path dir = OutputDir("verdict_flip");
  const fs::path refs = dir / "refs";
  fs::create_directories(refs);
  const std::vector<std::string> lightings = {"key", "side", "rim", "camera"};
  RenderReferences(refs, "bp-plastic", "blinn-phong",
                   {"kd=0.6,0.04,0.04", "ks=0.4", "shininess=60", "ka=0"}, lightings);
  const auto study = [&](const std::string& name, const std::string& material,
                         const std::string& images_dir) {
    std::string s = "[study]\nname = \"" + name + "\"\n[[group]]\nmaterial = \"" + material +
                    "\"\nimages = [\"" + images_dir + "/" + material +
                    "-*.exr\"]\nlightings = [\"key\", \"side\", \"rim\", \"camera\"]\n"
                    "[fit]\nmodels = [\"blinn-phong\", \"ggx\"]\ntrain = [\"key\"]\nstarts = 2\n"
                    "max_iterations = 40\npixel_stride = 2\n[probes]\nrun = [\"fresnel\"]\n"
                    "[verdicts.fresnel]\nsource = \"fresnel\"\nkind = \"relative\"\n"
                    "keys = [\"rim_to_centre\", \"*.rim_to_centre_theta_v\"]\n"
                    "tolerance = 0.25\nfloor = 0.01\n";
    const fs::path p = dir / (name + ".toml");
    std::ofstream(p) << s;
    EXPECT_EQ(RunShadefit("study run '" + p.string() + "' -o '" + (dir / "out").string() + "'", dir), 0)
        << ReadText(dir / "command.txt");
    return dir / "out" / name;
  };
  const fs::path cycles = study("cycles", "red-plastic", kRefs);
  const fs::path blinn = study("blinn", "bp-plastic", refs.string());
  // Cycles' Principled BSDF brightens towards grazing angles; Blinn-Phong cannot follow.
  EXPECT_FALSE(FresnelReproduced(cycles, "blinn-phong"));
  // The same model against a reference without a Fresnel rise: the verdict flips.
  EXPECT_TRUE(FresnelReproduced(blinn, "blinn-phong"));
}

}  // namespace
