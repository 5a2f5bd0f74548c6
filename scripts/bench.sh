#!/usr/bin/env bash
# The benchmark of docs/performance.md: Release build, one full rig-bench run, then the page and its plots.
# Usage: scripts/bench.sh [rig-bench flags...]   (JSON: build/bench.json)
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh Release
if ! command -v gnuplot >/dev/null; then
  sudo=()
  [ "$(id -u)" -eq 0 ] || sudo=(sudo)
  echo "bench: installing gnuplot-nox (the plots)" >&2
  DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get install -y -qq --no-install-recommends gnuplot-nox >/dev/null
fi
build_dir=${RIG_BUILD_DIR:-build}
"$build_dir/bin/rig-bench" --json "$build_dir/bench.json" "$@"
scripts/bench_report.py "$build_dir/bench.json"
