#include "job_records.h"

#include <fmt/format.h>

#include <fstream>
#include <set>

#include "shadefit/base/error.h"
#include "shadefit/base/files.h"

namespace shadefit::studies::internal {
namespace {
using json = nlohmann::json;

// The evaluation fields a C++ reader uses; the others go to EvaluationRecord::details.
const std::set<std::string> kTypedEvaluationFields = {
    "reference", "lighting", "split", "measured_fraction", "metrics", "metrics_all"};

// Reads one record file's fields, each checked for presence and type, errors naming the file
// and the field ("evaluations[2].lighting").
class FieldReader {
 public:
  FieldReader(const json& j, std::string path, std::string prefix = "")
      : j_(j), path_(std::move(path)), prefix_(std::move(prefix)) {}

  const json& At(const std::string& field) const {
    if (!j_.is_object() || !j_.contains(field)) Fail(field, "missing");
    return j_.at(field);
  }
  std::string String(const std::string& field) const {
    const json& v = At(field);
    if (!v.is_string()) Fail(field, "expected a string");
    return v.get<std::string>();
  }
  double Number(const std::string& field) const {
    const json& v = At(field);
    if (!v.is_number()) Fail(field, "expected a number");
    return v.get<double>();
  }
  bool Bool(const std::string& field) const {
    const json& v = At(field);
    if (!v.is_boolean()) Fail(field, "expected true or false");
    return v.get<bool>();
  }
  std::vector<std::string> Strings(const std::string& field) const {
    const json& v = At(field);
    std::vector<std::string> out;
    if (!v.is_array()) Fail(field, "expected an array of strings");
    for (const json& e : v) {
      if (!e.is_string()) Fail(field, "expected an array of strings");
      out.push_back(e.get<std::string>());
    }
    return out;
  }
  std::vector<double> Numbers(const std::string& field) const {
    const json& v = At(field);
    std::vector<double> out;
    if (!v.is_array()) Fail(field, "expected an array of numbers");
    for (const json& e : v) {
      if (!e.is_number()) Fail(field, "expected an array of numbers");
      out.push_back(e.get<double>());
    }
    return out;
  }
  const json& Object(const std::string& field) const {
    const json& v = At(field);
    if (!v.is_object()) Fail(field, "expected an object");
    return v;
  }
  const json& Array(const std::string& field) const {
    const json& v = At(field);
    if (!v.is_array()) Fail(field, "expected an array");
    return v;
  }
  // The schema and kind every record starts with.
  void ExpectKind(const std::string& kind) const {
    if (String("schema") != kJobSchema) {
      Fail("schema", fmt::format("'{}' is not {}", String("schema"), kJobSchema));
    }
    if (String("kind") != kind) Fail("kind", fmt::format("expected \"{}\"", kind));
  }
  [[noreturn]] void Fail(const std::string& field, const std::string& problem) const {
    throw Error(path_, prefix_ + field, problem);
  }
  const std::string& path() const { return path_; }

