// run_study: a study run as `shadefit study run` does it (studies/cli/study_command.cpp) up to
// the report, which __init__.py makes with report/make_report.py as `shadefit report` does.
//
// Links: shadefit::studies.
#include <fmt/format.h>
#include <pybind11/stl.h>

#include <cstdio>
#include <string>

#include "common.h"
#include "shadefit/base/error.h"
#include "shadefit/studies/parameter_charts.h"
#include "shadefit/studies/runner.h"
#include "shadefit/studies/study.h"

namespace shadefit::python {
namespace {

py::dict RunStudy(const std::string& path, const std::string& out, bool quick, int jobs, bool force,
                  bool quiet) {
  if (jobs < 0) throw Error("", "jobs", "must be >= 0");
  studies::RunSummary s;
  bool report = false;
  bool nothing = false;
  std::string skip;
  {
    py::gil_scoped_release no_gil;
    studies::StudySpec spec = studies::LoadStudy(path, quick);
    skip = studies::MeasuredSkipReason(spec);
    if (!skip.empty())
      std::fprintf(stderr, "shadefit: study %s: %s\n", spec.name.c_str(), skip.c_str());
    studies::MeasuredOptions mo;
    mo.quiet = quiet;
    studies::MaterialiseMeasuredReferences(&spec, out, mo);
    if (spec.groups.empty()) {
      std::fprintf(stderr, "shadefit: study %s: no material to study; nothing run\n",
                   spec.name.c_str());
      nothing = true;
    } else {
      studies::RunOptions ro;
      ro.jobs = jobs;
      ro.out_dir = out;
      ro.force = force;
      ro.quiet = quiet;
      s = studies::RunStudy(spec, ro);  // Its workers make their own GL contexts.
      if (s.failed > 0) {
        throw Error(s.study_dir + "/study.log", "study",
                    fmt::format("{} job(s) failed ({}...), {} not run", s.failed,
                                s.failed_ids.front(), s.not_run));
      }
      studies::WriteParameterCharts(spec, s.study_dir);
      report = spec.report;
    }
  }
  py::dict d;
  d["study_dir"] = s.study_dir;
  d["total"] = s.total;
  d["ran"] = s.ran;
  d["skipped"] = s.skipped;
  d["failed"] = s.failed;
  d["seconds"] = s.seconds;
  d["fits_without_parameters"] = s.fits_without_parameters;
  d["report"] = report;
  d["nothing_run"] = nothing;
  d["skip_reason"] = skip;
  return d;
}

}  // namespace

void RegisterStudy(py::module_& m) {
  m.def("run_study", &RunStudy, py::arg("path"), py::arg("out"), py::arg("quick"), py::arg("jobs"),
        py::arg("force"), py::arg("quiet"));
}

}  // namespace shadefit::python
