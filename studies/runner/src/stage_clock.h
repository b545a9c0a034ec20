// Where a job's seconds go (docs/studies.md, "Timings"): a job laps one StageClock at the end of
// each stage it runs; its timing JSON records the stages, timings.csv lists them, and `study run`
// ends with a table of the totals per stage.
#pragma once

#include <chrono>
#include <string>
#include <vector>

namespace shadefit::studies::internal {

// The stages of the jobs, in the order timings.csv and the closing table list them.
inline const std::vector<std::string> kStageNames = {
    "read",        // reading the references (images, sidecars, scenes, domains)
    // The BRDF-space start of an image fit ([fit] start = "brdf"): made by the first job that
    // asks for it (its seconds are that job's solver_seconds too), found by the others.
    "brdf_start",
    // fit::Fit: preparing the G-buffers and the solve. A job's solver_seconds are the seconds of
    // the fits it solved: this one (a BRDF-space training set's only when the job made it, not
    // found it) and a BRDF-space start it made.
    "fit",
    "render",      // the fit rendered under every lighting of the material
    // Every image metric, over the measured and over all covered pixels, one stage per family
    // (metrics::MetricsSeconds) and "metrics" for the rest (masks, pixel counts, the patched
    // reference).
    "metric_pixel",     // RMSE, relative RMSE, log RMSE, MAE, PSNR
    "metric_ssim",      // SSIM and MS-SSIM
    "metric_ciede2000",
    "metric_itp",       // Delta E_ITP
    "metric_flip_ldr",
    "metric_flip_hdr",
    "metric_maps",      // the error map the previews show
    "metrics",
    "regions",     // where the error lies (a G-buffer per lighting, region_errors.h)
    "previews",    // the reference, fit and error PNGs
    "write",       // the job's record
    // A probe job: its inputs (the references' G-buffers, the fits' records), then one stage per
    // probe (probes::ProbeName), each with the figures and JSON it writes.
    "probe_inputs",
    "probe_fresnel",
    "probe_highlight",
    "probe_energy",
    "probe_portability",
    "probe_brdf",
};

class StageClock {
 public:
  StageClock() : last_(Clock::now()), start_(last_) {}
  // Adds the time since the previous lap (or the clock's start) to `stage`, one of kStageNames.
  void Lap(const std::string& stage);
  // Moves `seconds` of what was lapped to `from` over to `to` (a stage timed inside another).
  void Move(const std::string& from, const std::string& to, double seconds);
  double Seconds(const std::string& stage) const;
  double Total() const { return std::chrono::duration<double>(last_ - start_).count(); }

 private:
  using Clock = std::chrono::steady_clock;
  Clock::time_point last_, start_;
  std::vector<double> seconds_ = std::vector<double>(kStageNames.size(), 0.0);
};

}  // namespace shadefit::studies::internal
