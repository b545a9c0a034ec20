#!/usr/bin/env bash
# The full-scale benchmark (issue 46 item 4, BENCHMARKS.md): a study shaped like MERL-100 x Ngan
# et al. 2005's seven models x two training sets, timed as a whole command, report included.
#
#   bash bench/merl100/run.sh [--slurm SHARDS] [--copies N] [--keep DIR] [SHADEFIT]
#
# Materials: the shared measured folder's 20 materials N times over (default 5: 100) under new
# names (<name>, <name>-r2, ...), each a set of symbolic links to the shared files; the project
# has no other 80. Every copy is a material of its own to the runner (its own references, fits,
# probes, report pages); what a copy cannot have is its own Ngan 2005 row or Lavoue class, which
# are keyed by the MERL name (the report leaves those rows out). It measures time, not findings:
# five copies of a material are not five samples, so the report's significance counts and
# intervals over these 100 mean nothing (run studies/ngan2005_models.toml for the answers).
# Models: studies/ngan2005_models.toml's first seven, Ngan's seven with GGX in the place of He et
# al. 1991 (not implemented): blinn-phong-normalized, ward, ward-duer, ashikhmin-shirley,
# lafortune, cook-torrance, ggx. Training sets: key + mirror60 (images) and brdf (the measured
# BRDF itself, Ngan's objective). Every other setting is that study file's.
#
# Without --slurm: `study run -j $(nproc)` from an empty folder, wall and CPU time, the stage
# table, then the report's share. With --slurm N: a one-node Slurm cluster on this machine
# (scripts/local-slurm.sh), `study slurm --array N --cpus nproc/N --merge-cpus nproc` (the merge
# runs after the shards, on the whole node), wall time from submission
# until the merge (with its report) is done, each shard's own seconds and the merge's.
# Needs ../shared/brdf-data/merl-nbrdf (or SHADEFIT_MEASURED=folder).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/../.." && pwd)
shards=0 copies=5 keep=""
while [ $# -gt 0 ]; do
  case "$1" in
    --slurm) shards=${2:?--slurm needs a shard count}; shift 2 ;;
    --copies) copies=${2:?--copies needs a count}; shift 2 ;;
    --keep) keep=${2:?--keep needs a folder}; shift 2 ;;
    -h | --help) sed -n '2,21p' "$0"; exit 0 ;;
    *) break ;;
  esac
done
shadefit=${1:-$repo/build/studies/shadefit}
measured=${SHADEFIT_MEASURED:-$repo/../shared/brdf-data/merl-nbrdf}
[ -d "$measured" ] || { echo "run.sh: error: $measured: no measured folder (SHADEFIT_MEASURED)" >&2; exit 2; }
[ -x "$shadefit" ] || { echo "run.sh: error: $shadefit: not an executable" >&2; exit 2; }
cpus=$(nproc)
if [ -n "$keep" ]; then work=$keep; mkdir -p "$work"; else work=$(mktemp -d /tmp/shadefit-merl100.XXXXXX); fi
cleanup() {
  [ "$shards" -gt 0 ] && local_slurm_stop "$work/cluster" 2>/dev/null || true
  [ -n "$keep" ] || rm -rf "$work"
}
trap cleanup EXIT

# The materials: every file of the measured folder, linked once per copy under the copy's name.
folder=$work/brdf-data/merl-nbrdf
mkdir -p "$folder"
count=0
for f in "$measured"/*; do
  base=$(basename "$f")
  stem=${base%%.*} ext=${base#*.}
  for ((k = 1; k <= copies; k++)); do
    name=$stem; [ "$k" -gt 1 ] && name=$stem-r$k
    ln -sf "$(cd "$(dirname "$f")" && pwd)/$base" "$folder/$name.$ext"
  done
  count=$((count + 1))
done

# The study: ngan2005_models.toml with the folder, the seven models and absolute scene paths.
study=$work/merl100_ngan7.toml
sed -e "s#^name = \"ngan2005_models\"#name = \"merl100_ngan7\"#" \
    -e "s#^folder = .*#folder = \"$folder\"#" \
    -e "s#^description = .*#description = \"Timing benchmark (bench/merl100/run.sh): Ngan 2005's seven models (GGX for He's) on the shared measured materials $copies times over; not findings\"#" \
    -e "s#\"\.\./reference_images/#\"$repo/reference_images/#g" \
    -e '/^models = \[/,/\]/c\models = ["blinn-phong-normalized", "ward", "ward-duer", "ashikhmin-shirley", "lafortune", "cook-torrance", "ggx"]' \
    "$repo/studies/ngan2005_models.toml" >"$study"
grep -q "^models = \[\"blinn-phong-normalized\", \"ward\"" "$study" || { echo "run.sh: error: could not write $study" >&2; exit 1; }

now() { date +%s.%N; }
since() { echo "$(now) - $1" | bc -l | xargs printf '%.1f'; }
echo "machine: $cpus CPUs, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//'), load $(cut -d' ' -f1-3 /proc/loadavg)"
echo "shadefit: $("$shadefit" --version)"
echo "materials: $(ls "$folder" | sed 's/\..*//' | sort -u | wc -l) ($copies copies of the files of $measured)"

