// `shadefit study run` + `shadefit report` end to end on a small study of shipped references
// (2 materials x 2 models x 2 lightings): the report's verdict cells equal verdicts recomputed
// here from results.csv and the probe files with the study's tolerances, its figures exist and
// are referenced, its LaTeX tables parse back to results.csv; and verdicts that follow the data.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
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

// The study file's tolerances (SmallStudy writes them; the checks below use the same numbers).
constexpr double kImageTolerance = 0.05;    // [verdicts.image], max of mean train LDR-FLIP
constexpr double kFresnelTolerance = 0.25;  // [verdicts.fresnel], relative

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
                       const std::string& dir, const std::string& extra,
                       const std::string& probes_extra = "") {
  std::string s = "[study]\nname = \"" + name + "\"\n";
  for (const std::string& m : materials) {
    s += "[[group]]\nmaterial = \"" + m + "\"\nimages = [\"" + dir + "/" + m +
         "-*.exr\"]\nlightings = [\"key\", \"rim\"]\n";
  }
  s += "[fit]\nmodels = [\"blinn-phong\", \"ggx\"]\ntrain = [[\"key\"]]\nstarts = 1\n"
       "max_iterations = 25\npixel_stride = 4\n"
       "[probes]\nrun = [\"fresnel\", \"highlight\", \"energy\", \"portability\"]\n" +
       probes_extra +
       "[verdicts.image]\nsource = \"metrics\"\nmetric = \"flip_ldr_mean\"\nsplit = \"train\"\n"
       "kind = \"max\"\ntolerance = " + std::to_string(kImageTolerance) + "\n"
       "[verdicts.fresnel]\nsource = \"fresnel\"\nkind = \"relative\"\ntolerance = " +
       std::to_string(kFresnelTolerance) + "\n" + extra;
  return s;
}

// --- Report content, recomputed here from the result files --------------------------------------

// Numeric leaves of a probe's numbers as "a.b" -> value, the flattening docs/studies.md
// ("Verdict rules") describes: nested objects joined with '.', lists of up to 8 numbers as
// "a[i]", booleans as 1/0, nulls and non-numbers left out.
void Flatten(const json& j, const std::string& prefix, std::map<std::string, double>* out) {
  if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it) Flatten(*it, prefix + it.key() + ".", out);
  } else if (j.is_array()) {
    if (j.size() > 8) return;
    for (const json& x : j) {
      if (!x.is_number()) return;
    }
    for (std::size_t i = 0; i < j.size(); ++i) {
      (*out)[prefix.substr(0, prefix.size() - 1) + "[" + std::to_string(i) + "]"] = j[i];
    }
  } else if (j.is_boolean()) {
    (*out)[prefix.substr(0, prefix.size() - 1)] = j.get<bool>() ? 1.0 : 0.0;
  } else if (j.is_number() && std::isfinite(j.get<double>())) {
    (*out)[prefix.substr(0, prefix.size() - 1)] = j.get<double>();
  }
}

struct Verdict {
  bool reproduced = false;
  double worst_error = 0;  // the error of the worst quantity (largest error / tolerance)
  double model_value = 0;  // the worst quantity's model number
  int quantities = 0;
};

// [verdicts.image]: the mean flip_ldr_mean of the fit's train rows of results.csv, judged as max.
Verdict ImageVerdict(const std::vector<std::map<std::string, std::string>>& rows,
                     const std::string& material, const std::string& label) {
  double sum = 0;
  int n = 0;
  for (const auto& r : rows) {
    if (r.at("material") == material && r.at("label") == label && r.at("split") == "train") {
      sum += std::stod(r.at("flip_ldr_mean"));
      ++n;
    }
  }
  Verdict v;
  v.quantities = n > 0 ? 1 : 0;
  v.model_value = v.worst_error = sum / n;
  v.reproduced = v.worst_error <= kImageTolerance;
  return v;
}

