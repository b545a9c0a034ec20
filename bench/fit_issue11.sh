#!/bin/bash
# The measurements of BENCHMARKS.md, "Fitter: iterations and starts": every shipped point-lit
# Cycles reference and the MERL materials under the key light (rendered here from
# ../shared/brdf-data when it is present), fitted with the staged Ceres solve (before) and the
# bounded LM (after), one start, the default starts and 16 starts. Writes TSVs (bench/fit_table.py
# columns) to build/bench-issue11/.
# Usage (repository root, after building shadefit): bash bench/fit_issue11.sh [what ...]
#   what: cycles merl (default: both)
set -euo pipefail
out=build/bench-issue11
mkdir -p "$out"
sf=build/studies/shadefit
table() { /usr/bin/python3 bench/fit_table.py --shadefit "$sf" "$@"; }
what=${*:-cycles merl}
uptime | tee "$out/uptime.txt"
for w in $what; do
  case $w in
    cycles)
      for m in ggx blinn-phong; do
        table --model $m -- --solver ceres --starts 1 > "$out/cycles.$m.ceres1.tsv"
        table --model $m -- --starts 1 > "$out/cycles.$m.lm1.tsv"
      done
      table --model ggx > "$out/cycles.ggx.default.tsv"
      table --model ggx -- --starts 16 > "$out/cycles.ggx.lm16.tsv"
      ;;
    merl)
      data=../shared/brdf-data/merl-nbrdf
      [ -d "$data" ] || { echo "no $data: MERL part skipped"; continue; }
      mkdir -p "$out/merl"
      for h5 in "$data"/*.h5; do
        name=$(basename "$h5" .h5)
        [ -f "$out/merl/$name-key.exr" ] ||
          "$sf" refs measured --brdf "$h5" --scene reference_images/cycles/scenes/sphere-key.toml \
            -o "$out/merl/$name-key.exr" > /dev/null
      done
      refs=("$out"/merl/*-key.exr)
      table --model ggx "${refs[@]}" -- --solver ceres --starts 1 > "$out/merl.ggx.ceres1.tsv"
      table --model ggx "${refs[@]}" -- --starts 1 > "$out/merl.ggx.lm1.tsv"
      table --model ggx "${refs[@]}" > "$out/merl.ggx.default.tsv"
      table --model ggx "${refs[@]}" -- --starts 16 > "$out/merl.ggx.lm16.tsv"
      ;;
  esac
done
uptime | tee -a "$out/uptime.txt"
