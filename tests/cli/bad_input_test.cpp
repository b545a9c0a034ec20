// Bad input to the real executable (build/studies/shadefit), one test per case of the input
// inventory (docs/inputs.md). Every case asserts the bar of issue 14: a non-zero exit that is
// not a crash, exactly one line on stderr that names the file and the field (and, for an
// unknown key or name, suggests the closest valid one), and an output folder left exactly as
// it was (no file, no hidden temporary, no changed size or time). Fixtures are made here, in
// the build tree's test_output/bad_input/<test>/in/, never committed.
#include <OpenImageIO/imageio.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <hdf5.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "shadefit/reference_images/measured_brdf.h"
#include "shadefit/render/image.h"

namespace {
namespace fs = std::filesystem;

const std::string kData = std::string(SHADEFIT_SOURCE_DIR) + "/tests/data";

// Everything under `dir`, hidden files included: path -> (size, modification time). A left-over
// temporary, a new file or a rewritten one all change it.
using Snapshot = std::map<std::string, std::pair<std::uintmax_t, std::int64_t>>;
Snapshot Take(const fs::path& dir) {
  Snapshot s;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    const auto t = e.last_write_time().time_since_epoch().count();
    s[fs::relative(e.path(), dir).string()] = {e.is_regular_file() ? e.file_size() : 0,
                                               static_cast<std::int64_t>(t)};
  }
  return s;
}

std::string ReadText(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void WriteText(const fs::path& p, const std::string& text) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out << text;
}

class BadInput : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    root_ = fs::path(SHADEFIT_TEST_OUTPUT) / "bad_input" / info->name();
    fs::remove_all(root_);
    fs::create_directories(in());
    fs::create_directories(out());
    fs::copy_file(kData + "/sphere_key.toml", in() / "scene.toml");
  }

  fs::path in() const { return root_ / "in"; }
  fs::path out() const { return root_ / "out"; }

  // A 64 x 64 RGBA reference of sphere_key.toml's size: a grey disc where the sphere is (it
  // covers the centre of the frame), alpha 1 everywhere; with its sidecar naming the scene.
  fs::path Reference(const std::string& name = "ref.exr", int channels = 4, int size = 64) {
    shadefit::Image image(size, size, channels, 0.0f);
    for (int y = 0; y < size; ++y) {
      for (int x = 0; x < size; ++x) {
        const double dx = x + 0.5 - size / 2.0, dy = y + 0.5 - size / 2.0;
        const float v = dx * dx + dy * dy < (size / 4.0) * (size / 4.0) ? 0.05f : 0.0f;
        for (int c = 0; c < std::min(channels, 3); ++c) image.at(x, y, c) = v;
        if (channels == 4) image.at(x, y, 3) = 1.0f;
      }
    }
    const fs::path p = in() / name;
    shadefit::WriteExr(p.string(), image);
    WriteText(fs::path(p).replace_extension(".json"), R"({"scene_file": "scene.toml"})");
    return p;
  }

  // Writes an 8-bit image through OpenImageIO (the format follows the extension).
  fs::path Image8(const std::string& name, int w, int h, int channels, unsigned char fill) {
    const fs::path p = in() / name;
    std::vector<unsigned char> pixels(static_cast<std::size_t>(w) * h * channels, fill);
    auto o = OIIO::ImageOutput::create(p.string());
    EXPECT_TRUE(o) << name;
    OIIO::ImageSpec spec(w, h, channels, OIIO::TypeDesc::UINT8);
    EXPECT_TRUE(o->open(p.string(), spec) && o->write_image(OIIO::TypeDesc::UINT8, pixels.data()) &&
                o->close())
        << o->geterror();
    return p;
  }

  // Keeps the first `fraction` of a file's bytes.
  static void Truncate(const fs::path& p, double fraction) {
    fs::resize_file(p, static_cast<std::uintmax_t>(fs::file_size(p) * fraction));
  }

  // Runs `shadefit <args>` in root_ (so paths read in/... and out/...), optionally through a
  // `wrapper` shell fragment that contains the token SHADEFIT; returns the exit status and
  // leaves stderr in err_.
  int Run(const std::string& args, const std::string& env = "",
          const std::string& wrapper = "SHADEFIT") {
    // SHADEFIT_BAD_INPUT_EXE runs the cases against another build of the executable (a
    // mutated one, to check that each case can fail: docs/inputs.md).
    const char* other = std::getenv("SHADEFIT_BAD_INPUT_EXE");
    const std::string exe = other != nullptr && *other ? other : SHADEFIT_EXE;
    std::string command = "'" + exe + "' " + args + " > '" + (root_ / "stdout.txt").string() +
                          "' 2> '" + (root_ / "stderr.txt").string() + "'";
    std::string line = wrapper;
    line.replace(line.find("SHADEFIT"), 8, command);
    const std::string full = "cd '" + root_.string() + "' && " + env + " " + line;
    const int status = std::system(full.c_str());
    err_ = ReadText(root_ / "stderr.txt");
    if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

  // The bar of issue 14 for one bad input: exit non-zero without a crash, one stderr line that
  // matches `regex` (the file and the field, and a suggestion where one is due), no change under
  // in/ or out/.
  void ExpectCleanFailure(const std::string& args, const std::string& regex,
                          const std::string& env = "", const std::string& wrapper = "SHADEFIT") {
    const Snapshot before_in = Take(in()), before_out = Take(out());
    const int code = Run(args, env, wrapper);
    EXPECT_NE(code, 0) << "exit status 0 for: " << args;
    EXPECT_LT(code, 128) << "killed by a signal (a crash) for: " << args << "\n" << err_;
    std::string line = err_;
    while (!line.empty() && line.back() == '\n') line.pop_back();
    EXPECT_EQ(std::count(line.begin(), line.end(), '\n'), 0) << "more than one line on stderr:\n"
                                                             << err_;
    EXPECT_FALSE(line.empty()) << "nothing on stderr";
    EXPECT_TRUE(std::regex_search(line, std::regex(regex)))
        << "stderr: " << line << "\nexpected to match: " << regex;
    EXPECT_EQ(Take(out()), before_out) << "the output folder changed";
    EXPECT_EQ(Take(in()), before_in) << "the input folder changed";
  }

  void ExpectRenderFails(const std::string& scene_text, const std::string& regex) {
    WriteText(in() / "bad.toml", scene_text);
    ExpectCleanFailure("render --scene in/bad.toml -o out/a.exr", regex);
  }

  // sphere_key.toml with `from` replaced by `to`.
  static std::string SceneWith(const std::string& from, const std::string& to) {
    std::string s = ReadText(kData + "/sphere_key.toml");
    const auto at = s.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) s.replace(at, from.size(), to);
    return s;
  }

  // A small valid study over one reference in in/ (material "m", lighting "key"); `fit_extra` is
  // appended to its [fit] table and `tail` to the file.
  fs::path Study(const std::string& fit_extra = "", const std::string& tail = "",
                 const std::string& head = "") {
    Reference("m-key.exr");
    const fs::path p = in() / "s.toml";
    WriteText(p, head +
                     "[study]\nname = \"s\"\n[[group]]\nmaterial = \"m\"\nimages = [\"m-*.exr\"]\n"
                     "[fit]\nmodels = [\"ggx\"]\ntrain = [\"key\"]\n" +
                     fit_extra + tail);
    return p;
  }
  void ExpectStudyFails(const std::string& fit_extra, const std::string& tail,
                        const std::string& regex) {
    Study(fit_extra, tail);
    ExpectCleanFailure("study run in/s.toml -q --no-report -o out", regex);
  }

  // Neural-BRDF network of the published shape (6 -> 21 -> 21 -> 3) with zero weights, the
  // datasets listed in `skip` left out and `bad_shape` written with one row too many.
  fs::path Network(const std::string& base, const std::string& skip = "",
                   const std::string& bad_shape = "") {
    const fs::path h5 = in() / (base + ".h5");
    const hid_t file = H5Fcreate(h5.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    const hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
    H5Pset_create_intermediate_group(lcpl, 1);
    const int width[4] = {6, 21, 21, 3};
    std::string json = R"({"class_name": "Sequential", "config": {"layers": [)";
    const char* activation[3] = {"relu", "relu", "linear"};
    for (int l = 0; l < 3; ++l) {
      const std::string name = "dense_" + std::to_string(l + 1);
      json += std::string(l ? ", " : "") + R"({"class_name": "Dense", "config": {"name": ")" +
              name + R"(", "units": )" + std::to_string(width[l + 1]) + R"(, "activation": ")" +
              activation[l] + R"("}})";
      for (const std::string kind : {"kernel:0", "bias:0"}) {
        const std::string path = "/" + name + "/" + name + "/" + kind;
        if (path == skip) continue;
        std::vector<hsize_t> shape =
            kind == "bias:0" ? std::vector<hsize_t>{hsize_t(width[l + 1])}
                             : std::vector<hsize_t>{hsize_t(width[l]), hsize_t(width[l + 1])};
        if (path == bad_shape) shape[0] += 1;
        std::size_t count = 1;
        for (hsize_t d : shape) count *= d;
        const std::vector<float> zeros(count, 0.0f);
        const hid_t space = H5Screate_simple(static_cast<int>(shape.size()), shape.data(), nullptr);
        const hid_t set =
            H5Dcreate2(file, path.c_str(), H5T_IEEE_F32LE, space, lcpl, H5P_DEFAULT, H5P_DEFAULT);
        H5Dwrite(set, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, zeros.data());
        H5Dclose(set);
        H5Sclose(space);
      }
    }
    json += "]}}";
    H5Pclose(lcpl);
    H5Fclose(file);
    WriteText(in() / (base + ".json"), json);
    return h5;
  }
  void ExpectMeasuredFails(const std::string& brdf, const std::string& regex) {
    ExpectCleanFailure("refs measured --brdf in/" + brdf + " --scene in/scene.toml -o out/m.exr",
                       regex);
  }

  // The MERL header (90, 90, 180) followed by `cells` float64 values of 1.
  fs::path Merl(const std::string& name, std::int32_t d0, std::size_t cells) {
    const fs::path p = in() / name;
    std::ofstream o(p, std::ios::binary);
    const std::int32_t dims[3] = {d0, 90, 180};
    o.write(reinterpret_cast<const char*>(dims), sizeof dims);
    const std::vector<double> ones(cells, 1.0);
    o.write(reinterpret_cast<const char*>(ones.data()),
            static_cast<std::streamsize>(ones.size() * sizeof(double)));
    return p;
  }

  fs::path root_;
  std::string err_;
};