if [ "$shards" -eq 0 ]; then
  t=$(now)
  /usr/bin/time -f "%U %S" -o "$work/cpu" "$shadefit" study run "$study" -q -j "$cpus" -o "$work/out" >/dev/null
  wall=$(since "$t")
  dir=$work/out/merl100_ngan7
  read -r user sys <"$work/cpu"
  echo "whole command (study run -j $cpus, report included): ${wall} s wall, $(echo "$user + $sys" | bc -l) CPU-s"
  echo "load after: $(cut -d' ' -f1-3 /proc/loadavg)"
  /usr/bin/python3 - "$dir" "$wall" <<'EOF'
import csv, sys, re, statistics
d, wall = sys.argv[1], float(sys.argv[2])
rows = list(csv.DictReader(open(f"{d}/timings.csv")))
stages = [k for k in rows[0] if k.endswith("_seconds") and k != "solver_seconds"]
total = sum(float(r["seconds"]) for r in rows)
kinds = {}
for r in rows:
    kinds[r["kind"]] = kinds.get(r["kind"], 0) + 1
print(f"jobs: {len(rows)} ({', '.join(f'{v} {k}' for k, v in sorted(kinds.items()))}), {total:.1f} job-s")
shares = sorted(((sum(float(r[k] or 0) for r in rows), k[:-8]) for k in stages), reverse=True)
print("stages: " + ", ".join(f"{n} {100 * s / total:.1f}%" for s, n in shares if s > 0.005 * total))
fits = [r for r in rows if r["kind"] == "fit" and float(r["solver_seconds"] or 0) > 0]
ratio = statistics.median((float(r["seconds"]) - float(r["solver_seconds"])) / float(r["solver_seconds"]) for r in fits)
print(f"median fit job: {statistics.median(float(r['seconds']) for r in fits):.2f} s, outside the solve / solve {ratio:.1f}x")
# study.log's last line: "... not run in X s": the references and jobs; the report follows it.
jobs = float(re.findall(r" in ([0-9.]+) s", open(f"{d}/study.log").read())[-1])
print(f"references and jobs {jobs:.1f} s wall, the report {wall - jobs:.1f} s (the rest of the command)")
EOF
else
  # shellcheck source=../../scripts/local-slurm.sh
  source "$repo/scripts/local-slurm.sh"
  local_slurm_start "$work/cluster"
  per=$((cpus / shards)); [ "$per" -ge 1 ] || per=1
  submit=$("$shadefit" study slurm "$study" --array "$shards" --cpus "$per" --merge-cpus "$cpus" \
    -o "$work/out" 2>/dev/null)
  t=$(now)
  bash -c "$submit" >/dev/null
  local_slurm_wait 7200
  wall=$(since "$t")
  dir=$work/out/merl100_ngan7
  grep -q "(merge)" "$dir/slurm/merge.out" || { echo "the merge failed:"; tail -n 5 "$dir/slurm/merge.out"; exit 1; }
  echo "slurm: $shards shard(s) x $per CPU(s), submission to merged report: ${wall} s wall"
  /usr/bin/python3 - "$dir" <<'EOF'
import json, glob, sys
for f in sorted(glob.glob(f"{sys.argv[1]}/shards/*-of-*.json")):
    j = json.load(open(f))
    print(f"  shard {f.split('/')[-1][:-5]}: {len(j.get('materials', []))} materials, "
          f"{j.get('seconds', float('nan')):.1f} s")
EOF
  grep -E "merge|report" "$dir/slurm/merge.out" | tail -n 3 || true
fi
