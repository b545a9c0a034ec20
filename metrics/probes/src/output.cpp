// Probe outputs: JSON and a plot of the curves, each through the one atomic writer
// (base/files.h).
#include <fmt/format.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "probe_common.h"
#include "shadefit/base/error.h"
#include "shadefit/base/files.h"

namespace shadefit::probes {
namespace {

namespace fs = std::filesystem;

// Groups curves by (x_label, y_label) into panels; honours y_scale/x_scale "log" and x_ticks. The
// legend names a curve "<series> @ <reference>: <kind>" (display only: nothing reads it back).
constexpr const char* kPlotScript = R"PY(
import json, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
d = json.load(open(sys.argv[1]))
groups = {}
for c in d.get("curves", []):
    name = c["series"] + (" @ " + c["reference"] if c.get("reference") else "") + ": " + c["kind"]
    groups.setdefault((c.get("x_label", ""), c.get("y_label", "")), []).append((name, c))
n = max(1, len(groups))
cols = min(2, n)
rows = (n + cols - 1) // cols
fig, axes = plt.subplots(rows, cols, figsize=(6.4 * cols, 4.6 * rows), squeeze=False)
for ax in list(axes.flat)[n:]:
    ax.axis("off")
if not groups:
    axes[0][0].text(0.5, 0.5, "no curves", ha="center", va="center")
for ax, ((xl, yl), items) in zip(axes.flat, groups.items()):
    for name, c in items:
        log_y = c.get("y_scale") == "log"
        flags = c.get("extrapolated") or [False] * len(c["x"])
        pts = [(x, y, f) for x, y, f in zip(c["x"], c["y"], flags)
               if x is not None and y is not None]
        if log_y:
            pts = [p for p in pts if p[1] > 0]
        if not pts:
            continue
        xs, ys, fs = zip(*pts)
        solid = [p for p in pts if not p[2]]
        line, = ax.plot([p[0] for p in solid], [p[1] for p in solid],
                        marker="o" if len(xs) < 30 else None, ms=3, lw=1.2, label=name)
        if any(fs):  # extrapolated points (the end of the axis): dotted, open markers
            i0 = max(0, fs.index(True) - 1)
            ax.plot(xs[i0:], ys[i0:], ls=":", marker="o", ms=3, mfc="white", lw=1.0,
                    color=line.get_color(), label=name + " (extrapolated)")
        if log_y:
            ax.set_yscale("log")
        if c.get("x_scale") == "log":
            ax.set_xscale("log")
        ticks = c.get("x_ticks")
        if ticks:
            ax.set_xticks(range(len(ticks)))
            ax.set_xticklabels(ticks, rotation=40, ha="right", fontsize=7)
    ax.set_xlabel(xl)
    ax.set_ylabel(yl)
    ax.grid(True, alpha=0.3)
    if items:
        ax.legend(fontsize=6 if len(items) <= 10 else 5, ncol=1 if len(items) <= 10 else 2)
fig.suptitle(d.get("probe", "") + " probe")
fig.tight_layout()
fig.savefig(sys.argv[2], format="png", dpi=90)
)PY";

// Scratch files of the plot (its script, data and log), named like the atomic writer's
// temporaries (TemporaryPathFor, base/files.h) so that an interrupted run's leftovers are
// recognised and swept by the same rule; removed when the plot is done.
class PlotScratch {
 public:
  explicit PlotScratch(const fs::path& base)
      : script_(TemporaryPathFor((base.string() + ".plot.py"))),
        data_(TemporaryPathFor(base.string() + ".plot.json")),
        log_(TemporaryPathFor(base.string() + ".plot.log")) {}
  ~PlotScratch() {
    std::error_code ec;
    for (const std::string& p : {script_, data_, log_}) fs::remove(p, ec);
  }
  PlotScratch(const PlotScratch&) = delete;
  PlotScratch& operator=(const PlotScratch&) = delete;