constexpr std::size_t kMerlValues = 3 * shadefit::reference_images::kMerlCells;

// Rewrites the width and height in a PNG's IHDR chunk (ISO/IEC 15948, 11.2.2) and its CRC-32
// (ISO 3309, over the chunk type and data: bytes 12 to 28), leaving the pixel data as it was.
void PatchPngSize(const fs::path& p, std::uint32_t width, std::uint32_t height) {
  std::string bytes = ReadText(p);
  for (int k = 0; k < 4; ++k) {
    bytes[16 + k] = static_cast<char>(width >> (24 - 8 * k));
    bytes[20 + k] = static_cast<char>(height >> (24 - 8 * k));
  }
  std::uint32_t crc = 0xffffffffu;
  for (int i = 12; i < 29; ++i) {
    crc ^= static_cast<unsigned char>(bytes[i]);
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
  }
  crc ^= 0xffffffffu;
  for (int k = 0; k < 4; ++k) bytes[29 + k] = static_cast<char>(crc >> (24 - 8 * k));
  WriteText(p, bytes);
}

// --- Images: EXR, PNG, JPEG, TGA, TIFF -----------------------------------------------------------

TEST_F(BadInput, TruncatedExr) {
  Truncate(Reference(), 0.5);
  ExpectCleanFailure("fit --ref in/ref.exr --model ggx -o out/fit.json",
                     "^shadefit: error: in/ref\\.exr: pixels: truncated or corrupt image");
}

TEST_F(BadInput, CorruptExr) {
  const fs::path p = Reference();
  std::string bytes = ReadText(p);
  for (std::size_t i = bytes.size() / 3; i < bytes.size(); i += 7) bytes[i] = '\x5a';
  WriteText(p, bytes);
  ExpectCleanFailure("fit --ref in/ref.exr --model ggx -o out/fit.json",
                     "in/ref\\.exr: (pixels|header): ");
}

TEST_F(BadInput, EmptyExrFile) {
  Reference();
  WriteText(in() / "ref.exr", "");
  ExpectCleanFailure("fit --ref in/ref.exr --model ggx -o out/fit.json",
                     "in/ref\\.exr: header: cannot read image");
}

TEST_F(BadInput, ExrAttributeClaimsTooManyBytes) {
  // Found by fuzz_image: OpenEXR 3.1 allocates what an attribute's size field says (1.9 GB for
  // a 541-byte file) before reading it. The channel list's size is set to 2^31 - 1 here.
  const fs::path p = Reference();
  std::string bytes = ReadText(p);
  const std::string type("chlist\0", 7);
  const std::size_t at = bytes.find(type);
  ASSERT_NE(at, std::string::npos);
  bytes.replace(at + 7, 4, "\xff\xff\xff\x7f", 4);
  WriteText(p, bytes);
  ExpectCleanFailure("fit --ref in/ref.exr --model ggx -o out/fit.json",
                     "in/ref\\.exr: header: EXR attribute 'channels' claims 2147483647 bytes");
}

TEST_F(BadInput, ExrHeaderOnly) {
  const fs::path p = Reference();
  Truncate(p, 0.05);
  ExpectCleanFailure("metrics in/ref.exr in/ref.exr", "in/ref\\.exr: (pixels|header): ");
}

TEST_F(BadInput, TruncatedPng) {
  Truncate(Image8("photo.png", 64, 64, 3, 128), 0.6);
  ExpectCleanFailure("refs import in/photo.png --scene in/scene.toml -o out/r.exr",
                     "in/photo\\.png: (pixels|image): ");
}

TEST_F(BadInput, TruncatedJpeg) {
  const fs::path p = in() / "photo.jpg";
  {
    // Noise, so that the entropy-coded data is long enough to cut.
    std::vector<unsigned char> px(64 * 64 * 3);
    for (std::size_t i = 0; i < px.size(); ++i)
      px[i] = static_cast<unsigned char>((i * 2654435761u) >> 13);
    auto o = OIIO::ImageOutput::create(p.string());
    ASSERT_TRUE(o->open(p.string(), OIIO::ImageSpec(64, 64, 3, OIIO::TypeDesc::UINT8)));
    ASSERT_TRUE(o->write_image(OIIO::TypeDesc::UINT8, px.data()));
    o->close();
  }
  Truncate(p, 0.5);
  ExpectCleanFailure("refs import in/photo.jpg --scene in/scene.toml -o out/r.exr",
                     "in/photo\\.jpg: (pixels|image): ");
}

