#!/usr/bin/env bash
# Whether two runs of a study found the same things: compares every result file of BEFORE and
# AFTER (two output folders of `shadefit study run`, e.g. from two builds, to check that a
# restructuring changed no result; docs/solver.md). Left out, as in the determinism tests: what
# records when, where or how a run ran (study.log, provenance.json, timings.csv, shards/, the
# jobs' .timing.json, the references' .key cache keys, which hash the build, and the report's
# figure cache keys, report/figures/*.hash, which cover the output folder's paths). In the other
# files, lines naming the output folder are compared with it replaced, and lines that carry a
# build's version, a duration, or a hash over files that hold one (a reference's sidecar records
# its render time) are left out. PNG files whose bytes differ are compared by their decoded
# pixels (size, channels, every value), so that a change of the encoder's settings (the zlib level,
# the row filter) is not a change of result. Prints each differing file; exits 1 if there is one.
#   bash scripts/same-results.sh BEFORE AFTER
set -euo pipefail
a=${1:?usage: same-results.sh BEFORE AFTER}
b=${2:?usage: same-results.sh BEFORE AFTER}
for d in "$a" "$b"; do [ -d "$d" ] || { echo "same-results: error: $d: not a folder" >&2; exit 2; }; done
a=$(cd "$a" && pwd); b=$(cd "$b" && pwd)
not_results='(^|/)(study\.log|provenance\.json|timings\.csv)$|(^|/)shards/|\.timing\.json$|\.key$|/figures/[^/]*\.hash$'
normalise() {
  sed -e "s#$2#OUT#g" "$1" |
    grep -Ev 'shadefit_version|git_revision|version&quot;: &quot;[0-9]|shadefit [0-9]+\.[0-9]+\.[0-9]+\+|_seconds"|"sha256"|"hash"' || true
}
differ=0 compared=0
pngs=()  # Byte-different PNG files, compared by pixels below.
while IFS= read -r rel; do
  compared=$((compared + 1))
  if [ ! -f "$b/$rel" ]; then echo "only in $a: $rel"; differ=$((differ + 1)); continue; fi
  case "$rel" in
    *.json | *.csv | *.md | *.tex | *.html | *.tsv | *.txt | *.toml)
      cmp -s <(normalise "$a/$rel" "$a") <(normalise "$b/$rel" "$b") ||
        { echo "differs: $rel"; differ=$((differ + 1)); } ;;
    *.png) cmp -s "$a/$rel" "$b/$rel" || pngs+=("$rel") ;;
    *) cmp -s "$a/$rel" "$b/$rel" || { echo "differs: $rel"; differ=$((differ + 1)); } ;;
  esac
done < <(cd "$a" && find . -type f ! -name '.*' | sed 's|^\./||' | grep -Ev "$not_results" | sort)
while IFS= read -r rel; do
  [ -f "$a/$rel" ] || { echo "only in $b: $rel"; differ=$((differ + 1)); }
done < <(cd "$b" && find . -type f ! -name '.*' | sed 's|^\./||' | grep -Ev "$not_results" | sort)
if [ "${#pngs[@]}" -gt 0 ]; then
  while IFS= read -r line; do
    echo "$line"
    differ=$((differ + 1))
  done < <(printf '%s\n' "${pngs[@]}" | /usr/bin/python3 -c '
import sys
a, b = sys.argv[1:3]
rels = sys.stdin.read().splitlines()
try:
    import numpy as np
    from PIL import Image
except ImportError as e:  # Without a decoder, byte-different files count as different.
    for rel in rels:
        print(f"differs: {rel} (bytes; no PNG decoder: {e})")
    sys.exit()
for rel in rels:
    try:
        x, y = (np.asarray(Image.open(f"{d}/{rel}")) for d in (a, b))
        same = x.shape == y.shape and x.dtype == y.dtype and np.array_equal(x, y)
    except Exception as e:
        same = False
        rel += f" ({e})"
    if not same:
        print(f"differs: {rel} (pixels)")
' "$a" "$b")
fi
echo "same-results: $compared files compared, $differ differ"
[ "$differ" -eq 0 ]