// [verdicts.fresnel]: every number both the reference and the fit report, relative error
// |model - reference| / max(|reference|, 1e-12) (floor 0), reproduced when all are within.
Verdict FresnelVerdict(const fs::path& study_dir, const std::string& material,
                       const std::string& label) {
  const json job = json::parse(ReadText(study_dir / "jobs" / ("probe." + material + ".json")));
  const json& numbers = job["probes"]["fresnel"]["numbers"];
  std::map<std::string, double> ref, mod;
  Flatten(numbers["reference"], "", &ref);
  Flatten(numbers[label], "", &mod);
  Verdict v;
  v.reproduced = true;
  double worst = -1;
  for (const auto& [key, r] : ref) {
    const auto it = mod.find(key);
    if (it == mod.end()) continue;
    const double err = std::abs(it->second - r) / std::max(std::abs(r), 1e-12);
    v.reproduced = v.reproduced && err <= kFresnelTolerance;
    if (err > worst) {
      worst = err;
      v.worst_error = err;
      v.model_value = it->second;
    }
    ++v.quantities;
  }
  return v;
}

// A CSV line split at commas outside double quotes (Python's csv module quotes cells with commas).
std::vector<std::string> SplitCsvLine(const std::string& line) {
  std::vector<std::string> cells(1);
  bool quoted = false;
  for (char ch : line) {
    if (ch == '"') {
      quoted = !quoted;
    } else if (ch == ',' && !quoted) {
      cells.emplace_back();
    } else {
      cells.back() += ch;
    }
  }
  return cells;
}

std::vector<std::vector<std::string>> ReadCsvRows(const fs::path& p) {
  std::vector<std::vector<std::string>> rows;
  std::istringstream in(ReadText(p));
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    rows.push_back(SplitCsvLine(line));
  }
  return rows;
}

std::string HtmlUnescape(std::string s) {
  const std::pair<const char*, const char*> entities[] = {
      {"&lt;", "<"}, {"&gt;", ">"}, {"&quot;", "\""}, {"&#x27;", "'"}, {"&amp;", "&"}};
  for (const auto& [from, to] : entities) {
    for (std::size_t p = s.find(from); p != std::string::npos; p = s.find(from, p + 1)) {
      s.replace(p, std::strlen(from), to);
    }
  }
  return s;
}

// The <td> texts of every <tr> in an HTML fragment.
std::vector<std::vector<std::string>> HtmlRows(const std::string& html) {
  std::vector<std::vector<std::string>> rows;
  for (std::size_t tr = html.find("<tr>"); tr != std::string::npos; tr = html.find("<tr>", tr + 4)) {
    const std::size_t end = html.find("</tr>", tr);
    const std::string row = html.substr(tr, end - tr);
    std::vector<std::string> cells;
    for (std::size_t td = row.find("<td"); td != std::string::npos; td = row.find("<td", td + 3)) {
      const std::size_t open = row.find('>', td) + 1;
      // The cell's text: markup inside it (the matrix's links to the evidence) dropped.
      std::string cell = row.substr(open, row.find("</td>", open) - open);
      for (std::size_t lt = cell.find('<'); lt != std::string::npos; lt = cell.find('<', lt)) {
        cell.erase(lt, cell.find('>', lt) - lt + 1);
      }
      cells.push_back(HtmlUnescape(cell));
    }
    if (!cells.empty()) rows.push_back(cells);
  }
  return rows;
}

// Attribute values `name='...'` in an HTML text.
std::vector<std::string> HtmlAttributes(const std::string& html, const std::string& name) {
  std::vector<std::string> out;
  const std::string key = name + "='";
  for (std::size_t p = html.find(key); p != std::string::npos; p = html.find(key, p + 1)) {
    const std::size_t start = p + key.size();
    out.push_back(html.substr(start, html.find('\'', start) - start));
  }
  return out;
}