TEST_F(BadInput, TruncatedJpegAsFitReference) {
  // The fitter reads references with ReadImage: a JPEG cut short must fail there too, not be
  // fitted as the grey libjpeg fills in.
  const fs::path p = in() / "ref.jpg";
  {
    std::vector<unsigned char> px(64 * 64 * 3);
    for (std::size_t i = 0; i < px.size(); ++i)
      px[i] = static_cast<unsigned char>((i * 2654435761u) >> 13);
    auto o = OIIO::ImageOutput::create(p.string());
    ASSERT_TRUE(o->open(p.string(), OIIO::ImageSpec(64, 64, 3, OIIO::TypeDesc::UINT8)));
    ASSERT_TRUE(o->write_image(OIIO::TypeDesc::UINT8, px.data()));
    o->close();
  }
  Truncate(p, 0.5);
  WriteText(in() / "ref.json", R"({"scene_file": "scene.toml"})");
  ExpectCleanFailure("fit --ref in/ref.jpg --model ggx -o out/fit.json",
                     "in/ref\\.jpg: pixels: truncated JPEG");
}

TEST_F(BadInput, ImageHeaderClaimsAbsurdSize) {
  // A valid 64 x 64 PNG whose IHDR is rewritten to 100000 x 100000 (CRC fixed): the reader must
  // refuse before allocating 120 GB of floats.
  PatchPngSize(Image8("huge.png", 64, 64, 3, 10), 100000, 100000);
  WriteText(in() / "huge.json", R"({"scene_file": "scene.toml"})");
  ExpectCleanFailure("fit --ref in/huge.png --model ggx -o out/fit.json",
                     "in/huge\\.png: resolution: 100000x100000 with 3 channel\\(s\\) is beyond");
}

TEST_F(BadInput, ImageHeaderClaimsTooManyValues) {
  // 16384 x 16384 RGB is within the per-side limit but 805 million values (3 GiB of floats).
  PatchPngSize(Image8("big.png", 64, 64, 3, 10), 16384, 16384);
  WriteText(in() / "big.json", R"({"scene_file": "scene.toml"})");
  ExpectCleanFailure("fit --ref in/big.png --model ggx -o out/fit.json",
                     "in/big\\.png: resolution: 16384x16384 with 3 channel\\(s\\) is beyond");
}

TEST_F(BadInput, TruncatedTga) {
  Truncate(Image8("photo.tga", 64, 64, 3, 77), 0.5);
  ExpectCleanFailure("refs import in/photo.tga --scene in/scene.toml -o out/r.exr",
                     "in/photo\\.tga: (pixels|image): ");
}

TEST_F(BadInput, TruncatedTiff) {
  Truncate(Image8("photo.tif", 64, 64, 3, 77), 0.5);
  ExpectCleanFailure("refs import in/photo.tif --scene in/scene.toml -o out/r.exr",
                     "in/photo\\.tif: (pixels|image): ");
}

TEST_F(BadInput, ZeroSizePng) {
  PatchPngSize(Image8("zero.png", 64, 64, 3, 128), 0, 64);
  ExpectCleanFailure("refs import in/zero.png --scene in/scene.toml -o out/r.exr",
                     "in/zero\\.png: (image|resolution): ");
}

TEST_F(BadInput, ZeroSizePngAsMask) {
  // Through ReadImage (fit's masks and references): libpng prints "libpng error: ..." itself.
  Reference();
  PatchPngSize(Image8("mask.png", 64, 64, 1, 255), 64, 0);
  ExpectCleanFailure("fit --ref in/ref.exr --mask in/mask.png --model ggx -o out/fit.json",
                     "in/mask\\.png: header: cannot read image: .*IHDR");
}

TEST_F(BadInput, NanPixelInReference) {
  const fs::path p = Reference();
  shadefit::Image image = shadefit::ReadImage(p.string());
  image.at(32, 32, 1) = std::numeric_limits<float>::quiet_NaN();
  shadefit::WriteExr(p.string(), image);
  ExpectCleanFailure("fit --ref in/ref.exr --model ggx -o out/fit.json",
                     "in/ref\\.exr: pixels: 1 non-finite \\(NaN or infinite\\) pixel");
}

TEST_F(BadInput, InfPixelInMetricsTest) {
  const fs::path p = Reference();
  shadefit::Image image = shadefit::ReadImage(p.string());
  image.at(3, 5, 0) = std::numeric_limits<float>::infinity();
  shadefit::WriteExr((in() / "test.exr").string(), image);
  ExpectCleanFailure("metrics in/ref.exr in/test.exr --json --maps out",
                     "in/test\\.exr: pixels: infinite value at \\(3, 5\\)");
}

TEST_F(BadInput, OneChannelReference) {
  Reference("ref.exr", 1);
  ExpectCleanFailure("fit --ref in/ref.exr --model ggx -o out/fit.json",
                     "in/ref\\.exr: channels: expected RGB or RGBA, got 1 channel");
}

TEST_F(BadInput, TwoChannelMetricsImage) {
  Reference("ref.exr", 4);
  Reference("two.exr", 2);
  ExpectCleanFailure("metrics in/ref.exr in/two.exr", "in/two\\.exr: channels: ");
}

TEST_F(BadInput, MetricsSizeMismatch) {
  Reference("ref.exr", 4, 64);
  Reference("small.exr", 4, 32);
  ExpectCleanFailure("metrics in/ref.exr in/small.exr --maps out", "in/small\\.exr: resolution: ");
}

TEST_F(BadInput, ReferenceSizeDiffersFromScene) {
  Reference("ref.exr", 4, 32);
  ExpectCleanFailure("fit --ref in/ref.exr --model ggx -o out/fit.json",
                     "in/ref\\.exr: resolution: image is 32x32 but scene .*scene\\.toml renders "
                     "64x64");
}

TEST_F(BadInput, MaskSizeMismatch) {
  Reference();
  shadefit::WritePng8((in() / "mask.png").string(), shadefit::Image(32, 32, 1, 1.0f));
  ExpectCleanFailure("fit --ref in/ref.exr --mask in/mask.png --model ggx -o out/fit.json",
                     "in/mask\\.png: resolution: mask is 32x32 but the reference");
}

TEST_F(BadInput, AllMaskedReference) {
  Reference();
  shadefit::WritePng8((in() / "mask.png").string(), shadefit::Image(64, 64, 1, 0.0f));
  ExpectCleanFailure("fit --ref in/ref.exr --mask in/mask.png --model ggx -o out/fit.json",
                     "in/ref\\.exr: pixels: nothing to fit: no pixel is fully covered");
}

TEST_F(BadInput, AllMaskedMetrics) {
  Reference();
  shadefit::WritePng8((in() / "mask.png").string(), shadefit::Image(64, 64, 1, 0.0f));
  ExpectCleanFailure("metrics in/ref.exr in/ref.exr --mask in/mask.png",
                     "in/mask\\.png: pixels: empty mask");
}

TEST_F(BadInput, BlackReference) {
  const fs::path p = Reference();
  shadefit::Image image = shadefit::ReadImage(p.string());
  for (std::size_t i = 0; i < image.PixelCount(); ++i) {
    for (int c = 0; c < 3; ++c) image.data[4 * i + c] = 0.0f;
  }
  shadefit::WriteExr(p.string(), image);
  ExpectCleanFailure("fit --ref in/ref.exr --model ggx -o out/fit.json",
                     "in/ref\\.exr: pixels: nothing to fit: all [0-9]+ valid pixels are black");
}

TEST_F(BadInput, MissingReference) {
  ExpectCleanFailure("fit --ref in/none.exr --model ggx -o out/fit.json",
                     "in/none\\.exr: reference image does not exist");
}

// --- Sidecars ------------------------------------------------------------------------------------

TEST_F(BadInput, SidecarMissing) {
  Reference();
  fs::remove(in() / "ref.json");
  ExpectCleanFailure("fit --ref in/ref.exr --model ggx -o out/fit.json",
                     "in/ref\\.json: missing sidecar JSON");
}

