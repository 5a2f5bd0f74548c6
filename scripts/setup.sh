#!/usr/bin/env bash
# Installs what is missing (Debian 12 packages), configures and builds. Quick when nothing changed.
# Usage: scripts/setup.sh [Release|Debug [TARGET...]]   (build folder: build/, or $RIG_BUILD_DIR)
set -euo pipefail
cd "$(dirname "$0")/.."

# libceres-dev is rig-bench's peer solver only (the project builds without it; docs/performance.md). pybind11 and
# NumPy build the Python module for Debian's /usr/bin/python3; pytest and PyYAML run its tests (docs/python.md).
# libjs-three is the three.js rig-invert --html embeds; chromium runs that page in the tests, libpng-dev reads
# their screenshots (docs/keys-anim-report.md). clang-format checks the house style (scripts/check_format.sh).
# libassimp-dev reads FBX, glTF, Collada, X, ... clips (docs/clips.md); assimp-testmodels holds the models and
# CMU clips the tests read (their tests skip without it).
packages=(cmake ninja-build g++ python3 libeigen3-dev libtbb-dev libyaml-cpp-dev libfmt-dev doctest-dev libcli11-dev
          nlohmann-json3-dev libceres-dev libassimp-dev assimp-testmodels pybind11-dev python3-pybind11 python3-numpy
          python3-pytest python3-yaml libjs-three chromium libpng-dev clang-format)
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
if [ ! -f "$build_dir/build.ninja" ] ||
   ! grep -q "CMAKE_BUILD_TYPE:STRING=$build_type" "$build_dir/CMakeCache.txt" 2>/dev/null; then
  cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE="$build_type" >/dev/null
fi
# Targets after the build type build only those (the quick start builds what the main job runs); none: everything.
targets=("${@:2}")
cmake --build "$build_dir" ${targets[@]+--target "${targets[@]}"} -- -j"$(nproc)" |
  grep -v -e '^\[' -e '^ninja: no work to do' || true
test "${PIPESTATUS[0]}" -eq 0