// The body rows of a booktabs tabular written by the report (between \midrule and \bottomrule),
// cells split at " & ", LaTeX escapes of '_', '%', '&', '#' undone.
std::vector<std::vector<std::string>> LatexRows(const fs::path& p) {
  const std::string tex = ReadText(p);
  const std::size_t begin = tex.find("\\midrule\n"), end = tex.find("\\bottomrule");
  EXPECT_NE(begin, std::string::npos) << p;
  EXPECT_NE(end, std::string::npos) << p;
  std::vector<std::vector<std::string>> rows;
  std::istringstream in(tex.substr(begin + 9, end - begin - 9));
  std::string line;
  while (std::getline(in, line)) {
    const std::size_t eol = line.rfind(" \\\\");
    EXPECT_NE(eol, std::string::npos) << line;
    line = line.substr(0, eol);
    std::vector<std::string> cells;
    std::size_t start = 0;
    for (std::size_t amp = line.find(" & "); ; amp = line.find(" & ", start)) {
      std::string cell = line.substr(start, amp == std::string::npos ? std::string::npos : amp - start);
      for (const char* esc : {"\\_", "\\%", "\\&", "\\#"}) {
        for (std::size_t q = cell.find(esc); q != std::string::npos; q = cell.find(esc, q)) {
          cell.erase(q, 1);
        }
      }
      cells.push_back(cell);
      if (amp == std::string::npos) break;
      start = amp + 3;
    }
    rows.push_back(cells);
  }
  return rows;
}