TEST_F(BadInput, SidecarMalformed) {
  Reference();
  WriteText(in() / "ref.json", "{\"scene_file\": \"scene.toml\",");
  ExpectCleanFailure("fit --ref in/ref.exr --model ggx -o out/fit.json",
                     "in/ref\\.json: json: cannot parse: .*");
}

TEST_F(BadInput, SidecarSceneWrongType) {
  Reference();
  WriteText(in() / "ref.json", "{\"scene_file\": 42}");
  ExpectCleanFailure("fit --ref in/ref.exr --model ggx -o out/fit.json",
                     "in/ref\\.json: scene_file: ");
}

TEST_F(BadInput, SidecarNamesMissingScene) {
  Reference();
  WriteText(in() / "ref.json", "{\"scene_file\": \"gone.toml\"}");
  ExpectCleanFailure("fit --ref in/ref.exr --model ggx -o out/fit.json",
                     "in/ref\\.json: scene_file: scene '.*gone\\.toml' does not exist");
}

TEST_F(BadInput, SidecarNamesADevice) {
  Reference();
  WriteText(in() / "ref.json", "{\"scene_file\": \"/dev/zero\"}");
  ExpectCleanFailure("fit --ref in/ref.exr --model ggx -o out/fit.json",
                     "/dev/zero: scene file is not a regular file");
}

TEST_F(BadInput, SidecarNotAnObject) {
  Reference();
  WriteText(in() / "ref.json", "[1, 2, 3]");
  ExpectCleanFailure("fit --ref in/ref.exr --model ggx -o out/fit.json",
                     "in/ref\\.json: scene_file: ");
}

// --- Scene TOML ----------------------------------------------------------------------------------

TEST_F(BadInput, SceneUnknownKeySuggests) {
  ExpectRenderFails(SceneWith("fov_y = 22.0", "fovy = 22.0"),
                    "bad\\.toml:6: camera\\.fovy: unknown key \\(did you mean 'fov_y'\\?\\)");
}

TEST_F(BadInput, SceneUnknownTableSuggests) {
  ExpectRenderFails(SceneWith("[[lights]]", "[[light]]"),
                    "bad\\.toml:14: light: unknown key \\(did you mean 'lights'\\?\\)");
}

TEST_F(BadInput, SceneDuplicateKey) {
  ExpectRenderFails(SceneWith("fov_y = 22.0", "fov_y = 22.0\nfov_y = 30.0"),
                    "bad\\.toml:7: malformed TOML: .*fov_y");
}

TEST_F(BadInput, SceneWrongType) {
  ExpectRenderFails(SceneWith("fov_y = 22.0", "fov_y = \"wide\""),
                    "bad\\.toml:6: camera\\.fov_y: expected a number");
}

TEST_F(BadInput, SceneNegativeFieldOfView) {
  ExpectRenderFails(SceneWith("fov_y = 22.0", "fov_y = -22.0"),
                    "bad\\.toml:6: camera\\.fov_y: value -22 outside \\[0\\.1, 179\\]");
}

TEST_F(BadInput, SceneAbsurdResolution) {
  ExpectRenderFails(SceneWith("[64, 64]", "[100000, 100000]"),
                    "bad\\.toml:7: camera\\.resolution: must be 1\\.\\.8192");
}

TEST_F(BadInput, SceneNanRadius) {
  ExpectRenderFails(SceneWith("radius = 1.0", "radius = nan"),
                    "bad\\.toml:12: objects\\[0\\]\\.radius: value nan outside");
}

TEST_F(BadInput, SceneLightTypeSuggests) {
  ExpectRenderFails(SceneWith("type = \"point\"", "type = \"pont\""),
                    "bad\\.toml:15: lights\\[0\\]\\.type: expected point, directional, ambient, "
                    "environment or uniform \\(did you mean 'point'\\?\\)");
}

TEST_F(BadInput, SceneMissingCamera) {
  std::string s = ReadText(kData + "/sphere_key.toml");
  s = s.substr(s.find("[[objects]]"));
  ExpectRenderFails(s, "bad\\.toml:1: camera: missing \\[camera\\] table");
}

TEST_F(BadInput, SceneEnvironmentFileMissing) {
  ExpectRenderFails(SceneWith("type = \"point\"\nposition = [4.0, -4.0, 3.0]\npower = 1000.0",
                              "type = \"environment\"\nfile = \"no-such-map.exr\""),
                    "bad\\.toml:16: lights\\[0\\]\\.file: '.*no-such-map\\.exr' not found");
}

// A path the file system cannot look up (a name past 255 bytes) is a one-line error naming the
// field, not std::filesystem's exception (found by fuzz_scene on a clean clone's CI run).
TEST_F(BadInput, SceneEnvironmentFileNameTooLong) {
  ExpectRenderFails(SceneWith("type = \"point\"\nposition = [4.0, -4.0, 3.0]\npower = 1000.0",
                              "type = \"environment\"\nfile = \"/" + std::string(300, 'a') + "\""),
                    "bad\\.toml:16: lights\\[0\\]\\.file: /a+: cannot be looked up: File name too "
                    "long");
}

TEST_F(BadInput, ReferencePathTooLong) {
  ExpectCleanFailure("fit --ref /" + std::string(300, 'b') + ".exr --model ggx -o out/fit.json",
                     "/b+\\.exr: cannot be looked up: File name too long");
}

TEST_F(BadInput, StudyImagePatternTooLong) {
  const std::string pattern = "/" + std::string(300, 'c') + "/n-*.exr";
  ExpectStudyFails("", "[[group]]\nmaterial = \"n\"\nimages = [\"" + pattern + "\"]\n",
                   "s\\.toml:1[0-9]: group\\.images: /c+: cannot be looked up: File name too long");
}

TEST_F(BadInput, SceneNegativeIntensity) {
  ExpectRenderFails(SceneWith("power = 1000.0", "power = [1.0, -1.0, 1.0]"),
                    "bad\\.toml:17: lights\\[0\\]\\.power: component 1 = -1 is not allowed");
}

TEST_F(BadInput, SceneFractionalSupersample) {
  ExpectRenderFails(SceneWith("fov_y = 22.0", "fov_y = 22.0\nsupersample = 2.5"),
                    "bad\\.toml:7: camera\\.supersample: expected an integer");
}

// A float beyond int64's range where an integer belongs: an error, not toml++'s float to integer
// conversion, which is undefined behaviour there (found by fuzz_scene; the input is also in
// tests/fuzz/corpus/scene/float_samples_beyond_int64.toml, replayed under UBSan).
TEST_F(BadInput, SceneIntegerFieldHugeFloat) {
  ExpectRenderFails(SceneWith("fov_y = 22.0", "fov_y = 22.0\nsupersample = 1.9e41"),
                    "bad\\.toml:7: camera\\.supersample: expected an integer");
}

TEST_F(BadInput, SceneMissingFile) {
  ExpectCleanFailure("render --scene in/none.toml -o out/a.exr",
                     "in/none\\.toml: scene file not found");
}

// --- Study TOML ----------------------------------------------------------------------------------

TEST_F(BadInput, StudyUnknownKeySuggests) {
  ExpectStudyFails("modles = [\"ggx\"]\n", "",
                   "s\\.toml:9: fit\\.modles: unknown key \\(did you mean 'models'\\?\\)");
}

TEST_F(BadInput, StudyUnknownTableSuggests) {
  ExpectStudyFails("", "[outputz]\nreport = false\n",
                   "s\\.toml:9: outputz: unknown key \\(did you mean 'outputs'\\?\\)");
}

