// The job JSON (jobs/<id>.json): the contract between a study's stages. A fit job's record is
// read back by the probe job (the fitted parameters), by results.csv (the evaluations) and by
// the runner (is the job up to date? did it leave parameters?); the report reads the same files
// and checks the same fields (report/report_inputs.py). One record type per job kind, written and
// read here only. A reader given a file that lacks a field, or has it with another type, throws
// shadefit::Error naming the file and the field; it never falls back to a default.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "fit_status.h"

namespace shadefit::studies::internal {

inline constexpr char kJobSchema[] = "shadefit.study.job/1";

// A fit evaluated under one lighting of its material. The fields a C++ reader uses are typed;
// `details` holds the rest as written (pixel counts, the full metrics, the previews), which only
// the report reads.
struct EvaluationRecord {
  std::string reference, lighting, split;  // split: "train", "test" or "other"
  double measured_fraction = 1;            // Of the covered pixels, those in the measured domain.
  nlohmann::json metrics;      // MetricsSummary of the measured pixels (nulls where none).
  nlohmann::json metrics_all;  // The same over every covered pixel.
  nlohmann::json details = nlohmann::json::object();
};

// What a record of either kind starts with.
struct JobRecordBase {
  std::string id, hash, shadefit_version, material;
  std::vector<std::string> outputs;  // Files it wrote, relative to the study folder.
};

struct FitJobRecord : JobRecordBase {
  std::string model;  // Its name, as `shadefit models` lists it.
  std::string label;  // The fit's label in tables ("ggx", "ggx@key+rim"): a field, never parsed.
  std::vector<std::string> train;
  FitStatus status = FitStatus::kOk;
  std::string error;  // Why a fit left no parameters (!HasFit(status)); "" otherwise.
  bool converged = false;
  // With parameters only (HasFit(status)): natural units, flattened; the fitted exposure; the
  // solver's termination; and, for the report, the settings, the estimates, the fitter's
  // result JSON and the encoding search (null when none ran).
  std::vector<double> values;
  double exposure = 1;
  std::string termination;
  nlohmann::json settings, parameters = nlohmann::json::array(), fit, encoding;
  std::vector<EvaluationRecord> evaluations;
};

// A material's probes.
struct ProbeJobRecord : JobRecordBase {
  std::string status;  // "ok", or "no-fit" when no fit of the material left parameters.
  std::vector<std::string> fits_without_parameters;         // Their labels.
  nlohmann::json probes_skipped = nlohmann::json::array();  // [{probe, why}]
  nlohmann::json probes = nlohmann::json::object();         // Probe name -> its summary.
};

nlohmann::json ToJson(const FitJobRecord& r);
nlohmann::json ToJson(const ProbeJobRecord& r);

// Read from jobs/<id>.json; throw shadefit::Error(path, field, problem).
FitJobRecord ReadFitJobRecord(const std::string& path);
ProbeJobRecord ReadProbeJobRecord(const std::string& path);

// What the runner's up-to-date check needs of a record of either kind: its hash, the fit's
// status (nullopt for a probe job) and the files it wrote.
struct JobRecordHead {
  std::string hash;
  std::optional<FitStatus> status;
  std::vector<std::string> outputs;
};
JobRecordHead ReadJobRecordHead(const std::string& path);

}  // namespace shadefit::studies::internal
