#!/usr/bin/env bash
# Sets everything up and runs the main job: the bundled biped follows a real CMU motion-capture clip
# through the rigInversion node (rigs/examples/biped_mocap.yaml), with a short report; then its curves are
# keyed for an animator (a Maya .anim file) and a report page is written (docs/keys-anim-report.md).
set -euo pipefail
cd "$(dirname "$0")"
# Only what the main job runs: a fresh machine installs and builds neither the tests nor the benchmarks to reach the
# report.
scripts/setup.sh --main-job Release rig-learn rig-invert graph-eval rigInversion

clip=/usr/share/assimp/models/BVH/01_01.bvh
frames=1:240
approx=build/biped.approx.yaml

# Learn the biped's approximation when it is missing or older than the rig or the list of what to invert.
if [ ! -f "$approx" ] || [ rigs/biped.yaml -nt "$approx" ] || [ rigs/biped_inversion.yaml -nt "$approx" ]; then
  echo "== learning rigs/biped.yaml's approximation (rigs/biped_inversion.yaml) -> $approx"
  build/bin/rig-learn rigs/biped.yaml --spec rigs/biped_inversion.yaml -o "$approx" \
    --report-json build/biped.learn.json > build/biped.learn.txt
  grep -E '^(Training|Discarded|Frames|  position error|  rotation error|  per unit)' build/biped.learn.txt
  echo "   (the whole report: build/biped.learn.txt)"
fi

echo "== rigs/examples/biped_mocap.yaml: $clip frames $frames -> rigInversion -> rigs/biped.yaml"
# rig-invert solves the same frames outside the graph and measures the real rig: its curves must be the graph's.
build/bin/rig-invert "$approx" --rig rigs/biped.yaml --clip "$clip" --map rigs/maps/cmu_to_biped.yaml \
  --frames "$frames" -o build/biped_invert_curves.json --report-json build/biped_invert_report.json -q
gets=$(python3 -c 'import json,sys
print(" ".join("--get " + k for k in json.load(open(sys.argv[1]))[0] if k != "frame"))' \
  build/biped_invert_curves.json)
# shellcheck disable=SC2086
build/bin/graph-eval rigs/examples/biped_mocap.yaml --frames "$frames" $gets --stats \
  -o build/biped_mocap_curves.json 2> build/biped_mocap_stats.txt || { cat build/biped_mocap_stats.txt >&2; exit 2; }
scripts/mocap_report.py build/biped_mocap_curves.json build/biped_invert_curves.json \
  build/biped_invert_report.json build/biped_mocap_stats.txt

echo "== keys: the same frames keyed within 0.1 cm and 0.5 degrees of the curves on the real rig's joints"
# rig-invert again, with sparse keys (a Maya .anim file) and the report page (docs/keys-anim-report.md).
build/bin/rig-invert "$approx" --rig rigs/biped.yaml --clip "$clip" --map rigs/maps/cmu_to_biped.yaml \
  --frames "$frames" --key-tolerance 0.1 --key-tolerance-deg 0.5 -o build/biped_keys.anim \
  --report-json build/biped_keys_report.json --html build/biped_report.html > build/biped_keys.txt
grep -E '^(keys  |keyed error|uniform keys|curves)' build/biped_keys.txt
echo "report page       $(pwd)/build/biped_report.html (open it in a browser: the clip, the rig, errors and curves)"