TEST_F(BadInput, StudyUnknownModelSuggests) {
  Study();
  WriteText(in() / "s.toml",
            std::regex_replace(ReadText(in() / "s.toml"), std::regex("\"ggx\""), "\"gxx\""));
  ExpectCleanFailure("study run in/s.toml -q -o out",
                     "s\\.toml:7: fit\\.models: model: unknown model 'gxx' \\(did you mean "
                     "'ggx'\\?\\)");
}

TEST_F(BadInput, StudyUnknownLossSuggests) {
  ExpectStudyFails("loss = \"cubroot\"\n", "",
                   "s\\.toml:9: fit\\.loss: unknown loss 'cubroot' \\(did you mean "
                   "'cuberoot'\\?\\)");
}

TEST_F(BadInput, StudyUnknownProbeSuggests) {
  ExpectStudyFails("", "[probes]\nrun = [\"fresnell\"]\n",
                   "s\\.toml:10: probes\\.run: unknown probe 'fresnell' \\(did you mean "
                   "'fresnel'\\?\\)");
}

TEST_F(BadInput, StudyWrongType) {
  ExpectStudyFails("starts = \"3\"\n", "", "s\\.toml:9: fit\\.starts: expected an integer");
}

TEST_F(BadInput, StudyNegativeStarts) {
  ExpectStudyFails("starts = -3\n", "", "s\\.toml:9: fit\\.starts: must be >= 1");
}

TEST_F(BadInput, StudyAbsurdStarts) {
  ExpectStudyFails("starts = 1000000000000\n", "",
                   "s\\.toml:9: fit\\.starts: value 1000000000000 above the maximum");
}

TEST_F(BadInput, StudyAbsurdPixelStride) {
  // 2^32 + 1 would wrap to a stride of 1 in a 32-bit int.
  ExpectStudyFails("pixel_stride = 4294967297\n", "",
                   "s\\.toml:9: fit\\.pixel_stride: value 4294967297 above the maximum");
}

TEST_F(BadInput, StudyDuplicateKey) {
  ExpectStudyFails("seed = 1\nseed = 2\n", "", "s\\.toml:10: malformed TOML: .*seed");
}

TEST_F(BadInput, StudyNamesMissingFile) {
  Study();
  WriteText(in() / "s.toml",
            std::regex_replace(ReadText(in() / "s.toml"), std::regex("m-\\*\\.exr"), "m-none.exr"));
  ExpectCleanFailure("study run in/s.toml -q -o out",
                     "s\\.toml:5: group\\.images: 'm-none\\.exr' matches no file");
}

TEST_F(BadInput, StudyGlobMatchesNothing) {
  Study();
  WriteText(in() / "s.toml",
            std::regex_replace(ReadText(in() / "s.toml"), std::regex("m-\\*\\.exr"), "q-*.exr"));
  ExpectCleanFailure("study run in/s.toml -q -o out",
                     "s\\.toml:5: group\\.images: 'q-\\*\\.exr' matches no file");
}

TEST_F(BadInput, StudyNegativePpd) {
  ExpectStudyFails("", "[metrics]\nppd = -67.0\n", "s\\.toml:10: metrics\\.ppd: value -67 ");
}

TEST_F(BadInput, StudyNanTolerance) {
  ExpectStudyFails("",
                   "[verdicts.image]\nsource = \"metrics\"\nmetric = \"rmse\"\ntolerance = nan\n",
                   "s\\.toml:12: verdicts\\.image\\.tolerance: value nan ");
}

TEST_F(BadInput, StudyAbsurdMeasuredSamples) {
  Study();
  WriteText(in() / "scene-key.toml", ReadText(in() / "scene.toml"));
  fs::create_directories(in() / "brdfs");
  WriteText(in() / "s.toml", ReadText(in() / "s.toml") +
                                 "[[measured]]\nfolder = \"brdfs\"\nscenes = [\"scene-key.toml\"]\n"
                                 "samples = 1e300\n");
  ExpectCleanFailure("study run in/s.toml -q -o out",
                     "s\\.toml:12: measured\\.samples: expected an integer");
}

TEST_F(BadInput, StudyMissingFile) {
  ExpectCleanFailure("study run in/none.toml -q -o out", "in/none\\.toml: study file not found");
}

TEST_F(BadInput, StudyMalformed) {
  WriteText(in() / "s.toml", "[study]\nname = \"s\n");
  ExpectCleanFailure("study run in/s.toml -q -o out", "in/s\\.toml:2: malformed TOML");
}

// --- Measured BRDFs: MERL .binary, Neural-BRDF .h5 + .json -------------------------------------

TEST_F(BadInput, MerlTruncated) {
  Merl("t.binary", 90, kMerlValues / 2);
  ExpectMeasuredFails("t.binary", "in/t\\.binary: size: file is [0-9]+ bytes, expected 34992012");
}

TEST_F(BadInput, MerlWrongHeader) {
  Merl("h.binary", 91, kMerlValues);
  ExpectMeasuredFails(
      "h.binary", "in/h\\.binary: dims: header is \\(91, 90, 180\\), expected \\(90, 90, 180\\)");
}

TEST_F(BadInput, MerlTooShortForHeader) {
  WriteText(in() / "s.binary", "MERL");
  ExpectMeasuredFails("s.binary", "in/s\\.binary: dims: file is 4 bytes, too short");
}

TEST_F(BadInput, MerlNanCell) {
  const fs::path p = Merl("n.binary", 90, kMerlValues);
  std::fstream f(p, std::ios::binary | std::ios::in | std::ios::out);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  f.seekp(12 + 8 * 1000);
  f.write(reinterpret_cast<const char*>(&nan), sizeof nan);
  f.close();
  ExpectMeasuredFails("n.binary", "in/n\\.binary: data: NaN or Inf in channel 0 at cell 1000");
}

TEST_F(BadInput, MeasuredUnknownExtension) {
  WriteText(in() / "x.brdf", "");
  ExpectMeasuredFails("x.brdf", "in/x\\.brdf: ");
}

TEST_F(BadInput, NeuralBrdfMissingDataset) {
  Network("net", "/dense_2/dense_2/kernel:0");
  ExpectMeasuredFails("net.h5", "in/net\\.h5: /dense_2/dense_2/kernel:0: dataset missing");
}

TEST_F(BadInput, NeuralBrdfMisShapedDataset) {
  Network("net", "", "/dense_3/dense_3/bias:0");
  ExpectMeasuredFails("net.h5",
                      "in/net\\.h5: /dense_3/dense_3/bias:0: shape \\(4\\), expected \\(3\\)");
}

TEST_F(BadInput, NeuralBrdfNotHdf5) {
  Network("net");
  WriteText(in() / "net.h5", "this is not HDF5");
  ExpectMeasuredFails("net.h5", "in/net\\.h5: (format|header): not an HDF5 file");
}

TEST_F(BadInput, NeuralBrdfTruncatedHdf5) {
  const fs::path h5 = Network("net");
  Truncate(h5, 0.5);
  ExpectMeasuredFails("net.h5", "in/net\\.h5: ");
}

TEST_F(BadInput, NeuralBrdfConfigMissing) {
  Network("net");
  fs::remove(in() / "net.json");
  ExpectMeasuredFails("net.h5",
                      "in/net\\.h5: config: the Keras model config in/net\\.json is missing");
}

TEST_F(BadInput, NeuralBrdfConfigMalformed) {
  Network("net");
  WriteText(in() / "net.json", "{\"config\": ");
  ExpectMeasuredFails("net.h5", "in/net\\.json: json: not valid JSON");
}

TEST_F(BadInput, NeuralBrdfLayerWithoutConfig) {
  Network("net");
  WriteText(in() / "net.json", R"({"config": {"layers": [{"class_name": "Dense"}]}})");
  ExpectMeasuredFails("net.h5", "in/net\\.json: config\\.layers\\[0\\]\\.config: missing");
}