// Every verdict cell of verdicts.csv, the HTML verdict table, the matrix (CSV, LaTeX, HTML,
// summary.md) equals the verdict recomputed here; every figure index.html names exists and every
// figure the report made is named; the LaTeX metrics table parses back to results.csv.
void ExpectReportContent(const fs::path& out, const std::vector<std::string>& materials,
                         const std::vector<std::string>& labels) {
  const fs::path report = out / "report";
  const auto rows = ReadCsv(out / "results.csv");
  std::map<std::string, Verdict> recomputed;  // "phenomenon/material/fit"
  for (const auto& m : materials) {
    for (const auto& l : labels) {
      recomputed["image/" + m + "/" + l] = ImageVerdict(rows, m, l);
      recomputed["fresnel/" + m + "/" + l] = FresnelVerdict(out, m, l);
    }
  }
  const auto yes_no = [](bool b) { return std::string(b ? "yes" : "no"); };

  // tables/verdicts.csv: one row per phenomenon x material x fit.
  const auto vcsv = ReadCsvRows(report / "tables/verdicts.csv");
  ASSERT_EQ(vcsv.size(), recomputed.size() + 1);
  for (std::size_t i = 1; i < vcsv.size(); ++i) {
    const auto& c = vcsv[i];
    ASSERT_EQ(c.size(), 9u) << i;
    const std::string key = c[0] + "/" + c[1] + "/" + c[2];
    ASSERT_TRUE(recomputed.count(key)) << key;
    const Verdict& v = recomputed[key];
    EXPECT_EQ(c[8], yes_no(v.reproduced)) << key;
    EXPECT_NEAR(std::stod(c[5]), v.model_value, 5e-4 * std::abs(v.model_value) + 1e-12) << key;
    EXPECT_NEAR(std::stod(c[6]), v.worst_error, 5e-3 * std::abs(v.worst_error) + 1e-12) << key;
  }

  // The matrix: "reproduced/judged" per phenomenon and fit.
  std::map<std::string, std::string> matrix;  // "phenomenon/fit" -> "k/n"
  for (const char* ph : {"image", "fresnel"}) {
    for (const auto& l : labels) {
      int good = 0;
      for (const auto& m : materials) good += recomputed[std::string(ph) + "/" + m + "/" + l].reproduced;
      matrix[std::string(ph) + "/" + l] =
          std::to_string(good) + "/" + std::to_string(materials.size());
    }
  }
  const auto check_matrix_row = [&](const std::vector<std::string>& cells, const std::string& where) {
    if (cells.size() != 2 + labels.size() || (cells[0] != "image" && cells[0] != "fresnel")) return 0;
    for (std::size_t k = 0; k < labels.size(); ++k) {
      EXPECT_EQ(cells[2 + k], matrix[cells[0] + "/" + labels[k]]) << where << " " << cells[0];
    }
    return 1;
  };
  int matrix_rows = 0;
  for (const auto& cells : ReadCsvRows(report / "tables/matrix.csv")) {
    matrix_rows += check_matrix_row(cells, "matrix.csv");
  }
  for (const auto& cells : LatexRows(report / "tables/matrix.tex")) {
    matrix_rows += check_matrix_row(cells, "matrix.tex");
  }

  // index.html: the findings open the page (a verdict table per training set and the forest
  // plot), then the comparative answers (sentences and their figures, no table); the tables
  // before the detail tables are then the matrix (first) and the verdicts (in the question
  // sections, one table per phenomenon).
  const std::string html = ReadText(report / "index.html");
  const std::size_t figures_at = html.find("<h2 id='details'>");
  ASSERT_NE(figures_at, std::string::npos);
  const std::size_t findings_at = html.find("<section id='findings'>");
  const std::size_t answers_at = html.find("<section id='answers'>");
  ASSERT_NE(findings_at, std::string::npos) << "no findings section";
  EXPECT_LT(findings_at, answers_at) << "the answers before the findings";
  EXPECT_LT(html.find("<table"), answers_at) << "no findings table before the answers";
  const std::size_t answers_end = html.find("</section>", answers_at);
  ASSERT_NE(answers_end, std::string::npos) << "no answers section";
  EXPECT_LT(answers_end, html.find("<table", answers_at)) << "a table inside the answers";
  EXPECT_LT(html.find("<table class='matrix'>"), html.find("<figure", answers_end))
      << "matrix not first after the answers";
  int html_verdicts = 0;
  for (const auto& cells : HtmlRows(html.substr(0, figures_at))) {
    matrix_rows += check_matrix_row(cells, "index.html");
    if (cells.size() == 9) {
      const std::string key = cells[0] + "/" + cells[1] + "/" + cells[2];
      ASSERT_TRUE(recomputed.count(key)) << key;
      EXPECT_EQ(cells[8], yes_no(recomputed[key].reproduced)) << "index.html " << key;
      ++html_verdicts;
    }
  }
  EXPECT_EQ(html_verdicts, static_cast<int>(recomputed.size()));
  // summary.md's matrix rows are Markdown: "| image | image | 1/2 | 2/2 |".
  const std::string summary = ReadText(report / "summary.md");
  for (const char* ph : {"image", "fresnel"}) {
    std::string row = std::string("| ") + ph + " | " + ph;
    for (const auto& l : labels) row += " | " + matrix[std::string(ph) + "/" + l];
    EXPECT_NE(summary.find(row + " |"), std::string::npos) << row << "\n" << summary;
  }
  EXPECT_EQ(matrix_rows, 2 * 3);  // two phenomena in CSV, LaTeX and HTML

  // Figures: everything index.html points at exists; every figure made is on the page (PNG and
  // PDF) and in report.tex.
  std::set<std::string> named;
  for (const char* attr : {"src", "href"}) {
    for (const std::string& f : HtmlAttributes(html, attr)) {
      if (f.rfind('#', 0) == 0) continue;  // In-page links: tests/report/browser_test.py.
      EXPECT_TRUE(fs::is_regular_file(report / f)) << "index.html names missing " << f;
      named.insert(f);
    }
  }
  const json figures = json::parse(ReadText(report / "figures.json"));
  const std::string tex = ReadText(report / "report.tex");
  for (const json& f : figures) {
    EXPECT_TRUE(named.count(f["png"].get<std::string>())) << f["png"] << " not on the page";
    EXPECT_TRUE(named.count(f["pdf"].get<std::string>())) << f["pdf"] << " not on the page";
    std::string braced = "{";
    braced.append(f["pdf"].get<std::string>()).append("}");
    EXPECT_NE(tex.find(braced), std::string::npos) << f["pdf"] << " not in report.tex";
  }
  int pngs = 0;
  for (const auto& e : fs::directory_iterator(report / "figures")) {
    if (e.path().extension() != ".png") continue;
    ++pngs;
    EXPECT_TRUE(named.count("figures/" + e.path().filename().string()))
        << e.path() << " made but not on the page";
  }
  EXPECT_EQ(pngs, static_cast<int>(figures.size()));
  // report.tex inputs the longtable pieces; the booktabs tabular pieces stay for \input elsewhere.
  for (const char* t : {"matrix", "verdicts", "metrics", "parameters", "probes"}) {
    EXPECT_NE(tex.find(std::string("\\input{tables/") + t + ".long.tex}"), std::string::npos) << t;
    EXPECT_NE(ReadText(report / "tables" / (std::string(t) + ".tex")).find("\\begin{tabular}"),
              std::string::npos) << t;
  }

  // tables/metrics.tex parses back to results.csv: each metric to the digits it is printed with.
  struct Column {
    const char* key;
    double abs_tol, rel_tol;  // half a unit of the last printed digit
  };
  const Column columns[] = {{"rmse", 0, 5.01e-4},          {"relative_rmse", 5.01e-4, 0},
                            {"psnr", 5.01e-3, 0},          {"ssim", 5.01e-5, 0},
                            {"ciede2000_mean", 5.01e-4, 0}, {"flip_ldr_mean", 5.01e-5, 0},
                            {"flip_hdr_mean", 5.01e-5, 0}, {"delta_e_itp_mean", 5.01e-4, 0}};
  const auto tex_rows = LatexRows(report / "tables/metrics.tex");
  ASSERT_EQ(tex_rows.size(), rows.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const auto& t = tex_rows[i];
    const auto& r = rows[i];
    ASSERT_EQ(t.size(), 13u) << i;
    EXPECT_EQ(t[0], r.at("material"));
    EXPECT_EQ(t[1], r.at("lighting"));
    EXPECT_EQ(t[2], r.at("label"));
    EXPECT_EQ(t[3], r.at("split"));
    for (int c = 0; c < 8; ++c) {
      const double want = std::stod(r.at(columns[c].key));
      EXPECT_NEAR(std::stod(t[4 + c]), want, columns[c].abs_tol + columns[c].rel_tol * std::abs(want))
          << r.at("reference") << " " << r.at("label") << " " << columns[c].key;
    }
    EXPECT_EQ(t[12], r.at("converged") == "1" ? "yes" : "NO");
  }
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
  // Parameter charts: the study renders the spheres, the report lays them out.
  expected.push_back("charts/charts.json");
  for (const auto& model : models) {
    expected.push_back("charts/" + model + "-0-0.png");
    expected.push_back("charts/" + model + "-4-4.png");
    expected.push_back("report/figures/chart-" + model + ".png");
    expected.push_back("report/figures/chart-" + model + ".pdf");
  }
  for (const auto& m : materials) {
    expected.push_back("report/figures/grid-" + m + ".png");
    expected.push_back("report/figures/grid-" + m + ".pdf");
    expected.push_back("jobs/probe." + m + ".json");
    expected.push_back("probes/" + m + "/fresnel.json");
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
  // Probe plots are opt-in ([probes] plots): the report draws its own probe figures.
  EXPECT_FALSE(fs::exists(out / "probes/gold/fresnel.png"));

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
  ExpectReportContent(out, materials, models);

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

  // [probes] plots = true reruns the probe jobs only, and they draw their PNGs.
  std::ofstream(study) << SmallStudy("e2e", {"red-plastic", "gold"}, kRefs,
                                     "[fit.override.ggx]\nmax_iterations = 24\n",
                                     "plots = true\n");
  offset = fs::file_size(out / "study.log");
  ASSERT_EQ(RunShadefit(run + " --no-report", dir), 0) << ReadText(dir / "command.txt");
  EXPECT_EQ(StartedSince(out / "study.log", offset),
            (std::set<std::string>{"probe.gold", "probe.red-plastic"}));
  for (const char* probe : {"fresnel", "highlight", "energy", "portability"}) {
    EXPECT_GT(fs::file_size(out / "probes/gold" / (std::string(probe) + ".png")), 1000u) << probe;
  }
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
