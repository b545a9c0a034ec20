#!/usr/bin/env bash
# shadefit quick start on a fresh Debian 12 machine (root, or a user with sudo):
#   bash scripts/bootstrap.sh main   install packages, build, run the default study -> report
#   bash scripts/bootstrap.sh test   install packages, build, run the whole test suite
# .ci/run calls the second form. Re-running is cheap: apt and the build are incremental.
set -euo pipefail
mode=${1:-main}
case "$mode" in main | test) ;; *) echo "usage: $0 main|test" >&2; exit 2 ;; esac
cd "$(dirname "$0")/.."

# Every dependency is a Debian 12 package (README, "Dependencies").
packages=(
  build-essential cmake ninja-build pkg-config git
  libceres-dev libopenimageio-dev openimageio-tools libopenexr-dev libglm-dev libopencv-dev libhdf5-dev
  libegl-dev libegl-mesa0 libgl1-mesa-dri libepoxy-dev
  libcli11-dev libtomlplusplus-dev nlohmann-json3-dev libfmt-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  python3 python3-numpy python3-matplotlib python3-skimage
  blender-data  # CC0 environment maps used by the environment-lit references, read by path
)
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

echo "== building (Release) in build/"
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$(nproc)"

if [ "$mode" = test ]; then
  echo "== running the test suite"
  cd build
  ctest --output-on-failure -j"$(nproc)" --timeout 900
  exit $?
fi

echo "== running the main job: the default study on the shipped references, then its report"
./build/studies/shadefit study run studies/pbs_vs_blinn_phong.toml -o out