TEST_F(BadInput, NeuralBrdfUnitsWrongType) {
  Network("net");
  std::string json = ReadText(in() / "net.json");
  json.replace(json.find("\"units\": 21"), 11, "\"units\": \"21\"");
  WriteText(in() / "net.json", json);
  ExpectMeasuredFails("net.h5", "in/net\\.json: config\\.layers\\[0\\]\\.config\\.units: ");
}

// --- Command-line arguments ----------------------------------------------------------------------

TEST_F(BadInput, CliNegativeStarts) {
  Reference();
  ExpectCleanFailure("fit --ref in/ref.exr --model ggx --starts -3 -o out/fit.json",
                     "--starts: must be >= 1");
}

TEST_F(BadInput, CliStartsNotANumber) {
  Reference();
  ExpectCleanFailure("fit --ref in/ref.exr --model ggx --starts three -o out/fit.json",
                     "--starts = three");
}

TEST_F(BadInput, CliZeroMaxIterations) {
  Reference();
  ExpectCleanFailure("fit --ref in/ref.exr --model ggx --max-iterations 0 -o out/fit.json",
                     "--max-iterations: must be >= 1");
}

TEST_F(BadInput, CliZeroThreads) {
  Reference();
  ExpectCleanFailure("fit --ref in/ref.exr --model ggx --threads 0 -o out/fit.json",
                     "--threads: must be >= 1");
}

TEST_F(BadInput, CliNegativeLossScale) {
  Reference();
  ExpectCleanFailure(
      "fit --ref in/ref.exr --model ggx --loss huber --loss-scale -1 -o out/fit.json",
      "--loss-scale: ");
}

TEST_F(BadInput, CliUnknownLossSuggests) {
  Reference();
  ExpectCleanFailure("fit --ref in/ref.exr --model ggx --loss hubber -o out/fit.json",
                     "--loss: unknown loss 'hubber' \\(did you mean 'huber'\\?\\)");
}

TEST_F(BadInput, CliNanParameter) {
  ExpectCleanFailure("render --scene in/scene.toml --model ggx --set roughness=nan -o out/a.exr",
                     "--set: roughness: value nan outside \\[0\\.01, 1\\]");
}

TEST_F(BadInput, CliParameterWithoutValue) {
  ExpectCleanFailure("render --scene in/scene.toml --model ggx --set roughness -o out/a.exr",
                     "--set: roughness: expected name=value");
}

TEST_F(BadInput, CliUnknownModelSuggests) {
  ExpectCleanFailure("render --scene in/scene.toml --model gxx -o out/a.exr",
                     "model: unknown model 'gxx' \\(did you mean 'ggx'\\?\\)");
}

TEST_F(BadInput, CliUnknownParameterSuggests) {
  ExpectCleanFailure("render --scene in/scene.toml --model blinn-phong --set shine=4 -o out/a.exr",
                     "--set: shine: unknown parameter for model blinn-phong \\(did you mean "
                     "'shininess'\\?\\)");
}

TEST_F(BadInput, CliUnknownOption) {
  ExpectCleanFailure("render --scene in/scene.toml --modle ggx -o out/a.exr", "--modle");
}

TEST_F(BadInput, CliMetricsInfinitePpd) {
  Reference();
  ExpectCleanFailure("metrics in/ref.exr in/ref.exr --ppd inf",
                     "--ppd: Value inf not in range 0\\.001000 to 1000\\.000000");
}

TEST_F(BadInput, CliMetricsNanExposure) {
  Reference();
  ExpectCleanFailure("metrics in/ref.exr in/ref.exr --exposure nan", "--exposure: nan stops");
}

TEST_F(BadInput, CliRenderNanExposure) {
  ExpectCleanFailure("render --scene in/scene.toml --exposure nan -o out/a.exr",
                     "--exposure: nan stops");
}

TEST_F(BadInput, ProbeFitJsonMalformed) {
  Reference();
  WriteText(in() / "fit.json", "{\"model\": \"ggx\", ");
  ExpectCleanFailure("probe fresnel --ref in/ref.exr --fit in/fit.json -o out",
                     "in/fit\\.json: json: malformed JSON: ");
}

TEST_F(BadInput, ProbeFitJsonUnknownModel) {
  Reference();
  WriteText(in() / "fit.json", R"({"model": "ggz", "values": {}})");
  ExpectCleanFailure("probe fresnel --ref in/ref.exr --fit in/fit.json -o out",
                     "in/fit\\.json: model: unknown model 'ggz' \\(did you mean 'ggx'\\?\\)");
}

TEST_F(BadInput, EnvironmentMapWithNan) {
  shadefit::Image map(16, 8, 3, 1.0f);
  map.at(3, 2, 1) = std::numeric_limits<float>::quiet_NaN();
  shadefit::WriteExr((in() / "map.exr").string(), map);
  ExpectRenderFails(SceneWith("type = \"point\"\nposition = [4.0, -4.0, 3.0]\npower = 1000.0",
                              "type = \"environment\"\nfile = \"map.exr\"\nsamples = 4"),
                    "in/map\\.exr: pixels: NaN or Inf in the map");
}

TEST_F(BadInput, EnvironmentMapOneChannel) {
  shadefit::WriteExr((in() / "map.exr").string(), shadefit::Image(16, 8, 1, 1.0f));
  ExpectRenderFails(SceneWith("type = \"point\"\nposition = [4.0, -4.0, 3.0]\npower = 1000.0",
                              "type = \"environment\"\nfile = \"map.exr\"\nsamples = 4"),
                    "in/map\\.exr: channels: environment map needs RGB");
}

TEST_F(BadInput, CliMetricsMapsFolderMissing) {
  Reference();
  ExpectCleanFailure("metrics in/ref.exr in/ref.exr --maps out/none",
                     "out/none: --maps: directory does not exist");
}

// --- Output paths
// ----------------------------------------------------------------------------------

TEST_F(BadInput, OutputPathIsADirectory) {
  fs::create_directories(out() / "a.exr");
  ExpectCleanFailure("render --scene in/scene.toml -o out/a.exr",
                     "out/a\\.exr: (-o|output): is a directory");
}

TEST_F(BadInput, OutputPreviewPathIsADirectory) {
  // render writes a.exr and then the a.png preview: the preview's failure must not leave a.exr.
  fs::create_directories(out() / "a.png");
  ExpectCleanFailure("render --scene in/scene.toml -o out/a.exr",
                     "out/a\\.png: (-o|output): is a directory");
}

TEST_F(BadInput, FitOutputImageIsADirectory) {
  Reference();
  fs::create_directories(out() / "fit.ref.error.png");
  ExpectCleanFailure("fit --ref in/ref.exr --model lambert --max-iterations 2 -o out/fit.json",
                     "out/fit\\.ref\\.error\\.png: ");
}

TEST_F(BadInput, OutputUnderARegularFile) {
  WriteText(out() / "file", "x");
  ExpectCleanFailure("render --scene in/scene.toml -o out/file/a.exr",
                     "out/file/a\\.exr: output directory does not exist");
}

TEST_F(BadInput, OutputDirectoryMissing) {
  ExpectCleanFailure("render --scene in/scene.toml -o out/none/a.exr",
                     "out/none/a\\.exr: output directory does not exist");
}

