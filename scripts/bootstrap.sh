#!/usr/bin/env bash
# shadefit quick start on a fresh Debian 12 machine (root, or a user with sudo):
#   bash scripts/bootstrap.sh main   install packages, build, run the default study -> report
#   bash scripts/bootstrap.sh test   install packages, build, run the whole test suite
# .ci/run calls the second form. Re-running is cheap: apt and the build are incremental.
#   bash scripts/bootstrap.sh packages   only install the test form's packages (no build, no run):
# scripts/sanitizer-check.sh calls it, so the sanitizer suite on CI's host has what the test
# command installs even where that command ran in a fresh root rather than on the host.
set -euo pipefail
mode=${1:-main}
case "$mode" in main | test | packages) ;; *) echo "usage: $0 main|test|packages" >&2; exit 2 ;; esac
cd "$(dirname "$0")/.."

# Every dependency is a Debian 12 package (README, "Dependencies").
packages=(
  build-essential cmake ninja-build pkg-config git
  libceres-dev libopenimageio-dev openimageio-tools libopenexr-dev libglm-dev libhdf5-dev
  libopencv-core-dev libopencv-imgproc-dev  # not libopencv-dev: every OpenCV module, 77 packages
  libegl-dev libegl-mesa0 libgl1-mesa-dri libepoxy-dev
  libcli11-dev libtomlplusplus-dev nlohmann-json3-dev libfmt-dev libssl-dev
  libassimp-dev libembree-dev libmatio-dev libeigen3-dev  # meshes, ray casting, .mat normals
  python3 python3-numpy python3-matplotlib python3-scipy python3-statsmodels
  python3-dev pybind11-dev  # the Python module `import shadefit` (docs/python.md)
  blender-data  # CC0 environment maps used by the environment-lit references, read by path
)
# Test mode also installs what the suite needs to run every test rather than skip it:
# Blender 3.4.1 (the version that made the references) for `blender_facts`, and pdflatex with
# booktabs and geometry (texlive-latex-recommended; graphicx is in -base) for
# StudyEndToEnd.LatexTablesCompile.
test_packages=(
  libgtest-dev libgmock-dev libbenchmark-dev  # the test suite and bench/
  python3-skimage  # SsimTest's peer: scikit-image's structural_similarity
  blender
  texlive-latex-base texlive-latex-recommended
  chromium chromium-driver python3-selenium  # report_browser: index.html in headless Chromium
  slurm-wlm munge  # slurm_cluster_test: a one-node Slurm cluster on localhost (docs/cluster.md)
  clang libclang-rt-dev  # scripts/fuzz-check.sh: libFuzzer harnesses of tests/fuzz (docs/inputs.md)
  python3-pytest python3-nbclient python3-nbformat python3-ipykernel  # tests/python, the notebook
  python3-mypy  # stubtest of python/shadefit/__init__.pyi (tests/python/test_stubs.py)
)
[ "$mode" != main ] && packages+=("${test_packages[@]}")
sudo=""
[ "$(id -u)" -eq 0 ] || sudo="sudo"
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "== installing ${#missing[@]} Debian packages: ${missing[*]}"
  $sudo env DEBIAN_FRONTEND=noninteractive apt-get update -qq
  $sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
    "${missing[@]}" >/dev/null
fi
[ "$mode" = packages ] && { echo "== the test command's packages are installed"; exit 0; }

# The main job builds what it runs: the shadefit executable and the Python module (the report is
# Python). Test mode builds everything: the tests, bench/, the executable and the module.
if [ "$mode" = test ]; then
  echo "== building (Release) in build/: everything"
  cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DBUILD_TESTING=ON \
    -DSHADEFIT_BUILD_BENCH=ON >/dev/null
  cmake --build build -j"$(nproc)"
else
  echo "== building (Release) in build/: the shadefit executable and the Python module"
  cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DBUILD_TESTING=OFF \
    -DSHADEFIT_BUILD_BENCH=OFF >/dev/null
  cmake --build build -j"$(nproc)" --target shadefit shadefit_python
fi

# `import shadefit` for /usr/bin/python3: one .pth file in its site-packages names build/python,
# where the build puts the package (docs/python.md says why it is used in place, not copied).
site=$(/usr/bin/python3 -c 'import site; print(site.getsitepackages()[0])')
$sudo mkdir -p "$site"
echo "$(pwd)/build/python" | $sudo tee "$site/shadefit.pth" >/dev/null
/usr/bin/python3 -c 'import shadefit' ||
  { echo "bootstrap: error: /usr/bin/python3 cannot import shadefit from $(pwd)/build/python" >&2; exit 1; }
echo "== /usr/bin/python3: import shadefit -> $(pwd)/build/python ($site/shadefit.pth)"

if [ "$mode" = test ]; then
  echo "== running the test suite"
  cd build
  rc=0
  ctest --output-on-failure -j"$(nproc)" --timeout 900 --output-junit ctest-junit.xml || rc=$?
  # Skip policy (docs/testing.md): under CI=true a skipped test is an error unless a line of
  # tests/ci-allowed-skips.txt names it and its skip output contains that line's reason.
  /usr/bin/python3 ../scripts/check-skips.py ctest-junit.xml ../tests/ci-allowed-skips.txt "${CI:-}" ||
    rc=1
  exit $rc
fi

echo "== running the main job: the default study on the shipped references, then its report"
./build/studies/shadefit study run studies/pbs_vs_blinn_phong.toml -o out
echo "== the measured-materials study (../shared/brdf-data, or says in one line why it is skipped)"
./build/studies/shadefit study run studies/merl_vs_blinn_phong.toml -o out