  // Draws the curves of `json_text` into `png` with /usr/bin/python3 and matplotlib.
  void Draw(const std::string& json_text, const std::string& png, const std::string& final_png) {
    WriteScratch(script_, kPlotScript);
    WriteScratch(data_, json_text);
    const std::string cmd =
        fmt::format("/usr/bin/python3 '{}' '{}' '{}' > '{}' 2>&1", script_, data_, png, log_);
    const int rc = std::system(cmd.c_str());
    if (rc != 0 || !fs::exists(png)) {
      std::ifstream lf(log_);
      std::string last, line;
      while (std::getline(lf, line)) {
        if (!line.empty()) last = line;
      }
      throw Error(final_png, "", "plot failed (/usr/bin/python3 with matplotlib): " + last);
    }
  }

 private:
  static void WriteScratch(const std::string& path, const std::string& text) {
    std::ofstream f(path, std::ios::binary | std::ios::trunc);
    f << text;
    f.close();
    if (!f) throw Error(path, "", "cannot write file");
  }

  std::string script_, data_, log_;
};

const char* ScaleName(AxisScale scale) { return scale == AxisScale::kLog ? "log" : "linear"; }

nlohmann::json CurveToJson(const ProbeCurve& c) {
  if (c.x.size() != c.y.size()) {
    throw Error(c.series, CurveKindName(c.kind),
                fmt::format("curve has {} x and {} y values", c.x.size(), c.y.size()));
  }
  nlohmann::json x = nlohmann::json::array(), y = nlohmann::json::array();
  for (std::size_t i = 0; i < c.x.size(); ++i) {
    x.push_back(internal::Num(c.x[i]));
    y.push_back(internal::Num(c.y[i]));
  }
  nlohmann::json j = {
      {"series", c.series},
      {"reference", c.reference.empty() ? nlohmann::json() : nlohmann::json(c.reference)},
      {"lighting", c.lighting.empty() ? nlohmann::json() : nlohmann::json(c.lighting)},
      {"kind", CurveKindName(c.kind)},
      {"x", std::move(x)},
      {"y", std::move(y)},
      {"x_label", c.x_label},
      {"y_label", c.y_label},
      {"x_scale", ScaleName(c.x_scale)},
      {"y_scale", ScaleName(c.y_scale)},
      {"x_ticks", c.x_ticks}};
  if (!c.extrapolated.empty()) {
    if (c.extrapolated.size() != c.x.size()) {
      throw Error(c.series, CurveKindName(c.kind),
                  fmt::format("curve has {} points and {} extrapolation flags", c.x.size(),
                              c.extrapolated.size()));
    }
    j["extrapolated"] = c.extrapolated;
  }
  return j;
}

}  // namespace

nlohmann::json ProbeResultToJson(const ProbeResult& result) {
  nlohmann::json curves = nlohmann::json::array();
  for (const ProbeCurve& c : result.curves) curves.push_back(CurveToJson(c));
  return {{"schema", kProbeResultSchema},
          {"probe", ProbeName(result.probe)},
          {"numbers", result.numbers.is_null() ? nlohmann::json::object() : result.numbers},
          {"curves", std::move(curves)},
          {"notes", result.notes}};
}

void WriteProbeOutputs(const ProbeResult& result, const std::string& dir, bool plot) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir)) throw Error(dir, "", "output directory cannot be created");
  const fs::path base = fs::path(dir) / ProbeName(result.probe);
  const std::string json_path = base.string() + ".json", png_path = base.string() + ".png";
  const std::string text = ProbeResultToJson(result).dump(1) + "\n";
  if (!plot) {
    // A plot of an earlier run would no longer match the JSON.
    fs::remove(png_path, ec);
    WriteTextAtomic(json_path, text);
    return;
  }
  // The plot first: when it fails, neither file is written (WriteAllOrNothing).
  WriteAllOrNothing({{png_path,
                      [&] {
                        WriteAtomic(png_path, [&](const std::string& tmp) {
                          PlotScratch scratch(base);
                          scratch.Draw(text, tmp, png_path);
                        });
                      }},
                     {json_path, [&] { WriteTextAtomic(json_path, text); }}});
}

}  // namespace shadefit::probes