// Unwritable output folder. Root ignores permission bits, so as root the folder is made
// read-only with a read-only bind mount in a private mount namespace (unshare -m): the write
// fails with EROFS as it would on a read-only share. As another user, chmod 555 does it.
TEST_F(BadInput, UnwritableOutputDirectory) {
  fs::create_directories(out() / "ro");
  std::string wrapper;
  if (geteuid() == 0) {
    if (std::system("unshare -m true 2>/dev/null") != 0) {
      GTEST_SKIP() << "running as root without the right to make a mount namespace "
                      "(unshare -m): cannot make a folder unwritable for root";
    }
    wrapper =
        "unshare -m sh -c 'mount --bind out/ro out/ro && "
        "mount -o remount,bind,ro out/ro && SHADEFIT'";
  } else {
    fs::permissions(out() / "ro", fs::perms::owner_read | fs::perms::owner_exec);
    wrapper = "SHADEFIT";
  }
  ExpectCleanFailure("render --scene in/scene.toml -o out/ro/a.exr",
                     "out/ro/a\\.exr: write failed: ", "", wrapper);
  fs::permissions(out() / "ro", fs::perms::owner_all);
}

// A disk that fills up mid-write: a 16 KiB tmpfs mounted over out/full in a private mount
// namespace (root, or an unprivileged user namespace with `unshare -rm`); the 256 x 256 float
// EXR needs far more. What is left on the tmpfs is listed before it goes away.
TEST_F(BadInput, DiskFullMidWrite) {
  fs::create_directories(out() / "full");
  WriteText(in() / "big.toml", SceneWith("[64, 64]", "[256, 256]"));
  const std::string ns = geteuid() == 0 ? "unshare -m" : "unshare -rm";
  if (std::system(
          (ns + " sh -c 'mount -t tmpfs -o size=16k tmpfs " + out().string() + "/full' 2>/dev/null")
              .c_str()) != 0) {
    GTEST_SKIP() << "cannot mount a small tmpfs (" << ns << " failed)";
  }
  const std::string listing = (root_ / "left-on-tmpfs.txt").string();
  ExpectCleanFailure("render --scene in/big.toml -o out/full/a.exr",
                     "out/full/a\\.exr: write failed: ", "",
                     ns +
                         " sh -c 'mount -t tmpfs -o size=16k tmpfs out/full && SHADEFIT; rc=$?; "
                         "ls -A out/full > " +
                         listing + "; exit $rc'");
  EXPECT_EQ(ReadText(listing), "") << "files left on the full disk";
}

// The disk fills up on the last of several outputs: render's EXR and PNG preview fit on the
// tmpfs, its AOV EXR does not. The EXR and PNG already written must go too (all or nothing).
// The tmpfs is sized from a first render of the same files elsewhere.
TEST_F(BadInput, DiskFullOnLastOutput) {
  fs::create_directories(out() / "full");
  fs::create_directories(root_ / "probe");
  WriteText(in() / "big.toml", SceneWith("[64, 64]", "[256, 256]"));
  ASSERT_EQ(Run("render --scene in/big.toml -o probe/a.exr --aov probe/aov.exr"), 0) << err_;
  auto pages = [](std::uintmax_t bytes) { return (bytes + 4095) / 4096 * 4096; };
  const std::uintmax_t size = pages(fs::file_size(root_ / "probe/a.exr")) +
                              pages(fs::file_size(root_ / "probe/a.png")) +
                              fs::file_size(root_ / "probe/aov.exr") / 2;
  fs::remove_all(root_ / "probe");
  const std::string ns = geteuid() == 0 ? "unshare -m" : "unshare -rm";
  const std::string mount = "mount -t tmpfs -o size=" + std::to_string(size) + " tmpfs ";
  if (std::system((ns + " sh -c '" + mount + out().string() + "/full' 2>/dev/null").c_str()) != 0) {
    GTEST_SKIP() << "cannot mount a small tmpfs (" << ns << " failed)";
  }
  const std::string listing = (root_ / "left-on-tmpfs.txt").string();
  ExpectCleanFailure("render --scene in/big.toml -o out/full/a.exr --aov out/full/aov.exr",
                     "out/full/aov\\.exr: write failed: ", "",
                     ns + " sh -c '" + mount + "out/full && SHADEFIT; rc=$?; ls -A out/full > " +
                         listing + "; exit $rc'");
  EXPECT_EQ(ReadText(listing), "") << "files left on the full disk";
}

// --- Environment variables ---------------------------------------------------------------------

TEST_F(BadInput, EnvEglDeviceUnknown) {
  ExpectCleanFailure("render --scene in/scene.toml -o out/a.exr",
                     "SHADEFIT_EGL_DEVICE: unknown value 'gpu0' \\(expected 'software'",
                     "SHADEFIT_EGL_DEVICE=gpu0");
}

TEST_F(BadInput, EnvNoEglDevice) {
  fs::create_directories(root_ / "empty");
  ExpectCleanFailure("render --scene in/scene.toml -o out/a.exr",
                     "no usable EGL/OpenGL 4\\.3\\+ device",
                     "__EGL_VENDOR_LIBRARY_DIRS=" + (root_ / "empty").string());
}

TEST_F(BadInput, EnvReportPythonMissing) {
  fs::create_directories(out() / "st");
  WriteText(out() / "st" / "results.csv", "model\n");
  ExpectCleanFailure("report out/st", "SHADEFIT_PYTHON", "SHADEFIT_PYTHON=/no/such/python3");
}

// `fit --brdf` (a BRDF-space fit): the arguments and the BRDF file are checked before anything
// is written.
TEST_F(BadInput, FitBrdfWithRefs) {
  ExpectCleanFailure("fit --brdf in/m.binary --ref in/r.exr --model ggx -o out/f.json",
                     "--ref: give reference images \\(--ref\\) or a measured BRDF \\(--brdf\\)");
}

TEST_F(BadInput, FitBrdfCellCountTooSmall) {
  Merl("m.binary", 90, kMerlValues);
  ExpectCleanFailure("fit --brdf in/m.binary --brdf-cells 90 1 45 --model ggx -o out/f.json",
                     "brdf_space.theta_d_cells: must be an integer in \\[2, 1024\\], got 1");
}

TEST_F(BadInput, FitBrdfCutAtTheHorizon) {
  Merl("m.binary", 90, kMerlValues);
  ExpectCleanFailure("fit --brdf in/m.binary --brdf-max-theta 90 --model ggx -o out/f.json",
                     "brdf_space.max_theta_deg: must be in \\(0, 90\\) degrees, got 90");
}

TEST_F(BadInput, FitBrdfCellsWithoutBrdf) {
  ExpectCleanFailure("fit --ref in/r.exr --brdf-cells 8 8 8 --model ggx -o out/f.json",
                     "--brdf-cells: only valid with --brdf");
}

TEST_F(BadInput, FitBrdfCubeRootLoss) {
  Merl("m.binary", 90, kMerlValues);
  ExpectCleanFailure("fit --brdf in/m.binary --loss cuberoot --model ggx -o out/f.json",
                     "--loss: a BRDF-space fit is an L2 fit");
}

TEST_F(BadInput, FitBrdfTruncatedMerlTable) {
  Merl("t.binary", 90, kMerlValues / 2);
  ExpectCleanFailure("fit --brdf in/t.binary --model ggx -o out/f.json", "in/t\\.binary: ");
}

TEST_F(BadInput, FitBrdfMissingFile) {
  ExpectCleanFailure("fit --brdf in/none.binary --model ggx -o out/f.json",
                     "in/none\\.binary: brdf: file not found");
}

// `probe brdf`: the measured BRDF file and the models are checked before anything is written.
TEST_F(BadInput, ProbeBrdfNeedsBrdf) {
  ExpectCleanFailure("probe brdf --model ggx -o out",
                     "--brdf: the brdf probe needs a measured BRDF file");
}

TEST_F(BadInput, ProbeBrdfTruncatedMerlTable) {
  WriteText(in() / "m.binary", std::string("\x5a\x00\x00\x00\x5a\x00\x00\x00", 8));
  ExpectCleanFailure("probe brdf --brdf in/m.binary -o out",
                     "in/m\\.binary: dims: file is 8 bytes, too short");
}

