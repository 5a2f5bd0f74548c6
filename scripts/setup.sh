#!/usr/bin/env bash
# Installs what is missing (Debian 12 packages), configures and builds. Quick when nothing changed.
# Usage: scripts/setup.sh [--main-job] [Release|Debug [TARGET...]]   (build folder: build/, or $RIG_BUILD_DIR)
# --main-job: only the packages and parts (no tests, no Python module) the quick start's main job runs.
set -euo pipefail
cd "$(dirname "$0")/.."

# Packages per purpose. The main job (quickstart.sh, --main-job): the compiler and build tools, the libraries the
# programs link (Eigen, oneTBB, yaml-cpp, fmt, CLI11, nlohmann-json, assimp: clips from FBX, glTF, Collada, X, ...;
# docs/clips.md), libjs-three (the three.js rig-invert --html embeds), python3 (the report script) and
# assimp-testmodels (the CMU clip it inverts). Everything else (test.sh): doctest and libpng-dev (the tests, and
# their browser screenshots, which chromium takes; docs/keys-anim-report.md), pybind11 and NumPy (the Python module
# for Debian's /usr/bin/python3) with pytest and PyYAML (its tests; docs/python.md), libceres-dev (rig-bench's peer
# solver only; docs/performance.md) and clang-format (the house style, scripts/check_format.sh).
main_job=(cmake ninja-build g++ python3 libeigen3-dev libtbb-dev libyaml-cpp-dev libfmt-dev libcli11-dev
          nlohmann-json3-dev libassimp-dev assimp-testmodels libjs-three)
rest=(doctest-dev libpng-dev chromium pybind11-dev python3-pybind11 python3-numpy python3-pytest python3-yaml
      libceres-dev clang-format)
packages=("${main_job[@]}")
main_only=false
if [ "${1:-}" = --main-job ]; then
  main_only=true
  shift
else
  packages+=("${rest[@]}")
fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}" >&2
  sudo=()
  [ "$(id -u)" -eq 0 ] || sudo=(sudo)
  "${sudo[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

build_type=${1:-Release}
build_dir=${RIG_BUILD_DIR:-build}
cache="$build_dir/CMakeCache.txt"
# A build folder made for the main job alone gains the tests and the Python module when everything is asked for; one
# that has them keeps them for the main job (nothing is built twice).
parts=()
if $main_only; then
  [ -f "$build_dir/build.ninja" ] || parts=(-DRIG_TESTS=OFF -DRIG_PYTHON=OFF)
elif ! grep -q "RIG_TESTS:BOOL=ON" "$cache" 2>/dev/null || ! grep -q "RIG_PYTHON:BOOL=ON" "$cache" 2>/dev/null; then
  parts=(-DRIG_TESTS=ON -DRIG_PYTHON=ON)
fi
if [ ! -f "$build_dir/build.ninja" ] || ! grep -q "CMAKE_BUILD_TYPE:STRING=$build_type" "$cache" 2>/dev/null ||
   ((${#parts[@]})); then
  cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE="$build_type" ${parts[@]+"${parts[@]}"} >/dev/null
fi
# Targets after the build type build only those (the quick start builds what the main job runs); none: everything.
targets=("${@:2}")
cmake --build "$build_dir" ${targets[@]+--target "${targets[@]}"} -- -j"$(nproc)" |
  grep -v -e '^\[' -e '^ninja: no work to do' || true
test "${PIPESTATUS[0]}" -eq 0
