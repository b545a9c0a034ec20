// `shadefit refs import-set` end to end on tests/data/ps_set: a photometric-stereo set in the
// common layout rendered by Cycles with its normal pass (make_ps_set.py beside it), where the
// truth is known: Principled GGX red plastic, roughness 0.3, lights as light_directions.txt and
// light_intensities.txt say. The import, then the study it writes, run as they are.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

namespace {
namespace fs = std::filesystem;

std::string Out(const std::string& sub) {
  const fs::path dir = fs::path(SHADEFIT_TEST_OUTPUT) / "import_set_test" / sub;
  fs::remove_all(dir);
  fs::create_directories(dir.parent_path());
  return dir.string();
}

int Shadefit(const std::string& args, std::string* output) {
  const std::string log = fs::path(SHADEFIT_TEST_OUTPUT) / "import_set_test" / "last.log";
  fs::create_directories(fs::path(log).parent_path());
  const int status = std::system((std::string(SHADEFIT_EXE) + " " + args + " > " + log + " 2>&1").c_str());
  std::ifstream in(log);
  std::stringstream ss;
  ss << in.rdbuf();
  *output = ss.str();
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

const std::string kSet = std::string(SHADEFIT_SOURCE_DIR) + "/tests/data/ps_set";

std::vector<std::map<std::string, std::string>> ReadCsv(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> header;
  std::stringstream hs(line);
  for (std::string f; std::getline(hs, f, ',');) header.push_back(f);
  std::vector<std::map<std::string, std::string>> rows;
  while (std::getline(in, line)) {
    std::map<std::string, std::string> row;
    std::stringstream ls(line);
    std::size_t k = 0;
    for (std::string f; std::getline(ls, f, ',') && k < header.size(); ++k) row[header[k]] = f;
    rows.push_back(row);
  }
  return rows;
}

TEST(ImportSet, TwoObjectsImportAndTheirStudyRunsAsItIs) {
  const std::string out = Out("set");
  std::string log;
  // The set is a Cycles render without bounces: no interreflection to leave out (a photograph's
  // import would; ObjectsAgainstCyclesInterreflection holds that rule).
  ASSERT_EQ(Shadefit("refs import-set " + kSet + " -o " + out + " --train 5 --direct-light-only",
                     &log),
            0)
      << log;
  {
    std::ifstream sidecar(fs::path(out) / "refs" / "suzanne-L001.json");
    std::stringstream text;
    text << sidecar.rdbuf();
    EXPECT_NE(text.str().find("\"direct_light_only\": true"), std::string::npos) << text.str();
  }
  // The normals' convention is checked against Lambertian photometric stereo on the images.
  EXPECT_NE(log.find("suzanne: 12 lights"), std::string::npos) << log;
  EXPECT_NE(log.find("(y up;"), std::string::npos) << log;
  // Suzanne's ears stand in front of its head: the depth integrated from its normals cannot cast
  // their shadows where Cycles does, and those pixels are left out (measured 5.8%); the torus has
  // no such step (0.0%).
  EXPECT_NE(log.find("torus: 12 lights"), std::string::npos) << log;
  EXPECT_NE(log.find("; 0.0% of pixel-lights left out"), std::string::npos) << log;
  for (const char* object : {"suzanne", "torus"}) {
    for (int k = 1; k <= 12; ++k) {
      char name[64];
      std::snprintf(name, sizeof name, "%s-L%03d", object, k);
      EXPECT_TRUE(fs::exists(fs::path(out) / "refs" / (std::string(name) + ".exr"))) << name;
      EXPECT_TRUE(fs::exists(fs::path(out) / "scenes" / (std::string(name) + ".toml"))) << name;
    }
  }
  const std::string study = (fs::path(out) / "ps_set.toml").string();
  ASSERT_TRUE(fs::exists(study));
  ASSERT_EQ(Shadefit("study run " + study + " -q -o " + out + "/run", &log), 0) << log;
  const auto rows = ReadCsv(out + "/run/ps_set/results.csv");
  ASSERT_FALSE(rows.empty());
  int checked = 0;
  for (const auto& row : rows) {
    EXPECT_EQ(row.at("object"), row.at("material"));
    if (row.at("model") != "ggx" || row.at("split") != "test") continue;
    // Held-out lights: GGX is the truth's model (Cycles' Principled BSDF), on the data's normals
    // (a 96 px normal pass: the pixel's normal, not its samples'; measured 0.037-0.133).
    EXPECT_LT(std::stod(row.at("relative_rmse")), 0.15) << row.at("reference");
    ++checked;
  }
  EXPECT_EQ(checked, 2 * 7);
  // The roughness of the truth, 0.3, comes back on both objects (measured 0.300 and 0.294).
  for (const char* object : {"suzanne", "torus"}) {
    bool found = false;
    for (const auto& entry : fs::directory_iterator(out + "/run/ps_set/jobs")) {
      const std::string file = entry.path().filename().string();
      if (file.rfind(std::string("fit.") + object + ".ggx.", 0) != 0 ||
          file.find(".timing.") != std::string::npos) {
        continue;
      }
      std::ifstream in(entry.path());
      const nlohmann::json job = nlohmann::json::parse(in);
      for (const auto& p : job.at("parameters")) {
        if (p.at("name") == "roughness") {
          EXPECT_NEAR(p.at("value").get<double>(), 0.3, 0.02) << object;
          found = true;
        }
      }
    }
    EXPECT_TRUE(found) << object;
  }
}

// Multiplies the normals' y and z (normal.npy, float32) and the lights' y and z of a copy of the
// torus: the set as a data set in another frame would store it.
std::string InFrame(const std::string& name, float ny, float nz, double ly, double lz) {
  const std::string copy = Out(name);
  fs::create_directories(copy);
  fs::copy(kSet + "/torus", copy + "/torus", fs::copy_options::recursive);
  const std::string npy = copy + "/torus/normal.npy";
  std::fstream f(npy, std::ios::in | std::ios::out | std::ios::binary);
  char magic[10];
  f.read(magic, 10);
  const int header = static_cast<unsigned char>(magic[8]) | (static_cast<unsigned char>(magic[9]) << 8);
  const std::streamoff data = 10 + header;
  f.seekg(0, std::ios::end);
  const std::streamoff bytes = f.tellg() - data;
  std::vector<float> v(static_cast<std::size_t>(bytes / 4));
  f.seekg(data);
  f.read(reinterpret_cast<char*>(v.data()), bytes);
  for (std::size_t i = 0; i < v.size(); i += 3) {
    v[i + 1] *= ny;
    v[i + 2] *= nz;
  }
  f.seekp(data);
  f.write(reinterpret_cast<const char*>(v.data()), bytes);
  f.close();
  std::ifstream in(copy + "/torus/light_directions.txt");
  std::stringstream out;
  for (double x, y, z; in >> x >> y >> z;) out << x << " " << y * ly << " " << z * lz << "\n";
  in.close();
  std::ofstream(copy + "/torus/light_directions.txt") << out.str();
  return copy;
}

TEST(ImportSet, TheDataSetsFrameIsFoundFromTheData) {
  std::string log;
  // Normals stored y-down, lights y-up: the normals integrate only y-down.
  ASSERT_EQ(Shadefit("refs import-set " + InFrame("ydown_normals", -1, 1, 1, 1) + " -o " +
                     Out("ydown_normals_out") + " --train 4", &log), 0) << log;
  EXPECT_NE(log.find("(y down; lights as given;"), std::string::npos) << log;
  // Everything in image coordinates (y down the picture, z into the scene).
  ASSERT_EQ(Shadefit("refs import-set " + InFrame("image_frame", -1, -1, -1, -1) + " -o " +
                     Out("image_frame_out") + " --train 4", &log), 0) << log;
  EXPECT_NE(log.find("(y down, z flipped; lights y flipped, z flipped;"), std::string::npos) << log;
  EXPECT_NE(log.find("median 2."), std::string::npos) << log;  // Measured 2.9 deg in every frame.
}

TEST(ImportSet, BadInputIsOneLineAndWritesNothing) {
  const std::string copy = Out("bad_in");
  fs::create_directories(copy);
  fs::copy(kSet + "/torus", copy + "/torus", fs::copy_options::recursive);
  {
    std::ofstream dirs(copy + "/torus/light_directions.txt", std::ios::app);
    dirs << "0 0 1\n";  // 13 directions for 12 images.
  }
  const std::string out = Out("bad");
  std::string log;
  EXPECT_NE(Shadefit("refs import-set " + copy + " -o " + out, &log), 0);
  EXPECT_NE(log.find("light_directions.txt: 13 directions for 12 images"), std::string::npos) << log;
  EXPECT_EQ(std::count(log.begin(), log.end(), '\n'), 1) << log;
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
