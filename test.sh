#!/usr/bin/env bash
# Sets everything up and runs every test (CTest).
set -euo pipefail
cd "$(dirname "$0")"
scripts/setup.sh Release
ctest --test-dir build --output-on-failure -j"$(nproc)"