 private:
  const json& j_;
  std::string path_;
  std::string prefix_;
};

json ReadJsonFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(path, "", "job record not found or unreadable");
  try {
    return json::parse(in);
  } catch (const json::exception& e) {
    throw Error(path, "", "malformed JSON: " + OneLine(e.what()));
  }
}

FitStatus StatusOf(const FieldReader& r) {
  const std::optional<FitStatus> s = ParseFitStatus(r.String("status"));
  if (!s) r.Fail("status", fmt::format("unknown fit status '{}'", r.String("status")));
  return *s;
}

EvaluationRecord ReadEvaluation(const json& e, const std::string& path, std::size_t i) {
  const std::string where = fmt::format("evaluations[{}]", i);
  if (!e.is_object()) throw Error(path, where, "expected an object");
  const FieldReader r(e, path, where + ".");
  EvaluationRecord out;
  out.reference = r.String("reference");
  out.lighting = r.String("lighting");
  out.split = r.String("split");
  out.measured_fraction = r.Number("measured_fraction");
  out.metrics = r.Object("metrics");
  out.metrics_all = r.Object("metrics_all");
  for (const auto& [key, value] : e.items()) {
    if (!kTypedEvaluationFields.contains(key)) out.details[key] = value;
  }
  return out;
}

json EvaluationJson(const EvaluationRecord& e) {
  json j = e.details;
  j.update({{"reference", e.reference},
            {"lighting", e.lighting},
            {"split", e.split},
            {"measured_fraction", e.measured_fraction},
            {"metrics", e.metrics},
            {"metrics_all", e.metrics_all}});
  return j;
}

// The fields of either kind, after checking the schema and the kind.
void ReadBase(const FieldReader& r, const std::string& kind, JobRecordBase* out) {
  r.ExpectKind(kind);
  out->id = r.String("id");
  out->hash = r.String("hash");
  out->shadefit_version = r.String("shadefit_version");
  out->material = r.String("material");
  out->outputs = r.Strings("outputs");
}

json BaseJson(const JobRecordBase& r, const std::string& kind) {
  return {{"schema", kJobSchema},
          {"id", r.id},
          {"kind", kind},
          {"hash", r.hash},
          {"shadefit_version", r.shadefit_version},
          {"material", r.material},
          {"outputs", r.outputs}};
}

FitJobRecord FitRecordOf(const json& j, const std::string& path) {
  const FieldReader r(j, path);
  FitJobRecord out;
  ReadBase(r, "fit", &out);
  out.model = r.String("model");
  out.label = r.String("label");
  out.train = r.Strings("train");
  out.status = StatusOf(r);
  out.converged = r.Bool("converged");
  out.parameters = r.Array("parameters");
  const json& evaluations = r.Array("evaluations");
  for (std::size_t i = 0; i < evaluations.size(); ++i) {
    out.evaluations.push_back(ReadEvaluation(evaluations[i], path, i));
  }
  if (!HasFit(out.status)) {
    out.error = r.String("error");
    return out;
  }
  out.settings = r.Object("settings");
  out.termination = r.String("termination");
  out.values = r.Numbers("values");
  out.exposure = r.Number("exposure");
  out.fit = r.Object("fit");
  if (j.contains("encoding")) out.encoding = r.Object("encoding");
  return out;
}

ProbeJobRecord ProbeRecordOf(const json& j, const std::string& path) {
  const FieldReader r(j, path);
  ProbeJobRecord out;
  ReadBase(r, "probe", &out);
  out.status = r.String("status");
  if (out.status != "ok" && out.status != "no-fit") r.Fail("status", "expected ok or no-fit");
  out.fits_without_parameters = r.Strings("fits_without_parameters");
  out.probes_skipped = r.Array("probes_skipped");
  out.probes = r.Object("probes");
  return out;
}

}  // namespace

json ToJson(const FitJobRecord& r) {
  json evaluations = json::array();
  for (const EvaluationRecord& e : r.evaluations) evaluations.push_back(EvaluationJson(e));
  json j = BaseJson(r, "fit");
  j.update({{"model", r.model},
            {"label", r.label},
            {"train", r.train},
            {"status", FitStatusName(r.status)},
            {"converged", r.converged},
            {"parameters", r.parameters},
            {"evaluations", evaluations}});
  if (!HasFit(r.status)) {
    j["error"] = r.error;
    return j;
  }
  j.update({{"settings", r.settings},
            {"termination", r.termination},
            {"values", r.values},
            {"exposure", r.exposure},
            {"fit", r.fit}});
  if (!r.encoding.is_null()) j["encoding"] = r.encoding;
  return j;
}

json ToJson(const ProbeJobRecord& r) {
  json j = BaseJson(r, "probe");
  j.update({{"status", r.status},
            {"fits_without_parameters", r.fits_without_parameters},
            {"probes_skipped", r.probes_skipped},
            {"probes", r.probes}});
  return j;
}

FitJobRecord ReadFitJobRecord(const std::string& path) {
  return FitRecordOf(ReadJsonFile(path), path);
}

ProbeJobRecord ReadProbeJobRecord(const std::string& path) {
  return ProbeRecordOf(ReadJsonFile(path), path);
}

JobRecordHead ReadJobRecordHead(const std::string& path) {
  const json j = ReadJsonFile(path);
  const FieldReader r(j, path);
  JobRecordHead head;
  const std::string kind = r.String("kind");
  if (kind == "fit") {
    const FitJobRecord fit = FitRecordOf(j, path);
    head.hash = fit.hash;
    head.status = fit.status;
    head.outputs = fit.outputs;
  } else if (kind == "probe") {
    const ProbeJobRecord probe = ProbeRecordOf(j, path);
    head.hash = probe.hash;
    head.outputs = probe.outputs;
  } else {
    r.Fail("kind", "expected \"fit\" or \"probe\"");
  }
  return head;
}

}  // namespace shadefit::studies::internal
