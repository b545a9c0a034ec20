// Measured isotropic BRDFs: the MERL database's .binary tables (Matusik, Pfister, Brand,
// McMillan 2003, "A Data-Driven Reflectance Model", SIGGRAPH) and the Neural-BRDF networks fitted
// to them (Sztrajman, Rainer, Ritschel, Weyrich 2021, "Neural BRDF Representation and Importance
// Sampling", CGF 40(6)). Formats, conventions and errors: docs/measured_and_imported.md.
#pragma once

#include <array>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "shadefit/render/vec.h"

namespace shadefit::reference_images {

// An isotropic BRDF in the local shading frame (normal = +z). Eval(wi, wo) is f(wi, wo) in 1/sr
// per RGB channel; the cosine factor is NOT included. wi and wo are unit vectors; either below
// the surface (z <= 0) gives 0. Implementations are immutable after construction and safe to
// call from many threads.
class MeasuredBrdf {
 public:
  virtual ~MeasuredBrdf() = default;
  virtual Vec3d Eval(const Vec3d& wi, const Vec3d& wo) const = 0;
  // The files the BRDF was read from (for provenance records).
  virtual std::vector<std::string> SourceFiles() const = 0;
  // "merl-binary" or "neural-brdf".
  virtual std::string Format() const = 0;
};

// Rusinkiewicz's half/difference angles (Rusinkiewicz 1998, "A New Change of Variables for
// Efficient BRDF Representation"): h = normalize(wi + wo); d is wi expressed in the frame where
// h is the pole, i.e. wi rotated by -phi_h about z, then by -theta_h about y.
struct HalfDiff {
  double theta_h = 0, phi_h = 0;  // spherical angles of h
  double theta_d = 0, phi_d = 0;  // spherical angles of d, phi_d in (-pi, pi]
  Vec3d h, d;                     // the unit vectors themselves
};
HalfDiff ToHalfDiff(const Vec3d& wi, const Vec3d& wo);
// The inverse for phi_h = 0 (isotropic BRDFs do not depend on it): returns wi, wo.
void FromHalfDiff(double theta_h, double theta_d, double phi_d, Vec3d* wi, Vec3d* wo);

// --- The measured domain -------------------------------------------------------------------------

// MERL's gonioreflectometer did not reach difference angles theta_d beyond about 75 degrees: the
// tables hold extrapolated values there (Matusik et al. 2003, sec. 5; Burley 2012, "Physically
// Based Shading at Disney", sec. 5.1), and the Neural-BRDF networks, fitted to those tables,
// inherit them. The one definition of the rule: the BRDF-space probes (probes/brdf_space.h) and
// the measured renderer's per-pixel domain (render_measured.h) both take it from here.
inline constexpr double kMeasuredThetaDMaxDeg = 75.0;
// A quantity (a pixel, an albedo point) counts as measured while at most this share of it comes
// from extrapolated data: the probes' extrapolated_point_fraction and the renderer's threshold.
inline constexpr double kExtrapolatedShareMax = 0.01;
// The rule and its source in words, as sidecars and probe notes record it.
inline constexpr const char* kMeasuredDomainRule =
    "f(wi, wo) is measured where theta_d <= 75 deg (Rusinkiewicz's difference angle, between wi "
    "and the half vector); beyond it MERL's tables are extrapolated (Matusik et al. 2003, sec. 5; "
    "Burley 2012, sec. 5.1), and Neural-BRDF networks fitted to them inherit the rule";

// Whether f(wi, wo) of a MERL table or of a network fitted to one lies in the measured domain:
// theta_d (ToHalfDiff) at most kMeasuredThetaDMaxDeg, with 1e-9 rad of slack so that MERL's own
// 75-degree cells count as measured. Directions below the horizon are the caller's business
// (Eval returns 0 there whatever the table holds).
inline bool InMeasuredDomain(const Vec3d& wi, const Vec3d& wo) {
  constexpr double kLimitRad = kMeasuredThetaDMaxDeg * 3.14159265358979323846 / 180.0;
  return ToHalfDiff(wi, wo).theta_d <= kLimitRad + 1e-9;
}

// --- MERL .binary -------------------------------------------------------------------------------

// Table sizes of the MERL format (Matusik et al. 2003): theta_h, theta_d, phi_d.
inline constexpr int kMerlThetaH = 90;
inline constexpr int kMerlThetaD = 90;
inline constexpr int kMerlPhiD = 180;
inline constexpr std::size_t kMerlCells =
    static_cast<std::size_t>(kMerlThetaH) * kMerlThetaD * kMerlPhiD;  // 1,458,000
// Per-channel scale from stored doubles to 1/sr (MERL's distribution code and README).
inline constexpr double kMerlScale[3] = {1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0};

// The angles at which table cell (i, j, k) was taken: theta_h = (i / 90)^2 * pi/2 (the square-root
// parameterisation that packs samples near the specular peak), theta_d = j * pi/180,
// phi_d = k * pi/180 in [0, pi) (phi_d and phi_d + pi are the same by reciprocity).
double MerlThetaH(int i);
double MerlThetaD(int j);
double MerlPhiD(int k);

enum class MerlLookup {
  kTrilinear,  // trilinear in (sqrt-mapped theta_h index, theta_d index, phi_d index); default
  kTruncate,   // MERL's reference lookup: each continuous index truncated to its cell
};

class MerlBrdf : public MeasuredBrdf {
 public:
  // Reads and validates a .binary file: int32 dims (90, 90, 180), then 3 x 1,458,000 float64,
  // channel-major (all red, then green, then blue), little-endian. Throws shadefit::Error naming
  // the file and the field ("dims", "size") on anything else.
  explicit MerlBrdf(const std::string& path, MerlLookup lookup = MerlLookup::kTrilinear);

