#!/usr/bin/env bash
# The house style: every C++ source as clang-format 14 writes it with .clang-format, and no line of a source,
# script or CMake file over 120 characters. Prints each offending file (and line) and exits 1; exit 0 when clean.
# Usage: scripts/check_format.sh [--fix]   (--fix rewrites the C++ sources in place first)
set -euo pipefail
cd "$(dirname "$0")/.."
clang_format=$(command -v clang-format-14 || command -v clang-format || true)
if [ -z "$clang_format" ]; then
  echo "check_format: clang-format is not installed (scripts/setup.sh installs it)" >&2
  exit 2
fi
mapfile -t sources < <(find core graph inversion nodes adapter app tools bench python tests fuzz \
                         \( -name '*.cpp' -o -name '*.h' \) | sort)
[ "${1:-}" = "--fix" ] && "$clang_format" -i "${sources[@]}"
status=0
# clang-format exits non-zero on a violation; under pipefail that would hide grep's verdict, so it is ignored here.
{ "$clang_format" --dry-run --Werror "${sources[@]}" 2>&1 || true; } | grep -E '^[^ ].*(warning|error):' && status=1
mapfile -t texts < <(find core graph inversion nodes adapter app tools bench python tests fuzz scripts \
  \( -name '*.cpp' -o -name '*.h' -o -name '*.py' -o -name '*.sh' -o -name 'CMakeLists.txt' \) | sort)
texts+=(CMakeLists.txt quickstart.sh test.sh)
if awk 'length($0) > 120 { printf "%s:%d: a line of %d characters (at most 120)\n", FILENAME, FNR, length($0); bad = 1 }
        END { exit bad ? 0 : 1 }' "${texts[@]}"; then
  status=1
fi
exit "$status"
