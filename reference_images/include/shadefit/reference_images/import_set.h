// A photometric-stereo data set in one command (`shadefit refs import-set DIR -o OUT`,
// docs/measured_and_imported.md, "Photometric-stereo data sets"): the common layout of such sets
//   DIR/[object/]  images (listed in filenames.txt, or numbered: 001.png, ...; 16-bit linear PNG)
//                  light_directions.txt   one "x y z" per image, toward the light, camera frame
//                  light_intensities.txt  one "r g b" per image (optional: 1 1 1)
//                  mask.png               the object's pixels
//                  normals                Normal_gt.mat, normal.txt, normal(s).npy/.png/.exr
// becomes references (one per image, with a normal-map scene of the object under that light),
// and a study file that fits a spread subset of the lights and tests on the rest, per object.
#pragma once

#include <string>
#include <vector>

#include "shadefit/render/renderer.h"

namespace shadefit::reference_images {

struct ImportSetOptions {
  std::string input;          // DIR: one object, or one object per subfolder.
  std::string output;         // OUT: refs/, scenes/ and <name>.toml are written there.
  std::string name;           // The study's name ("" = DIR's folder name).
  std::string normals;        // File name of the normals in each object folder ("" = look).
  std::string y_axis = "auto";  // "up", "down" or "auto" (checked against the images).
  int train_lights = 8;       // How many lights the fit trains on (a spread subset).
  int clip_threshold = 254;   // 8-bit code at or above which a channel counts as clipped.
  std::vector<std::string> models = {"ggx", "blinn-phong", "blinn-phong-normalized", "beckmann",
                                     "cook-torrance"};
  int pixel_stride = 2;       // The study's training stride (metrics see every pixel).
  bool direct_light_only = false;  // ImportOptions::direct_light_only, for every image.
};

struct ImportedObject {
  std::string name;
  int lights = 0;
  std::string normals_file;
  // The data set's frame as found (or as --y-axis says): the normals' y as stored runs "up" or
  // "down" the picture (the one whose slopes have the smaller mean curl: real normals
  // integrate), their z and the lights' flipped when most point away from the camera, and the
  // lights' y flipped when Lambertian photometric stereo agrees with the normals better so.
  // OUT/normals/<object>.npy holds the normals in shadefit's frame; the scenes read it.
  std::string y_axis;
  bool normals_z_flipped = false, lights_z_flipped = false, lights_y_flipped = false;
  double curl_as_stored = 0, curl_flipped = 0;
  // Lambertian photometric stereo (Woodham 1980) from the images and the calibrated lights,
  // against the normals: the median angle (degrees), and with the lights' y the other way.
  double check_angle_deg = 0, check_angle_flipped_deg = 0;
  std::vector<std::string> train;  // Lighting names of the training subset.
  long long masked_pixels = 0;     // The object's pixels (its mask).
  // Of the object's pixels over all lights, the share left out because its cast shadow is not
  // the one the object's depth casts (masks/<object>-<light>.png; import_set.cpp says how).
  double shadow_disagreement_fraction = 0;
};

struct ImportSetResult {
  std::string study_path;
  std::vector<ImportedObject> objects;
};

// Reads every object's files, checks them (one-line errors naming the file and the field: a
// missing or unreadable file, a light count that differs from the image count, a zero light
// direction, normals whose size differs from the images'), then writes the references, their
// scenes and the study, each file atomically; nothing is written before every input is read.
ImportSetResult ImportPhotometricSet(const ImportSetOptions& options, Renderer& renderer);

// The spread subset: greedy farthest-point sampling of the unit directions (the first is the one
// nearest the view axis +z, then each next maximises its smallest angle to those taken).
// Returns indices in increasing order. count >= directions.size() gives all.
std::vector<int> SpreadSubset(const std::vector<Vec3d>& directions, int count);

}  // namespace shadefit::reference_images
