#!/usr/bin/env bash
# Regenerates the node reference in docs/nodes.md from the registry (graph-eval --types).
# A test fails when the committed page differs from what the code registers.
set -euo pipefail
cd "$(dirname "$0")/.."
begin='<!-- BEGIN GENERATED: scripts/update-node-docs.sh -->'
end='<!-- END GENERATED -->'
# Through a file: the reference is larger than an argument may be.
reference=$(mktemp)
trap 'rm -f "$reference"' EXIT
build/bin/graph-eval --types >"$reference"
python3 - "$begin" "$end" "$reference" <<'PY'
import sys
begin, end, reference_file = sys.argv[1:4]
reference = open(reference_file).read()
path = "docs/nodes.md"
text = open(path).read()
head, rest = text.split(begin, 1)
_, tail = rest.split(end, 1)
open(path, "w").write(head + begin + "\n\n" + reference.rstrip("\n") + "\n\n" + end + tail)
PY
