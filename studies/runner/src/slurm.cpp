// `shadefit study slurm`: sbatch scripts for a study on a Slurm cluster (docs/cluster.md). One job
// array runs the shards (task i runs `study run --shard i/N`), and a merge job that depends on the
// whole array (--dependency=afterok) writes the study-wide tables and the report. shadefit has
// no scheduler of its own: Slurm places the tasks, and the shards share the output folder.
#include <fmt/core.h>

#include <filesystem>
#include <regex>

#include "shadefit/base/error.h"
#include "shadefit/base/files.h"
#include "shadefit/studies/runner.h"

namespace shadefit::studies {
namespace fs = std::filesystem;

namespace {

// A POSIX shell word: 'text' with each ' written as '\''.
std::string ShellQuote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

void Validate(const SlurmOptions& o) {
  if (o.array < 1 || o.array > 10000) {
    throw Error("", "--array", fmt::format("want 1..10000 shards, got {}", o.array));
  }
  if (o.cpus < 1 || o.cpus > 4096) {
    throw Error("", "--cpus", fmt::format("want 1..4096 CPUs per task, got {}", o.cpus));
  }
  if (o.merge_cpus < 0 || o.merge_cpus > 4096) {
    throw Error("", "--merge-cpus",
                fmt::format("want 1..4096 CPUs for the merge (or 0: --cpus), got {}",
                            o.merge_cpus));
  }
  if (o.gpus < 0 || o.gpus > 64) {
    throw Error("", "--gpus", fmt::format("want 0..64 GPUs per task, got {}", o.gpus));
  }
  // sbatch --time: minutes, MM:SS, HH:MM:SS, D-HH, D-HH:MM or D-HH:MM:SS.
  static const std::regex time(R"(\d+|\d+:\d{1,2}|\d+:\d{1,2}:\d{1,2}|\d+-\d+(:\d{1,2}){0,2})");
  if (!std::regex_match(o.time, time)) {
    throw Error("", "--time", "want a Slurm time (minutes, HH:MM:SS or D-HH:MM:SS), got '" +
                                  o.time + "'");
  }
  static const std::regex name(R"([A-Za-z0-9_.,-]+)");
  if (!o.partition.empty() && !std::regex_match(o.partition, name)) {
    throw Error("", "--partition", "want a partition name (letters, digits, _ . , -), got '" +
                                       o.partition + "'");
  }
  if (o.executable.empty() || !fs::exists(o.executable)) {
    throw Error(o.executable, "", "shadefit executable not found");
  }
}

std::string Header(const std::string& job_name, const SlurmOptions& o) {
  std::string h = "#!/bin/bash\n";
  h += fmt::format("#SBATCH --job-name={}\n", job_name);
  if (!o.partition.empty()) h += fmt::format("#SBATCH --partition={}\n", o.partition);
  h += fmt::format("#SBATCH --time={}\n", o.time);
  return h;
}

}  // namespace

SlurmScripts WriteSlurmScripts(const StudySpec& spec, const SlurmOptions& o) {
  Validate(o);
  const fs::path out = fs::absolute(o.out_dir).lexically_normal();
  const fs::path study_dir = out / spec.name;
  const fs::path dir = study_dir / "slurm";
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir)) throw Error(dir.string(), "", "cannot create the folder");
  const std::string exe = ShellQuote(fs::absolute(o.executable).string());
  const std::string quick = o.quick ? " --quick" : "";

  SlurmScripts s;
  s.shards_script = (dir / "shards.sbatch").string();
  s.merge_script = (dir / "merge.sbatch").string();

  std::string shards = Header("shadefit-" + spec.name, o);
  shards += fmt::format("#SBATCH --array=1-{}\n", o.array);
  shards += fmt::format("#SBATCH --cpus-per-task={}\n", o.cpus);
  if (o.gpus > 0) shards += fmt::format("#SBATCH --gres=gpu:{}\n", o.gpus);
  shards += fmt::format("#SBATCH --output={}\n", (dir / "shard-%a.out").string());
  shards += fmt::format(
      "# shadefit study '{}' as {} shards, one per array task (docs/cluster.md). Rendering\n"
      "# is headless EGL: no display is needed; on a GPU node the NVIDIA device is used,\n"
      "# elsewhere Mesa's llvmpipe. A task that fails can be rerun alone:\n"
      "#   sbatch --array=<i> {}\n"
      "set -euo pipefail\n"
      "exec {} study run {} -o {}{} --no-report -j \"${{SLURM_CPUS_PER_TASK:-{}}}\" \\\n"
      "  --shard \"${{SLURM_ARRAY_TASK_ID}}/{}\"\n",
      spec.name, o.array, s.shards_script, exe, ShellQuote(spec.path), ShellQuote(out.string()),
      quick, o.cpus, o.array);

  std::string merge = Header("shadefit-" + spec.name + "-merge", o);
  // The tables are one thread's work; the report draws its figures on every CPU it is given.
  merge += fmt::format("#SBATCH --cpus-per-task={}\n", o.merge_cpus > 0 ? o.merge_cpus : o.cpus);
  merge += fmt::format("#SBATCH --output={}\n", (dir / "merge.out").string());
  merge += fmt::format(
      "# Runs after every shard of shards.sbatch succeeded (--dependency=afterok): the study-wide\n"
      "# tables, byte-identical to a single-machine run, then the report.\n"
      "set -euo pipefail\n"
      "exec {} study merge {}\n",
      exe, ShellQuote(study_dir.string()));

  WriteTextAtomic(s.shards_script, shards);
  WriteTextAtomic(s.merge_script, merge);
  // --parsable prints "jobid" or "jobid;cluster"; the dependency wants the id.
  s.submit_command = fmt::format(
      "jid=$(sbatch --parsable {}) && sbatch --dependency=afterok:\"${{jid%%;*}}\" {}",
      ShellQuote(s.shards_script), ShellQuote(s.merge_script));
  return s;
}

}  // namespace shadefit::studies