  Vec3d Eval(const Vec3d& wi, const Vec3d& wo) const override;
  Vec3d EvalAngles(double theta_h, double theta_d, double phi_d) const;
  // The stored value of cell (i, j, k) after scaling, 1/sr; negative entries (MERL's marker for
  // cells without a measurement) are returned as they are.
  Vec3d Cell(int i, int j, int k) const;
  std::vector<std::string> SourceFiles() const override { return {path_}; }
  std::string Format() const override { return "merl-binary"; }

 private:
  std::string path_;
  MerlLookup lookup_;
  std::vector<double> data_;  // 3 * kMerlCells, scaled to 1/sr, channel-major
};

// Writes a MERL .binary table by sampling f(theta_h, theta_d, phi_d) -> RGB in 1/sr at the cell
// angles above (tests and synthetic references). The stored doubles are f / kMerlScale. Atomic.
void WriteMerlBinary(const std::string& path,
                     const std::function<Vec3d(double, double, double)>& f);

// --- Neural BRDF
// ----------------------------------------------------------------------------------

class NeuralBrdf : public MeasuredBrdf {
 public:
  // Reads the Keras model config (json_path: a Sequential of three Dense layers, relu, relu,
  // linear, then the exp(x) - 1 output Lambda) and the weights (h5_path, datasets
  // /<layer>/<layer>/kernel:0 and bias:0) with the HDF5 C API. Throws shadefit::Error naming the
  // file and the dataset path or JSON field that is missing or malformed.
  NeuralBrdf(const std::string& h5_path, const std::string& json_path);

  Vec3d Eval(const Vec3d& wi, const Vec3d& wo) const override;
  Vec3d EvalAngles(double theta_h, double theta_d, double phi_d) const;
  // The raw network on its 6-vector input (sin theta_h, 0, cos theta_h, d.x, d.y, d.z).
  Vec3d Forward(const std::array<double, 6>& x) const;
  std::vector<std::string> SourceFiles() const override { return {h5_path_, json_path_}; }
  std::string Format() const override { return "neural-brdf"; }

 private:
  struct Layer {
    int in = 0, out = 0;
    std::vector<float> kernel;  // in x out, row-major (x W with x a row vector)
    std::vector<float> bias;    // out
  };
  std::string h5_path_, json_path_;
  std::array<Layer, 3> layers_;
};

// The files a measured BRDF path reads: "x.binary" -> {x.binary}; "x.h5" -> {x.h5, x.json} (the
// Keras config beside it). For provenance and cache keys; nothing is opened.
std::vector<std::string> MeasuredBrdfFiles(const std::string& path);

// Opens a measured BRDF by file name: "x.binary" -> MerlBrdf; "x.h5" -> NeuralBrdf with the
// config "x.json" beside it. Throws shadefit::Error for other extensions and missing files.
std::unique_ptr<MeasuredBrdf> LoadMeasuredBrdf(const std::string& path);

}  // namespace shadefit::reference_images
