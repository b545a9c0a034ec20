// Runs report/make_report.py on a study's output folder; shared by `shadefit report` and
// `shadefit study run` (which makes the report when its jobs all succeeded).
#pragma once

#include <string>

namespace shadefit::cli {

// Runs `<python> <source>/report/make_report.py <study_dir>`. The interpreter is $SHADEFIT_PYTHON
// or /usr/bin/python3 (the system Python, which has matplotlib and numpy). Throws shadefit::Error
// when the script cannot be started or exits non-zero.
void MakeReport(const std::string& study_dir, bool quiet = false);

}  // namespace shadefit::cli