TEST_F(BadInput, ProbeBrdfNeuralWithoutConfig) {
  WriteText(in() / "n.h5", "not hdf5");
  ExpectCleanFailure("probe brdf --brdf in/n.h5 -o out",
                     "in/n\\.h5: config: the Keras model config .*n\\.json is missing");
}

TEST_F(BadInput, ProbeBrdfRefsRejected) {
  WriteText(in() / "m.binary", "x");
  ExpectCleanFailure("probe brdf --brdf in/m.binary --ref in/ref.exr -o out",
                     "--ref: not read by the brdf probe");
}

// --- Photographs: refs lights, fit and study encoding (issue 12 item 4) -------------------------

// A 64 x 64 photograph of a dark ball (code 8, radius 20 px at the centre) in a dim room (code
// 40), with a 3 x 3 clipped highlight at (36, 28) unless `highlight` is false; and a template
// scene of that size without lights.
void BallFixture(const fs::path& in, const std::string& name, bool highlight = true) {
  shadefit::Image im(64, 64, 3, 40.0f / 255.0f);
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 64; ++x) {
      const bool on_ball = std::hypot(x + 0.5 - 32.0, y + 0.5 - 32.0) < 20.0;
      const bool on_spot = highlight && std::abs(x - 36) <= 1 && std::abs(y - 28) <= 1;
      for (int c = 0; c < 3; ++c) {
        if (on_ball) im.at(x, y, c) = on_spot ? 1.0f : 8.0f / 255.0f;
      }
    }
  }
  shadefit::WritePng8((in / name).string(), im);
  WriteText(in / "template.toml",
            "[camera]\ntype = \"orthographic\"\nposition = [0.0, -10.0, 0.0]\n"
            "look_at = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\nheight = 2.4\n"
            "resolution = [64, 64]\n\n[[objects]]\ntype = \"sphere\"\n"
            "center = [0.0, 0.0, 0.0]\nradius = 1.0\n");
}

TEST_F(BadInput, RefsLightsMaskSizeMismatch) {
  BallFixture(in(), "ball-a.png");
  shadefit::WritePng8((in() / "mask.png").string(), shadefit::Image(32, 32, 1, 1.0f));
  ExpectCleanFailure(
      "refs lights --ball in/ball-a.png --mask in/mask.png --scene-template in/template.toml "
      "-o out",
      "in/mask\\.png: resolution: mask is 32x32, the image in/ball-a\\.png is 64x64");
}

TEST_F(BadInput, RefsLightsNoHighlight) {
  BallFixture(in(), "ball-a.png");
  BallFixture(in(), "ball-b.png", false);
  // The first ball is fine: nothing of it may be written either.
  ExpectCleanFailure("refs lights --ball in/ball-a.png --ball in/ball-b.png "
                     "--scene-template in/template.toml -o out",
                     "in/ball-b\\.png: highlight: no highlight on the ball");
}

TEST_F(BadInput, RefsLightsTemplateHasLights) {
  BallFixture(in(), "ball-a.png");
  ExpectCleanFailure("refs lights --ball in/ball-a.png --scene-template in/scene.toml -o out",
                     "in/scene\\.toml: lights: the template has 1 light\\(s\\); it must have none");
}

TEST_F(BadInput, RefsLightsImageSizeDiffersFromTemplate) {
  BallFixture(in(), "ball-a.png");
  WriteText(in() / "template.toml",
            std::regex_replace(ReadText(in() / "template.toml"), std::regex("\\[64, 64\\]"),
                               "[64, 48]"));
  ExpectCleanFailure("refs lights --ball in/ball-a.png --scene-template in/template.toml -o out",
                     "in/ball-a\\.png: resolution: image is 64x64, the camera of "
                     "in/template\\.toml is 64x48");
}

TEST_F(BadInput, RefsLightsSameLightingTwice) {
  BallFixture(in(), "ball-a.png");
  fs::create_directories(in() / "other");
  BallFixture(in() / "other", "ball-a.png");
  ExpectCleanFailure("refs lights --ball in/ball-a.png --ball in/other/ball-a.png "
                     "--scene-template in/template.toml -o out",
                     "in/other/ball-a\\.png: ball: a second photograph of lighting 'a'");
}

TEST_F(BadInput, FitEncodingNeedsFreeExposure) {
  Reference();
  ExpectCleanFailure("fit --ref in/ref.exr --model ggx --encoding fit -o out/fit.json",
                     "--encoding: fit needs a free exposure \\(the exposure of a photograph is "
                     "unknown too\\)");
}

TEST_F(BadInput, FitEncodingUnknown) {
  Reference();
  ExpectCleanFailure(
      "fit --ref in/ref.exr --model ggx --exposure free --encoding gamma -o out/fit.json",
      "--encoding: unknown encoding 'gamma' \\(known: as-imported, fit\\)");
}

TEST_F(BadInput, StudyEncodingFitNeedsFreeExposure) {
  ExpectStudyFails("encoding = \"fit\"\n", "",
                   "s\\.toml:9: fit\\.encoding: fit needs a free exposure \\(the exposure of a "
                   "photograph is unknown too\\)");
}

TEST_F(BadInput, StudyEncodingUnknown) {
  ExpectStudyFails("exposure = \"free\"\nencoding = \"gamma\"\n", "",
                   "s\\.toml:10: fit\\.encoding: unknown encoding 'gamma' \\(known: as-imported, "
                   "fit\\)");
}

// The study and the command line refuse the same values in the same words: one set of rules
// (fit/option_checks.h), each front end naming the field its own way.
TEST_F(BadInput, StudyAndCommandLineShareTheFitRules) {
  ExpectStudyFails("starts = 0\n", "", "s\\.toml:9: fit\\.starts: must be >= 1$");
  ExpectStudyFails("max_iterations = 200000\n", "",
                   "s\\.toml:9: fit\\.max_iterations: must be <= 100000 \\(200000 is a typo");
  ExpectStudyFails("loss_scale = -1.0\n", "",
                   "s\\.toml:9: fit\\.loss_scale: -1 is not a finite number >= 0");
  Reference();
  ExpectCleanFailure("fit --ref in/ref.exr --model ggx --starts 20000 -o out/fit.json",
                     "--starts: must be <= 10000 \\(20000 is a typo");
  ExpectCleanFailure("fit --ref in/ref.exr --model ggx --loss-scale -1 -o out/fit.json",
                     "--loss-scale: -1 is not a finite number >= 0");
}

}  // namespace

// Job ids are file names: two materials whose names differ only where FileSafe replaces
// characters would write one job file, so the study is refused before any job runs.
TEST_F(BadInput, StudyMaterialsWhoseJobIdsCollide) {
  Reference("m x-key.exr");
  Reference("m_x-key.exr");
  ExpectStudyFails("",
                   "[[group]]\nmaterial = \"m x\"\nimages = [\"m x-*.exr\"]\n"
                   "[[group]]\nmaterial = \"m_x\"\nimages = [\"m_x-*.exr\"]\n",
                   "s\\.toml: material: materials 'm x' and 'm_x' would both write "
                   "jobs/fit\\.m_x\\.ggx\\.key\\.json .*rename one");
}

TEST_F(BadInput, StudyLossListAndPixelStride) {
  ExpectStudyFails("loss = [\"l2\", \"l1\"]\n", "",
                   "s\\.toml:[0-9]+: fit\\.loss: unknown loss 'l1'");
  Reference("m-key.exr");
  ExpectCleanFailure("fit --ref in/m-key.exr --model ggx --pixel-stride 0 -o out/fit.json",
                     "--pixel-stride: must be >= 1");
}
