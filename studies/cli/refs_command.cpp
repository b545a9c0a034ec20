// refs: make reference images that are not plain model renders.
//   refs measured  a measured BRDF (MERL .binary or Neural-BRDF .h5 + .json) over a scene
//   refs import    a photograph or published image, with validity mask and counts
//   refs lights    directional lights from mirror-ball photographs or a data set's published
//                  directions and intensities, one scene per light
//   refs cycles    the Cycles references, through Blender (reference_images/cycles/gen.py)
#include <fmt/format.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "shadefit/base/error.h"
#include "shadefit/reference_images/import.h"
#include "shadefit/reference_images/import_set.h"
#include "shadefit/reference_images/light_calibration.h"
#include "shadefit/reference_images/render_measured.h"
#include "shadefit/render/gl_context.h"
#include "shadefit/render/renderer.h"

extern char** environ;

namespace shadefit::cli {
namespace {

namespace fs = std::filesystem;

// The repository root: where reference_images/cycles lives. The build may pass it in; otherwise
// the working directory (run from the repository root).
fs::path RepositoryRoot() {
  if (const char* env = std::getenv("SHADEFIT_SOURCE_DIR")) return env;
#ifdef SHADEFIT_SOURCE_DIR
  return SHADEFIT_SOURCE_DIR;
#else
  return fs::current_path();
#endif
}

// Finds an executable by name on PATH (or the path itself when it contains a slash).
std::string FindExecutable(const std::string& name) {
  if (name.find('/') != std::string::npos) {
    return access(name.c_str(), X_OK) == 0 ? name : std::string();
  }
  const char* path = std::getenv("PATH");
  std::string dirs = path ? path : "";
  std::size_t start = 0;
  while (start <= dirs.size()) {
    const std::size_t end = std::min(dirs.find(':', start), dirs.size());
    const fs::path candidate = fs::path(dirs.substr(start, end - start)) / name;
    if (end > start && access(candidate.c_str(), X_OK) == 0) return candidate.string();
    start = end + 1;
  }
  return {};
}

void AddMeasured(CLI::App& refs) {
  auto* cmd =
      refs.add_subcommand("measured",
                          "Render a measured BRDF (MERL .binary, or Neural-BRDF .h5 with its .json "
                          "beside it) over a scene's G-buffer");
  auto req = std::make_shared<reference_images::MeasuredReferenceRequest>();
  cmd->add_option("--brdf", req->brdf_path, "MERL .binary or Neural-BRDF .h5")->required();
  cmd->add_option("--scene", req->scene_path, "Scene TOML file")->required();
  cmd->add_option("-o,--output", req->output, "Output EXR (sidecar: same name, .json)")->required();
  cmd->add_option("--samples", req->options.samples,
                  "Environment samples per technique per pixel (default: the light's `samples`)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--lobe-alpha", req->options.lobe_alpha,
                  "GGX width of the third (BRDF lobe) sampling technique; -1 estimates it from "
                  "the BRDF, 0 turns it off");
  cmd->add_option("--seed", req->options.seed, "Random seed (fixed by default)");
  cmd->add_option("--threads", req->options.threads, "Worker threads (default: all cores)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--noise-exr", req->noise_output, "Also write the per-pixel standard error");
  cmd->callback([req] {
    GlContext context;
    Renderer renderer(context);
    const reference_images::RenderMeasuredStats s =
        reference_images::MakeMeasuredReference(*req, renderer);
    fmt::print(
        "wrote {} and {} ({} pixels, {} samples/technique, mean standard error "
        "({:.3g}, {:.3g}, {:.3g}), {:.1f} s)\n",
        req->output, reference_images::SidecarPath(req->output), s.shaded_pixels,
        s.samples_per_technique, s.mean_standard_error[0], s.mean_standard_error[1],
        s.mean_standard_error[2], s.seconds);
  });
}

void AddImport(CLI::App& refs) {
  auto* cmd = refs.add_subcommand(
      "import", "Import a photograph or published image (PNG, JPEG, EXR) as a reference");
  auto opt = std::make_shared<reference_images::ImportOptions>();
  auto encoding = std::make_shared<std::string>("auto");
  cmd->add_option("image", opt->image_path, "Image file (PNG, JPEG, EXR, ...)")->required();
  auto* scene = cmd->add_option("--scene", opt->scene_path, "Scene TOML matching the image");
  auto* autos = cmd->add_flag("--auto-sphere", opt->auto_sphere,
                              "Find one sphere on a dark background (orthographic view), write "
                              "the scene beside the output and estimate the light");
  scene->excludes(autos);
  cmd->add_option("--mask", opt->mask_path,
                  "Validity mask (non-zero = use the pixel); with --auto-sphere, the sphere is "
                  "the mask's disc");
  cmd->add_option("--encoding", *encoding, "auto | srgb | linear (auto: sRGB for 8/16-bit files)")
      ->check(CLI::IsMember({"auto", "srgb", "linear"}));
  cmd->add_option("--clip-threshold", opt->clip_threshold,
                  "8-bit code at or above which a channel counts as clipped (256: off)");
  cmd->add_flag("--direct-light-only", opt->direct_light_only,
                "The image holds direct light only (a render without bounces): keep the pixels "
                "of strong interreflection, which a photograph's fit leaves out");
  cmd->add_option("-o,--output", opt->output, "Output EXR (sidecar: same name, .json)")->required();
  cmd->callback([opt, encoding] {
    opt->encoding = reference_images::ParseEncoding(*encoding);
    GlContext context;
    Renderer renderer(context);
    const reference_images::ImportResult r = reference_images::ImportReference(*opt, renderer);
    const reference_images::ImportCounts& n = r.counts;
    fmt::print(
        "wrote {} and {} (encoding {}; {} pixels: {} masked out, {} clipped, {} valid, "
        "{} valid on the object; exposure unknown)\n",
        opt->output, reference_images::SidecarPath(opt->output),
        reference_images::EncodingName(r.encoding), n.total, n.masked_out, n.clipped, n.valid,
        n.valid_covered);
    if (r.has_sphere) {
      const reference_images::SphereEstimate& s = r.sphere;
      fmt::print("sphere: centre ({:.2f}, {:.2f}) px, radius {:.2f} px -> {}\n", s.center_x,
                 s.center_y, s.radius, r.scene_path);
      if (s.light_found) {
        fmt::print(
            "light (initial guess, towards the light): ({:.4f}, {:.4f}, {:.4f}) from the "
            "highlight at ({:.1f}, {:.1f}) px\n",
            s.light_direction.x, s.light_direction.y, s.light_direction.z, s.highlight_x,
            s.highlight_y);
      }
    }
  });
}

void AddImportSet(CLI::App& refs) {
  auto* cmd = refs.add_subcommand(
      "import-set",
      "Import a photometric-stereo data set (images, light_directions.txt, "
      "light_intensities.txt, mask.png, ground-truth normals; one object or one per subfolder): "
      "references, scenes and a study file that runs as it is");
  auto opt = std::make_shared<reference_images::ImportSetOptions>();
  cmd->add_option("dir", opt->input, "The data set's folder")->required();
  cmd->add_option("-o,--output", opt->output, "Output folder (refs/, scenes/, <name>.toml)")
      ->required();
  cmd->add_option("--name", opt->name, "The study's name (default: the folder's name)");
  cmd->add_option("--normals", opt->normals,
                  "File name of each object's normals (default: Normal_gt.mat, normal.txt, ...)");
  cmd->add_option("--y-axis", opt->y_axis,
                  "The normals' y axis: up, down, or auto (the one Lambertian photometric stereo "
                  "on the images agrees with)")
      ->check(CLI::IsMember({"auto", "up", "down"}));
  cmd->add_option("--train", opt->train_lights, "Lights the fit trains on (a spread subset)")
      ->check(CLI::Range(1, 1000));
  cmd->add_option("--clip-threshold", opt->clip_threshold,
                  "8-bit code at or above which a channel counts as clipped (256: off)");
  cmd->add_option("--pixel-stride", opt->pixel_stride, "The study's training pixel stride")
      ->check(CLI::Range(1, 64));
  cmd->add_flag("--direct-light-only", opt->direct_light_only,
                "The images hold direct light only (a synthetic set rendered without bounces): "
                "keep the pixels of strong interreflection, which photographs' fits leave out");
  cmd->callback([opt] {
    GlContext context;
    Renderer renderer(context);
    const reference_images::ImportSetResult r =
        reference_images::ImportPhotometricSet(*opt, renderer);
    for (const reference_images::ImportedObject& o : r.objects) {
      fmt::print(
          "{}: {} lights, normals {} (y {}{}; lights{}{}; Lambertian photometric stereo against "
          "them: median {:.1f} deg, {:.1f} with the lights' y flipped); {:.1f}% of pixel-lights "
          "left out: a cast shadow the integrated depth does not reproduce\n",
          o.name, o.lights, o.normals_file, o.y_axis, o.normals_z_flipped ? ", z flipped" : "",
          o.lights_y_flipped ? " y flipped" : " as given", o.lights_z_flipped ? ", z flipped" : "",
          o.check_angle_deg, o.check_angle_flipped_deg, 100 * o.shadow_disagreement_fraction);
    }
    fmt::print("wrote {} (train on {} lights); run: shadefit study run {} -o OUT\n",
               r.study_path, r.objects.front().train.size(), r.study_path);
  });
}

void AddLights(CLI::App& refs) {
  auto* cmd = refs.add_subcommand(
      "lights",
      "Directional lights, one scene per light from a template: from photographs of a mirror "
      "ball (--ball, one per light, same camera), or from a data set's published light "
      "directions and intensities (--directions)");
  auto opt = std::make_shared<reference_images::LightCalibrationOptions>();
  auto pub = std::make_shared<reference_images::PublishedLightsOptions>();
  auto encoding = std::make_shared<std::string>("auto");
  auto axes = std::make_shared<std::string>("x,y,z");
  auto* ball = cmd->add_option("--ball", opt->ball_paths,
                               "Photograph of the mirror ball under one light (repeat; "
                               "'ball-<lighting>.png' names the lighting)");
  cmd->add_option("--mask", opt->mask_path, "The ball's disc (non-zero = ball), for every photo")
      ->needs(ball);
  cmd->add_option("--encoding", *encoding, "auto | srgb | linear (of the ball photographs)")
      ->check(CLI::IsMember({"auto", "srgb", "linear"}))
      ->needs(ball);
  auto* directions = cmd->add_option(
      "--directions", pub->directions_path,
      "Text file of published light directions, one light per line: x y z from the object "
      "towards the light (normalised), or x y z r g b with its RGB intensity");
  cmd->add_option("--intensities", pub->intensities_path,
                  "Text file of per-light RGB intensities (r g b per line, same order), which "
                  "scale the irradiance")
      ->needs(directions);
  cmd->add_option("--names", pub->names_path,
                  "Text file of lighting names, one per line, same order (a file name gives its "
                  "stem: 001.png -> 001); default L0, L1, ...")
      ->needs(directions);
  cmd->add_option("--axes", *axes,
                  "The data set's axes as camera x,y,z (camera: x right, y up, z towards the "
                  "viewer): x,-y,-z for y down the picture and z into the scene")
      ->needs(directions);
  ball->excludes(directions);
  cmd->add_option("--scene-template", opt->scene_template,
                  "Scene of the object's photographs without lights (camera, objects)")
      ->required();
  cmd->add_option("--irradiance", opt->irradiance,
                  "Irradiance of each light, times its intensity (exposure is fitted)");
  cmd->add_option("-o,--output", opt->output_dir,
                  "Output folder (created when missing): <template stem>-<lighting>.toml per "
                  "light, <stem>-lights.json")
      ->required();
  cmd->callback([opt, pub, encoding, axes] {
    if (opt->ball_paths.empty() && pub->directions_path.empty()) {
      throw Error("", "lights", "give --ball photographs or a --directions file");
    }
    if (!pub->directions_path.empty()) {
      pub->axes = reference_images::ParseAxisMapping(*axes);
      pub->scene_template = opt->scene_template;
      pub->output_dir = opt->output_dir;
      pub->irradiance = opt->irradiance;
      for (const reference_images::PublishedLight& l :
           reference_images::LightsFromPublishedFiles(*pub)) {
        fmt::print(
            "{}: towards the light ({:.5f}, {:.5f}, {:.5f}), irradiance ({:.5g}, {:.5g}, "
            "{:.5g}) -> {}\n",
            l.lighting, l.to_light.x, l.to_light.y, l.to_light.z, l.irradiance.x, l.irradiance.y,
            l.irradiance.z, l.scene_path);
      }
      return;
    }
    opt->encoding = reference_images::ParseEncoding(*encoding);
    const std::vector<reference_images::CalibratedLight> lights =
        reference_images::CalibrateLightsFromMirrorBall(*opt);
    for (const reference_images::CalibratedLight& c : lights) {
      fmt::print(
          "{}: ball ({:.2f}, {:.2f}) r {:.2f} px ({}), highlight ({:.2f}, {:.2f}) px -> "
          "towards the light ({:.5f}, {:.5f}, {:.5f}) -> {}\n",
          c.ball_path, c.ball.center_x, c.ball.center_y, c.ball.radius, c.ball.found_by,
          c.ball.highlight_x, c.ball.highlight_y, c.to_light.x, c.to_light.y, c.to_light.z,
          c.scene_path);
    }
  });
}

void AddCycles(CLI::App& refs) {
  auto* cmd = refs.add_subcommand(
      "cycles", "Render the Cycles references with Blender (reference_images/cycles/gen.py)");
  struct Options {
    std::string manifest, out, blender = "blender";
    std::vector<std::string> only;
    bool overwrite = false;
  };
  auto opt = std::make_shared<Options>();
  cmd->add_option("--manifest", opt->manifest,
                  "Manifest (default: reference_images/cycles/manifest.toml)");
  cmd->add_option("--out", opt->out, "Output folder (default: reference_images/cycles)");
  cmd->add_flag("--overwrite", opt->overwrite, "Re-render references that exist");
  cmd->add_option("--only", opt->only, "Render only these reference names");
  cmd->add_option("--blender", opt->blender, "Blender executable (default: blender on PATH)");
  cmd->callback([opt] {
    const fs::path root = RepositoryRoot();
    const fs::path script = root / "reference_images/cycles/gen.py";
    if (!fs::exists(script)) {
      throw Error(script.string(), "cycles",
                  "generator script not found (run from the repository root or set "
                  "SHADEFIT_SOURCE_DIR)");
    }
    const std::string manifest = opt->manifest.empty()
                                     ? (root / "reference_images/cycles/manifest.toml").string()
                                     : opt->manifest;
    const std::string out =
        opt->out.empty() ? (root / "reference_images/cycles").string() : opt->out;
    if (!fs::exists(manifest)) throw Error(manifest, "manifest", "file not found");
    const std::string blender = FindExecutable(opt->blender);
    if (blender.empty()) {
      throw Error("", "blender",
                  "'" + opt->blender +
                      "' not found on PATH: install Blender (3.4, as recorded "
                      "in the references' sidecars) or pass --blender /path/to/blender");
    }
    std::vector<std::string> args = {blender,         "-b", "--factory-startup", "--python",
                                     script.string(), "--", "--manifest",        manifest,
                                     "--out",         out};
    if (opt->overwrite) args.push_back("--overwrite");
    if (!opt->only.empty()) {
      args.push_back("--only");
      args.insert(args.end(), opt->only.begin(), opt->only.end());
    }
    std::string shown;
    for (const std::string& a : args) shown += (shown.empty() ? "" : " ") + a;
    fmt::print("running: {}\n", shown);
    std::fflush(stdout);
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_t pid = 0;
    if (posix_spawn(&pid, blender.c_str(), nullptr, nullptr, argv.data(), environ) != 0) {
      throw Error(blender, "blender", "cannot start Blender");
    }
    int status = 0;
    if (waitpid(pid, &status, 0) < 0) throw Error(blender, "blender", "lost the Blender process");
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
      throw Error(script.string(), "cycles",
                  WIFEXITED(status)
                      ? fmt::format("Blender exited with status {}", WEXITSTATUS(status))
                      : std::string("Blender was killed by a signal"));
    }
  });
}

}  // namespace

void RegisterRefsCommand(CLI::App& app) {
  auto* refs =
      app.add_subcommand("refs", "Make reference images: measured, import, import-set, lights, cycles");
  refs->require_subcommand(1);
  AddMeasured(*refs);
  AddImport(*refs);
  AddImportSet(*refs);
  AddLights(*refs);
  AddCycles(*refs);
}

}  // namespace shadefit::cli
